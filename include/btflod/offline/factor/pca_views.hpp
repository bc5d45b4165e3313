// btflod — PCA over groups of k neighbouring views, paper 004 §4.3 (after Borshukov et al.).
//
// For each group g of k consecutive view indices (in the UBO orderings consecutive indices are
// angular neighbours on a ring), A_g has one row per texel and one column per
// (view in group, light, colour): column ((v − first)·n_light + l)·3 + c. The rows are
// mean-centred (m_t = mean of row t), B = A − m·1ᵀ = U Σ Vᵀ is truncated to C components and
// stored as L = [m | UΣ] (texels × (C+1)) and R = [1; Vᵀ] ((C+1) × columns), so A ≈ L·R
// (paper 004 §4.3.2). k = 1 is PCA-RF, k = n_view is PCA-BTF.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/factor/factor_file.hpp"
#include "btflod/offline/factor/truncated_svd.hpp"
#include "btflod/offline/math/eigen.hpp"  // Eigen as a system header

namespace btflod {

/// Options of factorize_pca_views().
struct PcaViewsOptions {
  int views_per_group = 3;  ///< k; 0 or ≥ n_view means all views (PCA-BTF)
  int components = 8;       ///< C per group
  SvdOptions svd{};
};

/// One group of consecutive views with its L and R matrices.
struct PcaViewGroup {
  uint32_t first_view = 0;
  uint32_t view_count = 0;
  int components = 0;  ///< C (L has C + 1 columns)
  /// L = [m | UΣ], row-major texels × (C + 1).
  std::vector<float> l;
  /// R = [1; Vᵀ], row-major (C + 1) × (view_count·n_light·3).
  std::vector<float> r;
};

/// The PCA-k representation (paper 004 §4.3).
struct PcaViews {
  BtfShape shape;
  int views_per_group = 0;
  std::vector<PcaViewGroup> groups;

  /// Reconstructed RGB at texel (x, y) for measured view and light indices:
  /// Σ_k L_{t,k} R_{k, col}. Precondition: indices in range. Thread-safe, allocation-free.
  glm::vec3 evaluate_measured(int x, int y, uint32_t view, uint32_t light) const noexcept {
    assert(view < shape.view_count() && light < shape.light_count());
    const auto& g = groups[view / static_cast<uint32_t>(views_per_group)];
    const size_t cols = static_cast<size_t>(g.view_count) * shape.light_count() * 3;
    const size_t kk = static_cast<size_t>(g.components) + 1;
    const size_t t = static_cast<size_t>(y) * static_cast<size_t>(shape.width) + static_cast<size_t>(x);
    const size_t col = ((view - g.first_view) * shape.light_count() + light) * 3;
    const float* lrow = g.l.data() + t * kk;
    glm::vec3 out(0.0f);
    for (size_t k = 0; k < kk; ++k) {
      const float* rr = g.r.data() + k * cols + col;
      out += lrow[k] * glm::vec3(rr[0], rr[1], rr[2]);
    }
    return out;
  }
  /// Interpolated evaluation: 3 × 3 taps of the light and view samples, weights multiplied.
  glm::vec3 evaluate(int x, int y, const AngularSample& light, const AngularSample& view) const noexcept {
    return combine_angular_taps(light, view, [&](uint32_t vi, uint32_t li) { return evaluate_measured(x, y, vi, li); });
  }
  /// Bytes of all L and R matrices as float32.
  size_t size_bytes() const noexcept {
    size_t s = 0;
    for (const auto& g : groups) s += (g.l.size() + g.r.size()) * sizeof(float);
    return s;
  }
  double compression_ratio() const noexcept {
    return size_bytes() ? static_cast<double>(shape.float_bytes()) / static_cast<double>(size_bytes()) : 0.0;
  }
  /// Full reconstruction L·R of every group (allocates the BTF).
  BtfFloat reconstruct() const {
    BtfFloat out(shape.width, shape.height, shape.views, shape.lights);
    using RowMat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const size_t n = shape.texel_count(), nl = shape.light_count();
    for (const auto& g : groups) {
      const Eigen::Index kk = g.components + 1;
      const Eigen::Index cols = static_cast<Eigen::Index>(g.view_count * nl * 3);
      const RowMat a = Eigen::Map<const RowMat>(g.l.data(), static_cast<Eigen::Index>(n), kk) *
                       Eigen::Map<const RowMat>(g.r.data(), kk, cols);
      for (size_t vv = 0; vv < g.view_count; ++vv)
        for (size_t l = 0; l < nl; ++l)
          for (size_t t = 0; t < n; ++t)
            for (size_t c = 0; c < 3; ++c)
              out.samples()[(((g.first_view + vv) * nl + l) * n + t) * 3 + c] =
                  a(static_cast<Eigen::Index>(t), static_cast<Eigen::Index>((vv * nl + l) * 3 + c));
    }
    return out;
  }

