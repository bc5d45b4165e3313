// btflod — the randomised truncated SVD of truncated_svd.hpp for matrices that do not fit in
// memory or on one machine: columns come from a reader that may fail (a BtfStore on disk,
// offline/btf/btf_store.hpp), peak memory stays under a budget, every pass ends with a checkpoint from
// which a killed run resumes, and the columns may be split across processes that combine their
// partial sums through a communicator (MPI: offline/factor/mpi_svd.hpp).
//
// The algorithm is truncated_svd()'s randomised path, operation for operation (Halko, Martinsson
// & Tropp 2011, alg. 4.3/4.4 with the fused projection and the adaptive number of power
// iterations; see truncated_svd.hpp for the derivation): same sparse sign (or Gaussian) test
// matrix from the same seed, same column blocks, same stripes summed in the same order. With one
// process and the same SvdOptions the result is bit-identical to truncated_svd().
//
// Distributed (communicator size P > 1): each process owns a contiguous range of columns (whole
// store blocks) and reads only those. Per pass:
//   sketch          Y = Σ_ranks A_r·Ω_r, ‖A‖²_F = Σ_ranks ‖A_r‖²_F     sum of m·k + 1 doubles
//   power iteration Z_r = A_rᵀ·Q (rows stay on their rank), Y = Σ_ranks A_r·Z_r   m·k doubles
//                   R of Z = P·R by TSQR (local Householder QR, R_r gathered, QR of the stack)
//                                                                      P·k·k floats
// The small factorisations between passes (QR of Y, SVDs of k × k matrices) run redundantly on
// every rank from identical inputs, so every rank holds identical U, Σ and Q. V stays
// distributed (each rank its own rows); factorize_fmf_out_of_core() gathers it on rank 0. The
// sums are formed in double and rounded once, so a distributed result differs from the
// single-process one only by rounding (the order of the partial sums and the TSQR R factor).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "btflod/core/progress.hpp"
#include "btflod/core/result.hpp"
#include "btflod/offline/factor/truncated_svd.hpp"
#include "btflod/offline/math/eigen.hpp"

