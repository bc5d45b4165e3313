// btflod — Laplacian-pyramid PCA with continuous LOD, paper 001 §3 (Ma et al.).
//
// Every BTF image is converted to YCbCr (BT.601, offline/metrics/image_metrics.hpp) and split per
// channel into a Laplacian pyramid (eq. 2–3): F_{k+1} = ↓(g ∗ F_k) with a 3×3 box filter g
// (clamped borders) and ↓ keeping every second texel, L_k = F_k − ↑F_{k+1} with nearest
// up-sampling ↑F(x, y) = F(x/2, y/2). Pyramid indices are GPU-style `mip` numbers as in the
// paper: mip 0 = finest band, mip λmax = the low-pass top (DESIGN.md: "mip" = 0 is finest).
//
// Per mip and channel the "Laplacian BTF" (texels × images) is compressed by an uncentred PCA
// (eq. 4; the Laplacian mean is ≈ 0): L ≈ D·Eᵀ, D = weights (texels × n), E = eigen Laplacian
// BRDFs (images × n). At the top, the Y mean over texels μ(ω_i, ω_o) is fitted by Phong
// (eq. 5) with Levenberg–Marquardt and the Cb/Cr means by constants (eq. 6); the top PCA then
// compresses F_top − μ' so that with all components the pyramid reconstructs exactly.
// Evaluation is eq. 7: Σ_{k=⌊λ⌋}^{λmax} w_k D_kᵀE_k + μ', w_k = clamp(1 − λ + k, 0, 1).
#pragma once

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/factor/factor_file.hpp"
#include "btflod/offline/factor/levenberg_marquardt.hpp"
#include "btflod/offline/factor/truncated_svd.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"

namespace btflod {

/// Phong shading function of paper 001 eq. 5: k_a + k_d (N·L) + k_s (N·H)^α with N = +z.
struct PhongParams {
  float ka = 0.0f;
  float kd = 0.0f;
  float ks = 0.0f;
  float alpha = 1.0f;
  /// Evaluates eq. 5 for unit light `l` and view `v` (local frame). Cosines are clamped at 0.
  float evaluate(glm::vec3 l, glm::vec3 v) const noexcept {
    const float nl = std::max(l.z, 0.0f);
    const glm::vec3 h = l + v;
    const float len = glm::length(h);
    const float nh = len > 0.0f ? std::max(h.z / len, 0.0f) : 0.0f;
    return ka + kd * nl + ks * (nh > 0.0f ? std::pow(nh, alpha) : 0.0f);
  }
};

/// Fits PhongParams to samples target[v·n_light + l] at (lights[l], views[v]) by
/// Levenberg–Marquardt (offline/factor/levenberg_marquardt.hpp: Eigen's MINPACK-style LM, analytic
/// Jacobian; the same solver as the SPMM fit), started from the best linear least-squares fit
/// over a ladder of exponents. α is kept in [0, 10⁴]. Returns the parameters
/// (deterministic). `max_iterations` bounds the LM iterations (as residual evaluations
/// 10·max_iterations). Precondition: target has n_view·n_light values.
PhongParams fit_phong_lm(const DirectionSet& views, const DirectionSet& lights, std::span<const float> target,
                         int max_iterations = 200);

/// Options of factorize_laplacian_pca(). Defaults follow paper 001 §3.3 (8 / 2 / 2).
struct LaplacianPcaOptions {
  int mip_count = 0;                       ///< λmax (bands below the top); 0 = automatic (halve while the next
                                           ///< mip has at least 2·components_y texels, as §3.2 stops the pyramid)
  std::array<int, 3> components{8, 2, 2};  ///< Y, Cb, Cr
  SvdOptions svd{};
};

/// One pyramid mip: weights D (texels × n, row-major) and eigen Laplacian BRDFs E
/// (images × n, row-major, image = v·n_light + l) per YCbCr channel.
struct LaplacianMip {
  int width = 0;
  int height = 0;
  std::array<int, 3> components{0, 0, 0};
  std::array<std::vector<float>, 3> weights;
  std::array<std::vector<float>, 3> eigen;
};

/// The Laplacian-pyramid PCA representation (paper 001 §3).
struct LaplacianPca {
  BtfShape shape;
  std::vector<LaplacianMip> mips;  ///< mip 0 (finest band) … mip λmax (top, low-pass residual)
  PhongParams phong;               ///< Y mean of the top (eq. 5)
  float cb_mean = 0.0f;            ///< eq. 6
  float cr_mean = 0.0f;

