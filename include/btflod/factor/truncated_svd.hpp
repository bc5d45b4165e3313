// btflod — truncated SVD of large matrices that are read in column blocks: exact (Eigen
// BDCSVD) for small inputs and a randomised range finder (Halko, Martinsson, Tropp 2011,
// algorithms 4.3/4.4 + 5.1: sketch with oversampling, power iterations with
// re-orthonormalisation; sparse sign test matrix as in Martinsson & Tropp 2020 §9.2) that never
// holds more than a few column blocks of the input, and whose last power iteration also yields
// the projection (no separate projection pass, see truncated_svd()).
//
// The matrix is never materialised by the randomised path: a caller-supplied `gather`
// functor copies columns [col0, col0 + count) into an m × count Eigen matrix. Peak memory is
// therefore the caller's storage plus O((m + n)·k) for the sketches plus
// stripes · m · block_columns for the gather buffers.
//
// Determinism: the test matrix comes from a fixed seed (own generator, not
// std::normal_distribution, so all standard libraries agree), the column blocks are split
// into a fixed number of stripes whose partial sums are added in stripe order, so results do
// not depend on the thread count. They do depend (in the last digits) on the compiler flags:
// an AVX2/FMA build (BTFLOD_OFFLINE_ARCH) rounds differently from an SSE2 build.
#pragma once

#include <Eigen/Dense>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "btflod/core/progress.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/thread_pool.hpp"

namespace btflod {

/// Which SVD path a factorisation uses.
enum class SvdMethod : uint8_t {
  automatic = 0,  ///< exact when the matrix has at most exact_limit elements, else randomised
  exact,          ///< Eigen BDCSVD of the whole matrix (materialised: memory = input size)
  randomized,     ///< blocked randomised SVD (Halko et al.)
};

/// Options of truncated_svd(). Defaults: sparse sign sketch (ζ = 8), oversampling 50, 2 power
/// iterations with the fused last pass (4 GEMM-sized products over A, 3 gathers of A). Measured
/// with bench_factor / docs/factor.md on the 64×64 UBO2003 cloth at rank 100 (error / Eckart–Young
/// optimum, x86-64-v3 build): 1.0021 (the previous default, Gaussian p = 30 with a separate
/// projection pass, 6 products and 4 gathers: 1.0022). Flat-tailed spectra need more: the 32×32
/// car paint at rank 64 gives 1.0063 with these defaults, 1.0037 with power_iterations = 3, p = 30.
struct SvdOptions {
  SvdMethod method = SvdMethod::automatic;
  int oversampling = 50;      ///< extra sketch columns p (k = rank + p)
  int power_iterations = 2;   ///< q: products with AᵀA (the last one fused with the projection)
  /// ζ: nonzeros (±1) per row of the sparse sign test matrix; 0 = dense Gaussian test matrix.
  int sketch_nonzeros = 8;
  size_t block_columns = 256; ///< columns gathered per block
  int stripes = 4;            ///< fixed partition of the blocks for parallel, deterministic sums
  uint64_t seed = 0x6274666c6f64ull;
  size_t exact_limit = size_t{1} << 22;  ///< automatic: exact up to this many matrix elements
  ThreadPool* pool = nullptr;            ///< nullptr: default_thread_pool()
};

/// A rank-C truncated SVD A ≈ U·diag(s)·Vᵀ: u is m × C, v is n × C (orthonormal columns),
/// s descending.
struct TruncatedSvd {
  Eigen::MatrixXf u;
  Eigen::VectorXf s;
  Eigen::MatrixXf v;
};

namespace detail {

/// SplitMix64: 64 random bits per call. Deterministic on every platform.
class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) noexcept : state_(seed) {}
  uint64_t next() noexcept {
    uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }

 private:
  uint64_t state_;
};

/// SplitMix64 → uniform doubles → Box–Muller normals. Deterministic on every platform.
class NormalGenerator {
 public:
  explicit NormalGenerator(uint64_t seed) noexcept : state_(seed) {}
  double next() noexcept {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = (static_cast<double>(bits() >> 11) + 0.5) * 0x1.0p-53;
    const double u2 = static_cast<double>(bits() >> 11) * 0x1.0p-53;
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(6.283185307179586 * u2);
    has_spare_ = true;
    return r * std::cos(6.283185307179586 * u2);
  }

