// btflod — MPI transport for the distributed out-of-core SVD (offline/factor/out_of_core_svd.hpp):
// an SvdCommunicator over an MPI communicator. Only this header includes <mpi.h>; it is usable
// when the program is built with MPI (CMake: BTFLOD_WITH_MPI, target btflod::mpi) and compiles
// to nothing otherwise.
//
// Usage (every rank; MPI_Init already called):
//   btflod::MpiSvdCommunicator comm(MPI_COMM_WORLD);
//   btflod::FmfOutOfCoreOptions o;  o.svd.communicator = &comm;
//   auto fmf = btflod::factorize_fmf_out_of_core(*store, o);   // complete on rank 0
#pragma once

#if __has_include(<mpi.h>)
#include <mpi.h>

#include <algorithm>
#include <climits>
#include <cstdint>
#include <span>
#include <vector>

#include "btflod/core/result.hpp"
#include "btflod/offline/factor/out_of_core_svd.hpp"

namespace btflod {

/// SvdCommunicator over MPI collectives. sum() reduces to rank 0 and broadcasts (so every rank
/// receives the same bits whatever reduction algorithm the MPI library picks); all_gather() is
/// MPI_Allgather; gather_to_root() is MPI_Gatherv; all_ok() is an MPI_Allreduce with MPI_LAND.
/// Large arrays are sent in chunks of at most 2^27 elements (MPI counts are int). Not
/// thread-safe: call from the thread that calls out_of_core_svd() (MPI_THREAD_FUNNELED suffices).
class MpiSvdCommunicator final : public SvdCommunicator {
 public:
  /// Wraps `comm` (not duplicated, not freed). Precondition: MPI is initialised.
  explicit MpiSvdCommunicator(MPI_Comm comm = MPI_COMM_WORLD) noexcept : comm_(comm) {
    MPI_Comm_rank(comm_, &rank_);
    MPI_Comm_size(comm_, &size_);
  }
  int rank() const noexcept override { return rank_; }
  int size() const noexcept override { return size_; }

  VoidResult sum(std::span<double> values) override {
    std::vector<double> reduced(rank_ == 0 ? std::min(values.size(), kChunk) : 0);
    for (size_t off = 0; off < values.size(); off += kChunk) {
      const int n = static_cast<int>(std::min(kChunk, values.size() - off));
      if (MPI_Reduce(values.data() + off, rank_ == 0 ? reduced.data() : nullptr, n, MPI_DOUBLE, MPI_SUM, 0, comm_) !=
          MPI_SUCCESS)
        return make_error(Status::io_error, "MPI_Reduce of %d doubles failed", n);
      if (rank_ == 0) std::copy_n(reduced.data(), n, values.data() + off);
      if (MPI_Bcast(values.data() + off, n, MPI_DOUBLE, 0, comm_) != MPI_SUCCESS)
        return make_error(Status::io_error, "MPI_Bcast of %d doubles failed", n);
      sent_ += static_cast<uint64_t>(n) * sizeof(double) * (rank_ == 0 ? static_cast<uint64_t>(size_ - 1) : 1);
    }
    return {};
  }

  VoidResult all_gather(std::span<const float> local, std::span<float> all) override {
    if (local.size() > kChunk || all.size() != local.size() * static_cast<size_t>(size_))
      return make_error(Status::invalid_argument, "MPI all_gather: %zu values per rank, %zu in total", local.size(),
                        all.size());
    if (MPI_Allgather(local.data(), static_cast<int>(local.size()), MPI_FLOAT, all.data(),
                      static_cast<int>(local.size()), MPI_FLOAT, comm_) != MPI_SUCCESS)
      return make_error(Status::io_error, "MPI_Allgather of %zu floats failed", local.size());
    sent_ += local.size() * sizeof(float) * static_cast<uint64_t>(size_ - 1);
    return {};
  }

  VoidResult gather_to_root(std::span<const float> local, std::span<float> all,
                            std::span<const size_t> counts) override {
    if (counts.size() != static_cast<size_t>(size_) || counts[static_cast<size_t>(rank_)] != local.size())
      return make_error(Status::invalid_argument, "MPI gather: counts do not match the ranks");
    // Rank by rank in chunks, so counts beyond INT_MAX need no MPI-4 large-count calls.
    size_t offset = 0;
    for (int r = 0; r < size_; ++r) {
      const size_t count = counts[static_cast<size_t>(r)];
      for (size_t off = 0; off < count; off += kChunk) {
        const int n = static_cast<int>(std::min(kChunk, count - off));
        if (r == 0 && rank_ == 0) {
          std::copy_n(local.data() + off, n, all.data() + offset + off);
        } else if (rank_ == 0) {
          if (MPI_Recv(all.data() + offset + off, n, MPI_FLOAT, r, kTag, comm_, MPI_STATUS_IGNORE) != MPI_SUCCESS)
            return make_error(Status::io_error, "MPI_Recv of %d floats from rank %d failed", n, r);
        } else if (rank_ == r) {
          if (MPI_Send(local.data() + off, n, MPI_FLOAT, 0, kTag, comm_) != MPI_SUCCESS)
            return make_error(Status::io_error, "MPI_Send of %d floats to rank 0 failed", n);
          sent_ += static_cast<uint64_t>(n) * sizeof(float);
        }
      }
      offset += count;
    }
    return {};
  }

  bool all_ok(bool ok) override {
    int local = ok ? 1 : 0, all = 0;
    if (MPI_Allreduce(&local, &all, 1, MPI_INT, MPI_LAND, comm_) != MPI_SUCCESS) return false;
    sent_ += sizeof(int);
    return all != 0;
  }

  uint64_t bytes_sent() const noexcept override { return sent_; }

 private:
  static constexpr size_t kChunk = size_t{1} << 27;
  static constexpr int kTag = 0x6266;
  MPI_Comm comm_;
  int rank_ = 0;
  int size_ = 1;
  uint64_t sent_ = 0;
};

}  // namespace btflod

#endif  // __has_include(<mpi.h>)
