// btflod — Full Matrix Factorisation (FMF) of a BTF, paper 000 §4, eq. 4–5.
//
// The BTF is the matrix A with rows r = (v·n_light + l)·3 + c (view, light, colour) and
// columns = texels t = y·W + x. A truncated SVD to rank C gives A ≈ U·Σ·Vᵀ; we keep
// U (m × C) and V := V·Σ (n × C, the "eigen-textures"), so that (eq. 5)
//   ρ'(x, l, v)_c = Σ_k U_k(l, v, c) · V_k(x).
// The "152nd basis illumination" of paper 000 §7 is stored as an extra ambient table per
// view: U_amb(v, c) = Σ_l w_l · U(l, v, c) with cosine weights w_l = cos θ_l / Σ cos θ_l', i.e.
// the cosine-weighted mean reflectance under a uniform white environment.
//
// FmfOptions::transform factorises E(A) instead of A (core/value_transform.hpp: a square-root or
// log dynamic-range reduction for glossy materials, as Bonn's DFMF does) and the evaluation
// decodes the sum of eq. 5 after the angular interpolation, as the shaders do.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "btflod/core/file_io.hpp"
#include "btflod/core/value_transform.hpp"
#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/factor/factor_file.hpp"
#include "btflod/offline/factor/truncated_svd.hpp"
#include "btflod/offline/math/eigen.hpp"  // Eigen as a system header

namespace btflod {

/// Options of factorize_fmf().
struct FmfOptions {
  int components = 16;  ///< rank C
  SvdOptions svd{};
  /// The domain the factorisation is computed in (linear: paper 000 as printed).
  ValueTransform transform{};
};

/// A BTF as rank-C factors U (angular) and V·Σ (spatial), paper 000 eq. 4–5.
struct Fmf {
  BtfShape shape;
  int components = 0;
  /// U, row-major (m × C): row (v·n_light + l)·3 + c.
  std::vector<float> u;
  /// V·Σ, row-major (texels × C): row y·W + x.
  std::vector<float> v;
  /// Ambient basis (paper 000 §7), row-major (n_view·3 × C): row v·3 + c.
  std::vector<float> u_ambient;
  /// Singular values of the kept components (diagnostic; not needed for evaluation).
  std::vector<float> singular_values;
  /// The encoding U·(VΣ)ᵀ approximates (FmfOptions::transform); evaluation decodes it.
  ValueTransform transform{};
  /// How the SVD went (iterations, error estimate; truncated_svd.hpp). Diagnostic: not
  /// serialised (a deserialised Fmf has the default report).
  SvdReport svd_report;

