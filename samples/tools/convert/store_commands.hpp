// btflod-convert — the out-of-core paths of `synth` and `factor` (and the MPI `factor_mpi`):
// synthesis into a BTF store view by view (offline/btf/btf_store.hpp), and the FMF of a store within a
// memory budget with a progress line per pass (rate and ETA), checkpoints and resume
// (offline/factor/fmf_out_of_core.hpp). Shared by cmd_synth.cpp, cmd_factor.cpp and cmd_factor_mpi.cpp.
#pragma once

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <string_view>

#include <sys/resource.h>
#include <unistd.h>

#include "command.hpp"

#include "btflod/offline/btf/btf_store.hpp"
#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/factor/any_factorization.hpp"
#include "btflod/offline/factor/fmf_out_of_core.hpp"

namespace btflod::convert {

/// Parses a byte count: an integer or decimal number with an optional K, M, G or T suffix
/// (powers of 1024; "B", "iB" after the letter are accepted), e.g. "4G", "512M", "1.5GiB".
/// Returns nullopt for anything else, zero or more than 2^60.
inline std::optional<uint64_t> parse_byte_size(std::string_view text) {
  const std::string s(text);
  char* end = nullptr;
  const double x = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || !(x > 0.0)) return std::nullopt;
  std::string unit(end);
  for (auto& c : unit) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (unit.size() > 1 && (unit.ends_with("IB") || unit.ends_with("B"))) unit = unit.substr(0, 1);
  double scale = 1.0;
  if (unit == "K")
    scale = 1024.0;
  else if (unit == "M")
    scale = 1048576.0;
  else if (unit == "G")
    scale = 1073741824.0;
  else if (unit == "T")
    scale = 1099511627776.0;
  else if (!unit.empty() && unit != "B")
    return std::nullopt;
  const double bytes = x * scale;
  if (bytes < 1.0 || bytes > 1152921504606846976.0) return std::nullopt;
  return static_cast<uint64_t>(bytes);
}

/// Human-readable hours:minutes:seconds.
inline std::string format_duration(double seconds) {
  if (!(seconds >= 0.0) || seconds > 1e7) return "--:--";
  const long s = std::lround(seconds);
  char buf[32];
  if (s >= 3600)
    std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  else
    std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
  return buf;
}

/// The progress line of an out-of-core factorisation: one line per pass with its fraction, read
/// rate and ETA of the pass (redrawn in place on a terminal, every 10% otherwise), and the SVD's
/// per-iteration error estimate lines. `pass_bytes` is what one pass reads (rate = bytes/s).
class PassProgress {
 public:
  PassProgress(std::FILE* out, bool enabled, uint64_t pass_bytes)
      : out_(out), enabled_(enabled), tty_(::isatty(::fileno(out)) != 0), pass_bytes_(pass_bytes) {}
  ProgressCallback callback() {
    return [this](std::string_view stage, double fraction) {
      update(stage, fraction);
      return true;
    };
  }
  void update(std::string_view stage, double fraction) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    if (stage.starts_with("power iteration ")) {  // the SVD's per-iteration summary
      end_line();
      std::fprintf(out_, "factor: %.*s\n", static_cast<int>(stage.size()), stage.data());
      std::fflush(out_);
      return;
    }
    if (stage != stage_) {
      end_line();
      stage_.assign(stage);
      start_ = now;
      last_decile_ = -1;
    }
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double rate = elapsed > 0.0 ? fraction * static_cast<double>(pass_bytes_) / elapsed : 0.0;
    const double eta = fraction > 0.0 ? elapsed * (1.0 - fraction) / fraction : -1.0;
    const int decile = static_cast<int>(fraction * 10.0);
    if (!tty_ && decile == last_decile_) return;
    last_decile_ = decile;
    std::fprintf(out_, "%sfactor: %s %5.1f%%  %7.1f MB/s  elapsed %s  ETA %s%s", tty_ ? "\r" : "", stage_.c_str(),
                 100.0 * fraction, rate / 1e6, format_duration(elapsed).c_str(), format_duration(eta).c_str(),
                 tty_ ? "   " : "\n");
    drawn_ = tty_;
    std::fflush(out_);
  }
  void end_line() {
    if (drawn_) std::fputc('\n', out_);
    drawn_ = false;
  }
  ~PassProgress() { end_line(); }

 private:
  std::FILE* out_;
  bool enabled_;
  bool tty_;
  uint64_t pass_bytes_;
  std::string stage_;
  std::chrono::steady_clock::time_point start_{};
  int last_decile_ = -1;
  bool drawn_ = false;
};