  int lambda_max() const noexcept { return static_cast<int>(mips.size()) - 1; }

  /// Eq. 7 at texel (x, y) of the finest level, measured view/light, continuous LOD λ ∈
  /// [0, λmax] (clamped). RGB. Thread-safe, allocation-free. Precondition: indices in range.
  glm::vec3 evaluate_measured(int x, int y, uint32_t view, uint32_t light, float lambda) const noexcept {
    const int lmax = lambda_max();
    lambda = std::clamp(lambda, 0.0f, static_cast<float>(lmax));
    const size_t image = static_cast<size_t>(view) * shape.light_count() + light;
    float ycc[3] = {phong.evaluate(shape.lights[light].vector, shape.views[view].vector), cb_mean, cr_mean};
    for (int k = static_cast<int>(std::floor(lambda)); k <= lmax; ++k) {
      const float wk = std::clamp(1.0f - lambda + static_cast<float>(k), 0.0f, 1.0f);
      if (wk == 0.0f) continue;
      const LaplacianMip& m = mips[static_cast<size_t>(k)];
      const int tx = std::min(x >> k, m.width - 1), ty = std::min(y >> k, m.height - 1);
      const size_t t = static_cast<size_t>(ty) * static_cast<size_t>(m.width) + static_cast<size_t>(tx);
      for (int ch = 0; ch < 3; ++ch) {
        const size_t n = static_cast<size_t>(m.components[static_cast<size_t>(ch)]);
        const float* d = m.weights[static_cast<size_t>(ch)].data() + t * n;
        const float* e = m.eigen[static_cast<size_t>(ch)].data() + image * n;
        float s = 0.0f;
        for (size_t j = 0; j < n; ++j) s += d[j] * e[j];
        ycc[ch] += wk * s;
      }
    }
    const auto rgb = ycbcr_to_rgb(ycc[0], ycc[1], ycc[2]);
    return {rgb[0], rgb[1], rgb[2]};
  }
  /// Eq. 7 with interpolated directions (3 × 3 taps, weights multiplied). Thread-safe.
  glm::vec3 evaluate(int x, int y, const AngularSample& light, const AngularSample& view, float lambda) const noexcept {
    return combine_angular_taps(light, view,
                                [&](uint32_t vi, uint32_t li) { return evaluate_measured(x, y, vi, li, lambda); });
  }
  /// The whole BTF evaluated at one LOD λ (allocates).
  BtfFloat reconstruct(float lambda = 0.0f) const {
    return reconstruct_measured(
        shape, [&](int x, int y, uint32_t v, uint32_t l) { return evaluate_measured(x, y, v, l, lambda); });
  }

  /// Float32 bytes of all weights and eigen vectors plus the 6 mean parameters.
  size_t size_bytes() const noexcept {
    size_t s = 6 * sizeof(float);
    for (const auto& m : mips)
      for (int ch = 0; ch < 3; ++ch)
        s += (m.weights[static_cast<size_t>(ch)].size() + m.eigen[static_cast<size_t>(ch)].size()) * sizeof(float);
    return s;
  }
  double compression_ratio() const noexcept {
    return static_cast<double>(shape.float_bytes()) / static_cast<double>(size_bytes());
  }
  /// Paper 001 §3.3 eigen Laplacian BRDF map: RGBA float32 texels, ⌈n_total/4⌉ per image and
  /// mip → 16·⌈n/4⌉·p·q·(λmax+1) bytes (= 48pq(λmax+1) for 8 + 2 + 2 components).
  size_t packed_eigen_map_bytes() const noexcept {
    size_t s = 0;
    for (const auto& m : mips)
      s += 16 * static_cast<size_t>((m.components[0] + m.components[1] + m.components[2] + 3) / 4) *
           shape.view_count() * shape.light_count();
    return s;
  }
  /// Paper 001 §3.3 PCA weight map: RGBA float32, ⌈n_total/4⌉ texels per pyramid texel,
  /// summed over mips (the paper rounds this up to a 2r × 2r square, 64r² bytes).
  size_t packed_weight_map_bytes() const noexcept {
    size_t s = 0;
    for (const auto& m : mips)
      s += 16 * static_cast<size_t>((m.components[0] + m.components[1] + m.components[2] + 3) / 4) *
           static_cast<size_t>(m.width) * static_cast<size_t>(m.height);
    return s;
  }

