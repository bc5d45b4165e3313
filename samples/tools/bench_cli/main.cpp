// btflod-bench — measure the scheduler and the codecs on your own data, keep the report, compare
// two reports. See docs/benchmarking.md for a walkthrough.
//
//   btflod-bench scheduler --trace FILE (--bsvtf FILE ... | --materials N [--texture S]
//                          [--components C]) [--slots N] [--uploads U] [--decoding D]
//                          [--requests R] [--bytes-in-flight B] [--mode weighted|votes-only]
//                          [--window N] [--repeat R] [--json OUT] [--check-determinism] [--runtime]
//                          [--sweep --sweep-slots a,b,.. --sweep-uploads a,b,.. --sweep-modes m,..
//                           --csv OUT --svg OUT]
//   btflod-bench codec --bsvtf FILE [--bsvtf FILE ...] [--repeat R] [--jpeg-quality Q]
//                      [--encode [--quality a,b,..]] [--json OUT]
//   btflod-bench compare A.json B.json [--min-band X]
//   btflod-bench generate --trace OUT [--bsvtf OUT] [--frames N] [--width W] [--height H]
//                         [--decimation D] [--texture S]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/lod/feedback_trace.hpp"
#include "codec_bench.hpp"
#include "common/arguments.hpp"
#include "report.hpp"
#include "scheduler_replay.hpp"
#include "sweep_plot.hpp"

using namespace btflod;
using namespace btflod::bench;