/// True when `path` names a BTF store (by its extension).
inline bool is_store_path(const std::string& path) { return path.ends_with(".btfstore"); }

/// Synthesises `meso` view by view into the store `out` (never holding the whole BTF).
/// Returns kExitOk or kExitFailure (message on stderr).
inline int synthesize_to_store(const Mesostructure& meso, SynthesisOptions so, const std::string& out,
                               BtfStoreValueType type, uint32_t block_texels, bool quiet) {
  auto w = BtfStoreWriter::create(out, meso.width(), meso.height(), so.views, so.lights, type, block_texels);
  if (!w) {
    std::fprintf(stderr, "btflod-convert synth: %s\n", w.message().c_str());
    return kExitFailure;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const size_t views = so.views.size();
  VoidResult write_status;
  so.progress = {};
  auto synth = synthesize_btf_views(meso, so, [&](size_t v, std::span<const float> block) {
    write_status = w->write_view(v, block);
    if (!quiet) {
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::fprintf(stderr, "%ssynth: view %zu of %zu written  elapsed %s  ETA %s%s", ::isatty(2) ? "\r" : "", v + 1,
                   views, format_duration(s).c_str(),
                   format_duration(s * static_cast<double>(views - v - 1) / static_cast<double>(v + 1)).c_str(),
                   ::isatty(2) && v + 1 < views ? "" : "\n");
    }
    return static_cast<bool>(write_status);
  });
  if (!write_status) {
    std::fprintf(stderr, "btflod-convert synth: %s\n", write_status.message().c_str());
    return kExitFailure;
  }
  if (!synth) {
    std::fprintf(stderr, "btflod-convert synth: %s\n", synth.message().c_str());
    return kExitFailure;
  }
  if (auto s = w->finish(); !s) {
    std::fprintf(stderr, "btflod-convert synth: %s\n", s.message().c_str());
    return kExitFailure;
  }
  if (!quiet)
    std::fprintf(stderr, "synth: wrote %s (%dx%d texels, %zu x %zu directions, %.1f MiB)\n", out.c_str(), meso.width(),
                 meso.height(), so.views.size(), so.lights.size(),
                 static_cast<double>(w->info().file_bytes()) / 1048576.0);
  return kExitOk;
}

/// What run_factor_store() needs.
struct StoreFactorArgs {
  std::string in, out;
  int components = 16;
  SvdOptions svd{};
  ValueTransform transform{};  ///< --value-encoding
  uint64_t memory_budget = uint64_t{4} << 30;
  std::string checkpoint;  ///< empty: OUT + ".checkpoint"
  int stop_after_passes = 0;
  bool quiet = false;
  SvdCommunicator* communicator = nullptr;
};

/// Peak resident set of this process so far, bytes (getrusage).
inline uint64_t peak_rss_bytes() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<uint64_t>(ru.ru_maxrss) * 1024;
}

/// CPU seconds (user + system) of this process so far.
inline double cpu_seconds() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

