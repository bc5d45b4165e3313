// btflod — truncated SVD of large matrices that are read in column blocks: exact (Eigen
// BDCSVD) for small inputs and a randomised range finder (Halko, Martinsson, Tropp 2011,
// algorithms 4.3/4.4 + 5.1: sketch with oversampling, power iterations with
// re-orthonormalisation; sparse sign test matrix as in Martinsson & Tropp 2020 §9.2) that never
// holds more than a few column blocks of the input, and whose last power iteration also yields
// the projection (no separate projection pass, see truncated_svd()). The number of power
// iterations is adaptive: every iteration also yields an estimate of the result's error from
// quantities the algorithm forms anyway, and iterations are added while the extrapolated
// remaining gap to the Eckart–Young optimum is not small (rule and math in truncated_svd()).
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
//
// Compile cost: the decompositions are instantiated once, in the implementation TU
// (BTFLOD_IMPLEMENTATION, see btflod.hpp): truncated_svd_blocked() and the in-memory overload are
// declared here and defined there; the templated truncated_svd(m, n, rank, gather) forwards to
// truncated_svd_blocked through a type-erased gather (one indirect call per column block).
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <vector>

#include "btflod/offline/math/eigen.hpp"

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

/// Options of truncated_svd(). Defaults: sparse sign sketch (ζ = 8), oversampling 50, and an
/// ADAPTIVE number of power iterations: at least 2, more while the error estimate of the
/// result is still improving (rule and math in the comment of truncated_svd() below), at most 6.
/// Every iteration's pass also yields the projection (2 GEMM-sized products and 1 gather of A
/// per iteration, plus one sketch gather). Measured (bench_factor, docs/factor.md; error /
/// Eckart–Young optimum): the 64×64 UBO2003 cloth at rank 100 stops after 2 iterations
/// (1.0016, as the old fixed default); the flat-tailed 32×32 car paint at rank 64, which gave
/// 1.0063 with the old fixed q = 2, takes 3 (1.0018).
struct SvdOptions {
  SvdMethod method = SvdMethod::automatic;
  int oversampling = 50;  ///< extra sketch columns p (k = rank + p)
  /// q_min: power iterations always run (products with A·Aᵀ, the last one fused with the
  /// projection). 0 with max_power_iterations = 0 gives the plain range finder (q = 0); 0 with
  /// a positive max_power_iterations runs at least 1 (the adaptive rule needs one iteration).
  int power_iterations = 2;
  /// q_max: cap of the adaptive rule; ≤ power_iterations gives exactly power_iterations
  /// iterations (the fixed-q behaviour of earlier versions).
  int max_power_iterations = 6;
  /// τ: stop once the predicted excess of the squared error over its limit (the Eckart–Young
  /// optimum) is ≤ τ times the squared error, i.e. error / optimum ≤ 1/sqrt(1 − τ) ≈ 1 + τ/2
  /// (1.0025 for the default τ = 0.005, half of a 1.005 bound).
  double power_tolerance = 0.005;
  /// ζ: nonzeros (±1) per row of the sparse sign test matrix; 0 = dense Gaussian test matrix.
  int sketch_nonzeros = 8;
  size_t block_columns = 256;  ///< columns gathered per block
  int stripes = 4;             ///< fixed partition of the blocks for parallel, deterministic sums
  uint64_t seed = 0x6274666c6f64ull;
  size_t exact_limit = size_t{1} << 22;  ///< automatic: exact up to this many matrix elements
  ThreadPool* pool = nullptr;            ///< nullptr: default_thread_pool()
};

/// What a truncated_svd() run did and how good its result is (diagnostics; cheap to compute).
struct SvdReport {
  bool exact = false;           ///< BDCSVD path (then the numbers below are exact)
  int power_iterations = 0;     ///< power iterations run (randomised path)
  double frobenius_norm = 0.0;  ///< ‖A‖_F (from the first pass over A)
  /// ‖A − U·diag(s)·Vᵀ‖_F = sqrt(‖A‖²_F − Σ s_i²) (exact up to rounding: U, V orthonormal).
  double error_estimate = 0.0;
  /// Predicted ratio error / Eckart–Young optimum of the randomised result (1 for exact), from
  /// the geometric extrapolation of the adaptive rule; ≥ 1. A prediction, not a bound.
  double predicted_ratio = 1.0;
  /// Where the time went (randomised path; timing only, results do not depend on it).
  int passes = 0;                ///< passes over A (each gathers every column once: m·n·4 bytes)
  double pass_seconds = 0.0;     ///< wall time of the passes
  double gather_seconds = 0.0;   ///< time in `gather`, summed over the pool threads
  double product_seconds = 0.0;  ///< time in the block products (sketch, Aᵀ·Q, A·Z), summed over threads
  double total_seconds = 0.0;    ///< wall time of the whole call; minus pass_seconds = QR and small SVDs
};