  /// Serialises (sections SHAP, META = {k, group count, per group: first, count, C}, and
  /// PL%02u / PR%02u… packed as one LALL and one RALL float array in group order).
  std::vector<uint8_t> serialize() const {
    FactorFileWriter w(FactorKind::pca_views);
    w.add_shape(shape);
    ByteWriter meta;
    meta.u32(static_cast<uint32_t>(views_per_group));
    meta.u32(static_cast<uint32_t>(groups.size()));
    std::vector<float> lall, rall;
    for (const auto& g : groups) {
      meta.u32(g.first_view);
      meta.u32(g.view_count);
      meta.u32(static_cast<uint32_t>(g.components));
      lall.insert(lall.end(), g.l.begin(), g.l.end());
      rall.insert(rall.end(), g.r.begin(), g.r.end());
    }
    w.add(factor_tag("META"), meta.take());
    w.add_array<float>(factor_tag("LALL"), lall);
    w.add_array<float>(factor_tag("RALL"), rall);
    return w.finish();
  }
  /// Parses a serialised PCA-k. Safe for untrusted input (checks the grouping covers every
  /// view exactly once in order, component counts, and array sizes).
  static Result<PcaViews> deserialize(std::span<const uint8_t> bytes) {
    auto head = parse_factor_file_head(bytes, FactorKind::pca_views, "PCA-k");
    if (!head) return head.error();
    const FactorFile& file = head->file;
    ByteReader r(head->meta);
    PcaViews p;
    p.shape = std::move(head->shape);
    const uint32_t k = r.u32(), count = r.u32();
    const size_t nv = p.shape.view_count(), nl = p.shape.light_count(), n = p.shape.texel_count();
    if (!r.ok() || k == 0 || k > nv || count != (nv + k - 1) / k || r.remaining() != static_cast<size_t>(count) * 12)
      return make_error(Status::bad_data, "PCA-k: META k=%u, %u groups inconsistent with %zu views", k, count, nv);
    p.views_per_group = static_cast<int>(k);
    size_t lsize = 0, rsize = 0;
    for (uint32_t i = 0; i < count; ++i) {
      PcaViewGroup g;
      g.first_view = r.u32();
      g.view_count = r.u32();
      const uint32_t c = r.u32();
      const size_t cols = static_cast<size_t>(g.view_count) * nl * 3;
      if (g.first_view != i * k || g.view_count != std::min<size_t>(k, nv - i * k) || c > std::min(n, cols))
        return make_error(Status::bad_data, "PCA-k: group %u (first %u, %u views, %u comps) is invalid", i,
                          g.first_view, g.view_count, c);
      g.components = static_cast<int>(c);
      if (static_cast<size_t>(c) + 1 > bytes.size() / (4 * (n + cols)))  // division: no overflow
        return make_error(Status::short_output, "PCA-k: group %u with %u components needs more than %zu bytes", i, c,
                          bytes.size());
      lsize += n * (c + 1);
      rsize += (c + 1) * cols;
      p.groups.push_back(std::move(g));
    }
    if ((lsize + rsize) * 4 > bytes.size())
      return make_error(Status::short_output, "PCA-k: groups need %zu bytes, file has %zu", (lsize + rsize) * 4,
                        bytes.size());
    std::vector<float> lall, rall;
    if (auto s = file.read_array<float>(factor_tag("LALL"), lsize, lall); !s) return s.error();
    if (auto s = file.read_array<float>(factor_tag("RALL"), rsize, rall); !s) return s.error();
    size_t lo = 0, ro = 0;
    for (auto& g : p.groups) {
      const size_t ls = n * static_cast<size_t>(g.components + 1);
      const size_t rs = static_cast<size_t>(g.components + 1) * g.view_count * nl * 3;
      g.l.assign(lall.begin() + static_cast<ptrdiff_t>(lo), lall.begin() + static_cast<ptrdiff_t>(lo + ls));
      g.r.assign(rall.begin() + static_cast<ptrdiff_t>(ro), rall.begin() + static_cast<ptrdiff_t>(ro + rs));
      lo += ls;
      ro += rs;
    }
    return p;
  }
};

/// Factorises `btf` into PCA over groups of k neighbouring views (paper 004 §4.3). Each group
/// is one truncated SVD (options.svd) of the mean-centred texels × columns matrix. Returns an
/// error for an empty BTF or components < 1; Status::cancelled when progress returns false.
inline Result<PcaViews> factorize_pca_views(const BtfFloat& btf, const PcaViewsOptions& options = {},
                                            const ProgressCallback& progress = {}) {
  if (btf.empty() || options.components < 1)
    return make_error(Status::invalid_argument, "factorize_pca_views: empty BTF or components %d < 1",
                      options.components);
  PcaViews p;
  p.shape = BtfShape{btf.width(), btf.height(), btf.views(), btf.lights()};
  const size_t nv = btf.view_count(), nl = btf.light_count(), n = btf.texel_count();
  const size_t k =
      options.views_per_group <= 0 ? nv : std::min<size_t>(static_cast<size_t>(options.views_per_group), nv);
  p.views_per_group = static_cast<int>(k);
  const size_t group_count = (nv + k - 1) / k;
  using RowMat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  for (size_t gi = 0; gi < group_count; ++gi) {
    PcaViewGroup g;
    g.first_view = static_cast<uint32_t>(gi * k);
    g.view_count = static_cast<uint32_t>(std::min(k, nv - gi * k));
    const size_t cols = g.view_count * nl * 3;
    // A_g (texels × cols), then centre each row (paper 004 §4.3.1).
    Eigen::MatrixXf a(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(cols));
    for (size_t vv = 0; vv < g.view_count; ++vv)
      for (size_t l = 0; l < nl; ++l) {
        const float* img = btf.samples().data() + ((g.first_view + vv) * nl + l) * n * 3;
        for (size_t c = 0; c < 3; ++c)
          for (size_t t = 0; t < n; ++t)
            a(static_cast<Eigen::Index>(t), static_cast<Eigen::Index>((vv * nl + l) * 3 + c)) = img[t * 3 + c];
      }
    const Eigen::VectorXf mean = a.rowwise().mean();
    a.colwise() -= mean;
    auto svd = truncated_svd(a, options.components, options.svd);
    if (!svd) return svd.error();
    const Eigen::Index c = svd->s.size();
    g.components = static_cast<int>(c);
    g.l.resize(n * static_cast<size_t>(c + 1));
    g.r.resize(static_cast<size_t>(c + 1) * cols);
    Eigen::Map<RowMat> lm(g.l.data(), static_cast<Eigen::Index>(n), c + 1);
    Eigen::Map<RowMat> rm(g.r.data(), c + 1, static_cast<Eigen::Index>(cols));
    lm.col(0) = mean;  // L = [m | UΣ]
    lm.rightCols(c) = svd->u * svd->s.asDiagonal();
    rm.row(0).setOnes();  // R = [1; Vᵀ]
    rm.bottomRows(c) = svd->v.transpose();
    p.groups.push_back(std::move(g));
    if (!report_progress(progress, "pca-k", static_cast<double>(gi + 1) / static_cast<double>(group_count)))
      return make_error(Status::cancelled, "factorize_pca_views cancelled");
  }
  return p;
}

}  // namespace btflod
