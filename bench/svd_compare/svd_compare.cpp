// btflod-svd-compare — btflod's randomised truncated SVD (in memory and out of core from a BTF
// store) against SLEPc's randomised SVD (SVDRANDOMIZED) and SLEPc's default solver on the same
// matrix in the same run: error against the Eckart–Young optimum (exact BDCSVD) and wall time.
// Opt-in (./run.sh svd-compare; needs Debian libslepc-real-dev), never part of CI.
//
// usage: btflod-svd-compare [--material cloth|stone|leather|tiles] [--size N] [--rank C] [--dir D]
#include <slepcsvd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>

#include "btflod/offline/btf/btf_store.hpp"
#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/out_of_core_svd.hpp"
#include "btflod/offline/factor/truncated_svd.hpp"

using namespace btflod;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// ‖A − U·diag(s)·Vᵀ‖_F computed against the dense matrix (not from the singular values).
double residual(const Eigen::MatrixXf& a, const Eigen::MatrixXd& u, const Eigen::VectorXd& s,
                const Eigen::MatrixXd& v) {
  const Eigen::MatrixXd r = a.cast<double>() - u * s.asDiagonal() * v.transpose();
  return r.norm();
}

struct SlepcRun {
  double seconds = 0.0, error = 0.0;
  int converged = 0, iterations = 0;
};