/// A rank-C truncated SVD A ≈ U·diag(s)·Vᵀ: u is m × C, v is n × C (orthonormal columns),
/// s descending.
struct TruncatedSvd {
  Eigen::MatrixXf u;
  Eigen::VectorXf s;
  Eigen::MatrixXf v;
  SvdReport report;
};

namespace detail {

/// The adaptive power-iteration rule's bound, shared by truncated_svd and out_of_core_svd (which
/// must stop after the same iteration). `h` holds the residual ‖A‖² − Σσ² after every half step;
/// the last improvement d is extrapolated geometrically with the ratio ρ of the last two
/// improvements (the larger of ρ and its linear trend, clamped to [0, 0.9]), so the error still
/// to gain is d·ρ/(1 − ρ). Settled when that is within `tolerance` of the current error (or the
/// improvements vanished against ‖A‖²).
struct PowerIterationBound {
  double error2 = 0;            ///< current residual ‖A − QQᵀA‖² estimate
  double predicted_excess = 0;  ///< error² still to gain by iterating further
  bool settled = false;
};
inline PowerIterationBound power_iteration_bound(const std::vector<double>& h, double tolerance, double norm2) {
  const size_t hl = h.size();
  PowerIterationBound b;
  if (hl < 2) return b;
  const double d_last = std::max(0.0, h[hl - 2] - h[hl - 1]);
  constexpr double kRhoMax = 0.9;
  double rho = kRhoMax;
  if (hl >= 4 && h[hl - 3] - h[hl - 2] > 0.0 && h[hl - 4] - h[hl - 3] > 0.0) {
    const double r_last = d_last / (h[hl - 3] - h[hl - 2]);
    const double r_prev = (h[hl - 3] - h[hl - 2]) / (h[hl - 4] - h[hl - 3]);
    rho = std::max(r_last, 2.0 * r_last - r_prev);
  }
  rho = std::clamp(rho, 0.0, kRhoMax);
  b.error2 = h[hl - 1];
  b.predicted_excess = d_last * rho / (1.0 - rho);
  b.settled = b.predicted_excess <= tolerance * b.error2 || d_last <= 1e-6 * norm2;
  return b;
}

/// Progress text after power iteration `iterations`. Before the extrapolation has two
/// improvements to work with, the predicted excess can exceed the error itself: then no ratio is
/// printed (there is no finite bound yet) instead of "inf".
inline void format_power_iteration_stage(char (&text)[160], int iterations, const PowerIterationBound& b) {
  if (b.predicted_excess < b.error2)
    std::snprintf(text, sizeof text, "power iteration %d: error estimate %.6g, predicted %.5fx optimum", iterations,
                  std::sqrt(b.error2), std::sqrt(b.error2 / (b.error2 - b.predicted_excess)));
  else
    std::snprintf(text, sizeof text, "power iteration %d: error estimate %.6g, no bound on the optimum yet", iterations,
                  std::sqrt(b.error2));
}

/// Y += A·Ω over one column block: `a` holds columns [col0, col0 + cnt) of A and `acc` is Y.
/// Ω is dense (`omega`, zeta == 0) or sparse: `sparse_omega` holds zeta entries per row of Ω
/// (column + 1, negated for −1), and Y(:, j) ± A(:, t) runs over row chunks of 512 so that the
/// touched part of Y (512 × k) stays in cache. Shared by truncated_svd and out_of_core_svd,
/// which must give identical bits.
inline void accumulate_sketch(Eigen::MatrixXf& acc, const Eigen::MatrixXf& a, const Eigen::MatrixXf& omega,
                              const std::vector<int32_t>& sparse_omega, Eigen::Index zeta, Eigen::Index col0,
                              Eigen::Index cnt) {
  using Eigen::Index;
  if (zeta == 0) {
    acc.noalias() += a * omega.middleRows(col0, cnt);
    return;
  }
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
}

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
Eigen::MatrixXf orthonormal_basis(const Eigen::MatrixXf& y);

/// The candidate result of one power iteration beyond the SVD of Z's R factor (`rsvd`,
/// R = Ur·Sr·Vrᵀ, whose first `kk` singular values lie above the noise threshold):
/// M = A·P' = Y·Vr·Sr⁻¹ = Qm·Rm (`mqr`) and Rm = Um·S·Wmᵀ (`msvd`), `km` = min(kk, rows of Y).
/// Shared by truncated_svd and out_of_core_svd, which must give identical bits.
struct PowerIterationCandidate {
  Eigen::HouseholderQR<Eigen::MatrixXf> mqr;
  Eigen::JacobiSVD<Eigen::MatrixXd> msvd;
  Eigen::Index km = 0;