namespace btflod {

/// Collective operations between the processes of a distributed factorisation. Every process
/// calls the same operations in the same order (like MPI collectives). The default
/// implementation (single_process_communicator()) is one process and does nothing.
class SvdCommunicator {
 public:
  virtual ~SvdCommunicator() = default;
  /// This process's index in [0, size()).
  virtual int rank() const noexcept = 0;
  /// Number of processes (≥ 1).
  virtual int size() const noexcept = 0;
  /// Replaces `values` by the element-wise sum over all processes; every process receives the
  /// same bits. Returns io_error when the transport fails.
  virtual VoidResult sum(std::span<double> values) = 0;
  /// Concatenates every process's `local` (the same size everywhere) in rank order into `all`
  /// (size() · local.size()) on every process.
  virtual VoidResult all_gather(std::span<const float> local, std::span<float> all) = 0;
  /// Gathers `local` (counts[r] values from rank r) in rank order into `all` on rank 0 (`all` is
  /// ignored elsewhere).
  virtual VoidResult gather_to_root(std::span<const float> local, std::span<float> all,
                                    std::span<const size_t> counts) = 0;
  /// True on every process iff `ok` is true on every process (agreement before a collective
  /// that a failed process would not reach).
  virtual bool all_ok(bool ok) = 0;
  /// Bytes this process has sent so far (diagnostic: communication volume).
  virtual uint64_t bytes_sent() const noexcept = 0;
};

/// The communicator of a single process (size 1): every operation is the identity.
/// Thread-safe (stateless).
SvdCommunicator& single_process_communicator() noexcept;

/// Reads columns [col0, col0 + count) (global indices) of A into `out` (already m × count);
/// `scratch` is a per-thread buffer the reader may use. Called concurrently from pool threads
/// with distinct out/scratch. Returns an error to stop the run.
using SvdColumnReader =
    std::function<VoidResult(size_t col0, size_t count, Eigen::MatrixXf& out, std::vector<uint8_t>& scratch)>;

/// Options of out_of_core_svd().
struct OutOfCoreSvdOptions {
  /// The algorithm: same meaning as for truncated_svd() (method is ignored: always randomised;
  /// at least one power iteration). block_columns is the largest block; the budget may lower it.
  SvdOptions svd{};
  /// Peak memory of the factorisation in bytes (its matrices and read buffers; the reader's own
  /// state is not counted). 0: no limit. A run that cannot fit returns insufficient_space
  /// before reading anything, naming the minimum.
  uint64_t memory_budget = 0;
  /// Column blocks are multiples of this (the store's block_texels), so reads are whole blocks.
  size_t column_alignment = 1;
  /// File of the checkpoint written after every pass (atomically: written beside and renamed);
  /// an existing checkpoint of the same problem is resumed. Empty: no checkpoints. The file is
  /// left in place after success: the caller removes it once the result is safely stored.
  std::string checkpoint_path;
  /// Identity of the matrix (e.g. BtfStore::content_id()): a checkpoint of another matrix is
  /// refused.
  uint64_t source_id = 0;
  /// > 0: stop with Status::cancelled after this many passes of this call (checkpoint written),
  /// e.g. to spread a run over several jobs of a cluster scheduler with a time limit.
  int stop_after_passes = 0;
  /// The processes sharing the work; nullptr: single process.
  SvdCommunicator* communicator = nullptr;
};

/// What an out_of_core_svd() call did.
struct OutOfCoreSvdReport {
  size_t block_columns = 0;           ///< columns per block actually used
  uint64_t estimated_peak_bytes = 0;  ///< the budget check's estimate of this process's peak
  int passes = 0;                     ///< passes over A run by this call
  int resumed_passes = 0;             ///< passes restored from a checkpoint
  size_t column_begin = 0;            ///< this process's columns: [column_begin, column_end)
  size_t column_end = 0;
  uint64_t columns_read = 0;         ///< columns read by this process (all passes)
  uint64_t bytes_communicated = 0;   ///< bytes sent by this process
  std::vector<double> pass_seconds;  ///< wall time of each pass of this call
};

/// A truncated SVD computed out of core. `svd.v` holds the rows of V of this process's columns
/// ([report.column_begin, report.column_end)); `svd.u`, `svd.s` and `svd.report` are complete on
/// every process.
struct OutOfCoreSvd {
  TruncatedSvd svd;
  OutOfCoreSvdReport report;
};

/// This process's contiguous column range when n columns in blocks of `alignment` are split
/// over `ranks` processes: whole blocks, as even as possible, rank order. Thread-safe.
inline std::pair<size_t, size_t> out_of_core_column_range(size_t n, size_t alignment, int rank, int ranks) noexcept {
  const size_t a = alignment ? alignment : 1, blocks = (n + a - 1) / a;
  const size_t b0 = blocks * static_cast<size_t>(rank) / static_cast<size_t>(ranks);
  const size_t b1 = blocks * static_cast<size_t>(rank + 1) / static_cast<size_t>(ranks);
  return {std::min(n, b0 * a), std::min(n, b1 * a)};
}

/// Estimated peak bytes of out_of_core_svd() on one process: m rows, `local_columns` columns,
/// rank, options.svd (oversampling, stripes, sketch), `block_columns` columns per block,
/// `threads` concurrent readers, `scratch_bytes_per_thread` of reader scratch, `ranks` processes.
/// Conservative (sums matrices that are not all alive at once). Thread-safe.
uint64_t out_of_core_svd_peak_bytes(size_t m, size_t n, size_t local_columns, int rank, const SvdOptions& svd,
                                    size_t block_columns, size_t threads, size_t scratch_bytes_per_thread, int ranks);

/// Rank-`rank` truncated SVD of the m × n matrix whose columns `reader` provides, within
/// options.memory_budget, resuming from and writing options.checkpoint_path. Returns the
/// factors (see OutOfCoreSvd), or: invalid_argument for empty shapes, rank < 1, no power
/// iteration allowed, more processes than column blocks; insufficient_space when the budget is
/// below the minimum (message names it); bad_data for an unreadable checkpoint or one of another
/// problem or a matrix holding NaN/infinity; cancelled when `progress` returns false or after
/// stop_after_passes passes; the reader's error. Progress: stage "pass i: sketch" / "pass i: power iteration j",
/// fraction of the current pass in [0, 1]. Threading: runs on options.svd.pool; with a communicator, every process must
/// call this with the same m, n, rank and options. Not for untrusted sizes.
Result<OutOfCoreSvd> out_of_core_svd(size_t m, size_t n, int rank, const SvdColumnReader& reader,
                                     const OutOfCoreSvdOptions& options = {}, const ProgressCallback& progress = {});

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_FACTOR_IMPLEMENTATION)
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <mutex>

#include <fcntl.h>
#include <unistd.h>

#include "btflod/core/bytes.hpp"
#include "btflod/core/file_io.hpp"