/// SLEPc SVD of the dense matrix `a` with the given solver type, nsv = rank, ncv = rank + oversampling.
SlepcRun run_slepc(const Eigen::MatrixXf& a, int rank, int ncv, SVDType type, double tol) {
  SlepcRun out;
  const PetscInt m = static_cast<PetscInt>(a.rows()), n = static_cast<PetscInt>(a.cols());
  Mat mat;
  MatCreateSeqDense(PETSC_COMM_SELF, m, n, nullptr, &mat);
  PetscScalar* data = nullptr;
  MatDenseGetArray(mat, &data);
  for (PetscInt j = 0; j < n; ++j)
    for (PetscInt i = 0; i < m; ++i) data[j * m + i] = static_cast<PetscScalar>(a(i, j));
  MatDenseRestoreArray(mat, &data);
  MatAssemblyBegin(mat, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(mat, MAT_FINAL_ASSEMBLY);
  const auto t0 = Clock::now();
  SVD svd;
  SVDCreate(PETSC_COMM_SELF, &svd);
  SVDSetOperators(svd, mat, nullptr);
  SVDSetType(svd, type);
  SVDSetDimensions(svd, rank, ncv, PETSC_DEFAULT);
  SVDSetTolerances(svd, tol, 1000);
  SVDSolve(svd);
  PetscInt nconv = 0, its = 0;
  SVDGetConverged(svd, &nconv);
  SVDGetIterationNumber(svd, &its);
  out.seconds = seconds_since(t0);
  out.converged = static_cast<int>(nconv);
  out.iterations = static_cast<int>(its);
  const int c = std::min<int>(rank, static_cast<int>(nconv));
  Eigen::MatrixXd u(m, c), v(n, c);
  Eigen::VectorXd s(c);
  Vec uv, vv;
  MatCreateVecs(mat, &vv, &uv);
  for (int i = 0; i < c; ++i) {
    PetscReal sigma = 0;
    SVDGetSingularTriplet(svd, i, &sigma, uv, vv);
    s[i] = sigma;
    const PetscScalar* p = nullptr;
    VecGetArrayRead(uv, &p);
    for (PetscInt r = 0; r < m; ++r) u(r, i) = p[r];
    VecRestoreArrayRead(uv, &p);
    VecGetArrayRead(vv, &p);
    for (PetscInt r = 0; r < n; ++r) v(r, i) = p[r];
    VecRestoreArrayRead(vv, &p);
  }
  out.error = residual(a, u, s, v);
  VecDestroy(&uv);
  VecDestroy(&vv);
  SVDDestroy(&svd);
  MatDestroy(&mat);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::string material_name = "cloth", dir = ".";
  int size = 32, rank = 32;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "--material")
      material_name = argv[i + 1];
    else if (k == "--size")
      size = std::atoi(argv[i + 1]);
    else if (k == "--rank")
      rank = std::atoi(argv[i + 1]);
    else if (k == "--dir")
      dir = argv[i + 1];
  }
  const auto material = material_from_name(material_name);
  if (!material || size < 4 || size > 256 || rank < 1) {
    std::fprintf(
        stderr,
        "usage: btflod-svd-compare [--material cloth|stone|leather|tiles] [--size 4..256] [--rank C] [--dir D]\n");
    return 2;
  }
  int pargc = 1;
  char* pargv0[] = {argv[0], nullptr};
  char** pargv = pargv0;
  SlepcInitialize(&pargc, &pargv, nullptr, nullptr);
  SynthesisOptions so;
  auto btf = synthesize_material(*material, size, size, 1, so);
  if (!btf) {
    std::fprintf(stderr, "%s\n", btf.message().c_str());
    return 1;
  }
  const size_t m = btf->view_count() * btf->light_count() * 3, n = btf->texel_count();
  Eigen::MatrixXf a(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(n));
  gather_fmf_columns(*btf, 0, n, a);
  std::printf("Command: btflod-svd-compare --material %s --size %d --rank %d\n", material_name.c_str(), size, rank);
  std::printf("matrix %zu x %zu (UBO2003 81 x 81 directions x %d^2 texels, %s), rank %d, %u threads for btflod\n\n", m,
              n, size, material_name.c_str(), rank, default_thread_pool().thread_count() + 1);

  auto t0 = Clock::now();
  SvdOptions exact_o;
  exact_o.method = SvdMethod::exact;
  auto exact = truncated_svd(a, rank, exact_o);
  const double exact_s = seconds_since(t0);
  if (!exact) return 1;
  const double optimum = exact->report.error_estimate;
  std::printf("| method | time s | error | error / optimum | notes |\n|---|---:|---:|---:|---|\n");
  std::printf("| exact BDCSVD (Eigen) | %.3f | %.6g | 1 | the Eckart-Young optimum |\n", exact_s, optimum);

  SvdOptions ro;
  ro.method = SvdMethod::randomized;
  t0 = Clock::now();
  auto mem = truncated_svd(a, rank, ro);
  const double mem_s = seconds_since(t0);
  if (!mem) return 1;
  const double mem_err = residual(a, mem->u.cast<double>(), mem->s.cast<double>(), mem->v.cast<double>());
  std::printf("| btflod randomised, in memory | %.3f | %.6g | %.5f | %d power iterations, sparse sign sketch |\n",
              mem_s, mem_err, mem_err / optimum, mem->report.power_iterations);

  const std::string store_path = dir + "/svd_compare.btfstore";
  if (auto s = write_btf_store(*btf, store_path, BtfStoreValueType::float32, 256); !s) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    return 1;
  }
  auto store = BtfStore::open(store_path);
  if (!store) return 1;
  OutOfCoreSvdOptions oo;
  oo.svd = ro;
  oo.column_alignment = 256;
  oo.memory_budget = uint64_t{1} << 30;
  t0 = Clock::now();
  auto ooc = out_of_core_svd(
      m, n, rank,
      [&](size_t col0, size_t count, Eigen::MatrixXf& out, std::vector<uint8_t>& scratch) {
        return store->read_columns(col0, count, out.data(), m, scratch);
      },
      oo);
  const double ooc_s = seconds_since(t0);
  if (!ooc) {
    std::fprintf(stderr, "%s\n", ooc.message().c_str());
    return 1;
  }
  const double ooc_err = residual(a, ooc->svd.u.cast<double>(), ooc->svd.s.cast<double>(), ooc->svd.v.cast<double>());
  std::printf(
      "| btflod randomised, out of core (store, 1 GiB budget) | %.3f | %.6g | %.5f | bit-identical to in memory: %s "
      "|\n",
      ooc_s, ooc_err, ooc_err / optimum,
      (ooc->svd.u.size() == mem->u.size() &&
       std::memcmp(ooc->svd.u.data(), mem->u.data(), sizeof(float) * static_cast<size_t>(mem->u.size())) == 0)
          ? "yes"
          : "no");
  std::remove(store_path.c_str());

  for (double tol : {1e-2, 1e-4}) {
    const SlepcRun r = run_slepc(a, rank, rank + ro.oversampling, SVDRANDOMIZED, tol);
    std::printf("| SLEPc SVDRANDOMIZED, tol %.0e, ncv %d | %.3f | %.6g | %.5f | %d converged, %d iterations |\n", tol,
                rank + ro.oversampling, r.seconds, r.error, r.error / optimum, r.converged, r.iterations);
  }
  {
    const SlepcRun r = run_slepc(a, rank, rank + ro.oversampling, SVDTRLANCZOS, 1e-8);
    std::printf("| SLEPc SVDTRLANCZOS (Lanczos), tol 1e-8 | %.3f | %.6g | %.5f | %d converged, %d restarts |\n",
                r.seconds, r.error, r.error / optimum, r.converged, r.iterations);
  }
  SlepcFinalize();
  return 0;
}
