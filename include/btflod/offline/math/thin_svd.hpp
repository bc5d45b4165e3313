// btflod — thin SVD of an in-memory float matrix (Eigen BDCSVD), compiled once.
//
// Offline code. Eigen's BDCSVD is among the most expensive templates to instantiate (tens of
// seconds per translation unit); callers use exact_thin_svd() instead of instantiating it
// themselves, and its one instantiation lives in the implementation TU (BTFLOD_IMPLEMENTATION,
// see btflod.hpp).
#pragma once

#include "btflod/offline/math/eigen.hpp"

namespace btflod {

/// A = u · diag(s) · vᵀ with u m × r, s r (descending), v n × r, r = min(m, n).
struct ThinSvd {
  Eigen::MatrixXf u;
  Eigen::VectorXf s;
  Eigen::MatrixXf v;
};

/// Thin SVD of `a` by Eigen's BDCSVD (ComputeThinU | ComputeThinV): the same numbers as
/// instantiating `Eigen::BDCSVD<Eigen::MatrixXf>` in place. Allocates O((m + n)·min(m, n)); not
/// for untrusted sizes. Thread-safe (no shared state).
ThinSvd exact_thin_svd(const Eigen::MatrixXf& a);

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_FACTOR_IMPLEMENTATION)
namespace btflod {

ThinSvd exact_thin_svd(const Eigen::MatrixXf& a) {
  Eigen::BDCSVD<Eigen::MatrixXf> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
  return ThinSvd{svd.matrixU(), svd.singularValues(), svd.matrixV()};
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
