// btflod — truncated SVD of large matrices that are read in column blocks: exact (Eigen
// BDCSVD) for small inputs and a randomised range finder (Halko, Martinsson, Tropp 2011,
// algorithms 4.3/4.4 + 5.1: Gaussian sketch with oversampling, power iterations with
// re-orthonormalisation) that never holds more than a few column blocks of the input.
//
// The matrix is never materialised by the randomised path: a caller-supplied `gather`
// functor copies columns [col0, col0 + count) into an m × count Eigen matrix. Peak memory is
// therefore the caller's storage plus O((m + n)·k) for the sketches plus
// stripes · m · block_columns for the gather buffers.
//
// Determinism: the Gaussian test matrix comes from a fixed seed (own generator, not
// std::normal_distribution, so all standard libraries agree), the column blocks are split
// into a fixed number of stripes whose partial sums are added in stripe order, so results do
// not depend on the thread count.
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

/// Options of truncated_svd(). Defaults: oversampling 30, 2 power iterations. Measured on a 64×64
/// UBO2003 cloth at rank 100 (bench_factor): error / Eckart–Young optimum = 1.0081 for p = 10,
/// q = 2; 1.0029 for p = 10, q = 3; 1.0017 for p = 30, q = 2 (fewest flops of the last two).
struct SvdOptions {
  SvdMethod method = SvdMethod::automatic;
  int oversampling = 30;      ///< extra sketch columns p (k = rank + p)
  int power_iterations = 2;   ///< q: passes of Y ← A·Aᵀ·Q, each followed by re-orthonormalisation
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
/// Status::cancelled when `progress` returns false.
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

  MatrixXf omega(static_cast<Index>(n), k);
  {
    detail::NormalGenerator gen(options.seed);
    for (Index j = 0; j < k; ++j)
      for (Index i = 0; i < omega.rows(); ++i) omega(i, j) = static_cast<float>(gen.next());
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
  const int total_passes = 2 + std::max(0, options.power_iterations);
  int done = 0;
  if (!report_progress(progress, "sketch", 0.0)) return make_error(Status::cancelled, "truncated_svd cancelled");
  MatrixXf q = detail::orthonormal_basis(pass([&](const MatrixXf& a, Index col0, Index cnt, MatrixXf& acc) {
    acc.noalias() += a * omega.middleRows(col0, cnt);
  }));
  omega.resize(0, 0);
  ++done;
  for (int it = 0; it < options.power_iterations; ++it) {
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
  const Eigen::MatrixXd r = qr.matrixQR().topRows(kr).template triangularView<Eigen::Upper>().toDenseMatrix().template cast<double>();
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
