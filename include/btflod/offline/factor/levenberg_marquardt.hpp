// btflod — small non-linear least-squares problems (a handful of parameters, up to a few
// thousand residuals): Levenberg–Marquardt through Eigen's unsupported/Eigen/LevenbergMarquardt.
//
// Why Eigen's LM and not Ceres Solver: btflod is a header-only library and its fitters
// (offline/factor/spmm.hpp, the Phong fit of offline/factor/laplacian_pca.hpp) are called by engines and tools
// directly, so the solver must live in a header too. Eigen is already btflod's linear-algebra
// dependency and ships this solver as a header (a port of MINPACK's lmder: trust-region LM with
// Moré's scaling and QR solves, the reference implementation the NLS literature tests
// against); Ceres would add a compiled library plus glog/gflags to every consumer for problems
// of 1 to 6 parameters, where its sparse machinery and automatic differentiation buy nothing.
// The problems here are smooth and tiny, so Jacobians are either analytic or forward
// differences (minimize_least_squares_numeric).
#pragma once

#include <Eigen/Dense>
#include <unsupported/Eigen/LevenbergMarquardt>

#include <algorithm>
#include <cmath>
#include <utility>

namespace btflod {

/// Options of minimize_least_squares().
struct LeastSquaresOptions {
  int max_evaluations = 400;  ///< residual evaluations (MINPACK maxfev)
  double tolerance = 1e-10;   ///< relative tolerance on the cost (ftol) and the parameters (xtol)
};

/// What the solver did.
struct LeastSquaresReport {
  double cost = 0.0;    ///< ½‖r‖² at the returned parameters
  int evaluations = 0;  ///< residual evaluations
  int status = 0;       ///< Eigen::LevenbergMarquardtSpace::Status
};

namespace detail {
template <class Residual, class Jacobian>
struct LmFunctor : Eigen::DenseFunctor<double> {
  LmFunctor(int inputs, int values, Residual& r, Jacobian& j)
      : Eigen::DenseFunctor<double>(inputs, values), res(r), jac(j) {}
  int operator()(const InputType& x, ValueType& f) const {
    res(x, f);
    for (Eigen::Index i = 0; i < f.size(); ++i)
      if (!std::isfinite(f[i])) f[i] = 1e30;  // keeps the trust region shrinking away from NaN
    return 0;
  }
  int df(const InputType& x, JacobianType& j) const {
    jac(x, j);
    return 0;
  }
  Residual& res;
  Jacobian& jac;
};
}  // namespace detail

/// Minimises ½‖r(p)‖² over p (in place) with Levenberg–Marquardt. `residual(p, r)` fills
/// r (size residual_count) and `jacobian(p, J)` fills J (residual_count × p.size()), both as
/// Eigen::VectorXd / Eigen::MatrixXd. Non-finite residuals are replaced by 1e30 so a step into
/// an invalid region is rejected. Deterministic; allocates; thread-safe when the callables are.
/// Precondition: residual_count ≥ p.size() ≥ 1.
template <class Residual, class Jacobian>
LeastSquaresReport minimize_least_squares(Eigen::VectorXd& p, Eigen::Index residual_count, Residual&& residual,
                                          Jacobian&& jacobian, const LeastSquaresOptions& options = {}) {
  using F = detail::LmFunctor<std::remove_reference_t<Residual>, std::remove_reference_t<Jacobian>>;
  F functor(static_cast<int>(p.size()), static_cast<int>(residual_count), residual, jacobian);
  Eigen::LevenbergMarquardt<F> lm(functor);
  lm.setMaxfev(options.max_evaluations);
  lm.setFtol(options.tolerance);
  lm.setXtol(options.tolerance);
  const Eigen::VectorXd start = p;
  const auto status = lm.minimize(p);
  Eigen::VectorXd r(residual_count);
  functor(p, r);
  LeastSquaresReport report;
  report.cost = 0.5 * r.squaredNorm();
  report.evaluations = static_cast<int>(lm.nfev());
  report.status = static_cast<int>(status);
  if (!p.allFinite()) {  // never hand back NaN parameters
    p = start;
    functor(p, r);
    report.cost = 0.5 * r.squaredNorm();
  }
  return report;
}

/// minimize_least_squares() with a forward-difference Jacobian (step 1e-6·max(1, |p_i|)).
template <class Residual>
LeastSquaresReport minimize_least_squares_numeric(Eigen::VectorXd& p, Eigen::Index residual_count, Residual&& residual,
                                                  const LeastSquaresOptions& options = {}) {
  Eigen::VectorXd base(residual_count), moved(residual_count);
  auto jacobian = [&](const Eigen::VectorXd& x, Eigen::MatrixXd& j) {
    residual(x, base);
    Eigen::VectorXd xh = x;
    for (Eigen::Index k = 0; k < x.size(); ++k) {
      const double h = 1e-6 * std::max(1.0, std::abs(x[k]));
      xh[k] = x[k] + h;
      residual(xh, moved);
      j.col(k) = (moved - base) / h;
      xh[k] = x[k];
    }
  };
  return minimize_least_squares(p, residual_count, residual, jacobian, options);
}

}  // namespace btflod