  /// Forms M from `y` (the pass's Y, one row per row of A) and `rsvd`, factorises it, and
  /// appends to `h` the two half-step residuals ‖A‖² − Σσ² (`norm2` = ‖A‖²) of the first `c`
  /// singular values of R and of Rm, both clamped at 0. Precondition: 1 ≤ kk ≤ rank of rsvd.
  void project(const Eigen::MatrixXf& y, const Eigen::JacobiSVD<Eigen::MatrixXd>& rsvd, Eigen::Index kk, Eigen::Index c,
               double norm2, std::vector<double>& h);
  /// Writes the rank-`c` factors U and S of the last projected candidate into `out`, with its
  /// report's error_estimate (√ of the last residual in `h`) and predicted_ratio (from
  /// `predicted_excess`), and returns the k × c rotation `rot` with V = P·rot (P the orthonormal
  /// basis of Z). When rank(A) < c the remaining c − min(c, km) components get singular value 0
  /// and orthonormal completions (unused columns of the two Householder bases).
  Eigen::MatrixXf finish(TruncatedSvd& out, const Eigen::JacobiSVD<Eigen::MatrixXd>& rsvd, Eigen::Index k,
                         Eigen::Index kk, Eigen::Index c, const std::vector<double>& h, double predicted_excess) const;
};

}  // namespace detail

/// The column source of the blocked truncated_svd(): copies columns [col0, col0 + count) of A
/// into `out` (already m × count).
using SvdColumnGather = std::function<void(size_t col0, size_t count, Eigen::MatrixXf& out)>;

/// The blocked truncated SVD behind truncated_svd(m, n, rank, gather, …): same contract, with the
/// column source type-erased, so that the Eigen decompositions it runs (BDCSVD, JacobiSVD,
/// Householder QR, large GEMMs) are compiled once, in the implementation TU (BTFLOD_IMPLEMENTATION),
/// not in every translation unit that includes this header.
Result<TruncatedSvd> truncated_svd_blocked(size_t m, size_t n, int rank, const SvdColumnGather& gather,
                                           const SvdOptions& options = {}, const ProgressCallback& progress = {});

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
  return truncated_svd_blocked(
      m, n, rank, [&gather](size_t col0, size_t count, Eigen::MatrixXf& out) { gather(col0, count, out); }, options,
      progress);
}

