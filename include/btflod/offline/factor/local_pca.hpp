// btflod — Local PCA (clustered eigen-BRDFs), paper 002 §3 after its reference [10]
// (Müller, Meseth, Klein 2003), with the 8-bit quantisation of paper 002 §6.3.
//
// Every texel's ABRDF x_t (d = n_view·n_light·3 values, index (v·n_light + l)·3 + c) belongs to
// one of K clusters; cluster j has a mean m_j and C orthonormal eigen-BRDFs E_j (d × C), and
// the texel stores C weights: x_t ≈ m_j + E_j·w_t. Clustering is iterative (ref. [10]):
// initial clusters from farthest-point seeds, then repeat { PCA per cluster; reassign every
// texel to the cluster with the smallest reconstruction error ‖x − m_j‖² − ‖E_jᵀ(x − m_j)‖² }
// until no texel changes cluster (or max_iterations).
//
// Quantisation (paper 002 §6.3): each eigen-BRDF e_{j,k} is stored as int8 q = round(127·e/s)
// with s_{j,k} = max|e_{j,k}|, and the scale is folded into the weights, w'_{t,k} = w_{t,k}·s_{j,k},
// so the shader evaluates m_j + Σ_k w'_k·(q_k/127) with no per-component rescaling (q/127 is
// what a GPU snorm8 texture returns).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/factor/factor_file.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/truncated_svd.hpp"
#include "btflod/offline/math/eigen.hpp"  // Eigen as a system header

namespace btflod {

/// Options of factorize_local_pca().
struct LocalPcaOptions {
  int clusters = 8;         ///< K
  int components = 4;       ///< C per cluster
  int max_iterations = 20;  ///< reclustering passes; 0 = initial clusters only
  bool quantize_8bit = true;
  SvdOptions svd{};
};

/// The Local PCA representation.
struct LocalPca {
  BtfShape shape;
  int clusters = 0;
  int components = 0;
  bool quantized = false;
  int iterations = 0;  ///< reclustering passes actually run (diagnostic)
  /// Total squared reconstruction error (float eigen-BRDFs, before quantisation) of the clusters
  /// and fits at the start of each reclustering pass; non-increasing. Diagnostic: not
  /// serialised.
  std::vector<double> error_history;
  /// Cluster per texel (texel = y·W + x).
  std::vector<uint16_t> cluster_of;
  /// Cluster means, K × d row-major.
  std::vector<float> means;
  /// Eigen-BRDFs, K × d × C (row-major: cluster, angular index, component). Float when not
  /// quantised, else empty.
  std::vector<float> eigen;
  /// Quantised eigen-BRDFs (same layout) when quantized, else empty.
  std::vector<int8_t> eigen_q;
  /// Weights per texel, n × C; scales folded in when quantized.
  std::vector<float> weights;

  size_t angular_size() const noexcept { return shape.view_count() * shape.light_count() * 3; }

  /// Reconstructed RGB at texel (x, y) for measured view and light. Thread-safe,
  /// allocation-free. Precondition: indices in range.
  glm::vec3 evaluate_measured(int x, int y, uint32_t view, uint32_t light) const noexcept {
    const size_t t = static_cast<size_t>(y) * static_cast<size_t>(shape.width) + static_cast<size_t>(x);
    const size_t j = cluster_of[t], d = angular_size(), cc = static_cast<size_t>(components);
    const size_t row = (static_cast<size_t>(view) * shape.light_count() + light) * 3;
    const float* w = weights.data() + t * cc;
    glm::vec3 out(means[j * d + row], means[j * d + row + 1], means[j * d + row + 2]);
    for (int c = 0; c < 3; ++c) {
      const size_t base = (j * d + row + static_cast<size_t>(c)) * cc;
      float s = 0.0f;
      if (quantized) {
        for (size_t k = 0; k < cc; ++k) s += w[k] * static_cast<float>(eigen_q[base + k]);
        s *= 1.0f / 127.0f;
      } else {
        for (size_t k = 0; k < cc; ++k) s += w[k] * eigen[base + k];
      }
      out[c] += s;
    }
    return out;
  }
  /// Interpolated evaluation: 3 × 3 taps of the light and view samples, weights multiplied.
  glm::vec3 evaluate(int x, int y, const AngularSample& light, const AngularSample& view) const noexcept {
    return combine_angular_taps(light, view, [&](uint32_t vi, uint32_t li) { return evaluate_measured(x, y, vi, li); });
  }
  /// Stored bytes: float means, int8 or float eigen-BRDFs, float weights, u16 cluster ids.
  size_t size_bytes() const noexcept {
    return means.size() * 4 + eigen.size() * 4 + eigen_q.size() + weights.size() * 4 + cluster_of.size() * 2;
  }
  double compression_ratio() const noexcept {
    return static_cast<double>(shape.float_bytes()) / static_cast<double>(size_bytes());
  }
  /// Full reconstruction (allocates the BTF).
  BtfFloat reconstruct() const {
    return reconstruct_measured(shape,
                                [this](int x, int y, uint32_t v, uint32_t l) { return evaluate_measured(x, y, v, l); });
  }