 private:
  uint64_t bits() noexcept {
    uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  uint64_t state_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

/// Thin orthonormal basis of the columns of y (m × k, m ≥ k) by Householder QR.
inline Eigen::MatrixXf orthonormal_basis(const Eigen::MatrixXf& y) {
  Eigen::HouseholderQR<Eigen::MatrixXf> qr(y);
  return qr.householderQ() * Eigen::MatrixXf::Identity(y.rows(), y.cols());
}

}  // namespace detail

/// Truncated SVD of the m × n matrix whose columns `gather(col0, count, out)` provides
/// (`out` is resized by the caller to m × count and must be fully written).
/// Returns the rank-min(rank, m, n) factors, or an error for empty shapes / rank < 1, or
/// Status::cancelled when `progress` returns false. If A has lower numerical rank than asked,
/// the trailing singular values are 0 (with orthonormal completions in u and v).
/// Threading: gather is called concurrently from pool threads for disjoint column ranges,
/// each with its own `out`; it must be thread-safe for that. Not safe for untrusted sizes
/// (it allocates O((m + n)·k)).
template <class Gather>
Result<TruncatedSvd> truncated_svd(size_t m, size_t n, int rank, Gather&& gather, const SvdOptions& options = {},
                                   const ProgressCallback& progress = {}) {
  using Eigen::Index;
  using Eigen::MatrixXf;
  if (m == 0 || n == 0 || rank < 1)
    return make_error(Status::invalid_argument, "truncated_svd: matrix %zux%zu, rank %d: need non-empty, rank >= 1", m,
                      n, rank);
  const Index c = std::min<Index>({static_cast<Index>(rank), static_cast<Index>(m), static_cast<Index>(n)});
  ThreadPool& pool = options.pool ? *options.pool : default_thread_pool();
  const bool exact = options.method == SvdMethod::exact ||
                     (options.method == SvdMethod::automatic && m * n <= options.exact_limit);
  TruncatedSvd out;
  if (exact) {
    if (!report_progress(progress, "gather", 0.0)) return make_error(Status::cancelled, "truncated_svd cancelled");
    MatrixXf a(static_cast<Index>(m), static_cast<Index>(n));
    const size_t bc = std::max<size_t>(1, options.block_columns);
    const size_t blocks = (n + bc - 1) / bc;
    pool.parallel_for(0, blocks, 1, [&](size_t b0, size_t b1) {
      MatrixXf buf;
      for (size_t b = b0; b < b1; ++b) {
        const size_t col0 = b * bc, cnt = std::min(bc, n - col0);
        buf.resize(static_cast<Index>(m), static_cast<Index>(cnt));
        gather(col0, cnt, buf);
        a.middleCols(static_cast<Index>(col0), static_cast<Index>(cnt)) = buf;
      }
    });
    if (!report_progress(progress, "svd", 0.1)) return make_error(Status::cancelled, "truncated_svd cancelled");
    Eigen::BDCSVD<MatrixXf> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
    out.u = svd.matrixU().leftCols(c);
    out.s = svd.singularValues().head(c);
    out.v = svd.matrixV().leftCols(c);
    report_progress(progress, "svd", 1.0);
    return out;
  }

  // Randomised range finder (Halko et al. 2011, alg. 4.4 with a fused A·Aᵀ step).
  const Index k = std::min<Index>({c + options.oversampling, static_cast<Index>(m), static_cast<Index>(n)});
  const size_t bc = std::max<size_t>(1, options.block_columns);
  const size_t blocks = (n + bc - 1) / bc;
  const size_t stripes = std::max<size_t>(1, std::min<size_t>(static_cast<size_t>(std::max(1, options.stripes)), blocks));
  const Index mi = static_cast<Index>(m);

  // Test matrix Ω (n × k): dense Gaussian, or a sparse sign matrix with ζ = sketch_nonzeros
  // entries ±1 per row in distinct random columns (Martinsson & Tropp 2020, §9.2; Tropp et al.
  // 2019): A·Ω then costs m·n·ζ additions instead of 2·m·n·k flops.
  const Index zeta = options.sketch_nonzeros > 0 ? std::min<Index>(options.sketch_nonzeros, k) : 0;
  MatrixXf omega;
  std::vector<int32_t> sparse_omega;  // n × zeta entries: column + 1, negated for −1
  if (zeta == 0) {
    omega.resize(static_cast<Index>(n), k);
    detail::NormalGenerator gen(options.seed);
    for (Index j = 0; j < k; ++j)
      for (Index i = 0; i < omega.rows(); ++i) omega(i, j) = static_cast<float>(gen.next());
  } else {
    sparse_omega.resize(n * static_cast<size_t>(zeta));
    detail::SplitMix64 gen(options.seed);
    for (size_t t = 0; t < n; ++t) {
      int32_t* row = sparse_omega.data() + t * static_cast<size_t>(zeta);
      for (Index e = 0; e < zeta; ++e) {
        int32_t col = 0;
        bool fresh = false;
        while (!fresh) {  // distinct columns within a row (rejection; ζ ≤ k)
          col = static_cast<int32_t>(gen.next() % static_cast<uint64_t>(k));
          fresh = true;
          for (Index f = 0; f < e; ++f) fresh = fresh && std::abs(row[f]) - 1 != col;
        }
        row[e] = (gen.next() & 1u) ? col + 1 : -(col + 1);
      }
    }
  }
  std::vector<MatrixXf> partial(stripes);
  // One pass over the matrix: for every block, body(a_block, col0, cnt, stripe_accumulator).
  auto pass = [&](auto&& body) {
    for (auto& p : partial) p.setZero(mi, k);
    pool.parallel_for(0, stripes, 1, [&](size_t s0, size_t s1) {
      MatrixXf buf;
      for (size_t s = s0; s < s1; ++s) {
        const size_t first = s * blocks / stripes, last = (s + 1) * blocks / stripes;
        for (size_t b = first; b < last; ++b) {
          const size_t col0 = b * bc, cnt = std::min(bc, n - col0);
          buf.resize(mi, static_cast<Index>(cnt));
          gather(col0, cnt, buf);
          body(buf, static_cast<Index>(col0), static_cast<Index>(cnt), partial[s]);
        }
      }
    });
    MatrixXf sum = partial[0];
    for (size_t s = 1; s < stripes; ++s) sum += partial[s];
    return sum;
  };
  // Passes over A (each gathers every column block once):
  //   q = 0: Y = A·Ω, Q = orth(Y); Bᵀ = Aᵀ·Q                      2 passes, 2 GEMMs
  //   q ≥ 1: Y = A·Ω, Q = orth(Y); q − 1 times Y = A·(Aᵀ·Q), Q = orth(Y);
  //          last pass fused: Z = Aᵀ·Q (kept) and Y = A·Z           q + 1 passes, 2q + 1 GEMMs
  // The last pass yields the row-space basis Z ∝ (AᵀA)^q·Ω (Halko et al. §4.5 applied to Aᵀ) AND
  // A·Z, so no separate projection pass is needed: with Z = P·R = (P·Ur)·Sr·Vrᵀ (QR, then the small
  // SVD of R), A·(P·Ur) = Y·Vr·Sr⁻¹, and A ≈ (A·P')·P'ᵀ is the optimal approximation with rows in
  // span(Z). Versus the textbook loop (q + 2 passes, 2q + 2 GEMMs, column basis ∝ A(AᵀA)^q·Ω) this
  // saves one GEMM and one gather per factorisation for one power of the spectrum less;
  // measured in docs/factor.md (64×64 cloth, rank 100: ratio to the Eckart–Young optimum).
  const int q_iters = std::max(0, options.power_iterations);
  const int total_passes = q_iters == 0 ? 2 : q_iters + 1;
  int done = 0;
  if (!report_progress(progress, "sketch", 0.0)) return make_error(Status::cancelled, "truncated_svd cancelled");
  MatrixXf q = detail::orthonormal_basis(pass([&](const MatrixXf& a, Index col0, Index cnt, MatrixXf& acc) {
    if (zeta == 0) {
      acc.noalias() += a * omega.middleRows(col0, cnt);
      return;
    }
    // Y(:, j) ± A(:, t) for the ζ entries of row t of Ω, over row chunks of 512 so that the
    // touched part of Y (512 × k) stays in cache.
    constexpr Index kRowChunk = 512;
    for (Index r0 = 0; r0 < a.rows(); r0 += kRowChunk) {
      const Index rn = std::min<Index>(kRowChunk, a.rows() - r0);
      for (Index t = 0; t < cnt; ++t) {
        const int32_t* row = sparse_omega.data() + static_cast<size_t>(col0 + t) * static_cast<size_t>(zeta);
        const auto src = a.col(t).segment(r0, rn);
        for (Index e = 0; e < zeta; ++e) {
          if (row[e] > 0)
            acc.col(row[e] - 1).segment(r0, rn) += src;
          else
            acc.col(-row[e] - 1).segment(r0, rn) -= src;
        }
      }
    }
  }));
  omega.resize(0, 0);
  sparse_omega = {};
  ++done;
  for (int it = 0; it + 1 < q_iters; ++it) {
    if (!report_progress(progress, "power iteration", static_cast<double>(done) / total_passes))
      return make_error(Status::cancelled, "truncated_svd cancelled");
    // Y = A·(Aᵀ·Q), block by block: Z_b = A_bᵀ·Q, Y += A_b·Z_b; then Q = orth(Y).
    q = detail::orthonormal_basis(pass([&](const MatrixXf& a, Index, Index, MatrixXf& acc) {
      const MatrixXf z = a.transpose() * q;
      acc.noalias() += a * z;
    }));
    ++done;
  }
  if (!report_progress(progress, "project", static_cast<double>(done) / total_passes))
    return make_error(Status::cancelled, "truncated_svd cancelled");
  if (q_iters == 0) {
    // B = Qᵀ·A (k × n), written column block by column block (disjoint, no reduction needed).
    MatrixXf bt(static_cast<Index>(n), k);  // Bᵀ
    pool.parallel_for(0, blocks, 1, [&](size_t b0, size_t b1) {
      MatrixXf buf;
      for (size_t b = b0; b < b1; ++b) {
        const size_t col0 = b * bc, cnt = std::min(bc, n - col0);
        buf.resize(mi, static_cast<Index>(cnt));
        gather(col0, cnt, buf);
        bt.middleRows(static_cast<Index>(col0), static_cast<Index>(cnt)).noalias() = buf.transpose() * q;
      }
    });
    // SVD of B through Bᵀ = Q2·R: B = Rᵀ·Q2ᵀ, Rᵀ = Ur·S·Vrᵀ (small, in double) ⇒
    // U = Q·Ur, V = Q2·Vr.
    Eigen::HouseholderQR<MatrixXf> qr(bt);
    const Index kr = std::min<Index>(k, bt.rows());
    const Eigen::MatrixXd r =
        qr.matrixQR().topRows(kr).template triangularView<Eigen::Upper>().toDenseMatrix().template cast<double>();
    const MatrixXf q2 = qr.householderQ() * MatrixXf::Identity(bt.rows(), kr);
    bt.resize(0, 0);
    Eigen::JacobiSVD<Eigen::MatrixXd> small(r.transpose(), Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Index cc = std::min<Index>(c, small.singularValues().size());
    out.u = q * small.matrixU().leftCols(cc).template cast<float>();
    out.s = small.singularValues().head(cc).template cast<float>();
    out.v = q2 * small.matrixV().leftCols(cc).template cast<float>();
    report_progress(progress, "project", 1.0);
    return out;
  }
  // Fused last pass: Z_b = A_bᵀ·Q into the rows of Z (disjoint), Y += A_b·Z_b (striped sums).
  MatrixXf z(static_cast<Index>(n), k);
  MatrixXf y = pass([&](const MatrixXf& a, Index col0, Index cnt, MatrixXf& acc) {
    auto zb = z.middleRows(col0, cnt);
    zb.noalias() = a.transpose() * q;
    acc.noalias() += a * zb;
  });
  q.resize(0, 0);
  // Z = P·R (Householder QR, n × k), R = Ur·Sr·Vrᵀ (k × k, double Jacobi).
  Eigen::HouseholderQR<MatrixXf> zqr(z);
  const Eigen::MatrixXd rz =
      zqr.matrixQR().topRows(k).template triangularView<Eigen::Upper>().toDenseMatrix().template cast<double>();
  Eigen::JacobiSVD<Eigen::MatrixXd> rsvd(rz, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::VectorXd& sr = rsvd.singularValues();
  // Directions of Z below this relative size carry only rounding noise (A has no component
  // there, e.g. rank(A) < k); dividing by them would amplify it, so they are dropped.
  const double tol = sr.size() > 0 ? sr[0] * 1e-6 : 0.0;
  Index kk = 0;
  while (kk < sr.size() && sr[kk] > tol) ++kk;
  if (kk == 0) {  // A = 0 (or numerically so): zero factors with orthonormal bases
    out.u = MatrixXf::Identity(mi, c);
    out.s = Eigen::VectorXf::Zero(c);
    out.v = MatrixXf::Identity(static_cast<Index>(n), c);
    report_progress(progress, "project", 1.0);
    return out;
  }
  // M = A·P' = Y·Vr·Sr⁻¹ (m × kk), P' = P·Ur (n × kk, orthonormal). A ≈ M·P'ᵀ.
  const Eigen::MatrixXd w = rsvd.matrixV().leftCols(kk) * sr.head(kk).cwiseInverse().asDiagonal();
  const MatrixXf mmat = y * w.template cast<float>();
  y.resize(0, 0);
  // M = Qm·Rm (float QR), Rm = Um·S·Wmᵀ (double) ⇒ U = Qm·Um, V = P'·Wm = P·(Ur·Wm).
  Eigen::HouseholderQR<MatrixXf> mqr(mmat);
  const Index km = std::min<Index>(kk, mi);
  const Eigen::MatrixXd rm =
      mqr.matrixQR().topRows(km).template triangularView<Eigen::Upper>().toDenseMatrix().template cast<double>();
  Eigen::JacobiSVD<Eigen::MatrixXd> msvd(rm, Eigen::ComputeFullU | Eigen::ComputeFullV);
  // cc = min(c, kk) components carry the approximation; if rank(A) < c the remaining c − cc get
  // singular value 0 and orthonormal completions (unused columns of the two Householder bases).
  const Index cc = std::min<Index>(c, km), pad = c - cc;
  const MatrixXf qm = mqr.householderQ() * MatrixXf::Identity(mi, km + pad);
  out.u.resize(mi, c);
  out.u.leftCols(cc) = qm.leftCols(km) * msvd.matrixU().leftCols(cc).template cast<float>();
  out.u.rightCols(pad) = qm.rightCols(pad);
  out.s = Eigen::VectorXf::Zero(c);
  out.s.head(cc) = msvd.singularValues().head(cc).template cast<float>();
  MatrixXf rot(k, c);  // V = P·rot
  rot.leftCols(cc) = (rsvd.matrixU().leftCols(kk) * msvd.matrixV().leftCols(cc)).template cast<float>();
  rot.rightCols(pad) = rsvd.matrixU().middleCols(kk, pad).template cast<float>();
  const MatrixXf pz = zqr.householderQ() * MatrixXf::Identity(static_cast<Index>(n), k);
  out.v = pz * rot;
  report_progress(progress, "project", 1.0);
  return out;
}

/// Truncated SVD of an in-memory matrix (convenience over the blocked version).
inline Result<TruncatedSvd> truncated_svd(const Eigen::MatrixXf& a, int rank, const SvdOptions& options = {},
                                          const ProgressCallback& progress = {}) {
  return truncated_svd(
      static_cast<size_t>(a.rows()), static_cast<size_t>(a.cols()), rank,
      [&a](size_t col0, size_t count, Eigen::MatrixXf& out) {
        out = a.middleCols(static_cast<Eigen::Index>(col0), static_cast<Eigen::Index>(count));
      },
      options, progress);
}

}  // namespace btflod