/// Truncated SVD of an in-memory matrix (convenience over the blocked version; implementation
/// TU).
Result<TruncatedSvd> truncated_svd(const Eigen::MatrixXf& a, int rank, const SvdOptions& options = {},
                                   const ProgressCallback& progress = {});

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_FACTOR_IMPLEMENTATION)
#if defined(BTFLOD_WITH_OPENBLAS)
extern "C" void openblas_set_num_threads(int);  // OpenBLAS's own API (cblas.h declares them too)
extern "C" int openblas_get_num_threads(void);
#endif
namespace btflod {

namespace detail {
/// With BTFLOD_WITH_OPENBLAS: OpenBLAS runs single-threaded while it lives (restored after).
/// The pool runs one product per thread during a pass, and OpenBLAS's own threads on top of it
/// oversubscribe the cores; between passes they spin-wait next to the pool's idle workers (the
/// QR and small-SVD stage took 19 % of the 256 × 256 factorisation with them, 3 % with Eigen).
/// Without OpenBLAS: nothing.
struct SingleThreadedBlas {
#if defined(BTFLOD_WITH_OPENBLAS)
  SingleThreadedBlas() noexcept : saved(openblas_get_num_threads()) { openblas_set_num_threads(1); }
  ~SingleThreadedBlas() { openblas_set_num_threads(saved); }
  SingleThreadedBlas(const SingleThreadedBlas&) = delete;
  SingleThreadedBlas& operator=(const SingleThreadedBlas&) = delete;
  int saved;
#endif
};

Eigen::MatrixXf orthonormal_basis(const Eigen::MatrixXf& y) {
  Eigen::HouseholderQR<Eigen::MatrixXf> qr(y);
  return qr.householderQ() * Eigen::MatrixXf::Identity(y.rows(), y.cols());
}

void PowerIterationCandidate::project(const Eigen::MatrixXf& y, const Eigen::JacobiSVD<Eigen::MatrixXd>& rsvd,
                                      Eigen::Index kk, Eigen::Index c, double norm2, std::vector<double>& h) {
  using Eigen::Index;
  const Eigen::VectorXd& sr = rsvd.singularValues();
  const Eigen::MatrixXd w = rsvd.matrixV().leftCols(kk) * sr.head(kk).cwiseInverse().asDiagonal();
  mqr.compute(y * w.template cast<float>());
  km = std::min<Index>(kk, y.rows());
  const Eigen::MatrixXd rm =
      mqr.matrixQR().topRows(km).template triangularView<Eigen::Upper>().toDenseMatrix().template cast<double>();
  msvd.compute(rm, Eigen::ComputeFullU | Eigen::ComputeFullV);
  h.push_back(std::max(0.0, norm2 - sr.head(std::min<Index>(c, sr.size())).squaredNorm()));
  h.push_back(std::max(0.0, norm2 - msvd.singularValues().head(std::min<Index>(c, km)).squaredNorm()));
}

Eigen::MatrixXf PowerIterationCandidate::finish(TruncatedSvd& out, const Eigen::JacobiSVD<Eigen::MatrixXd>& rsvd,
                                                Eigen::Index k, Eigen::Index kk, Eigen::Index c,
                                                const std::vector<double>& h, double predicted_excess) const {
  using Eigen::Index;
  using Eigen::MatrixXf;
  out.report.error_estimate = std::sqrt(h.back());
  out.report.predicted_ratio = predicted_excess <= 0.0       ? 1.0
                               : predicted_excess < h.back() ? std::sqrt(h.back() / (h.back() - predicted_excess))
                                                             : HUGE_VAL;
  // U = Qm·Um, V = P'·Wm = P·(Ur·Wm).
  const Index mi = mqr.rows();
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
  return rot;
}
}  // namespace detail

Result<TruncatedSvd> truncated_svd_blocked(size_t m, size_t n, int rank, const SvdColumnGather& gather,
                                           const SvdOptions& options, const ProgressCallback& progress) {
  using Eigen::Index;
  using Eigen::MatrixXf;
  if (m == 0 || n == 0 || rank < 1)
    return make_error(Status::invalid_argument, "truncated_svd: matrix %zux%zu, rank %d: need non-empty, rank >= 1", m,
                      n, rank);
  const Index c = std::min<Index>({static_cast<Index>(rank), static_cast<Index>(m), static_cast<Index>(n)});
  ThreadPool& pool = options.pool ? *options.pool : default_thread_pool();
  const bool exact =
      options.method == SvdMethod::exact || (options.method == SvdMethod::automatic && m * n <= options.exact_limit);
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
    const Eigen::VectorXd all = svd.singularValues().template cast<double>();
    out.report.exact = true;
    out.report.frobenius_norm = all.norm();
    out.report.error_estimate = all.tail(all.size() - c).norm();
    report_progress(progress, "svd", 1.0);
    return out;
  }

