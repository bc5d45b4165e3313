// btflod-convert factor_mpi — the FMF of a BTF store distributed over MPI ranks
// (offline/factor/mpi_svd.hpp): run under mpirun; each rank reads only its range of texel columns from
// the (shared) store, rank 0 writes the factor file.
// btflod-link: btflod_mpi
#include <mpi.h>

#include <cstdio>
#include <string>

#include "command.hpp"
#include "store_commands.hpp"

#include "btflod/offline/factor/mpi_svd.hpp"

namespace {

using namespace btflod;

int run_factor_mpi(convert::Options& opt) {
  const bool paper = convert::paper_profile(opt);
  const SvdOptions d{};
  convert::StoreFactorArgs a;
  a.components = static_cast<int>(opt.integer("components", paper ? 100 : 16, 1, 100000));
  const std::string memory_text = opt.string("memory", "4G");
  const auto memory = convert::parse_byte_size(memory_text);
  if (!memory) opt.error("--memory " + memory_text + ": expected a size such as 4G, 512M or 1500000000");
  a.checkpoint = opt.string("checkpoint", "");
  a.svd.block_columns = static_cast<size_t>(opt.integer("block-columns", 256, 1, 1 << 20));
  a.svd.power_iterations = static_cast<int>(opt.integer("power-iterations", d.power_iterations, 0, 20));
  a.svd.max_power_iterations = static_cast<int>(opt.integer("max-power-iterations", d.max_power_iterations, 0, 20));
  a.svd.power_tolerance = opt.number("power-tolerance", d.power_tolerance, 0.0, 1.0);
  a.svd.oversampling = static_cast<int>(opt.integer("oversampling", d.oversampling, 0, 1000));
  a.svd.sketch_nonzeros = static_cast<int>(opt.integer("sketch-nonzeros", d.sketch_nonzeros, 0, 1000));
  a.stop_after_passes = static_cast<int>(opt.integer("stop-after-passes", 0, 0, 100));
  a.quiet = opt.flag("quiet", 'q');
  if (!opt.finish()) return convert::kExitUsage;
  if (opt.positional().size() != 2) {
    std::fprintf(stderr, "btflod-convert factor_mpi: expected IN.btfstore and OUT (got %zu arguments)\n",
                 opt.positional().size());
    return convert::kExitUsage;
  }
  a.in = opt.positional()[0];
  a.out = opt.positional()[1];
  a.memory_budget = *memory;
  int provided = 0;
  MPI_Init_thread(&opt.argc(), &opt.argv(), MPI_THREAD_FUNNELED, &provided);
  int code = convert::kExitFailure;
  {
    MpiSvdCommunicator comm(MPI_COMM_WORLD);
    a.communicator = &comm;
    code = convert::run_factor_store(a);
    int mine = code, worst = 0;
    MPI_Allreduce(&mine, &worst, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    code = worst;
  }
  MPI_Finalize();
  return code;
}

constexpr char kFactorMpiUsage[] =
    "usage: mpirun -np P btflod-convert factor_mpi IN.btfstore OUT [--components C] [--profile paper]\n"
    "                             [--memory SIZE] [--checkpoint FILE] [--block-columns N]\n"
    "                             [--power-iterations Q] [--max-power-iterations QMAX] [--power-tolerance T]\n"
    "                             [--oversampling P] [--sketch-nonzeros Z] [--stop-after-passes K] [--quiet]\n"
    "  FMF (paper 000) of a BTF store on P MPI ranks: rank r reads only its contiguous range of texel\n"
    "  columns (whole store blocks); sketch, power iterations and projections are combined with MPI\n"
    "  collectives; rank 0 writes OUT and the checkpoint after every pass (resumed by the same\n"
    "  command). --memory is the budget of each rank (default 4G). Same algorithm and seed as\n"
    "  `btflod-convert factor IN.btfstore OUT`; the results agree to rounding (1e-6 relative).";

}  // namespace

BTFLOD_CONVERT_COMMAND(factor_mpi, "FMF of a .btfstore on MPI ranks (run under mpirun)", kFactorMpiUsage,
                       run_factor_mpi);