  /// Serialises (SHAP; META = K, C, quantised flag, iterations; CLID u16; MEAN; EIGF float or
  /// EIGQ int8; WGHT).
  std::vector<uint8_t> serialize() const {
    FactorFileWriter w(FactorKind::local_pca);
    w.add_shape(shape);
    ByteWriter meta;
    meta.u32(static_cast<uint32_t>(clusters));
    meta.u32(static_cast<uint32_t>(components));
    meta.u32(quantized ? 1u : 0u);
    meta.u32(static_cast<uint32_t>(iterations));
    w.add(factor_tag("META"), meta.take());
    w.add_array<uint16_t>(factor_tag("CLID"), cluster_of);
    w.add_array<float>(factor_tag("MEAN"), means);
    if (quantized)
      w.add_array<int8_t>(factor_tag("EIGQ"), eigen_q);
    else
      w.add_array<float>(factor_tag("EIGF"), eigen);
    w.add_array<float>(factor_tag("WGHT"), weights);
    return w.finish();
  }
  /// Parses a serialised Local PCA. Safe for untrusted input: sizes are checked against the
  /// shape, every cluster id against K.
  static Result<LocalPca> deserialize(std::span<const uint8_t> bytes) {
    auto head = parse_factor_file_head(bytes, FactorKind::local_pca, "Local PCA");
    if (!head) return head.error();
    const FactorFile& file = head->file;
    LocalPca p;
    p.shape = std::move(head->shape);
    ByteReader r(head->meta);
    const uint32_t k = r.u32(), c = r.u32(), q = r.u32(), it = r.u32();
    const size_t d = p.angular_size(), n = p.shape.texel_count();
    if (!r.ok() || r.remaining() != 0 || k == 0 || k > 65535 || k > n || c > d || q > 1)
      return make_error(Status::bad_data, "Local PCA: META (K=%u, C=%u, quantised=%u) invalid for %zu texels, d=%zu", k,
                        c, q, n, d);
    // Lower bound of the payload (int8 eigen-BRDFs, 1 byte per weight), by division: no overflow.
    if (d > bytes.size() / k || static_cast<size_t>(c) + 1 > bytes.size() / (k * d + n))
      return make_error(Status::short_output, "Local PCA: K=%u, C=%u need more than the %zu bytes of the file", k, c,
                        bytes.size());
    p.clusters = static_cast<int>(k);
    p.components = static_cast<int>(c);
    p.quantized = q == 1;
    p.iterations = static_cast<int>(std::min<uint32_t>(it, 1u << 20));
    if (auto s = file.read_array<uint16_t>(factor_tag("CLID"), n, p.cluster_of); !s) return s.error();
    for (size_t t = 0; t < n; ++t)
      if (p.cluster_of[t] >= k)
        return make_error(Status::bad_data, "Local PCA: texel %zu has cluster %u, K = %u", t, p.cluster_of[t], k);
    if (auto s = file.read_array<float>(factor_tag("MEAN"), k * d, p.means); !s) return s.error();
    if (p.quantized) {
      if (auto s = file.read_array<int8_t>(factor_tag("EIGQ"), k * d * c, p.eigen_q); !s) return s.error();
    } else {
      if (auto s = file.read_array<float>(factor_tag("EIGF"), k * d * c, p.eigen); !s) return s.error();
    }
    if (auto s = file.read_array<float>(factor_tag("WGHT"), n * c, p.weights); !s) return s.error();
    return p;
  }
};

/// Builds the Local PCA of `btf` (paper 002 §3 / ref. [10]). Deterministic. Returns an error
/// for an empty BTF, K < 1, C < 0 or K > texels; Status::cancelled when progress returns false.
/// Memory: one copy of the BTF as a d × n matrix plus O(K·d·C + n·K).
/// Defined in the implementation TU (BTFLOD_IMPLEMENTATION).
Result<LocalPca> factorize_local_pca(const BtfFloat& btf, const LocalPcaOptions& options = {},
                                     const ProgressCallback& progress = {});

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_FACTOR_IMPLEMENTATION)
// factorize_local_pca instantiates Eigen's SelfAdjointEigenSolver and the blocked truncated SVD:
// compiled once, in the implementation TU.
namespace btflod {

Result<LocalPca> factorize_local_pca(const BtfFloat& btf, const LocalPcaOptions& options,
                                     const ProgressCallback& progress) {
  const size_t n = btf.texel_count(), d = btf.view_count() * btf.light_count() * 3;
  if (btf.empty() || options.clusters < 1 || options.components < 0 || static_cast<size_t>(options.clusters) > n ||
      options.clusters > 65535)
    return make_error(Status::invalid_argument, "factorize_local_pca: %d clusters, %d components for %zu texels",
                      options.clusters, options.components, n);
  using Eigen::Index;
  const Index K = options.clusters;
  const Index C = std::min<Index>(options.components, static_cast<Index>(d));
  Eigen::MatrixXf x(static_cast<Index>(d), static_cast<Index>(n));  // columns = texel ABRDFs
  gather_fmf_columns(btf, 0, n, x);
  const Eigen::VectorXd norms2 = x.colwise().squaredNorm().transpose().cast<double>();

  // Initial clusters: farthest-point seeds (first = farthest from the global mean), nearest seed.
  std::vector<uint16_t> assign(n, 0);
  {
    const Eigen::VectorXf gmean = x.rowwise().mean();
    std::vector<double> dist(n);
    Index seed = 0;
    double best = -1.0;
    for (Index t = 0; t < static_cast<Index>(n); ++t) {
      const double dd = (x.col(t) - gmean).squaredNorm();
      if (dd > best) best = dd, seed = t;
    }
    for (size_t t = 0; t < n; ++t) dist[t] = std::numeric_limits<double>::infinity();
    for (Index j = 0; j < K; ++j) {
      for (Index t = 0; t < static_cast<Index>(n); ++t) {
        const double dd = (x.col(t) - x.col(seed)).squaredNorm();
        if (dd < dist[static_cast<size_t>(t)])
          dist[static_cast<size_t>(t)] = dd, assign[static_cast<size_t>(t)] = static_cast<uint16_t>(j);
      }
      Index far = 0;
      double fd = -1.0;
      for (Index t = 0; t < static_cast<Index>(n); ++t)
        if (dist[static_cast<size_t>(t)] > fd) fd = dist[static_cast<size_t>(t)], far = t;
      seed = far;
    }
  }

  Eigen::MatrixXf means(static_cast<Index>(d), K);
  std::vector<Eigen::MatrixXf> bases(static_cast<size_t>(K));  // d × C each (zero-padded)
  // Per-cluster PCA. Small clusters (≤ kGramMembers, the usual case for the smaller ones): the
  // left singular vectors follow exactly from the members × members Gram matrix (Eigen's
  // SelfAdjointEigenSolver), U_k = M·v_k / sqrt(λ_k): d·members² flops plus O(members³) for the
  // eigen-solver. That cost is quadratic/cubic in the cluster size, and specular materials put
  // most texels into one cluster (the 64 × 64 car paint: ~75 % of the 4,096 texels in one of
  // K = 8), where it dominated everything (483 s for K = 8). Large clusters therefore use the
  // randomised truncated SVD of the centred members (truncated_svd.hpp, adaptive power
  // iterations, read through a gather functor: no copy), whose cost is linear in the members,
  // O(d·members·(C + p)) per pass. Its basis is an approximation, so the previous basis of the
  // cluster is kept when it captures more energy of the new members: with the new mean (the
  // centroid, optimal for any fixed basis) the error then cannot grow, and reclustering stays
  // monotone (Lloyd argument: reassignment and refit each never increase the total error).
  constexpr Index kGramMembers = 256;
  auto fit_clusters = [&]() -> VoidResult {
    for (Index j = 0; j < K; ++j) {
      std::vector<Index> members;
      for (size_t t = 0; t < n; ++t)
        if (assign[t] == j) members.push_back(static_cast<Index>(t));
      Eigen::MatrixXf& e = bases[static_cast<size_t>(j)];
      Eigen::MatrixXf previous = std::move(e);
      e.setZero(static_cast<Index>(d), C);
      if (members.empty()) {
        means.col(j).setZero();
        continue;
      }
      const Index cols = static_cast<Index>(members.size());
      Eigen::VectorXd sum = Eigen::VectorXd::Zero(static_cast<Index>(d));
      for (Index t : members) sum += x.col(t).template cast<double>();
      means.col(j) = (sum / static_cast<double>(cols)).template cast<float>();
      if (C == 0 || cols < 2) continue;
      if (cols <= kGramMembers && cols < static_cast<Index>(d)) {
        Eigen::MatrixXf m(static_cast<Index>(d), cols);
        for (Index i = 0; i < cols; ++i) m.col(i) = x.col(members[static_cast<size_t>(i)]) - means.col(j);
        // Components with λ_k below 1e-6 of the largest (noise of the float Gram matrix) are
        // left at zero.
        const Eigen::MatrixXd g = (m.transpose() * m).template cast<double>();
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(g);
        const double top = es.eigenvalues()[cols - 1];
        for (Index k = 0; k < std::min<Index>(C, cols); ++k) {
          const Index idx = cols - 1 - k;  // eigenvalues ascend
          const double lambda = es.eigenvalues()[idx];
          if (!(lambda > 1e-6 * top)) break;
          e.col(k) = (m * es.eigenvectors().col(idx).template cast<float>()) / static_cast<float>(std::sqrt(lambda));
        }
        continue;
      }
      const Eigen::VectorXf mj = means.col(j);
      auto gather = [&](size_t col0, size_t count, Eigen::MatrixXf& out) {
        for (size_t i = 0; i < count; ++i) out.col(static_cast<Index>(i)) = x.col(members[col0 + i]) - mj;
      };
      auto svd = truncated_svd(d, members.size(), static_cast<int>(C), gather, options.svd);
      if (!svd) return svd.error();
      e.leftCols(svd->u.cols()) = svd->u;
      if (previous.rows() == static_cast<Index>(d) && previous.cols() == C) {
        // Captured energy Σ_t ‖Bᵀ(x_t − m_j)‖² of the new and the previous basis, in blocks.
        Eigen::MatrixXf both(static_cast<Index>(d), 2 * C);
        both << e, previous;
        Eigen::VectorXd captured = Eigen::VectorXd::Zero(2 * C);
        Eigen::MatrixXf block;
        for (size_t c0 = 0; c0 < members.size(); c0 += 256) {
          const size_t cnt = std::min<size_t>(256, members.size() - c0);
          block.resize(static_cast<Index>(d), static_cast<Index>(cnt));
          gather(c0, cnt, block);
          captured += (both.transpose() * block).rowwise().squaredNorm().template cast<double>();
        }
        if (captured.tail(C).sum() > captured.head(C).sum()) e = std::move(previous);
      }
    }
    return {};
  };
  // errors(j, t) = ‖x_t − m_j‖² − ‖E_jᵀ(x_t − m_j)‖² for every cluster j and texel t, from ONE
  // product of all bases and means with the data, [E_1 … E_K | m_1 … m_K]ᵀ·X (K·(C + 1) × n):
  // a single pass over X instead of 2K thin (memory-bound) ones.
  Eigen::MatrixXf stacked(static_cast<Index>(d), K * (C + 1));
  Eigen::MatrixXf proj;
  Eigen::MatrixXd errors(K, static_cast<Index>(n));
  auto all_errors = [&]() {
    for (Index j = 0; j < K; ++j) {
      stacked.middleCols(j * C, C) = bases[static_cast<size_t>(j)];
      stacked.col(K * C + j) = means.col(j);
    }
    proj.noalias() = stacked.transpose() * x;
    for (Index j = 0; j < K; ++j) {
      const Eigen::VectorXf em = bases[static_cast<size_t>(j)].transpose() * means.col(j);
      const double mm = means.col(j).squaredNorm();
      for (Index t = 0; t < static_cast<Index>(n); ++t) {
        const double captured = (proj.col(t).segment(j * C, C) - em).squaredNorm();
        errors(j, t) = std::max(0.0, norms2[t] - 2.0 * proj(K * C + j, t) + mm - captured);
      }
    }
  };

  int iterations = 0;
  std::vector<double> history;
  if (auto s = fit_clusters(); !s) return s.error();
  for (int it = 0; it < options.max_iterations; ++it) {
    std::vector<double> best(n, std::numeric_limits<double>::infinity());
    std::vector<uint16_t> next(n, 0);
    double current = 0.0;  // total error of the current clusters and fits
    all_errors();
    for (size_t t = 0; t < n; ++t) {
      const Index ti = static_cast<Index>(t);
      current += errors(assign[t], ti);
      for (Index j = 0; j < K; ++j)
        if (errors(j, ti) < best[t]) best[t] = errors(j, ti), next[t] = static_cast<uint16_t>(j);
    }
    history.push_back(current);
    // An emptied cluster is re-seeded with the worst-represented texel (deterministic).
    std::vector<size_t> count(static_cast<size_t>(K), 0);
    for (auto a : next) ++count[a];
    for (Index j = 0; j < K; ++j)
      if (count[static_cast<size_t>(j)] == 0) {
        size_t worst = 0;
        for (size_t t = 1; t < n; ++t)
          if (best[t] > best[worst] && count[next[t]] > 1) worst = t;
        --count[next[worst]];
        next[worst] = static_cast<uint16_t>(j);
        best[worst] = 0.0;
        ++count[static_cast<size_t>(j)];
      }
    const bool changed = next != assign;
    assign = std::move(next);
    ++iterations;
    if (!changed) break;
    if (auto s = fit_clusters(); !s) return s.error();
    if (!report_progress(progress, "local pca", static_cast<double>(it + 1) / options.max_iterations))
      return make_error(Status::cancelled, "factorize_local_pca cancelled");
  }

  LocalPca p;
  p.shape = BtfShape{btf.width(), btf.height(), btf.views(), btf.lights()};
  p.clusters = static_cast<int>(K);
  p.components = static_cast<int>(C);
  p.iterations = iterations;
  p.error_history = std::move(history);
  p.quantized = options.quantize_8bit;
  p.cluster_of = assign;
  p.means.resize(static_cast<size_t>(K) * d);
  for (Index j = 0; j < K; ++j)
    for (size_t i = 0; i < d; ++i) p.means[static_cast<size_t>(j) * d + i] = means(static_cast<Index>(i), j);
  p.weights.assign(n * static_cast<size_t>(C), 0.0f);
  std::vector<float> scale(static_cast<size_t>(K * C), 1.0f);
  if (p.quantized) {
    p.eigen_q.assign(static_cast<size_t>(K) * d * static_cast<size_t>(C), 0);
    for (Index j = 0; j < K; ++j)
      for (Index k = 0; k < C; ++k) {
        const float s = bases[static_cast<size_t>(j)].col(k).cwiseAbs().maxCoeff();
        scale[static_cast<size_t>(j * C + k)] = s;
        for (size_t i = 0; i < d; ++i) {
          const float v = s > 0.0f ? bases[static_cast<size_t>(j)](static_cast<Index>(i), k) / s * 127.0f : 0.0f;
          p.eigen_q[(static_cast<size_t>(j) * d + i) * static_cast<size_t>(C) + static_cast<size_t>(k)] =
              static_cast<int8_t>(std::clamp(std::lround(v), -127L, 127L));
        }
      }
  } else {
    p.eigen.resize(static_cast<size_t>(K) * d * static_cast<size_t>(C));
    for (Index j = 0; j < K; ++j)
      for (size_t i = 0; i < d; ++i)
        for (Index k = 0; k < C; ++k)
          p.eigen[(static_cast<size_t>(j) * d + i) * static_cast<size_t>(C) + static_cast<size_t>(k)] =
              bases[static_cast<size_t>(j)](static_cast<Index>(i), k);
  }
  // Weights w_t = E_jᵀ(x_t − m_j), folded with the quantisation scale (paper 002 §6.3).
  for (size_t t = 0; t < n; ++t) {
    const Index j = assign[t];
    const Eigen::VectorXf w = bases[static_cast<size_t>(j)].transpose() * (x.col(static_cast<Index>(t)) - means.col(j));
    for (Index k = 0; k < C; ++k)
      p.weights[t * static_cast<size_t>(C) + static_cast<size_t>(k)] = w[k] * scale[static_cast<size_t>(j * C + k)];
  }
  return p;
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