  // Randomised range finder (Halko et al. 2011, alg. 4.4 with a fused A·Aᵀ step).
  const Index k = std::min<Index>({c + options.oversampling, static_cast<Index>(m), static_cast<Index>(n)});
  const size_t bc = std::max<size_t>(1, options.block_columns);
  const size_t blocks = (n + bc - 1) / bc;
  const size_t stripes =
      std::max<size_t>(1, std::min<size_t>(static_cast<size_t>(std::max(1, options.stripes)), blocks));
  const Index mi = static_cast<Index>(m);
  [[maybe_unused]] const detail::SingleThreadedBlas single_threaded_blas;
  using Clock = std::chrono::steady_clock;
  const auto seconds_since = [](Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
  };
  const Clock::time_point call_start = Clock::now();
  std::vector<double> gather_s(stripes, 0.0), product_s(stripes, 0.0);

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
  std::vector<double> norm2_partial(stripes, 0.0);
  // One pass over the matrix: for every block, body(a_block, col0, cnt, stripe); the body adds
  // into partial[stripe] (and may write rows col0… of an n × k matrix: disjoint, no reduction).
  auto pass = [&](auto&& body) {
    const Clock::time_point pass_start = Clock::now();
    for (auto& p : partial) p.setZero(mi, k);
    pool.parallel_for(0, stripes, 1, [&](size_t s0, size_t s1) {
      MatrixXf buf;
      for (size_t s = s0; s < s1; ++s) {
        const size_t first = s * blocks / stripes, last = (s + 1) * blocks / stripes;
        for (size_t b = first; b < last; ++b) {
          const size_t col0 = b * bc, cnt = std::min(bc, n - col0);
          buf.resize(mi, static_cast<Index>(cnt));
          Clock::time_point t = Clock::now();
          gather(col0, cnt, buf);
          gather_s[s] += seconds_since(t);
          t = Clock::now();
          body(buf, static_cast<Index>(col0), static_cast<Index>(cnt), s);
          product_s[s] += seconds_since(t);
        }
      }
    });
    MatrixXf sum = std::move(partial[0]);
    for (size_t s = 1; s < stripes; ++s) sum += partial[s];
    for (auto& p : partial) p.resize(0, 0);  // not held during the small SVDs between passes
    ++out.report.passes;
    out.report.pass_seconds += seconds_since(pass_start);
    return sum;
  };
  // Fills the timing fields of the report (every return of the randomised path).
  const auto finish_timing = [&] {
    for (size_t s = 0; s < stripes; ++s) {
      out.report.gather_seconds += gather_s[s];
      out.report.product_seconds += product_s[s];
    }
    out.report.total_seconds = seconds_since(call_start);
  };
  // Passes over A (each gathers every column block once):
  //   q = 0: Y = A·Ω, Q = orth(Y); Bᵀ = Aᵀ·Q                          2 passes, 2 GEMMs
  //   q ≥ 1: Y = A·Ω, Q = orth(Y); then q times
  //          { Z = Aᵀ·Q (kept), Y = A·Z; candidate result from (Z, Y); Q = orth(Y) }
  //                                                                   q + 1 passes, 2q GEMMs
  // Each iteration's pass yields the row-space basis Z ∝ (AᵀA)^j·Ω (Halko et al. §4.5 applied to
  // Aᵀ) AND A·Z, so no separate projection pass is needed: with Z = P·R = (P·Ur)·Sr·Vrᵀ (QR, then
  // the small SVD of R), A·(P·Ur) = Y·Vr·Sr⁻¹, and A ≈ (A·P')·P'ᵀ is the optimal approximation
  // with rows in span(Z). Versus the textbook loop (q + 2 passes, 2q + 2 GEMMs, column basis
  // ∝ A(AᵀA)^q·Ω) this saves one GEMM and one gather for one power of the spectrum less.
  //
  // Adaptive number of power iterations (q_min ≤ q ≤ q_max). Error estimates: with ‖A‖²_F from
  // the sketch pass and any orthonormal Q (m × k), P (n × k),
  //   ‖A − [QQᵀA]_C‖²_F = ‖A‖²_F − Σ_{i≤C} σ_i(QᵀA)²,   ‖A − [AP]_C Pᵀ‖²_F = ‖A‖²_F − Σ_{i≤C} σ_i(AP)²
  // ([X]_C: rank-C truncation; Pythagoras, the residual of the projection is orthogonal to it).
  // Iteration j forms Z = AᵀQ_{j−1}, i.e. (QᵀA)ᵀ, whose singular values are those of R in Z = PR,
  // and A·P' = Y·Vr·Sr⁻¹ whose singular values the final SVD needs anyway. That gives, for free
  // (O((m + n)k²) next to the O(mnk) pass), two estimates per iteration:
  //   g_j = residual of [Q_{j−1}Q_{j−1}ᵀA]_C  (subspace ∝ A(AᵀA)^{j−1}Ω, one power of A less),
  //   e_j = residual of the candidate result [AP_j]_C P_jᵀ (∝ (AᵀA)^j Ω),
  // and g_1 ≥ e_1 ≥ g_2 ≥ e_2 ≥ … (each step's subspace contains the previous step's best rank-C
  // approximation, so the best rank-C error within it cannot grow), converging to the
  // Eckart–Young optimum e* = Σ_{i>C} σ_i² (subspace iteration converges to the dominant
  // k-subspace ⊇ the top-C one; Halko, Martinsson & Tropp 2011 §4.5 and §10.4: the power
  // scheme's error bounds contract geometrically, by a singular-value gap ratio per power of A).
  // For a geometric sequence of
  // half-step improvements d_i = h_{i−1} − h_i (h = g_1, e_1, g_2, e_2, …) with ratio ρ < 1,
  //   e_j − e* = Σ_{i>last} d_i = d_last · ρ/(1 − ρ),
  // so the remaining gap is bounded by a multiple of the last improvement. The sequence is a sum
  // of geometric modes, and its ratios grow as the fast modes die out (measured ratios d_i/d_{i−1}
  // 0.21, 0.36, 0.43, 0.47, … on the 32 × 32 car paint), so a constant ρ taken from the last
  // ratios underestimates the gap (by 1.1–1.7× on the synthesised materials). We therefore
  // extrapolate the ratio linearly, ρ = max(r_last, 2·r_last − r_prev) with r = d_i/d_{i−1},
  // clamp it to [0, 0.9], and stop once
  //   d_last · ρ/(1 − ρ) ≤ τ · e_j          (τ = power_tolerance),
  // or at q_max, or when d_last is at the float rounding level of the estimates (≤ 1e-6 ‖A‖²_F:
  // nothing left to measure). Measured on the synthesised 32 × 32 / 64 × 64 UBO2003 materials
  // (docs/factor.md) at the deciding iterations this predicts the true excess within 0.85–1.13×,
  // so τ = 0.005 keeps error / optimum below ~1.003 against the 1.005 bound. Fast-decaying
  // spectra converge in q_min = 2 iterations (no extra work); flat tails (car paint) take more.
  // The decision uses only deterministic quantities, so the iteration count and the result are
  // still independent of the thread count.
  const int q_request = std::max(0, options.power_iterations);
  const int q_max = std::max(q_request, options.max_power_iterations);
  const int q_min = q_max == 0 ? 0 : std::max(1, q_request);
  const double passes_bound = static_cast<double>(q_max == 0 ? 2 : q_max + 1);
  int done = 0;
  if (!report_progress(progress, "sketch", 0.0)) return make_error(Status::cancelled, "truncated_svd cancelled");
  MatrixXf q = detail::orthonormal_basis(pass([&](const MatrixXf& a, Index col0, Index cnt, size_t s) {
    MatrixXf& acc = partial[s];
    norm2_partial[s] += a.colwise().squaredNorm().template cast<double>().sum();
    detail::accumulate_sketch(acc, a, omega, sparse_omega, zeta, col0, cnt);
  }));
  omega.resize(0, 0);
  sparse_omega = {};
  ++done;
  double norm2 = 0.0;
  for (double p : norm2_partial) norm2 += p;  // stripe order: deterministic
  out.report.frobenius_norm = std::sqrt(norm2);
  if (q_max == 0) {
    if (!report_progress(progress, "project", done / passes_bound))
      return make_error(Status::cancelled, "truncated_svd cancelled");
    // B = Qᵀ·A (k × n), written column block by column block (disjoint, no reduction needed).
    MatrixXf bt(static_cast<Index>(n), k);  // Bᵀ
    const Clock::time_point project_start = Clock::now();
    pool.parallel_for(0, blocks, 1, [&](size_t b0, size_t b1) {
      MatrixXf buf;
      for (size_t b = b0; b < b1; ++b) {
        const size_t col0 = b * bc, cnt = std::min(bc, n - col0);
        buf.resize(mi, static_cast<Index>(cnt));
        gather(col0, cnt, buf);
        bt.middleRows(static_cast<Index>(col0), static_cast<Index>(cnt)).noalias() = buf.transpose() * q;
      }
    });
    ++out.report.passes;
    out.report.pass_seconds += seconds_since(project_start);
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
    out.report.error_estimate = std::sqrt(std::max(0.0, norm2 - small.singularValues().head(cc).squaredNorm()));
    out.report.predicted_ratio = 0.0;  // no iterations, nothing to extrapolate
    finish_timing();
    report_progress(progress, "project", 1.0);
    return out;
  }
  MatrixXf z(static_cast<Index>(n), k);
  MatrixXf y;
  // The candidate result of the latest iteration: Z = P·R (zqr), R = Ur·Sr·Vrᵀ (rsvd, double
  // Jacobi), M = A·P' = Y·Vr·Sr⁻¹ = Qm·Rm (candidate.mqr), Rm = Um·S·Wmᵀ (candidate.msvd).
  Eigen::HouseholderQR<MatrixXf> zqr;
  Eigen::JacobiSVD<Eigen::MatrixXd> rsvd;
  detail::PowerIterationCandidate candidate;
  Index kk = 0;
  std::vector<double> h;  // g_1, e_1, g_2, e_2, … (squared errors)
  double predicted_excess = 0.0;
  int iterations = 0;
  for (;;) {
    if (!report_progress(progress, iterations + 1 == q_min ? "project" : "power iteration", done / passes_bound))
      return make_error(Status::cancelled, "truncated_svd cancelled");
    // Z_b = A_bᵀ·Q into the rows of Z (disjoint), Y += A_b·Z_b (striped sums).
    y = pass([&](const MatrixXf& a, Index col0, Index cnt, size_t s) {
      auto zb = z.middleRows(col0, cnt);
      zb.noalias() = a.transpose() * q;
      partial[s].noalias() += a * zb;
    });
    ++done;
    ++iterations;
    q.resize(0, 0);  // the next basis, if any, is orth(Y)
    zqr.compute(z);
    const Eigen::MatrixXd rz =
        zqr.matrixQR().topRows(k).template triangularView<Eigen::Upper>().toDenseMatrix().template cast<double>();
    rsvd.compute(rz, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::VectorXd& sr = rsvd.singularValues();
    // Directions of Z below this relative size carry only rounding noise (A has no component
    // there, e.g. rank(A) < k); dividing by them would amplify it, so they are dropped.
    const double tol = sr.size() > 0 ? sr[0] * 1e-6 : 0.0;
    kk = 0;
    while (kk < sr.size() && sr[kk] > tol) ++kk;
    if (kk == 0) {  // A = 0 (or numerically so): zero factors with orthonormal bases
      out.u = MatrixXf::Identity(mi, c);
      out.s = Eigen::VectorXf::Zero(c);
      out.v = MatrixXf::Identity(static_cast<Index>(n), c);
      out.report.power_iterations = iterations;
      out.report.error_estimate = out.report.frobenius_norm;
      finish_timing();
      report_progress(progress, "project", 1.0);
      return out;
    }
    // M = A·P' = Y·Vr·Sr⁻¹ (m × kk), P' = P·Ur (n × kk, orthonormal). A ≈ M·P'ᵀ.
    candidate.project(y, rsvd, kk, c, norm2, h);
    // Extrapolation of the half-step improvements (see above).
    const detail::PowerIterationBound bound = detail::power_iteration_bound(h, options.power_tolerance, norm2);
    predicted_excess = bound.predicted_excess;
    const bool settled = bound.settled;
    if (progress) {
      char stage[160];
      detail::format_power_iteration_stage(stage, iterations, bound);
      if (!report_progress(progress, stage, done / passes_bound))
        return make_error(Status::cancelled, "truncated_svd cancelled");
    }
    if (iterations >= q_max || (iterations >= q_min && settled)) break;
    q = detail::orthonormal_basis(y);
  }
  y.resize(0, 0);
  out.report.power_iterations = iterations;
  const MatrixXf rot = candidate.finish(out, rsvd, k, kk, c, h, predicted_excess);
  const MatrixXf pz = zqr.householderQ() * MatrixXf::Identity(static_cast<Index>(n), k);
  out.v = pz * rot;
  finish_timing();
  report_progress(progress, "project", 1.0);
  return out;
}

Result<TruncatedSvd> truncated_svd(const Eigen::MatrixXf& a, int rank, const SvdOptions& options,
                                   const ProgressCallback& progress) {
  return truncated_svd_blocked(
      static_cast<size_t>(a.rows()), static_cast<size_t>(a.cols()), rank,
      [&a](size_t col0, size_t count, Eigen::MatrixXf& out) {
        out = a.middleCols(static_cast<Eigen::Index>(col0), static_cast<Eigen::Index>(count));
      },
      options, progress);
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