namespace btflod {

namespace detail {

class SingleProcessCommunicator final : public SvdCommunicator {
 public:
  int rank() const noexcept override { return 0; }
  int size() const noexcept override { return 1; }
  VoidResult sum(std::span<double>) override { return {}; }
  VoidResult all_gather(std::span<const float> local, std::span<float> all) override {
    std::copy(local.begin(), local.end(), all.begin());
    return {};
  }
  VoidResult gather_to_root(std::span<const float> local, std::span<float> all, std::span<const size_t>) override {
    std::copy(local.begin(), local.end(), all.begin());
    return {};
  }
  bool all_ok(bool ok) override { return ok; }
  uint64_t bytes_sent() const noexcept override { return 0; }
};

/// The state between passes: what a checkpoint holds.
struct OocState {
  uint32_t passes_done = 0;  // 1 after the sketch, +1 per power iteration
  uint32_t iterations = 0;
  uint64_t block_columns = 0;
  double norm2 = 0.0;
  std::vector<double> h;
  Eigen::MatrixXf q;  // the basis for the next pass
};

constexpr char kOocCheckpointMagic[9] = "BTFLODCK";

inline std::vector<uint64_t> ooc_fingerprint(size_t m, size_t n, int rank, const OutOfCoreSvdOptions& o) {
  uint64_t tol = 0;
  std::memcpy(&tol, &o.svd.power_tolerance, 8);
  return {m,
          n,
          static_cast<uint64_t>(rank),
          static_cast<uint64_t>(o.svd.oversampling),
          static_cast<uint64_t>(o.svd.power_iterations),
          static_cast<uint64_t>(o.svd.max_power_iterations),
          tol,
          static_cast<uint64_t>(o.svd.sketch_nonzeros),
          static_cast<uint64_t>(o.svd.stripes),
          o.svd.seed,
          o.source_id};
}

inline VoidResult write_ooc_checkpoint(const std::string& path, const std::vector<uint64_t>& fingerprint,
                                       const OocState& st) {
  ByteWriter w;
  w.text(std::string_view(kOocCheckpointMagic, 8));
  w.u32(1);
  w.u32(static_cast<uint32_t>(fingerprint.size()));
  for (uint64_t f : fingerprint) w.u64(f);
  w.u32(st.passes_done);
  w.u32(st.iterations);
  w.u64(st.block_columns);
  w.write(st.norm2);
  w.u32(static_cast<uint32_t>(st.h.size()));
  for (double x : st.h) w.write(x);
  w.u64(static_cast<uint64_t>(st.q.rows()));
  w.u64(static_cast<uint64_t>(st.q.cols()));
  w.raw(st.q.data(), static_cast<size_t>(st.q.size()) * sizeof(float));
  std::vector<uint8_t> bytes = w.take();
  const uint32_t crc = crc32_of(bytes);
  bytes.resize(bytes.size() + 4);
  std::memcpy(bytes.data() + bytes.size() - 4, &crc, 4);
  const std::string tmp = path + ".partial";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0)
    return make_error(Status::io_error, "checkpoint %s: cannot create: %s", tmp.c_str(), std::strerror(errno));
  size_t off = 0;
  while (off < bytes.size()) {
    const ssize_t put = ::write(fd, bytes.data() + off, bytes.size() - off);
    if (put < 0 && errno == EINTR) continue;
    if (put <= 0) {
      ::close(fd);
      return make_error(Status::io_error, "checkpoint %s: write failed: %s", tmp.c_str(), std::strerror(errno));
    }
    off += static_cast<size_t>(put);
  }
  const bool synced = ::fsync(fd) == 0;
  ::close(fd);
  if (!synced || std::rename(tmp.c_str(), path.c_str()) != 0)
    return make_error(Status::io_error, "checkpoint %s: cannot commit: %s", path.c_str(), std::strerror(errno));
  return {};
}

/// Reads a checkpoint; returns passes_done = 0 when the file does not exist.
inline Result<OocState> read_ooc_checkpoint(const std::string& path, const std::vector<uint64_t>& fingerprint, size_t m,
                                            size_t k) {
  if (::access(path.c_str(), F_OK) != 0) return OocState{};
  auto bytes = read_file_bytes(path, uint64_t{1} << 40);
  if (!bytes) return bytes.error();
  if (bytes->size() < 12)
    return make_error(Status::bad_data, "checkpoint %s: %zu bytes is too short", path.c_str(), bytes->size());
  uint32_t stored = 0;
  std::memcpy(&stored, bytes->data() + bytes->size() - 4, 4);
  if (crc32_of(std::span<const uint8_t>(bytes->data(), bytes->size() - 4)) != stored)
    return make_error(Status::bad_data, "checkpoint %s: CRC-32 mismatch (corrupt or partly written)", path.c_str());
  ByteReader r(std::span<const uint8_t>(bytes->data(), bytes->size() - 4));
  if (!r.match(std::string_view(kOocCheckpointMagic, 8)) || r.u32() != 1)
    return make_error(Status::bad_data, "checkpoint %s: not a version 1 SVD checkpoint", path.c_str());
  const uint32_t nf = r.u32();
  if (nf != fingerprint.size())
    return make_error(Status::bad_data, "checkpoint %s: made for another problem", path.c_str());
  static const char* const kNames[] = {"rows",
                                       "columns",
                                       "rank",
                                       "oversampling",
                                       "power iterations",
                                       "max power iterations",
                                       "power tolerance",
                                       "sketch nonzeros",
                                       "stripes",
                                       "seed",
                                       "source"};
  for (uint32_t i = 0; i < nf; ++i)
    if (const uint64_t f = r.u64(); r.ok() && f != fingerprint[i])
      return make_error(Status::bad_data, "checkpoint %s: made with %s %llu, this run has %llu", path.c_str(),
                        i < std::size(kNames) ? kNames[i] : "?", static_cast<unsigned long long>(f),
                        static_cast<unsigned long long>(fingerprint[i]));
  OocState st;
  st.passes_done = r.u32();
  st.iterations = r.u32();
  st.block_columns = r.u64();
  st.norm2 = r.f64();
  const uint32_t hn = r.u32();
  if (!r.ok() || hn > 64 || !r.can_hold(hn, 8))
    return make_error(Status::bad_data, "checkpoint %s: truncated state", path.c_str());
  st.h.resize(hn);
  for (double& x : st.h) x = r.f64();
  const uint64_t qr = r.u64(), qc = r.u64();
  if (!r.ok() || qr != m || qc != k || !r.can_hold(qr * qc, 4) || r.remaining() != qr * qc * 4 || st.passes_done < 1 ||
      st.iterations + 1 != st.passes_done || st.block_columns == 0)
    return make_error(Status::bad_data, "checkpoint %s: inconsistent state (passes %u, basis %llux%llu)", path.c_str(),
                      st.passes_done, static_cast<unsigned long long>(qr), static_cast<unsigned long long>(qc));
  st.q.resize(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(k));
  r.copy_to(st.q.data(), static_cast<size_t>(qr * qc * 4));
  return st;
}

/// Sums float matrices over processes (in double, rounded once). Identity for one process.
inline VoidResult comm_sum(SvdCommunicator& comm, Eigen::MatrixXf& x) {
  if (comm.size() == 1) return {};
  Eigen::MatrixXd d = x.cast<double>();
  if (auto s = comm.sum(std::span<double>(d.data(), static_cast<size_t>(d.size()))); !s) return s;
  x = d.cast<float>();
  return {};
}

}  // namespace detail