namespace {

constexpr const char* kUsage =
    "usage:\n"
    "  btflod-bench scheduler --trace FILE (--bsvtf FILE ... | --materials N [--texture S] [--components C])\n"
    "               [--slots N] [--uploads U] [--decoding D] [--requests R] [--bytes-in-flight B]\n"
    "               [--mode weighted|votes-only] [--window N] [--repeat R] [--json OUT] [--check-determinism] "
    "[--runtime]\n"
    "               [--sweep [--sweep-slots a,b,..] [--sweep-uploads a,b,..] [--sweep-modes m,..] [--csv OUT] [--svg "
    "OUT]]\n"
    "      Replays a feedback trace (btflod-demo --record-feedback, or FeedbackTraceRecorder in your engine)\n"
    "      through votes -> scheduler -> tile cache with an immediate source; reports per-frame CPU time\n"
    "      percentiles next to one read of each feedback buffer, operations, budget hits and bytes. --runtime also\n"
    "      replays it through the runtime Streamer (update() per frame, decode jobs pumped, containers in memory).\n"
    "  btflod-bench codec --bsvtf FILE [--bsvtf FILE ...] [--repeat R] [--jpeg-quality Q] [--encode [--quality "
    "a,b,..]]\n"
    "               [--json OUT]\n"
    "      Decodes every tile of each container per level (zlib and libdeflate backends) next to libjpeg-turbo\n"
    "      and deflated raw halves (zlib, libdeflate) on the same tiles; --encode times the encoder too.\n"
    "  btflod-bench compare A.json B.json [--min-band X]\n"
    "      Prints B/A per metric and flags regressions beyond the noise band of the two runs (exit 1).\n"
    "  btflod-bench generate --trace OUT [--bsvtf OUT] [--frames N] [--width W] [--height H] [--decimation D]\n"
    "               [--texture S]\n"
    "      Writes a small synthetic trace (a camera panning over one material) and a matching container.";

int fail(const std::string& msg) {
  std::fprintf(stderr, "btflod-bench: %s\n", msg.c_str());
  return 2;
}

// Slots of a near-square cache: slots_x = ⌈√N⌉, slots_y = ⌈N / slots_x⌉.
TileCacheConfig cache_for(uint32_t slots) {
  const uint32_t x = static_cast<uint32_t>(std::ceil(std::sqrt(static_cast<double>(slots))));
  return TileCacheConfig{x, (slots + x - 1) / x};
}

const char* mode_name(PriorityMode m) { return m == PriorityMode::weighted ? "weighted" : "votes-only"; }

// ---------------------------------------------------------------------------------------------
struct SchedulerArgs {
  std::string trace;
  std::vector<std::string> bsvtf;
  uint32_t materials = 0, texture = 2048, components = 32;
  uint32_t slots = 256;
  ReplayConfig replay;
  uint32_t repeat = 5;
  std::string json, csv, svg;
  bool check_determinism = false;
  bool sweep = false;
  bool runtime = false;  ///< also replay through runtime/streamer.hpp (update + decode jobs)
  std::vector<uint32_t> sweep_slots{64, 256, 1024};
  std::vector<uint32_t> sweep_uploads{8, 32};
  std::vector<PriorityMode> sweep_modes{PriorityMode::weighted, PriorityMode::votes_only};
};

struct SchedulerOutcome {
  bool deterministic = true;
  uint64_t digest = 0;
};

// Runs `repeat` interleaved replays of one configuration and adds its metrics to the report.
Result<SchedulerOutcome> measure_scheduler(const Materials& mats, const FeedbackTrace& trace, const ReplayConfig& cfg,
                                           uint32_t repeat, Report& report, const std::string& prefix, bool print) {
  SchedulerOutcome out;
  for (uint32_t r = 0; r < repeat; ++r) {
    auto run = replay_trace(mats, trace, cfg, r % 2 == 1);
    if (!run) return run.error();
    if (r == 0) out.digest = run->digest;
    if (run->digest != out.digest) out.deterministic = false;
    const double frames = static_cast<double>(std::max<size_t>(trace.frame_count(), 1));
    std::vector<double> us(run->frame_ns.size()), ratio(run->frame_ns.size());
    for (size_t i = 0; i < us.size(); ++i) {
      us[i] = run->frame_ns[i] / 1000.0;
      ratio[i] = run->frame_ns[i] / std::max(run->read_ns[i], 1.0);
    }
    std::vector<double> read_us(run->read_ns.size());
    for (size_t i = 0; i < read_us.size(); ++i) read_us[i] = run->read_ns[i] / 1000.0;
    report.add(prefix + "frame_cpu_us.p50", percentile(us, 0.5), "us", Better::lower);
    report.add(prefix + "frame_cpu_us.p95", percentile(us, 0.95), "us", Better::lower);
    report.add(prefix + "frame_cpu_us.p99", percentile(us, 0.99), "us", Better::lower);
    report.add(prefix + "frame_cpu_us.max", percentile(us, 1.0), "us", Better::lower);
    report.add(prefix + "read_us.p50", percentile(read_us, 0.5), "us", Better::none);
    report.add(prefix + "x_read.p50", percentile(us, 0.5) / std::max(percentile(read_us, 0.5), 1e-3), "x",
               Better::lower);
    report.add(prefix + "x_read_per_frame.p50", percentile(ratio, 0.5), "x", Better::lower);
    const SchedulerCounters& t = run->total;
    report.add(prefix + "ops_per_frame", static_cast<double>(t.adds + t.swaps) / frames, "ops", Better::none);
    report.add(prefix + "adds", static_cast<double>(t.adds), "ops", Better::none);
    report.add(prefix + "swaps", static_cast<double>(t.swaps), "ops", Better::none);
    report.add(prefix + "requests", static_cast<double>(t.requests), "", Better::none);
    report.add(prefix + "uploads", static_cast<double>(t.uploads), "", Better::none);
    report.add(prefix + "bytes_requested", static_cast<double>(t.bytes_requested), "B", Better::none);
    report.add(prefix + "budget_hits", static_cast<double>(t.budget_hits()), "", Better::none);
    report.add(prefix + "budget_hits.upload", static_cast<double>(t.upload_budget_hits), "", Better::none);
    report.add(prefix + "budget_hits.decoding", static_cast<double>(t.decoding_budget_hits), "", Better::none);
    report.add(prefix + "budget_hits.requests", static_cast<double>(t.request_budget_hits), "", Better::none);
    report.add(prefix + "budget_hits.bytes", static_cast<double>(t.byte_budget_hits), "", Better::none);
    report.add(prefix + "swaps_rejected", static_cast<double>(t.swaps_rejected), "", Better::none);
    report.add(prefix + "visible_missing", static_cast<double>(t.visible_missing), "", Better::none);
    report.add(prefix + "max_lod_bias", run->max_lod_bias, "levels", Better::none);
    report.add(prefix + "used_slots_at_end", run->used_slots, "slots", Better::none);
    report.add(prefix + "rejected_words", static_cast<double>(run->rejected_words), "words", Better::none);
    if (r == 0 && print && !run->real_tile_bytes)
      std::printf("note: this scheduler counts %llu bytes per tile request (no per-tile payload sizes)\n",
                  static_cast<unsigned long long>(cfg.scheduler.tile_bytes));
  }
  return out;
}

void print_scheduler(const Report& rep, const std::string& p) {
  auto v = [&](const char* n) {
    const Metric* m = rep.find(p + n);
    return m ? m->value : 0.0;
  };
  auto nz = [&](const char* n) {
    const Metric* m = rep.find(p + n);
    return m ? m->noise * 100.0 : 0.0;
  };
  std::printf(
      "  frame CPU time  p50 %8.2f us  p95 %8.2f us  p99 %8.2f us  max %8.2f us   (p50 spread over repetitions "
      "%.0f%%)\n",
      v("frame_cpu_us.p50"), v("frame_cpu_us.p95"), v("frame_cpu_us.p99"), v("frame_cpu_us.max"),
      nz("frame_cpu_us.p50"));
  std::printf(
      "  one read of the feedback buffer p50 %.2f us  ->  frame / read = %.1fx (median of per-frame ratios %.1fx)\n",
      v("read_us.p50"), v("x_read.p50"), v("x_read_per_frame.p50"));
  std::printf(
      "  operations: %.0f adds, %.0f swaps (%.2f per frame), %.0f requests, %.0f uploads, %.0f swaps rejected\n",
      v("adds"), v("swaps"), v("ops_per_frame"), v("requests"), v("uploads"), v("swaps_rejected"));
  std::printf("  budget hits: %.0f (uploads %.0f, decoding %.0f, requests %.0f, bytes %.0f); max LOD bias %.0f\n",
              v("budget_hits"), v("budget_hits.upload"), v("budget_hits.decoding"), v("budget_hits.requests"),
              v("budget_hits.bytes"), v("max_lod_bias"));
  std::printf(
      "  bytes requested %.0f (%.2f MiB); visible-but-missing %.0f; slots used at the end %.0f; words rejected %.0f\n",
      v("bytes_requested"), v("bytes_requested") / 1048576.0, v("visible_missing"), v("used_slots_at_end"),
      v("rejected_words"));
}

// A subcommand's options: argv[1] is the subcommand, skipped with argv[0].
samples::Arguments subcommand_arguments(int argc, char** argv) {
  return samples::Arguments(std::string("btflod-bench ") + argv[1], argc - 1, argv + 1);
}

// The integers of a comma-separated list option, each in [lo, hi].
std::vector<uint32_t> integer_list(samples::Arguments& args, std::string_view name, uint32_t lo, uint32_t hi,
                                   std::vector<uint32_t> fallback) {
  const auto items = args.list(name);
  if (!items) return fallback;
  std::vector<uint32_t> out;
  for (const std::string& s : *items) {
    char* end = nullptr;
    const unsigned long long x = std::strtoull(s.c_str(), &end, 10);
    const uint32_t v = static_cast<uint32_t>(x);
    if (end == s.c_str() || *end != '\0' || s[0] == '-' || x < lo || x > hi)
      args.error("--" + std::string(name) + " " + s + ": expected integers in [" + std::to_string(lo) + ", " +
                 std::to_string(hi) + "]");
    out.push_back(v);
  }
  return out;
}

int cmd_scheduler(int argc, char** argv) {
  SchedulerArgs a;
  samples::Arguments args = subcommand_arguments(argc, argv);
  a.check_determinism = args.flag("check-determinism");
  a.sweep = args.flag("sweep");
  a.runtime = args.flag("runtime");
  a.trace = args.string("trace", a.trace);
  a.bsvtf = args.values("bsvtf");
  a.materials = args.integer_as("materials", a.materials, 1, kFeedbackMaxMaterials);
  a.texture = args.integer_as("texture", a.texture, 64, 1 << 15);
  a.components = args.integer_as("components", a.components, 1, 4096);
  a.slots = args.integer_as("slots", a.slots, 1, 1 << 22);
  auto& budgets = a.replay.scheduler.budgets;
  budgets.uploads_per_frame = args.integer_as("uploads", budgets.uploads_per_frame, 1, 1 << 20);
  budgets.tiles_decoding = args.integer_as("decoding", budgets.tiles_decoding, 1, 1 << 20);
  budgets.requests_in_flight = args.integer_as("requests", budgets.requests_in_flight, 1, 1 << 20);
  budgets.bytes_in_flight = args.integer_as("bytes-in-flight", budgets.bytes_in_flight, 1, 1ll << 40);
  a.replay.window = args.integer_as("window", a.replay.window, 1, 4096);
  a.repeat = args.integer_as("repeat", a.repeat, 1, 1000);
  a.json = args.string("json", a.json);
  a.csv = args.string("csv", a.csv);
  a.svg = args.string("svg", a.svg);
  if (const auto m = args.choice("mode", {"weighted", "votes-only"}))
    a.replay.scheduler.mode = *m == 1 ? PriorityMode::votes_only : PriorityMode::weighted;
  a.sweep_slots = integer_list(args, "sweep-slots", 1, 1u << 22, a.sweep_slots);
  a.sweep_uploads = integer_list(args, "sweep-uploads", 1, 1u << 20, a.sweep_uploads);
  if (const auto modes = args.list("sweep-modes")) {
    a.sweep_modes.clear();
    for (const std::string& s : *modes) {
      if (s != "weighted" && s != "votes-only") args.error("--sweep-modes " + s + ": expected weighted or votes-only");
      a.sweep_modes.push_back(s == "votes-only" ? PriorityMode::votes_only : PriorityMode::weighted);
    }
  }
  if (!args.finish(0)) return fail(kUsage);
  if (a.trace.empty()) return fail("scheduler: --trace FILE is required\n" + std::string(kUsage));
  if (a.bsvtf.empty() && a.materials == 0)
    return fail("scheduler: give --bsvtf FILE (one per material) or --materials N");
  auto trace = read_feedback_trace_file(a.trace);
  if (!trace) return fail("cannot use the trace: " + trace.message());
  Materials mats;
  for (const auto& p : a.bsvtf)
    if (auto r = add_bsvtf_material(mats, p); !r) return fail(r.message());
  if (a.materials) add_described_materials(mats, a.materials, a.texture, a.components);
  a.replay.cache = cache_for(a.slots);

  uint64_t words = 0;
  for (size_t i = 0; i < trace->frame_count(); ++i) words += trace->frame_words(i).size();
  std::printf("trace %s: %zu frames, %.0f words per frame on average, decimation %u\n", a.trace.c_str(),
              trace->frame_count(),
              trace->frame_count() ? static_cast<double>(words) / static_cast<double>(trace->frame_count()) : 0.0,
              trace->frame_count() ? trace->frames[0].decimation : 0);
  for (uint32_t m = 0; m < mats.set.material_count(); ++m)
    std::printf("material %u: %s, %u virtual textures, %u levels\n", m, mats.names[m].c_str(),
                mats.set.material(m).texture_count, mats.set.material(m).levels.finest_level() + 1);

  Report report("scheduler");
  report.input("trace", a.trace);
  report.input("frames", static_cast<double>(trace->frame_count()));
  report.input("materials", static_cast<double>(mats.set.material_count()));
  report.input("virtual_textures", static_cast<double>(mats.set.texture_count()));
  report.input("repetitions", a.repeat);
  std::string names;
  for (const auto& n : mats.names) names += (names.empty() ? "" : ";") + n;
  report.input("material_names", names);

  if (!a.sweep) {
    report.input("slots", a.replay.cache.slots_x * a.replay.cache.slots_y);
    report.input("uploads_per_frame", a.replay.scheduler.budgets.uploads_per_frame);
    report.input("tiles_decoding", a.replay.scheduler.budgets.tiles_decoding);
    report.input("requests_in_flight", a.replay.scheduler.budgets.requests_in_flight);
    report.input("bytes_in_flight", static_cast<double>(a.replay.scheduler.budgets.bytes_in_flight));
    report.input("mode", mode_name(a.replay.scheduler.mode));
    auto out = measure_scheduler(mats, *trace, a.replay, a.repeat, report, "", true);
    if (!out) return fail(out.message());
    report.finish();
    std::printf("cache %u slots, %u uploads/frame, mode %s, %u repetitions (medians):\n",
                a.replay.cache.slots_x * a.replay.cache.slots_y, a.replay.scheduler.budgets.uploads_per_frame,
                mode_name(a.replay.scheduler.mode), a.repeat);
    print_scheduler(report, "");
    std::printf("schedule digest %016llx; deterministic: %s\n", static_cast<unsigned long long>(out->digest),
                out->deterministic ? "yes" : "no");
    report.input("schedule_digest", std::to_string(out->digest));
    if (a.runtime) {
      if (a.bsvtf.empty() || a.materials)
        return fail("scheduler --runtime: needs --bsvtf containers (and no described materials)");
      std::vector<std::vector<uint8_t>> containers;
      for (const auto& p : a.bsvtf) {
        auto b = read_file_bytes(p);
        if (!b) return fail(b.message());
        containers.push_back(std::move(*b));
      }
      uint64_t first_digest = 0;
      bool same = true;
      for (uint32_t r = 0; r < a.repeat; ++r) {
        auto run = replay_trace_runtime(containers, *trace, a.replay, r % 2 == 1);
        if (!run) return fail("runtime replay: " + run.message());
        if (r == 0) first_digest = run->digest;
        same = same && run->digest == first_digest;
        std::vector<double> fu(run->frame_ns.size()), uu(run->update_ns.size()), ru(run->read_ns.size());
        for (size_t i = 0; i < fu.size(); ++i) fu[i] = run->frame_ns[i] / 1000.0, uu[i] = run->update_ns[i] / 1000.0;
        for (size_t i = 0; i < ru.size(); ++i) ru[i] = run->read_ns[i] / 1000.0;
        for (const char* q : {"p50", "p95", "p99", "max"}) {
          const double pq = q[0] == 'm' ? 1.0 : std::atof(q + 1) / 100.0;
          report.add(std::string("runtime.update_us.") + q, percentile(uu, pq), "us", Better::lower);
          report.add(std::string("runtime.update_and_decode_us.") + q, percentile(fu, pq), "us", Better::lower);
        }
        report.add("runtime.x_read.p50", percentile(uu, 0.5) / std::max(percentile(ru, 0.5), 1e-3), "x", Better::lower);
        report.add("runtime.tile_uploads", static_cast<double>(run->tile_uploads), "", Better::none);
        report.add("runtime.page_table_writes", static_cast<double>(run->page_table_writes), "", Better::none);
        report.add("runtime.bytes_read", static_cast<double>(run->bytes_read), "B", Better::none);
        report.add("runtime.adds", static_cast<double>(run->total.adds), "ops", Better::none);
        report.add("runtime.swaps", static_cast<double>(run->total.swaps), "ops", Better::none);
        report.add("runtime.budget_hits", static_cast<double>(run->total.budget_hits()), "", Better::none);
      }
      report.finish();
      auto v = [&](const std::string& n) { return report.find(n)->value; };
      std::printf("runtime (Streamer::update + decode jobs pumped on this thread, %u repetitions, medians):\n",
                  a.repeat);
      std::printf("  update()          p50 %8.2f us  p95 %8.2f us  p99 %8.2f us  max %8.2f us  (%.1fx one read)\n",
                  v("runtime.update_us.p50"), v("runtime.update_us.p95"), v("runtime.update_us.p99"),
                  v("runtime.update_us.max"), v("runtime.x_read.p50"));
      std::printf("  update + decode   p50 %8.2f us  p95 %8.2f us  p99 %8.2f us  max %8.2f us\n",
                  v("runtime.update_and_decode_us.p50"), v("runtime.update_and_decode_us.p95"),
                  v("runtime.update_and_decode_us.p99"), v("runtime.update_and_decode_us.max"));
      std::printf(
          "  %.0f tile uploads, %.0f page-table writes, %.0f bytes read, %.0f adds, %.0f swaps, %.0f budget hits; "
          "deterministic: %s\n",
          v("runtime.tile_uploads"), v("runtime.page_table_writes"), v("runtime.bytes_read"), v("runtime.adds"),
          v("runtime.swaps"), v("runtime.budget_hits"), same ? "yes" : "no");
      if (!same) out->deterministic = false;
    }
    if (!a.json.empty())
      if (auto w = write_text(a.json, report.json()); !w) return fail(w.message());
    if (a.check_determinism && !out->deterministic) return 1;
    return 0;
  }

  // Sweep: every combination, fewer repetitions by default.
  std::vector<SweepRow> rows;
  for (const PriorityMode mode : a.sweep_modes)
    for (const uint32_t uploads : a.sweep_uploads)
      for (const uint32_t slots : a.sweep_slots) {
        ReplayConfig cfg = a.replay;
        cfg.cache = cache_for(slots);
        cfg.scheduler.mode = mode;
        cfg.scheduler.budgets.uploads_per_frame = uploads;
        const uint32_t real_slots = cfg.cache.slots_x * cfg.cache.slots_y;
        char prefix[96];
        std::snprintf(prefix, sizeof prefix, "sweep.slots%u.uploads%u.%s.", real_slots, uploads, mode_name(mode));
        Report one("scheduler");
        auto out = measure_scheduler(mats, *trace, cfg, a.repeat, one, "", false);
        if (!out) {
          std::printf("slots %u: skipped (%s)\n", real_slots, out.message().c_str());
          continue;
        }
        one.finish();
        for (const Metric& m : one.metrics())
          for (const double s : m.samples) report.add(prefix + m.name, s, m.unit.c_str(), m.better);
        SweepRow row;
        row.slots = real_slots, row.uploads = uploads, row.mode = mode_name(mode);
        auto v = [&](const char* n) { return one.find(n)->value; };
        row.p50 = v("frame_cpu_us.p50"), row.p95 = v("frame_cpu_us.p95"), row.p99 = v("frame_cpu_us.p99");
        row.max = v("frame_cpu_us.max"), row.x_read = v("x_read.p50"), row.ops = v("ops_per_frame");
        row.budget_hits = v("budget_hits"), row.bytes = v("bytes_requested"),
        row.visible_missing = v("visible_missing");
        row.noise = one.find("frame_cpu_us.p50")->noise;
        rows.push_back(row);
        std::printf(
            "slots %5u uploads %4u %-10s p50 %8.2f us p99 %8.2f us  x_read %6.1f  ops/frame %6.2f  budget hits %6.0f  "
            "%8.2f MiB\n",
            real_slots, uploads, mode_name(mode), row.p50, row.p99, row.x_read, row.ops, row.budget_hits,
            row.bytes / 1048576.0);
      }
  report.finish();
  if (!a.json.empty())
    if (auto w = write_text(a.json, report.json()); !w) return fail(w.message());
  if (!a.csv.empty())
    if (auto w = write_text(a.csv, sweep_csv(rows)); !w) return fail(w.message());
  if (!a.svg.empty())
    if (auto w = write_text(a.svg, sweep_svg(rows, a.trace)); !w) return fail(w.message());
  return 0;
}

// ---------------------------------------------------------------------------------------------
int cmd_codec(int argc, char** argv) {
  std::vector<std::string> files;
  CodecOptions o;
  std::string json;
  samples::Arguments args = subcommand_arguments(argc, argv);
  o.encode = args.flag("encode");
  files = args.values("bsvtf");
  json = args.string("json", json);
  o.repetitions = args.integer_as("repeat", o.repetitions, 1, 1000);
  o.jpeg_quality = args.integer_as("jpeg-quality", o.jpeg_quality, 1, 100);
  if (const auto qualities = args.list("quality")) {
    o.qualities.clear();
    for (const std::string& s : *qualities) {
      char* end = nullptr;
      const float q = std::strtof(s.c_str(), &end);
      if (end == s.c_str() || *end != '\0' || !(q >= 1.0f && q <= 100.0f))
        args.error("--quality " + s + ": expected numbers in [1, 100]");
      o.qualities.push_back(q);
    }
  }
  if (!args.finish(0)) return fail(kUsage);
  if (files.empty()) return fail("codec: --bsvtf FILE is required\n" + std::string(kUsage));
  Report report("codec");
  report.input("repetitions", o.repetitions);
  report.input("jpeg_quality", o.jpeg_quality);
  std::string names;
  for (const auto& f : files) names += (names.empty() ? "" : ";") + f;
  report.input("containers", names);
  std::vector<std::string> prefixes;
  std::vector<ContainerTiles> all;
  for (size_t fi = 0; fi < files.size(); ++fi) {
    auto c = load_container_tiles(files[fi]);
    if (!c) return fail("cannot use the container: " + c.message());
    const std::string prefix = files.size() == 1 ? "" : "c" + std::to_string(fi) + ".";
    std::printf("%s: %s, %zu tiles of %ux%u x %u, %u levels\n", files[fi].c_str(), c->metadata.material_name.c_str(),
                c->ids.size(), c->layout.stored_size(), c->layout.stored_size(), c->layout.channels,
                c->metadata.level_count);
    run_codec_bench(*c, o, report, prefix);
    prefixes.push_back(prefix);
    all.push_back(std::move(*c));
  }
  report.finish();
  for (size_t fi = 0; fi < all.size(); ++fi) {
    const std::string& p = prefixes[fi];
    std::printf("\n%s (medians of %d interleaved repetitions; MB/s of decoded raw half floats)\n", files[fi].c_str(),
                o.repetitions);
    std::vector<std::string> codec_names;
    for (const Metric& m : report.metrics()) {
      if (m.name.rfind(p + "decode.", 0) != 0 || m.name.find(".all.us_per_tile") == std::string::npos) continue;
      codec_names.push_back(m.name.substr(p.size() + 7, m.name.size() - p.size() - 7 - 16));
    }
    std::printf("%-24s %9s", "codec", "B/tile");
    for (uint32_t l = 0; l < all[fi].metadata.level_count; ++l) std::printf("  level %u us/tile  MB/s", l);
    std::printf("       all us/tile   MB/s  spread\n");
    const Metric* ref = report.find(p + "decode.btflod_zlib.all.us_per_tile");
    for (const auto& n : codec_names) {
      std::printf("%-24s %9.0f", n.c_str(), report.find(p + "decode." + n + ".bytes_per_tile")->value);
      for (uint32_t l = 0; l < all[fi].metadata.level_count; ++l) {
        const Metric* us = report.find(p + "decode." + n + ".level" + std::to_string(l) + ".us_per_tile");
        const Metric* mb = report.find(p + "decode." + n + ".level" + std::to_string(l) + ".mb_per_s");
        if (us)
          std::printf("  %15.2f %6.0f", us->value, mb->value);
        else
          std::printf("  %15s %6s", "-", "-");
      }
      const Metric* us = report.find(p + "decode." + n + ".all.us_per_tile");
      std::printf("  %15.2f %6.0f  %5.0f%%", us->value, report.find(p + "decode." + n + ".all.mb_per_s")->value,
                  us->noise * 100);
      if (ref && us != ref) std::printf("  (%.2fx btflod_zlib's time)", us->value / ref->value);
      std::printf("\n");
    }
    if (const Metric* r = report.find(p + "decode.turbojpeg.rmse_vs_btflod"))
      std::printf("(libjpeg-turbo at quality %d: RMSE %.4g vs the btflod-decoded samples it codes)\n", o.jpeg_quality,
                  r->value);
    if (o.encode) {
      for (const float q : o.qualities) {
        char qn[32];
        std::snprintf(qn, sizeof qn, "q%g", static_cast<double>(q));
        std::printf("encode btflod %-5s %9.2f us/tile  %8.0f B/tile\n", qn,
                    report.find(p + "encode.btflod." + qn + ".us_per_tile")->value,
                    report.find(p + "encode.btflod." + qn + ".bytes_per_tile")->value);
      }
      std::printf("encode zlib raw halves (level 6) %9.2f us/tile\n",
                  report.find(p + "encode.zlib_raw_halves.us_per_tile")->value);
    }
  }
  if (!json.empty())
    if (auto w = write_text(json, report.json()); !w) return fail(w.message());
  return 0;
}

// ---------------------------------------------------------------------------------------------
int cmd_compare(int argc, char** argv) {
  std::vector<std::string> files;
  double min_band = 0.05;
  samples::Arguments args = subcommand_arguments(argc, argv);
  min_band = args.number("min-band", min_band, 0.0, 99.999);
  if (!args.finish()) return fail(kUsage);
  files = args.positional();
  if (files.size() != 2) return fail("compare: expected two reports, A.json B.json\n" + std::string(kUsage));
  auto a = read_report(files[0]);
  if (!a) return fail(a.message());
  auto b = read_report(files[1]);
  if (!b) return fail(b.message());
  if (a->first != b->first)
    return fail("compare: " + files[0] + " is a " + a->first + " report, " + files[1] + " a " + b->first + " one");
  std::printf("%-58s %14s %14s %8s %7s  %s\n", "metric", "A", "B", "B/A", "band", "verdict");
  int regressions = 0, improvements = 0, changed = 0, missing = 0;
  for (const Metric& ma : a->second) {
    const auto it =
        std::find_if(b->second.begin(), b->second.end(), [&](const Metric& m) { return m.name == ma.name; });
    if (it == b->second.end()) {
      ++missing;
      std::printf("%-58s %14.6g %14s %8s %7s  missing in B\n", ma.name.c_str(), ma.value, "-", "-", "-");
      continue;
    }
    const Metric& mb = *it;
    // Noise band: the spread each run measured over its repetitions, at least min_band.
    const double band = std::max(min_band, ma.noise + mb.noise);
    const double ratio = ma.value != 0 ? mb.value / ma.value : (mb.value == 0 ? 1.0 : INFINITY);
    const char* verdict = "~";
    if (ma.better == Better::lower) {
      if (ratio > 1.0 + band)
        verdict = "REGRESSION", ++regressions;
      else if (ratio < 1.0 / (1.0 + band))
        verdict = "improved", ++improvements;
    } else if (ma.better == Better::higher) {
      if (ratio < 1.0 / (1.0 + band))
        verdict = "REGRESSION", ++regressions;
      else if (ratio > 1.0 + band)
        verdict = "improved", ++improvements;
    } else if (ma.noise > 0 || mb.noise > 0) {
      verdict = ratio > 1.0 + band || ratio < 1.0 / (1.0 + band) ? "changed" : "~";  // a timing kept for reference
      if (verdict[0] == 'c') ++changed;
    } else {
      verdict = ma.value == mb.value ? "=" : "changed";
      if (ma.value != mb.value) ++changed;
    }
    std::printf("%-58s %14.6g %14.6g %8.3f %6.0f%%  %s\n", ma.name.c_str(), ma.value, mb.value, ratio,
                ma.better == Better::none && ma.noise == 0 && mb.noise == 0 ? 0.0 : band * 100.0, verdict);
  }
  std::printf(
      "%d regressions, %d improvements beyond the noise band; %d exact counters changed; %d metrics missing in B\n",
      regressions, improvements, changed, missing);
  return regressions > 0 ? 1 : 0;
}

// ---------------------------------------------------------------------------------------------
int cmd_generate(int argc, char** argv) {
  std::string trace_path, bsvtf_path;
  uint32_t frames = 48, width = 80, height = 45, decimation = 4, texture = 512;
  samples::Arguments args = subcommand_arguments(argc, argv);
  trace_path = args.string("trace", trace_path);
  bsvtf_path = args.string("bsvtf", bsvtf_path);
  frames = args.integer_as("frames", frames, 1, 100000);
  width = args.integer_as("width", width, 1, 4096);
  height = args.integer_as("height", height, 1, 4096);
  decimation = args.integer_as("decimation", decimation, 1, 64);
  texture = args.integer_as("texture", texture, 64, 8192);
  if (!args.finish(0)) return fail(kUsage);
  if (trace_path.empty()) return fail("generate: --trace OUT is required");
  const VtGeometry g = VtGeometry::make(texture, texture);
  const uint32_t L = std::min(g.finest_level, kFeedbackMaxLevel);
  // A camera panning over a plane of one material: the level falls with the distance (row),
  // texture coordinates scroll with the frame, the sample position rotates (decimation d).
  auto rec = FeedbackTraceRecorder::open(trace_path, {width * height, 1});
  if (!rec) return fail(rec.message());
  std::vector<uint32_t> words(size_t{width} * height);
  for (uint32_t f = 0; f < frames; ++f) {
    FeedbackFrameInfo info;
    info.frame_index = f;
    info.width = width, info.height = height, info.decimation = decimation;
    feedback_sample_offset(f, decimation, info.sample_dx, info.sample_dy);
    info.has_camera = true;
    info.camera.position[0] = 0.05f * static_cast<float>(f);
    info.camera.position[1] = 1.0f;
    for (uint32_t y = 0; y < height; ++y)
      for (uint32_t x = 0; x < width; ++x) {
        if (y < height / 6) {  // sky
          words[size_t{y} * width + x] = kFeedbackNone;
          continue;
        }
        const double depth = 1.0 + 6.0 * (1.0 - static_cast<double>(y) / height);  // far rows at the top
        const double rho = depth * decimation * 0.5;  // texels per pixel grows with distance
        const uint32_t level =
            L - std::min<uint32_t>(L, static_cast<uint32_t>(std::max(0.0, std::floor(std::log2(rho)))));
        const double u = std::fmod((x * decimation + info.sample_dx) * rho / texture + 0.01 * f, 1.0);
        const double v = std::fmod((y * decimation + info.sample_dy) * rho / texture, 1.0);
        const uint32_t n_x = g.tiles_x(level), n_y = g.tiles_y(level);
        words[size_t{y} * width + x] = pack_feedback({0, level, std::min(n_x - 1, static_cast<uint32_t>(u * n_x)),
                                                      std::min(n_y - 1, static_cast<uint32_t>(v * n_y))});
      }
    if (const Status s = rec->record(info, words); s != Status::success)
      return fail(std::string("recording frame failed: ") + status_name(s));
  }
  if (auto c = rec->close(); !c) return fail(c.message());
  std::printf("wrote %s: %u frames of %ux%u words (decimation %u)\n", trace_path.c_str(), frames, width, height,
              decimation);
  if (bsvtf_path.empty()) return 0;

  // A matching container: 8 components (2 virtual textures), smooth + noisy content.
  BsvtfMetadata md;
  md.material_name = "generated";
  md.width = md.height = texture;
  md.level_count = g.finest_level + 1;
  md.component_count = 8;
  md.light_set = md.view_set = "generated-2";  // 2 lights x 2 views x RGB = 12 rows of U
  md.light_directions = md.view_directions = {0.0f, 0.0f, 1.0f, 0.5f, 0.0f, 0.8660254f};
  md.u_rows = 12;
  std::vector<float> u(size_t{md.u_rows} * md.component_count);
  for (size_t i = 0; i < u.size(); ++i) u[i] = std::sin(0.7f * static_cast<float>(i));
  const TileLayout layout = md.layout();
  std::vector<BsvtfTileInput> tiles;
  std::vector<std::vector<float>> samples;  // owned here, viewed by the tile inputs
  samples.reserve(g.tile_count() * md.texture_count());
  for (uint32_t t = 0; t < md.texture_count(); ++t)
    for (uint32_t l = 0; l <= g.finest_level; ++l)
      for (uint32_t ty = 0; ty < g.tiles_y(l); ++ty)
        for (uint32_t tx = 0; tx < g.tiles_x(l); ++tx) {
          BsvtfTileInput in;
          in.id = TileId{t, l, tx, ty};
          std::vector<float>& data = samples.emplace_back(layout.sample_count());
          const double scale =
              std::ldexp(1.0, static_cast<int>(g.finest_level - l));  // texels of the finest level per texel
          for (uint32_t j = 0; j < layout.stored_size(); ++j)
            for (uint32_t i = 0; i < layout.stored_size(); ++i)
              for (uint32_t k = 0; k < 4; ++k) {
                const double X = ((tx * 64.0 + i - 4) * scale) / texture * 6.2831853,
                             Y = ((ty * 64.0 + j - 4) * scale) / texture * 6.2831853;
                const uint32_t c = 4 * t + k;
                uint32_t h = (tx * 73856093u) ^ (ty * 19349663u) ^ (i * 83492791u) ^ (j * 2654435761u) ^ (c * 97u) ^ l;
                h ^= h >> 13, h *= 0x5bd1e995u, h ^= h >> 15;
                data[(size_t{j} * layout.stored_size() + i) * 4 + k] =
                    static_cast<float>(std::sin(X * (c + 1)) * std::cos(Y * (2 + c)) / (c + 1) +
                                       0.02 * ((h & 0xffu) / 255.0 - 0.5) / (c + 1));
              }
          in.samples = data;
          in.weight = static_cast<float>(1.0 / ((t + 1) * (l + 1)));
          tiles.push_back(std::move(in));
        }
  BsvtfBuildOptions bo;
  bo.quality = 50.0f;
  auto file = build_bsvtf(md, u, tiles, bo);
  if (!file) return fail(file.message());
  if (auto w = write_file_bytes(bsvtf_path, *file); !w) return fail(w.message());
  std::printf("wrote %s: %zu tiles, %zu bytes\n", bsvtf_path.c_str(), tiles.size(), file->size());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0) {
    std::puts(kUsage);
    return argc < 2 ? 2 : 0;
  }
  const std::string cmd = argv[1];
  if (cmd == "scheduler") return cmd_scheduler(argc, argv);
  if (cmd == "codec") return cmd_codec(argc, argv);
  if (cmd == "compare") return cmd_compare(argc, argv);
  if (cmd == "generate") return cmd_generate(argc, argv);
  return fail("unknown command " + cmd + "\n" + kUsage);
}