  /// ρ' at texel (x, y), measured view index `view` and light index `light`, RGB: the decoded
  /// sum of eq. 5. Precondition: indices in range (asserted in debug). Thread-safe, allocation-free.
  glm::vec3 evaluate_measured(int x, int y, uint32_t view, uint32_t light) const noexcept {
    return decode(evaluate_encoded(x, y, view, light));
  }
  /// The sum of eq. 5 before decoding (= evaluate_measured() for a linear transform).
  glm::vec3 evaluate_encoded(int x, int y, uint32_t view, uint32_t light) const noexcept {
    assert(x >= 0 && x < shape.width && y >= 0 && y < shape.height && view < shape.view_count() &&
           light < shape.light_count());
    const size_t cc = static_cast<size_t>(components);
    const float* vt =
        v.data() + (static_cast<size_t>(y) * static_cast<size_t>(shape.width) + static_cast<size_t>(x)) * cc;
    const float* ur = u.data() + (static_cast<size_t>(view) * shape.light_count() + light) * 3 * cc;
    glm::vec3 out(0.0f);
    for (size_t k = 0; k < cc; ++k) {
      out.r += ur[k] * vt[k];
      out.g += ur[cc + k] * vt[k];
      out.b += ur[2 * cc + k] * vt[k];
    }
    return out;
  }
  /// ρ' at texel (x, y) for interpolated light and view directions: the 3 × 3 taps of the two
  /// AngularSamples with multiplied weights. Thread-safe, allocation-free.
  /// The taps are combined before decoding, as the shaders do.
  glm::vec3 evaluate(int x, int y, const AngularSample& light, const AngularSample& view) const noexcept {
    return decode(
        combine_angular_taps(light, view, [&](uint32_t vi, uint32_t li) { return evaluate_encoded(x, y, vi, li); }));
  }
  /// D(s) of a summed RGB triple (the identity for a linear transform).
  glm::vec3 decode(glm::vec3 s) const noexcept {
    if (!transform.is_linear()) transform.decode_rgb(&s.x);
    return s;
  }
  /// The view-dependent ambient term at texel (x, y) (paper 000 §7): the cosine-weighted mean of
  /// U's rows, decoded (for a non-linear transform a mean in the encoded domain, not of ρ').
  /// Thread-safe.
  glm::vec3 evaluate_ambient(int x, int y, const AngularSample& view) const noexcept {
    const size_t cc = static_cast<size_t>(components);
    const float* vt =
        v.data() + (static_cast<size_t>(y) * static_cast<size_t>(shape.width) + static_cast<size_t>(x)) * cc;
    glm::vec3 out(0.0f);
    for (int i = 0; i < 3; ++i) {
      const float w = view.weight[static_cast<size_t>(i)];
      if (w == 0.0f) continue;
      const float* ur = u_ambient.data() + static_cast<size_t>(view.index[static_cast<size_t>(i)]) * 3 * cc;
      for (size_t k = 0; k < cc; ++k) {
        out.r += w * ur[k] * vt[k];
        out.g += w * ur[cc + k] * vt[k];
        out.b += w * ur[2 * cc + k] * vt[k];
      }
    }
    return decode(out);
  }

  /// Bytes of the factors as float32 (U, V·Σ and the ambient table).
  size_t size_bytes() const noexcept { return (u.size() + v.size() + u_ambient.size()) * sizeof(float); }
  /// Float32 source BTF bytes / size_bytes().
  double compression_ratio() const noexcept {
    return size_bytes() ? static_cast<double>(shape.float_bytes()) / static_cast<double>(size_bytes()) : 0.0;
  }

  /// The full reconstruction U·(VΣ)ᵀ as a BTF (allocates the BTF).
  BtfFloat reconstruct() const {
    BtfFloat out(shape.width, shape.height, shape.views, shape.lights);
    const Eigen::Index m = static_cast<Eigen::Index>(shape.view_count() * shape.light_count() * 3);
    const Eigen::Index n = static_cast<Eigen::Index>(shape.texel_count());
    using RowMat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    Eigen::Map<const RowMat> um(u.data(), m, components);
    Eigen::Map<const RowMat> vm(v.data(), n, components);
    const size_t nvl = shape.view_count() * shape.light_count();
    // Image i occupies rows 3i..3i+2; its memory is a 3 × n column-major block.
    for (size_t i = 0; i < nvl; ++i) {
      Eigen::Map<Eigen::MatrixXf> img(out.samples().data() + i * static_cast<size_t>(n) * 3, 3, n);
      img.noalias() = um.middleRows(static_cast<Eigen::Index>(3 * i), 3) * vm.transpose();
    }
    if (!transform.is_linear()) transform.decode_triples(out.samples().data(), out.samples().size());  // RGB innermost
    return out;
  }