SvdCommunicator& single_process_communicator() noexcept {
  static detail::SingleProcessCommunicator comm;
  return comm;
}

uint64_t out_of_core_svd_peak_bytes(size_t m, size_t n, size_t local_columns, int rank, const SvdOptions& svd,
                                    size_t block_columns, size_t threads, size_t scratch_bytes_per_thread, int ranks) {
  const uint64_t c = std::min<uint64_t>({static_cast<uint64_t>(std::max(rank, 1)), m, n});
  const uint64_t k = std::min<uint64_t>({c + static_cast<uint64_t>(std::max(0, svd.oversampling)), m, n});
  const uint64_t blocks = (local_columns + block_columns - 1) / std::max<size_t>(1, block_columns);
  const uint64_t stripes =
      std::max<uint64_t>(1, std::min<uint64_t>(static_cast<uint64_t>(std::max(1, svd.stripes)), blocks));
  const uint64_t nl = local_columns, mm = m;
  const uint64_t zeta = svd.sketch_nonzeros > 0 ? std::min<uint64_t>(static_cast<uint64_t>(svd.sketch_nonzeros), k) : 0;
  const uint64_t omega = zeta ? nl * zeta * 4 : nl * k * 4;
  // Pass: stripes partials, Q, Z; between passes: Y, its QR and Q, the Z QR copy, M's QR;
  // result: the Householder bases P (n × k), Qm (m × k), U, V.
  const uint64_t matrices = 4 * ((stripes + 5) * mm * k + 4 * nl * k + nl * c + mm * c) + 8 * 12 * k * k +
                            4 * static_cast<uint64_t>(ranks) * k * k * 2;
  const uint64_t active = std::min<uint64_t>(threads, stripes);  // one stripe per thread at a time
  const uint64_t buffers = active * (mm * block_columns * 4 + scratch_bytes_per_thread);
  return matrices + omega + buffers + (uint64_t{8} << 20);  // + 8 MiB for stacks and small objects
}

