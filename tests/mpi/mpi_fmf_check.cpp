// Run under mpirun (ctest: -np 2 and -np 3): the distributed out-of-core FMF
// (offline/factor/mpi_svd.hpp + offline/factor/fmf_out_of_core.hpp) against the single-process run of the same
// algorithm and seed on the same store:
//   - singular values and the reconstruction U·Σ·Vᵀ agree to 1e-6 relative;
//   - every rank read only its own columns (columns_read = passes × its range);
//   - a distributed run stopped after pass 2 resumes from its checkpoint to the identical bits;
//   - V gathered on rank 0 covers every texel.
// Exit code 0 on every rank when all checks pass, 1 otherwise (printed by rank 0).
#include <mpi.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <sys/resource.h>
#include <unistd.h>

#include "btflod/offline/btf/btf_store.hpp"
#include "btflod/offline/factor/fmf_out_of_core.hpp"
#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/factor/mpi_svd.hpp"

using namespace btflod;

namespace {

int failures = 0;

void check(bool ok, const char* what, double value = 0.0) {
  if (!ok) {
    ++failures;
    std::fprintf(stderr, "FAILED: %s (%g)\n", what, value);
  }
}

Eigen::MatrixXf reconstruction(const Fmf& f) {
  using RowMat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Eigen::Index m = static_cast<Eigen::Index>(f.u.size() / static_cast<size_t>(f.components));
  const Eigen::Index n = static_cast<Eigen::Index>(f.v.size() / static_cast<size_t>(f.components));
  Eigen::Map<const RowMat> u(f.u.data(), m, f.components), v(f.v.data(), n, f.components);
  return u * v.transpose();
}

double cpu_seconds() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  MpiSvdCommunicator comm(MPI_COMM_WORLD);
  const std::string dir = argc > 1 ? argv[1] : ".";
  const std::string tag = std::to_string(comm.size());
  const std::string store_path = dir + "/mpi_check_" + tag + ".btfstore";
  const std::string ckpt = dir + "/mpi_check_" + tag + ".ckpt";
  // 40 × 30 texels in 75 blocks of 16, 9 × 9 directions: A is 243 × 1200.
  if (comm.rank() == 0) {
    const BtfFloat btf =
        make_low_rank_btf(40, 30, small_direction_set(3, 4), small_direction_set(3, 4), 14, 0.8f, 0.002f, 5);
    if (auto s = write_btf_store(btf, store_path, BtfStoreValueType::float32, 16); !s) {
      std::fprintf(stderr, "%s\n", s.message().c_str());
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    std::remove(ckpt.c_str());
  }
  MPI_Barrier(MPI_COMM_WORLD);
  auto store = BtfStore::open(store_path);
  if (!store) {
    std::fprintf(stderr, "rank %d: %s\n", comm.rank(), store.message().c_str());
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  FmfOutOfCoreOptions o;
  o.components = 10;
  o.svd.svd.oversampling = 10;
  o.svd.svd.block_columns = 32;
  o.svd.svd.power_iterations = 3;
  o.svd.svd.max_power_iterations = 6;
  o.svd.communicator = &comm;
  const double cpu0 = cpu_seconds();
  FmfOutOfCoreReport rep;
  auto dist = factorize_fmf_out_of_core(*store, o, {}, &rep);
  const double cpu = cpu_seconds() - cpu0;
  if (!dist) {
    std::fprintf(stderr, "rank %d: %s\n", comm.rank(), dist.message().c_str());
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  const size_t local = rep.svd.column_end - rep.svd.column_begin;
  check(local > 0 && local < store->columns(), "each rank owns a proper part of the columns",
        static_cast<double>(local));
  check(rep.svd.columns_read == static_cast<uint64_t>(rep.svd.passes) * local, "a rank reads only its own columns",
        static_cast<double>(rep.svd.columns_read));
  std::printf("rank %d: columns [%zu, %zu), %d passes, %.3f s CPU, %llu bytes read, %llu bytes sent\n", comm.rank(),
              rep.svd.column_begin, rep.svd.column_end, rep.svd.passes, cpu,
              static_cast<unsigned long long>(rep.bytes_read),
              static_cast<unsigned long long>(rep.svd.bytes_communicated));

  // Stop after pass 2, resume: identical bits on rank 0.
  FmfOutOfCoreOptions oc = o;
  oc.svd.checkpoint_path = ckpt;
  oc.svd.stop_after_passes = 2;
  auto stopped = factorize_fmf_out_of_core(*store, oc);
  check(!stopped && stopped.status() == Status::cancelled, "the injected stop after pass 2 stops the run");
  oc.svd.stop_after_passes = 0;
  auto resumed = factorize_fmf_out_of_core(*store, oc);
  check(static_cast<bool>(resumed), "the resumed run succeeds");

  if (comm.rank() == 0) {
    FmfOutOfCoreOptions single = o;
    single.svd.communicator = nullptr;
    auto one = factorize_fmf_out_of_core(*store, single);
    if (!one) {
      std::fprintf(stderr, "single process: %s\n", one.message().c_str());
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    check(dist->v.size() == store->columns() * 10, "V is gathered on rank 0", static_cast<double>(dist->v.size()));
    double s_err = 0.0;
    for (size_t i = 0; i < one->singular_values.size(); ++i)
      s_err = std::max(s_err, std::fabs(static_cast<double>(dist->singular_values[i] - one->singular_values[i])) /
                                  static_cast<double>(one->singular_values[0]));
    const Eigen::MatrixXf a = reconstruction(*one), b = reconstruction(*dist);
    const double rec_err = static_cast<double>((a - b).norm() / a.norm());
    std::printf("%d ranks vs 1 process: singular values %.3g, reconstruction %.3g relative (%d vs %d iterations)\n",
                comm.size(), s_err, rec_err, dist->svd_report.power_iterations, one->svd_report.power_iterations);
    check(s_err <= 1e-6, "singular values match the single-process run to 1e-6", s_err);
    check(rec_err <= 1e-6, "the reconstruction matches the single-process run to 1e-6", rec_err);
    check(dist->svd_report.power_iterations == one->svd_report.power_iterations, "same number of power iterations");
    if (resumed) {
      check(resumed->u == dist->u, "resumed U is bit-identical");
      check(resumed->v == dist->v, "resumed V is bit-identical");
    }
    std::remove(ckpt.c_str());
    std::remove(store_path.c_str());
  }
  int local_fail = failures, all_fail = 0;
  MPI_Allreduce(&local_fail, &all_fail, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  if (comm.rank() == 0)
    std::printf("%s\n", all_fail == 0 ? "mpi_fmf_check: all checks passed" : "mpi_fmf_check: FAILED");
  MPI_Finalize();
  return all_fail == 0 ? 0 : 1;
}