  /// Serialises (SHAP; META = mip count, per mip width, height, 3 component counts; MEAN =
  /// phong ka kd ks α, cb, cr; WALL / EALL = weights / eigen vectors in mip, channel order).
  std::vector<uint8_t> serialize() const {
    FactorFileWriter w(FactorKind::laplacian_pca);
    w.add_shape(shape);
    ByteWriter meta;
    meta.u32(static_cast<uint32_t>(mips.size()));
    std::vector<float> wall, eall;
    for (const auto& m : mips) {
      meta.u32(static_cast<uint32_t>(m.width));
      meta.u32(static_cast<uint32_t>(m.height));
      for (int ch = 0; ch < 3; ++ch) {
        meta.u32(static_cast<uint32_t>(m.components[static_cast<size_t>(ch)]));
        wall.insert(wall.end(), m.weights[static_cast<size_t>(ch)].begin(), m.weights[static_cast<size_t>(ch)].end());
        eall.insert(eall.end(), m.eigen[static_cast<size_t>(ch)].begin(), m.eigen[static_cast<size_t>(ch)].end());
      }
    }
    w.add(factor_tag("META"), meta.take());
    const float means[6] = {phong.ka, phong.kd, phong.ks, phong.alpha, cb_mean, cr_mean};
    w.add_array<float>(factor_tag("MEAN"), means);
    w.add_array<float>(factor_tag("WALL"), wall);
    w.add_array<float>(factor_tag("EALL"), eall);
    return w.finish();
  }
  /// Parses a serialised Laplacian PCA. Safe for untrusted input: mip sizes must follow the
  /// halving rule from the shape, component counts are bounded, arrays sized exactly.
  static Result<LaplacianPca> deserialize(std::span<const uint8_t> bytes) {
    auto head = parse_factor_file_head(bytes, FactorKind::laplacian_pca, "Laplacian PCA");
    if (!head) return head.error();
    const FactorFile& file = head->file;
    LaplacianPca p;
    p.shape = std::move(head->shape);
    ByteReader r(head->meta);
    const uint32_t count = r.u32();
    if (!r.ok() || count == 0 || count > 17 || r.remaining() != static_cast<size_t>(count) * 20)
      return make_error(Status::bad_data, "Laplacian PCA: META declares %u mips in %zu bytes", count,
                        head->meta.size());
    const size_t images = p.shape.view_count() * p.shape.light_count();
    size_t wsize = 0, esize = 0;
    int w = p.shape.width, h = p.shape.height;
    for (uint32_t k = 0; k < count; ++k) {
      LaplacianMip m;
      m.width = static_cast<int>(r.u32());
      m.height = static_cast<int>(r.u32());
      if (m.width != w || m.height != h)
        return make_error(Status::bad_data, "Laplacian PCA: mip %u is %dx%d, expected %dx%d", k, m.width, m.height, w,
                          h);
      for (size_t ch = 0; ch < 3; ++ch) {
        const uint32_t c = r.u32();
        if (c > std::min<size_t>(images, static_cast<size_t>(w) * static_cast<size_t>(h)))
          return make_error(Status::bad_data, "Laplacian PCA: mip %u channel %zu has %u components", k, ch, c);
        m.components[ch] = static_cast<int>(c);
        if (c > bytes.size() / (4 * (static_cast<size_t>(w) * static_cast<size_t>(h) + images)))  // no overflow
          return make_error(Status::short_output, "Laplacian PCA: mip %u channel %zu: %u components exceed the file", k,
                            ch, c);
        wsize += static_cast<size_t>(w) * static_cast<size_t>(h) * c;
        esize += images * c;
      }
      p.mips.push_back(std::move(m));
      w = (w + 1) / 2;
      h = (h + 1) / 2;
    }
    if ((wsize + esize) * 4 > bytes.size())
      return make_error(Status::short_output, "Laplacian PCA: mips need %zu bytes, file has %zu", (wsize + esize) * 4,
                        bytes.size());
    std::vector<float> means, wall, eall;
    if (auto s = file.read_array<float>(factor_tag("MEAN"), 6, means); !s) return s.error();
    if (auto s = file.read_array<float>(factor_tag("WALL"), wsize, wall); !s) return s.error();
    if (auto s = file.read_array<float>(factor_tag("EALL"), esize, eall); !s) return s.error();
    p.phong = PhongParams{means[0], means[1], means[2], means[3]};
    if (!(p.phong.alpha >= 0.0f && p.phong.alpha <= 1e4f))
      return make_error(Status::bad_data, "Laplacian PCA: Phong exponent %g out of [0, 1e4]",
                        static_cast<double>(p.phong.alpha));
    p.cb_mean = means[4];
    p.cr_mean = means[5];
    size_t wo = 0, eo = 0;
    for (auto& m : p.mips)
      for (size_t ch = 0; ch < 3; ++ch) {
        const size_t ws =
            static_cast<size_t>(m.width) * static_cast<size_t>(m.height) * static_cast<size_t>(m.components[ch]);
        const size_t es = images * static_cast<size_t>(m.components[ch]);
        m.weights[ch].assign(wall.begin() + static_cast<ptrdiff_t>(wo), wall.begin() + static_cast<ptrdiff_t>(wo + ws));
        m.eigen[ch].assign(eall.begin() + static_cast<ptrdiff_t>(eo), eall.begin() + static_cast<ptrdiff_t>(eo + es));
        wo += ws;
        eo += es;
      }
    return p;
  }
};

namespace detail {
/// F_{k+1} = ↓(g ∗ F_k): 3×3 box filter (clamped borders) sampled at even texels (eq. 2).
inline void box_downsample(const float* src, int w, int h, float* dst) {
  const int w2 = (w + 1) / 2, h2 = (h + 1) / 2;
  for (int y = 0; y < h2; ++y)
    for (int x = 0; x < w2; ++x) {
      float s = 0.0f;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int sx = std::clamp(2 * x + dx, 0, w - 1), sy = std::clamp(2 * y + dy, 0, h - 1);
          s += src[static_cast<size_t>(sy) * static_cast<size_t>(w) + static_cast<size_t>(sx)];
        }
      dst[static_cast<size_t>(y) * static_cast<size_t>(w2) + static_cast<size_t>(x)] = s / 9.0f;
    }
}
}  // namespace detail