/// FMF of a store: factorises, writes OUT on rank 0, removes the checkpoint after the result is
/// stored, prints a summary (time, passes, bytes read, peak RSS, CPU, communication). Returns a
/// convert exit code; a stopped run (stop_after_passes) exits with kExitFailure and says how to
/// resume.
inline int run_factor_store(const StoreFactorArgs& a) {
  SvdCommunicator& comm = a.communicator ? *a.communicator : single_process_communicator();
  const bool root = comm.rank() == 0;
  auto store = BtfStore::open(a.in);
  if (!comm.all_ok(static_cast<bool>(store))) {
    if (!store) std::fprintf(stderr, "btflod-convert factor: %s\n", store.message().c_str());
    return kExitFailure;
  }
  FmfOutOfCoreOptions o;
  o.components = a.components;
  o.transform = a.transform;
  o.svd.svd = a.svd;
  o.svd.memory_budget = a.memory_budget;
  o.svd.checkpoint_path = a.checkpoint.empty() ? a.out + ".checkpoint" : a.checkpoint;
  o.svd.stop_after_passes = a.stop_after_passes;
  o.svd.communicator = a.communicator;
  const auto [c0, c1] =
      out_of_core_column_range(store->columns(), store->info().block_texels, comm.rank(), comm.size());
  PassProgress progress(stderr, root && !a.quiet,
                        static_cast<uint64_t>(c1 - c0) * store->rows() * store->info().value_size());
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = cpu_seconds();
  FmfOutOfCoreReport rep;
  auto fmf = factorize_fmf_out_of_core(*store, o, progress.callback(), &rep);
  progress.end_line();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = cpu_seconds() - cpu0;
  if (!fmf) {
    std::fprintf(stderr, "btflod-convert factor%s: %s\n",
                 comm.size() > 1 ? (" (rank " + std::to_string(comm.rank()) + ")").c_str() : "", fmf.message().c_str());
    if (fmf.status() == Status::cancelled && root)
      std::fprintf(stderr, "btflod-convert factor: run the same command again to resume from %s\n",
                   o.svd.checkpoint_path.c_str());
    return kExitFailure;
  }
  // Per-rank figures, gathered on rank 0 in rank order.
  const double mine[4] = {cpu, static_cast<double>(rep.bytes_read), static_cast<double>(rep.svd.bytes_communicated),
                          static_cast<double>(peak_rss_bytes())};
  std::vector<float> all(4 * static_cast<size_t>(comm.size()));
  const float minef[4] = {static_cast<float>(mine[0]), static_cast<float>(mine[1] / 1048576.0),
                          static_cast<float>(mine[2] / 1048576.0), static_cast<float>(mine[3] / 1048576.0)};
  (void)comm.all_gather(std::span<const float>(minef, 4), all);
  if (!root) return kExitOk;
  const SvdReport r = fmf->svd_report;
  if (auto s = save_factorization(AnyFactorization(std::move(*fmf)), a.out); !s) {
    std::fprintf(stderr, "btflod-convert factor: %s\n", s.message().c_str());
    return kExitFailure;
  }
  std::remove(o.svd.checkpoint_path.c_str());
  double pass_sum = 0.0;
  for (double p : rep.svd.pass_seconds) pass_sum += p;
  std::printf("%s: %dx%d texels, %zu views x %zu lights (%.2f GiB as stored) -> %s: FMF rank %d in %.1f s\n",
              a.in.c_str(), store->info().width, store->info().height, store->info().views.size(),
              store->info().lights.size(), static_cast<double>(store->info().data_bytes()) / 1073741824.0,
              a.out.c_str(), a.components, seconds);
  std::printf("  SVD: %d power iterations, error estimate %.6g, predicted %.5fx the optimum, |A| %.6g\n",
              r.power_iterations, r.error_estimate, r.predicted_ratio, r.frobenius_norm);
  std::printf(
      "  passes: %d run (+%d resumed), %.1f s in passes, %zu-column blocks, estimated peak %.1f MiB of %.1f "
      "MiB budget\n",
      rep.svd.passes, rep.svd.resumed_passes, pass_sum, rep.svd.block_columns,
      static_cast<double>(rep.svd.estimated_peak_bytes) / 1048576.0, static_cast<double>(a.memory_budget) / 1048576.0);
  for (int rk = 0; rk < comm.size(); ++rk) {
    const float* f = all.data() + 4 * rk;
    std::printf("  rank %d: %.1f s CPU, %.1f MiB read (%.1f MB/s of wall time), %.2f MiB sent, peak RSS %.1f MiB\n", rk,
                static_cast<double>(f[0]), static_cast<double>(f[1]),
                static_cast<double>(f[1]) * 1.048576 / std::max(seconds, 1e-9), static_cast<double>(f[2]),
                static_cast<double>(f[3]));
  }
  return kExitOk;
}

}  // namespace btflod::convert