Result<OutOfCoreSvd> out_of_core_svd(size_t m, size_t n, int rank, const SvdColumnReader& reader,
                                     const OutOfCoreSvdOptions& options, const ProgressCallback& progress) {
  using Eigen::Index;
  using Eigen::MatrixXf;
  using Clock = std::chrono::steady_clock;
  if (m == 0 || n == 0 || rank < 1)
    return make_error(Status::invalid_argument, "out_of_core_svd: matrix %zux%zu, rank %d: need non-empty, rank >= 1",
                      m, n, rank);
  const SvdOptions& so = options.svd;
  SvdCommunicator& comm = options.communicator ? *options.communicator : single_process_communicator();
  ThreadPool& pool = so.pool ? *so.pool : default_thread_pool();
  [[maybe_unused]] const detail::SingleThreadedBlas single_threaded_blas;  // as truncated_svd (truncated_svd.hpp)
  const Index c = std::min<Index>({static_cast<Index>(rank), static_cast<Index>(m), static_cast<Index>(n)});
  const Index k = std::min<Index>({c + so.oversampling, static_cast<Index>(m), static_cast<Index>(n)});
  const Index mi = static_cast<Index>(m);
  const int q_request = std::max(0, so.power_iterations);
  const int q_max = std::max(q_request, so.max_power_iterations);
  const int q_min = q_max == 0 ? 0 : std::max(1, q_request);
  if (q_max == 0)
    return make_error(Status::invalid_argument,
                      "out_of_core_svd: at least one power iteration is needed (max_power_iterations 0 given)");
  const size_t align = std::max<size_t>(1, options.column_alignment);
  // Not a structured binding: clang before 16 cannot capture those in the lambdas below.
  const std::pair<size_t, size_t> range = out_of_core_column_range(n, align, comm.rank(), comm.size());
  const size_t c0 = range.first, c1 = range.second;
  if (!comm.all_ok(c1 > c0))
    return make_error(Status::invalid_argument, "out_of_core_svd: %d processes for %zu column blocks of %zu",
                      comm.size(), (n + align - 1) / align, align);
  const size_t nl = c1 - c0;
  const Index nli = static_cast<Index>(nl);
  OutOfCoreSvd result;
  OutOfCoreSvdReport& rep = result.report;
  rep.column_begin = c0;
  rep.column_end = c1;
  const auto fingerprint = detail::ooc_fingerprint(m, n, rank, options);

  // Restore (rank 0 reads, everyone receives it through sums with zero contributions).
  detail::OocState st;
  bool ckpt_ok = true;
  Error ckpt_error;
  if (!options.checkpoint_path.empty() && comm.rank() == 0) {
    auto loaded = detail::read_ooc_checkpoint(options.checkpoint_path, fingerprint, m, static_cast<size_t>(k));
    if (!loaded) {
      ckpt_ok = false;
      ckpt_error = loaded.error();
    } else {
      st = std::move(*loaded);
    }
  }
  if (!comm.all_ok(ckpt_ok))
    return comm.rank() == 0 ? ckpt_error
                            : make_error(Status::bad_data, "out_of_core_svd: rank 0 refused the checkpoint");
  if (!options.checkpoint_path.empty() && comm.size() > 1) {
    std::vector<double> head(4 + 2 * static_cast<size_t>(q_max) + 2, 0.0);
    if (comm.rank() == 0) {
      head[0] = st.passes_done;
      head[1] = st.iterations;
      head[2] = static_cast<double>(st.block_columns);
      head[3] = st.norm2;
      head[4] = static_cast<double>(st.h.size());
      for (size_t i = 0; i < st.h.size() && 5 + i < head.size(); ++i) head[5 + i] = st.h[i];
    }
    if (auto s = comm.sum(head); !s) return s.error();
    st.passes_done = static_cast<uint32_t>(head[0]);
    st.iterations = static_cast<uint32_t>(head[1]);
    st.block_columns = static_cast<uint64_t>(head[2]);
    st.norm2 = head[3];
    st.h.assign(head.begin() + 5, head.begin() + 5 + static_cast<ptrdiff_t>(head[4]));
    if (st.passes_done > 0) {
      MatrixXf q = comm.rank() == 0 ? st.q : MatrixXf::Zero(mi, k);
      if (auto s = detail::comm_sum(comm, q); !s) return s.error();
      st.q = std::move(q);
    }
  }
  rep.resumed_passes = static_cast<int>(st.passes_done);

  // Block size: the requested one (or the checkpoint's), lowered to fit the budget.
  const size_t threads = pool.thread_count() + 1;
  auto scratch_for = [&](size_t) { return m * align * 4; };  // a reader reads one aligned block at a time
  auto peak_for = [&](size_t bc) {
    return out_of_core_svd_peak_bytes(m, n, nl, rank, so, bc, threads, scratch_for(bc), comm.size());
  };
  size_t bc = st.block_columns ? static_cast<size_t>(st.block_columns) : std::max<size_t>(1, so.block_columns);
  if (!st.block_columns && bc > align) bc = bc / align * align;
  while (!st.block_columns && options.memory_budget && bc > align && peak_for(bc) > options.memory_budget)
    bc = std::max(align, bc / 2 / align * align);
  rep.block_columns = bc;
  rep.estimated_peak_bytes = peak_for(bc);
  if (!comm.all_ok(!options.memory_budget || rep.estimated_peak_bytes <= options.memory_budget))
    return make_error(Status::insufficient_space,
                      "out_of_core_svd: %zu x %zu (%zu columns here), rank %d needs at least %.1f MiB with %zu-column "
                      "blocks; the budget is %.1f MiB",
                      m, n, nl, rank, static_cast<double>(rep.estimated_peak_bytes) / 1048576.0, bc,
                      static_cast<double>(options.memory_budget) / 1048576.0);
  st.block_columns = bc;

  const size_t blocks = (nl + bc - 1) / bc;
  const size_t stripes = std::max<size_t>(1, std::min<size_t>(static_cast<size_t>(std::max(1, so.stripes)), blocks));
  const double passes_bound = static_cast<double>(q_max + 1);
  std::vector<MatrixXf> partial(stripes);
  std::vector<double> norm2_partial(stripes, 0.0);
  std::atomic<uint64_t> columns_read{0};
  std::mutex progress_mutex;
  bool cancelled = false;
  std::string stage;
  // One pass over this process's columns; body(a, col0_local, cnt, stripe) as in truncated_svd().
  auto pass = [&](auto&& body) -> Result<MatrixXf> {
    const auto t_start = Clock::now();
    for (auto& p : partial) p.setZero(mi, k);
    std::vector<Error> errors(stripes);
    std::vector<char> failed(stripes, 0);
    std::atomic<bool> stop{false};
    std::atomic<size_t> blocks_done{0};
    pool.parallel_for(0, stripes, 1, [&](size_t s0, size_t s1) {
      MatrixXf buf;
      std::vector<uint8_t> scratch;
      for (size_t s = s0; s < s1; ++s) {
        const size_t first = s * blocks / stripes, last = (s + 1) * blocks / stripes;
        for (size_t b = first; b < last && !stop.load(); ++b) {
          const size_t col0 = b * bc, cnt = std::min(bc, nl - col0);
          buf.resize(mi, static_cast<Index>(cnt));
          if (auto r = reader(c0 + col0, cnt, buf, scratch); !r) {
            errors[s] = r.error();
            failed[s] = 1;
            stop = true;
            break;
          }
          columns_read += cnt;
          body(buf, static_cast<Index>(col0), static_cast<Index>(cnt), s);
          const size_t done_blocks = ++blocks_done;
          if (progress) {
            std::lock_guard lock(progress_mutex);
            if (!progress(stage, static_cast<double>(done_blocks) / static_cast<double>(blocks))) {
              cancelled = true;
              stop = true;
            }
          }
        }
      }
    });
    rep.pass_seconds.push_back(std::chrono::duration<double>(Clock::now() - t_start).count());
    ++rep.passes;
    bool ok = !stop.load();
    if (!comm.all_ok(ok)) {
      for (size_t s = 0; s < stripes; ++s)
        if (failed[s]) return errors[s];
      if (cancelled) return make_error(Status::cancelled, "out_of_core_svd cancelled");
      return make_error(Status::io_error, "out_of_core_svd: another process failed during the pass");
    }
    MatrixXf sum = std::move(partial[0]);
    for (size_t s = 1; s < stripes; ++s) sum += partial[s];
    for (auto& p : partial) p.resize(0, 0);
    if (auto s = detail::comm_sum(comm, sum); !s) return s.error();
    return sum;
  };
  auto checkpoint = [&]() -> VoidResult {
    if (options.checkpoint_path.empty() || comm.rank() != 0) return {};
    return detail::write_ooc_checkpoint(options.checkpoint_path, fingerprint, st);
  };
  auto stop_requested = [&] { return options.stop_after_passes > 0 && rep.passes >= options.stop_after_passes; };
  auto set_stage = [&](const char* what) {
    char text[96];
    std::snprintf(text, sizeof text, "pass %u of at most %d: %s", st.passes_done + 1, q_max + 1, what);
    stage = text;
    (void)passes_bound;
  };

  if (st.passes_done == 0) {
    // Test matrix Ω: this process's rows of truncated_svd()'s (same generator, same order).
    const Index zeta = so.sketch_nonzeros > 0 ? std::min<Index>(so.sketch_nonzeros, k) : 0;
    MatrixXf omega;
    std::vector<int32_t> sparse_omega;
    if (zeta == 0) {
      omega.resize(nli, k);
      detail::NormalGenerator gen(so.seed);
      for (Index j = 0; j < k; ++j)
        for (size_t i = 0; i < n; ++i) {
          const float x = static_cast<float>(gen.next());
          if (i >= c0 && i < c1) omega(static_cast<Index>(i - c0), j) = x;
        }
    } else {
      sparse_omega.resize(nl * static_cast<size_t>(zeta));
      detail::SplitMix64 gen(so.seed);
      std::vector<int32_t> row(static_cast<size_t>(zeta));
      for (size_t t = 0; t < n; ++t) {
        for (Index e = 0; e < zeta; ++e) {
          int32_t col = 0;
          bool fresh = false;
          while (!fresh) {
            col = static_cast<int32_t>(gen.next() % static_cast<uint64_t>(k));
            fresh = true;
            for (Index f = 0; f < e; ++f) fresh = fresh && std::abs(row[static_cast<size_t>(f)]) - 1 != col;
          }
          row[static_cast<size_t>(e)] = (gen.next() & 1u) ? col + 1 : -(col + 1);
        }
        if (t >= c0 && t < c1)
          std::copy(row.begin(), row.end(),
                    sparse_omega.begin() + static_cast<ptrdiff_t>((t - c0) * static_cast<size_t>(zeta)));
      }
    }
    set_stage("sketch");
    if (!report_progress(progress, stage, 0.0)) return make_error(Status::cancelled, "out_of_core_svd cancelled");
    auto y = pass([&](const MatrixXf& a, Index col0, Index cnt, size_t s) {
      MatrixXf& acc = partial[s];
      norm2_partial[s] += a.colwise().squaredNorm().template cast<double>().sum();
      detail::accumulate_sketch(acc, a, omega, sparse_omega, zeta, col0, cnt);
    });
    if (!y) return y.error();
    double norm2 = 0.0;
    for (double p : norm2_partial) norm2 += p;
    if (comm.size() > 1) {
      double v[1] = {norm2};
      if (auto s = comm.sum(v); !s) return s.error();
      norm2 = v[0];
    }
    // A NaN or infinity anywhere in A reaches ‖A‖²_F (and Y): refuse it here rather than return
    // factors of NaN (a store's halves may hold them; its checksums only prove they were written).
    if (!std::isfinite(norm2))
      return make_error(Status::bad_data, "out_of_core_svd: the matrix holds NaN or infinite values (|A|^2 = %g)",
                        norm2);
    st.norm2 = norm2;
    st.q = detail::orthonormal_basis(*y);
    st.passes_done = 1;
    if (auto s = checkpoint(); !s) return s.error();
    if (stop_requested())
      return make_error(Status::cancelled, "out_of_core_svd: stopped after pass %u (checkpoint %s)", st.passes_done,
                        options.checkpoint_path.c_str());
  }
  result.svd.report.frobenius_norm = std::sqrt(st.norm2);

  MatrixXf z(nli, k);
  MatrixXf y;
  Eigen::HouseholderQR<MatrixXf> zqr, sqr;
  Eigen::JacobiSVD<Eigen::MatrixXd> rsvd;
  detail::PowerIterationCandidate candidate;
  Index kk = 0;
  const Index kl = std::min<Index>(nli, k);  // rows of this process's R factor
  double predicted_excess = 0.0;
  for (;;) {
    set_stage("power iteration");
    if (!report_progress(progress, stage, 0.0)) return make_error(Status::cancelled, "out_of_core_svd cancelled");
    const MatrixXf& q = st.q;
    auto yr = pass([&](const MatrixXf& a, Index col0, Index cnt, size_t s) {
      auto zb = z.middleRows(col0, cnt);
      zb.noalias() = a.transpose() * q;
      partial[s].noalias() += a * zb;
    });
    if (!yr) return yr.error();
    y = std::move(*yr);
    ++st.passes_done;
    ++st.iterations;
    st.q.resize(0, 0);
    zqr.compute(z);
    Eigen::MatrixXd rz;
    if (comm.size() == 1) {
      rz = zqr.matrixQR().topRows(k).template triangularView<Eigen::Upper>().toDenseMatrix().template cast<double>();
    } else {
      // TSQR: R of the stacked per-process R factors.
      MatrixXf rl = MatrixXf::Zero(k, k);
      rl.topRows(kl) = zqr.matrixQR().topRows(kl).template triangularView<Eigen::Upper>().toDenseMatrix();
      MatrixXf stack(k, k * comm.size());  // transposed stack: process r's Rᵀ in columns r·k…
      const MatrixXf rlt = rl.transpose();
      if (auto s = comm.all_gather(std::span<const float>(rlt.data(), static_cast<size_t>(rlt.size())),
                                   std::span<float>(stack.data(), static_cast<size_t>(stack.size())));
          !s)
        return s.error();
      sqr.compute(stack.transpose());
      rz = sqr.matrixQR().topRows(k).template triangularView<Eigen::Upper>().toDenseMatrix().template cast<double>();
    }
    rsvd.compute(rz, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::VectorXd& sr = rsvd.singularValues();
    const double tol = sr.size() > 0 ? sr[0] * 1e-6 : 0.0;
    kk = 0;
    while (kk < sr.size() && sr[kk] > tol) ++kk;
    if (kk == 0) {
      result.svd.u = MatrixXf::Identity(mi, c);
      result.svd.s = Eigen::VectorXf::Zero(c);
      result.svd.v = MatrixXf::Identity(static_cast<Index>(n), c).middleRows(static_cast<Index>(c0), nli);
      result.svd.report.power_iterations = static_cast<int>(st.iterations);
      result.svd.report.error_estimate = result.svd.report.frobenius_norm;
      rep.columns_read = columns_read;
      rep.bytes_communicated = comm.bytes_sent();
      return result;
    }
    auto& h = st.h;
    candidate.project(y, rsvd, kk, c, st.norm2, h);
    // The same adaptive rule as truncated_svd (detail::power_iteration_bound), so both stop
    // after the same iteration and give identical bits.
    const detail::PowerIterationBound bound = detail::power_iteration_bound(h, so.power_tolerance, st.norm2);
    predicted_excess = bound.predicted_excess;
    const bool settled = bound.settled;
    const int iterations = static_cast<int>(st.iterations);
    if (progress) {
      char text[160];
      detail::format_power_iteration_stage(text, iterations, bound);
      if (!report_progress(progress, text, 1.0)) return make_error(Status::cancelled, "out_of_core_svd cancelled");
    }
    if (iterations >= q_max || (iterations >= q_min && settled)) break;
    st.q = detail::orthonormal_basis(y);
    if (auto s = checkpoint(); !s) return s.error();
    if (stop_requested())
      return make_error(Status::cancelled, "out_of_core_svd: stopped after pass %u (checkpoint %s)", st.passes_done,
                        options.checkpoint_path.c_str());
  }
  y.resize(0, 0);
  const auto& h = st.h;
  TruncatedSvd& out = result.svd;
  out.report.power_iterations = static_cast<int>(st.iterations);
  const MatrixXf rot = candidate.finish(out, rsvd, k, kk, c, h, predicted_excess);
  if (comm.size() == 1) {
    const MatrixXf pz = zqr.householderQ() * MatrixXf::Identity(nli, k);
    out.v = pz * rot;
  } else {
    // P's rows here: (local Householder basis) · (this process's k rows of the stack's basis).
    const MatrixXf ql = zqr.householderQ() * MatrixXf::Identity(nli, kl);
    const MatrixXf qs = sqr.householderQ() * MatrixXf::Identity(k * comm.size(), k);
    out.v = ql * (qs.middleRows(static_cast<Index>(comm.rank()) * k, kl) * rot);
  }
  rep.columns_read = columns_read;
  rep.bytes_communicated = comm.bytes_sent();
  return result;
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