/// Automatic λmax for a w×h BTF (see LaplacianPcaOptions::mip_count).
inline int laplacian_auto_mip_count(int width, int height, int components_y) {
  int k = 0;
  int w = width, h = height;
  const long need = 2L * std::max(1, components_y);
  while (true) {
    const int w2 = (w + 1) / 2, h2 = (h + 1) / 2;
    if ((w2 == w && h2 == h) || static_cast<long>(w2) * h2 < need) break;
    w = w2, h = h2, ++k;
  }
  return k;
}

/// Builds the Laplacian-pyramid PCA of `btf` (paper 001 §3). Returns an error for an empty BTF
/// or a mip count that does not fit the size; Status::cancelled when progress returns false.
/// Memory: the whole pyramid of coefficients (≈ 1.33 × the input) during construction.
Result<LaplacianPca> factorize_laplacian_pca(const BtfFloat& btf, const LaplacianPcaOptions& options = {},
                                             const ProgressCallback& progress = {});

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_FACTOR_IMPLEMENTATION)
// The Levenberg–Marquardt Phong fit (Eigen's LevenbergMarquardt) and the factorisation are compiled once, in the
// implementation TU.
namespace btflod {

PhongParams fit_phong_lm(const DirectionSet& views, const DirectionSet& lights, std::span<const float> target,
                         int max_iterations) {
  const size_t nv = views.size(), nl = lights.size(), count = nv * nl;
  std::vector<double> cl(count), ch(count);
  for (size_t v = 0; v < nv; ++v)
    for (size_t l = 0; l < nl; ++l) {
      const glm::vec3 lv = lights[l].vector, vv = views[v].vector;
      const glm::vec3 h = lv + vv;
      const float len = glm::length(h);
      cl[v * nl + l] = std::max(lv.z, 0.0f);
      ch[v * nl + l] = len > 0.0f ? std::max(h.z / len, 0.0f) : 0.0f;
    }
  auto powc = [](double c, double a) { return c > 0.0 ? std::pow(c, a) : 0.0; };
  auto cost = [&](const Eigen::Vector4d& p) {
    double s = 0.0;
    for (size_t i = 0; i < count; ++i) {
      const double r = target[i] - (p[0] + p[1] * cl[i] + p[2] * powc(ch[i], p[3]));
      s += r * r;
    }
    return s;
  };
  // Initial guess: linear least squares in (ka, kd, ks) for each α of a ladder.
  Eigen::Vector4d best(0, 0, 0, 1);
  double best_cost = INFINITY;
  for (double a : {1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0}) {
    Eigen::MatrixXd j(static_cast<Eigen::Index>(count), 3);
    Eigen::VectorXd y(static_cast<Eigen::Index>(count));
    for (size_t i = 0; i < count; ++i) {
      const auto ii = static_cast<Eigen::Index>(i);
      j(ii, 0) = 1.0;
      j(ii, 1) = cl[i];
      j(ii, 2) = powc(ch[i], a);
      y[ii] = target[i];
    }
    const Eigen::Vector3d k = j.colPivHouseholderQr().solve(y);
    const Eigen::Vector4d p(k[0], k[1], k[2], a);
    const double c = cost(p);
    if (c < best_cost) best_cost = c, best = p;
  }
  // Levenberg–Marquardt on r_i = model_i − target_i; α is clamped inside the model, so the
  // solver may step past the bounds without leaving the valid range.
  const auto n = static_cast<Eigen::Index>(count);
  auto residual = [&](const Eigen::VectorXd& q, Eigen::VectorXd& r) {
    const double a = std::clamp(q[3], 0.0, 1e4);
    for (size_t i = 0; i < count; ++i)
      r[static_cast<Eigen::Index>(i)] = q[0] + q[1] * cl[i] + q[2] * powc(ch[i], a) - target[i];
  };
  auto jacobian = [&](const Eigen::VectorXd& q, Eigen::MatrixXd& jac) {
    const double a = std::clamp(q[3], 0.0, 1e4);
    const bool inside = q[3] > 0.0 && q[3] < 1e4;
    for (size_t i = 0; i < count; ++i) {
      const auto ii = static_cast<Eigen::Index>(i);
      const double pw = powc(ch[i], a);
      jac(ii, 0) = 1.0;
      jac(ii, 1) = cl[i];
      jac(ii, 2) = pw;
      jac(ii, 3) = inside && ch[i] > 0.0 ? q[2] * pw * std::log(ch[i]) : 0.0;
    }
  };
  Eigen::VectorXd q = best;
  LeastSquaresOptions lo;
  lo.max_evaluations = 10 * std::max(1, max_iterations);
  lo.tolerance = 1e-12;
  if (n >= 4) minimize_least_squares(q, n, residual, jacobian, lo);
  q[3] = std::clamp(q[3], 0.0, 1e4);
  Eigen::Vector4d p = best;
  if (q.allFinite() && cost(Eigen::Vector4d(q)) <= best_cost) p = q;
  return PhongParams{static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2]),
                     static_cast<float>(p[3])};
}