  /// Serialises to the factor file format (factor_file.hpp; sections SHAP, META, FMFU, FMFV,
  /// FMFA, FMFS, and VENC — encoding u32, log offset f32 — for a non-linear transform). Allocates.
  std::vector<uint8_t> serialize() const {
    FactorFileWriter w(FactorKind::fmf);
    w.add_shape(shape);
    ByteWriter meta;
    meta.u32(static_cast<uint32_t>(components));
    w.add(factor_tag("META"), meta.take());
    w.add_array<float>(factor_tag("FMFU"), u);
    w.add_array<float>(factor_tag("FMFV"), v);
    w.add_array<float>(factor_tag("FMFA"), u_ambient);
    w.add_array<float>(factor_tag("FMFS"), singular_values);
    if (!transform.is_linear()) {
      ByteWriter venc;
      venc.u32(static_cast<uint32_t>(transform.encoding));
      venc.f32(transform.log_offset);
      w.add(factor_tag("VENC"), venc.take());
    }
    return w.finish();
  }
  /// Parses a serialised FMF. Safe for untrusted input: every size is checked against the
  /// shape; returns an error naming the bad section.
  static Result<Fmf> deserialize(std::span<const uint8_t> bytes) {
    auto head = parse_factor_file_head(bytes, FactorKind::fmf, "FMF");
    if (!head) return head.error();
    const FactorFile& file = head->file;
    const BtfShape& shape = head->shape;
    ByteReader r(head->meta);
    const uint32_t comps = r.u32();
    if (!r.ok() || r.remaining() != 0)
      return make_error(Status::bad_data, "FMF: META has %zu bytes, expected 4", head->meta.size());
    const size_t m = shape.view_count() * shape.light_count() * 3;
    const size_t n = shape.texel_count();
    if (comps == 0 || comps > std::min(m, n))
      return make_error(Status::bad_data, "FMF: %u components for a %zu x %zu matrix", comps, m, n);
    const size_t remaining = bytes.size();
    // Division instead of a product: comps·(m + n)·4 may overflow for hostile shapes.
    if (comps > remaining / ((m + n + shape.view_count() * 3) * 4))
      return make_error(Status::short_output, "FMF: %u components need more than the %zu bytes of the file", comps,
                        remaining);
    Fmf f;
    f.shape = std::move(head->shape);
    f.components = static_cast<int>(comps);
    if (auto s = file.read_array<float>(factor_tag("FMFU"), m * comps, f.u); !s) return s.error();
    if (auto s = file.read_array<float>(factor_tag("FMFV"), n * comps, f.v); !s) return s.error();
    if (auto s = file.read_array<float>(factor_tag("FMFA"), f.shape.view_count() * 3 * comps, f.u_ambient); !s)
      return s.error();
    if (auto s = file.read_array<float>(factor_tag("FMFS"), comps, f.singular_values); !s) return s.error();
    if (file.has_section(factor_tag("VENC"))) {
      auto venc = file.section(factor_tag("VENC"));
      if (!venc) return venc.error();
      ByteReader vr(*venc);
      f.transform.encoding = static_cast<ValueEncoding>(vr.u32());
      f.transform.log_offset = vr.f32();
      if (!vr.ok() || vr.remaining() != 0 || f.transform.is_linear() || !f.transform.valid())
        return make_error(Status::bad_data, "FMF: VENC (%zu bytes) holds no valid non-linear value transform",
                          venc->size());
    }
    return f;
  }
};

/// Copies columns (texels) [t0, t0 + count) of the FMF matrix of `btf` into `out` (m × count,
/// already sized): out(r, j) with r = (v·n_light + l)·3 + c. Thread-safe for disjoint outputs.
/// Memory order: the texel range of image i is a contiguous 3 × count block; 16 images are
/// copied together, column by column, so every column receives 48 consecutive floats (whole
/// cache lines) from 16 sequential read streams. Copying image by image instead wrote 12 bytes
/// into each of `count` columns per image and ran at 0.3–0.4× this rate (docs/factor.md,
/// "Throughput").
inline void gather_fmf_columns(const BtfFloat& btf, size_t t0, size_t count, Eigen::MatrixXf& out) {
  const size_t nvl = btf.view_count() * btf.light_count();
  const size_t n = btf.texel_count();
  const float* base = btf.samples().data();
  const size_t ld = static_cast<size_t>(out.rows());
  constexpr size_t kGroup = 16;
  const float* src[kGroup];
  for (size_t i0 = 0; i0 < nvl; i0 += kGroup) {
    const size_t gi = std::min(kGroup, nvl - i0);
    for (size_t g = 0; g < gi; ++g) src[g] = base + ((i0 + g) * n + t0) * 3;
    for (size_t j = 0; j < count; ++j) {
      float* d = out.data() + j * ld + 3 * i0;
      for (size_t g = 0; g < gi; ++g) std::memcpy(d + 3 * g, src[g] + 3 * j, 3 * sizeof(float));
    }
  }
}

/// E over the first `count` columns of a gathered block (FmfOptions::transform). Each column's
/// rows are (image · 3 + colour): RGB triples are consecutive.
inline void encode_columns(const ValueTransform& t, size_t count, Eigen::MatrixXf& block) {
  for (Eigen::Index j = 0; j < static_cast<Eigen::Index>(count); ++j)
    t.encode_triples(block.col(j).data(), static_cast<size_t>(block.rows()));
}

/// Cosine weights of the ambient term: w_l = max(cos θ_l, 0) / Σ (uniform if all are 0).
inline std::vector<float> ambient_light_weights(const DirectionSet& lights) {
  std::vector<float> w(lights.size());
  double sum = 0.0;
  for (size_t l = 0; l < lights.size(); ++l) {
    w[l] = std::max(0.0f, lights[l].vector.z);
    sum += w[l];
  }
  for (auto& x : w) x = sum > 0.0 ? static_cast<float>(x / sum) : 1.0f / static_cast<float>(w.size());
  return w;
}

/// Factorises `btf` by truncated SVD (paper 000 §4): exact BDCSVD or the blocked randomised
/// SVD per options.svd. Returns the factors, or an error for an empty BTF / bad rank, or
/// Status::cancelled. Uses options.svd.pool for threads. Memory: randomised path ≈ input +
/// O((m + n)·C); exact path materialises a copy of the matrix.
inline Result<Fmf> factorize_fmf(const BtfFloat& btf, const FmfOptions& options = {},
                                 const ProgressCallback& progress = {}) {
  if (btf.empty()) return make_error(Status::invalid_argument, "factorize_fmf: empty BTF");
  const size_t m = btf.view_count() * btf.light_count() * 3;
  const size_t n = btf.texel_count();
  if (!options.transform.valid()) return make_error(Status::invalid_argument, "factorize_fmf: invalid value transform");
  const ValueTransform tr = options.transform;
  auto svd = truncated_svd(
      m, n, options.components,
      [&btf, tr](size_t t0, size_t count, Eigen::MatrixXf& out) {
        gather_fmf_columns(btf, t0, count, out);
        if (!tr.is_linear()) encode_columns(tr, count, out);
      },
      options.svd, progress);
  if (!svd) return svd.error();
  Fmf f;
  f.shape = BtfShape{btf.width(), btf.height(), btf.views(), btf.lights()};
  const Eigen::Index c = svd->s.size();
  f.components = static_cast<int>(c);
  using RowMat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  f.u.resize(m * static_cast<size_t>(c));
  f.v.resize(n * static_cast<size_t>(c));
  Eigen::Map<RowMat>(f.u.data(), static_cast<Eigen::Index>(m), c) = svd->u;
  Eigen::Map<RowMat>(f.v.data(), static_cast<Eigen::Index>(n), c) = svd->v * svd->s.asDiagonal();  // V := VΣ
  f.singular_values.assign(svd->s.data(), svd->s.data() + c);
  f.svd_report = svd->report;
  f.transform = tr;
  // Ambient basis (paper 000 §7).
  const auto w = ambient_light_weights(btf.lights());
  const size_t nl = btf.light_count(), cc = static_cast<size_t>(c);
  f.u_ambient.assign(btf.view_count() * 3 * cc, 0.0f);
  for (size_t vi = 0; vi < btf.view_count(); ++vi)
    for (size_t l = 0; l < nl; ++l)
      for (size_t ch = 0; ch < 3; ++ch)
        for (size_t k = 0; k < cc; ++k)
          f.u_ambient[(vi * 3 + ch) * cc + k] += w[l] * f.u[((vi * nl + l) * 3 + ch) * cc + k];
  return f;
}

}  // namespace btflod
