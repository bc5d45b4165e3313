// btflod — the error report of compare_btfs() (offline/metrics/btf_metrics.hpp) against a BTF store on
// disk (offline/btf/btf_store.hpp) instead of an in-memory BTF: the store is streamed view by view, a
// group of lights at a time, so a reference larger than RAM is evaluated within a memory budget.
// The images are visited in compare_btfs()'s order (views, then lights) and every sum is formed
// in the same order, so for the same values the report is identical to the in-memory one.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "btflod/core/progress.hpp"
#include "btflod/offline/btf/btf_store.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/metrics/btf_metrics.hpp"

namespace btflod {

/// Options of compare_btf_store().
struct BtfStoreEvalOptions {
  /// Peak value used by PSNR and SSIM; 0 = the store's largest value (BtfStore::peak(), one
  /// extra sequential pass), what compare_btfs() is given as btf_peak() of the source.
  double data_range = 0.0;
  /// Bytes of images held at once: reference and approximation of a group of lights, the view
  /// chunk being read and the SSIM temporaries of one image.
  uint64_t memory_budget = uint64_t{256} << 20;
  bool verify = true;         ///< check the CRC of every chunk read
  ProgressCallback progress;  ///< (stage, fraction of images done); returning false cancels
};

/// How compare_btf_store() ran.
struct BtfStoreEvalStats {
  size_t lights_per_group = 0;  ///< images of one view evaluated together
  size_t groups = 0;            ///< light groups over all views (each reads the view's chunks once)
  uint64_t buffer_bytes = 0;    ///< estimated peak bytes of the buffers (≤ the budget)
  uint64_t bytes_read = 0;      ///< bytes read from the store, the peak pass included
};

namespace detail {
/// Bytes one image's metrics allocate at most (SSIM maps and filtered moments, CIELAB): an
/// estimate for the budget, 8 doubles per texel and channel.
inline uint64_t store_eval_metric_bytes(size_t texels) { return static_cast<uint64_t>(texels) * 3 * 8 * 8; }
}  // namespace detail

/// The smallest budget compare_btf_store() accepts for `info` (one light per group).
inline uint64_t btf_store_eval_min_budget(const BtfStoreInfo& info) {
  const uint64_t n = info.columns();
  const uint64_t chunk =
      static_cast<uint64_t>(info.lights.size()) * std::min<uint64_t>(info.block_texels, n) * 3 * info.value_size();
  return 2 * n * 3 * sizeof(float) + chunk + detail::store_eval_metric_bytes(n);
}

/// Compares the approximation produced by `approx` with the reference in `store`, image by image,
/// exactly as compare_btfs(reference, approx, data_range) does (same metrics, same summation
/// order: identical results for the same values). `approx(view, light, out)` writes image
/// (view, light) as H × W × 3 floats (TabulatedBtf image layout) into `out` and returns a
/// VoidResult; it is called once per image, views in order, lights in order within a view.
/// The store is read view by view: each view's chunk of every block once per light group (with
/// a budget holding a whole view, the store is read exactly once, plus the peak pass when
/// data_range is 0). Returns insufficient_space when the budget is below
/// btf_store_eval_min_budget(), cancelled when progress returns false, and the errors of the
/// store's reads (corrupt chunk: bad_data naming block and view) or of `approx`. Allocates the
/// group buffers once; single-threaded; the store may be shared with other readers.
template <class ApproxImage>
Result<BtfErrorReport> compare_btf_store(const BtfStore& store, ApproxImage&& approx,
                                         const BtfStoreEvalOptions& options = {}, BtfStoreEvalStats* stats = nullptr) {
  const BtfStoreInfo& info = store.info();
  const size_t nv = info.views.size(), nl = info.lights.size(), n = info.columns();
  const uint64_t min_budget = btf_store_eval_min_budget(info);
  if (options.memory_budget < min_budget)
    return make_error(Status::insufficient_space, "%s: evaluation needs at least %.1f MiB (budget %.1f MiB)",
                      store.path().c_str(), static_cast<double>(min_budget) / 1048576.0,
                      static_cast<double>(options.memory_budget) / 1048576.0);
  const uint64_t image_bytes = static_cast<uint64_t>(n) * 3 * sizeof(float);
  const size_t group =
      static_cast<size_t>(std::min<uint64_t>(nl, 1 + (options.memory_budget - min_budget) / (2 * image_bytes)));
  BtfStoreEvalStats st;
  st.lights_per_group = group;
  st.buffer_bytes = min_budget + (group - 1) * 2 * image_bytes;
  double range = options.data_range;
  if (!(range > 0.0)) {
    auto p = store.peak(options.verify);
    if (!p) return p.error();
    range = *p;
    st.bytes_read += info.data_bytes();
  }
  std::vector<float> ref(group * n * 3), rec(group * n * 3);
  std::vector<uint8_t> scratch;
  BtfErrorAccumulator sums(range);  // the sums compare_btfs() forms, in its order
  const size_t images = nv * nl;
  size_t done = 0;
  for (size_t v = 0; v < nv; ++v)
    for (size_t l0 = 0; l0 < nl; l0 += group) {
      const size_t l1 = std::min(nl, l0 + group);
      const std::span<float> ref_span(ref.data(), (l1 - l0) * n * 3);
      if (auto s = store.read_view_images(v, l0, l1, ref_span, scratch, options.verify); !s) return s.error();
      st.bytes_read += static_cast<uint64_t>(nl) * n * 3 * info.value_size();
      ++st.groups;
      for (size_t l = l0; l < l1; ++l) {
        const std::span<float> out(rec.data() + (l - l0) * n * 3, n * 3);
        if (auto s = approx(v, l, out); !s) return s.error();
        const ImageView<const float> a(ref.data() + (l - l0) * n * 3, info.width, info.height, 3);
        sums.add(a, ImageView<const float>(out.data(), info.width, info.height, 3));
      }
      done += l1 - l0;
      if (options.progress && !options.progress("evaluate", static_cast<double>(done) / static_cast<double>(images)))
        return make_error(Status::cancelled, "%s: evaluation cancelled", store.path().c_str());
    }
  if (stats) *stats = st;
  return sums.report();
}

/// Image (view, light) of an FMF reconstruction D(U·(VΣ)ᵀ) into `out` (H × W × 3 floats, the
/// TabulatedBtf image layout): the same product Fmf::reconstruct() forms for that image, so the
/// values are identical to the whole reconstruction's. Returns invalid_argument for an index or
/// size mismatch. Allocation-free apart from Eigen's product temporaries; thread-safe.
inline VoidResult fmf_reconstruct_image(const Fmf& f, size_t view, size_t light, std::span<float> out) {
  const size_t nv = f.shape.view_count(), nl = f.shape.light_count(), n = f.shape.texel_count();
  if (view >= nv || light >= nl || out.size() != n * 3 || f.components <= 0 ||
      f.u.size() != nv * nl * 3 * static_cast<size_t>(f.components) ||
      f.v.size() != n * static_cast<size_t>(f.components))
    return make_error(Status::invalid_argument, "FMF image (%zu, %zu): shape mismatch", view, light);
  using RowMat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Eigen::Index m = static_cast<Eigen::Index>(nv * nl * 3);
  Eigen::Map<const RowMat> um(f.u.data(), m, f.components);
  Eigen::Map<const RowMat> vm(f.v.data(), static_cast<Eigen::Index>(n), f.components);
  const size_t i = view * nl + light;
  Eigen::Map<Eigen::MatrixXf> img(out.data(), 3, static_cast<Eigen::Index>(n));
  img.noalias() = um.middleRows(static_cast<Eigen::Index>(3 * i), 3) * vm.transpose();
  if (!f.transform.is_linear())
    f.transform.decode_triples(out.data(), out.size());  // f.transform's decode, as reconstruct() applies
  return {};
}

}  // namespace btflod