Result<LaplacianPca> factorize_laplacian_pca(const BtfFloat& btf, const LaplacianPcaOptions& options,
                                             const ProgressCallback& progress) {
  if (btf.empty()) return make_error(Status::invalid_argument, "factorize_laplacian_pca: empty BTF");
  const int lmax = options.mip_count > 0 ? options.mip_count
                                         : laplacian_auto_mip_count(btf.width(), btf.height(), options.components[0]);
  int max_mips = 0;
  for (int w = btf.width(), h = btf.height(); w > 1 || h > 1; w = (w + 1) / 2, h = (h + 1) / 2) ++max_mips;
  if (lmax > max_mips)
    return make_error(Status::invalid_argument, "factorize_laplacian_pca: %d mips do not fit %dx%d (at most %d)", lmax,
                      btf.width(), btf.height(), max_mips);
  LaplacianPca p;
  p.shape = BtfShape{btf.width(), btf.height(), btf.views(), btf.lights()};
  const size_t nv = btf.view_count(), nl = btf.light_count(), images = nv * nl;
  std::vector<int> ws(static_cast<size_t>(lmax) + 1), hs(static_cast<size_t>(lmax) + 1);
  ws[0] = btf.width(), hs[0] = btf.height();
  for (int k = 1; k <= lmax; ++k)
    ws[static_cast<size_t>(k)] = (ws[static_cast<size_t>(k) - 1] + 1) / 2,
    hs[static_cast<size_t>(k)] = (hs[static_cast<size_t>(k) - 1] + 1) / 2;
  auto texels = [&](int k) {
    return static_cast<size_t>(ws[static_cast<size_t>(k)]) * static_cast<size_t>(hs[static_cast<size_t>(k)]);
  };
  // coef[k][ch]: texels_k × images, column-major (one column per BTF image).
  std::vector<std::array<Eigen::MatrixXf, 3>> coef(static_cast<size_t>(lmax) + 1);
  for (int k = 0; k <= lmax; ++k)
    for (auto& m : coef[static_cast<size_t>(k)])
      m.resize(static_cast<Eigen::Index>(texels(k)), static_cast<Eigen::Index>(images));
  ThreadPool& pool = options.svd.pool ? *options.svd.pool : default_thread_pool();
  pool.parallel_for(0, images, 8, [&](size_t i0, size_t i1) {
    std::vector<float> f, next;
    for (size_t i = i0; i < i1; ++i) {
      const float* img = btf.samples().data() + i * btf.texel_count() * 3;
      for (int ch = 0; ch < 3; ++ch) {
        f.resize(btf.texel_count());
        for (size_t t = 0; t < btf.texel_count(); ++t)
          f[t] = rgb_to_ycbcr(img[t * 3], img[t * 3 + 1], img[t * 3 + 2])[static_cast<size_t>(ch)];
        for (int k = 0; k < lmax; ++k) {
          const int w = ws[static_cast<size_t>(k)], w2 = ws[static_cast<size_t>(k) + 1];
          next.resize(texels(k + 1));
          detail::box_downsample(f.data(), w, hs[static_cast<size_t>(k)], next.data());
          float* col = coef[static_cast<size_t>(k)][static_cast<size_t>(ch)].col(static_cast<Eigen::Index>(i)).data();
          for (int y = 0; y < hs[static_cast<size_t>(k)]; ++y)
            for (int x = 0; x < w; ++x) {
              const size_t t = static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x);
              col[t] =
                  f[t] -
                  next[static_cast<size_t>(y >> 1) * static_cast<size_t>(w2) + static_cast<size_t>(x >> 1)];  // eq. 3
            }
          std::swap(f, next);
        }
        float* top = coef[static_cast<size_t>(lmax)][static_cast<size_t>(ch)].col(static_cast<Eigen::Index>(i)).data();
        std::copy(f.begin(), f.begin() + static_cast<ptrdiff_t>(texels(lmax)), top);
      }
    }
  });
  // Top means: Phong for Y (eq. 5, LM), constants for Cb and Cr (eq. 6); subtract them.
  auto& top = coef[static_cast<size_t>(lmax)];
  const Eigen::RowVectorXf ymean = top[0].colwise().mean();
  p.phong = fit_phong_lm(btf.views(), btf.lights(), std::span<const float>(ymean.data(), images));
  p.cb_mean = top[1].mean();
  p.cr_mean = top[2].mean();
  for (size_t v = 0; v < nv; ++v)
    for (size_t l = 0; l < nl; ++l)
      top[0].col(static_cast<Eigen::Index>(v * nl + l)).array() -=
          p.phong.evaluate(btf.lights()[l].vector, btf.views()[v].vector);
  top[1].array() -= p.cb_mean;
  top[2].array() -= p.cr_mean;
  // Per mip and channel: uncentred PCA (eq. 4).
  using RowMat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  p.mips.resize(static_cast<size_t>(lmax) + 1);
  for (int k = 0; k <= lmax; ++k) {
    LaplacianMip& m = p.mips[static_cast<size_t>(k)];
    m.width = ws[static_cast<size_t>(k)];
    m.height = hs[static_cast<size_t>(k)];
    for (size_t ch = 0; ch < 3; ++ch) {
      const Eigen::MatrixXf& a = coef[static_cast<size_t>(k)][ch];
      if (options.components[ch] <= 0) continue;
      auto svd = truncated_svd(a, options.components[ch], options.svd);
      if (!svd) return svd.error();
      const Eigen::Index c = svd->s.size();
      m.components[ch] = static_cast<int>(c);
      m.weights[ch].resize(static_cast<size_t>(a.rows() * c));
      m.eigen[ch].resize(static_cast<size_t>(a.cols() * c));
      Eigen::Map<RowMat>(m.weights[ch].data(), a.rows(), c) = svd->u * svd->s.asDiagonal();  // D
      Eigen::Map<RowMat>(m.eigen[ch].data(), a.cols(), c) = svd->v;                          // E
    }
    coef[static_cast<size_t>(k)] = {};
    if (!report_progress(progress, "laplacian pca", static_cast<double>(k + 1) / (lmax + 1)))
      return make_error(Status::cancelled, "factorize_laplacian_pca cancelled");
  }
  return p;
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
