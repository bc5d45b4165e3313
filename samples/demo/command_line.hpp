// btflod-demo — command line: DemoConfig and its parser.
#pragma once

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <string_view>

#include "btflod/core/value_transform.hpp"
#include "btflod/offline/btf/heightfield.hpp"
#include "btflod/runtime/vt/cache_config.hpp"
#include "common/arguments.hpp"

namespace btflod::demo {

struct DemoConfig {
  std::string out_dir;          ///< --out DIR (required)
  int size = 32;                ///< --size N texels (square) of each material
  int frames = 200;             ///< --frames N of the fly-through
  int materials = 4;            ///< --materials N synthesised materials
  std::string backend = "gl";   ///< --backend gl|cpu
  double bandwidth_kib = 96.0;  ///< --bandwidth KiB/s of the throttled link
  int settle = 60;              ///< --settle N: max frames at the last view
  /// --cut: after the settle, cut to the first view and measure frames and bytes until the image
  /// stays within SSIM 0.99 of its converged frame (cut_convergence.hpp).
  bool cut = false;
  bool no_swap = false;
  /// --value-encoding: the domain of the FMF (core/value_transform.hpp); unset: the profile's default.
  std::optional<ValueEncoding>
      value_encoding;  ///< --no-swap: no material swapped on the live Streamer during the flight
  /// --material NAME: every material is synthesised as NAME (seed + index still differs);
  /// unset: cloth, stone, leather, tiles in turn.
  std::optional<SynthMaterial> material;
  /// --brdf FILE.mbsdf: a measured BRDF as every material's base reflectance (empty: analytic).
  std::string brdf_path;
  uint64_t seed = 1;   ///< --seed N
  int components = 0;  ///< --components C: FMF rank (0: the profile's default)
  /// --rank-target S: each material's rank is the smallest of 4, 8, 12, 16 (up to --components)
  /// whose displayed images reach mean SSIM S (offline/factor/fmf_rank.hpp); 0: a fixed rank. Default
  /// profile without --components: kDefaultDemoRankTarget.
  double rank_target = -1.0;
  bool interreflection = false;         ///< --interreflection: one diffuse bounce in the synthesis
  bool quiet = false;                   ///< --quiet: no progress bars
  bool window = false;                  ///< --window: show the frames in an X11 window
  bool deflate = false;                 ///< --deflate: deflate tiles (format 2), not zstd
  std::string record_feedback;          ///< --record-feedback FILE: feedback trace for btflod-bench
  bool separate_feedback_pass = false;  ///< --feedback-pass: feedback words in a pass of their own
  /// --cache-format rgba16f|rgba8|bc5 (runtime/vt/cache_format.hpp, cache_bc5.hpp). rgba8 by default: half the cache
  /// memory, ΔE*ab p99 0.1 against rgba16f on the settled view (docs/bsvtf_format.md, "Cache formats").
  CacheFormat cache_format = CacheFormat::rgba8_affine;
  /// --profile paper: paper 000's configuration (151 x 151 directions, C = 100, T = 64 + 4-texel
  /// border, a 56 x 56-slot cache, 1280 x 720); the materials are synthesised into BTF stores and
  /// factorised out of core. --size defaults to 64 there (512 is the paper's; ~36 GB of store each).
  std::string profile;
  uint64_t memory_bytes = uint64_t{2} << 30;  ///< --memory SIZE: out-of-core factorisation budget (paper)
  /// --keep-stores: keep each material's BTF store (paper profile: deleted after its raw-BTF pass).
  bool keep_stores = false;
  std::string inputs_dir;                 ///< --inputs DIR: prebuilt <name>.btfstore / <name>.fmf (paper profile)
  int frame_width = 0, frame_height = 0;  ///< --frame-size WxH (0: the profile's, 480x270 or 1280x720)
  bool size_given = false, frames_given = false, materials_given = false, bandwidth_given = false;
  bool seed_given = false, components_given = false;
};

/// The largest FMF rank the demo accepts: the generated shaders hold at most 128 components
/// (runtime/shader/shader_config.hpp).
inline constexpr int kMaxDemoComponents = 128;

/// The FMF rank of the default profile (docs/demo.md, "Default rank": measured against the raw
/// BTF through the same rays). A macro so that the usage text can print it.
#define BTFLOD_DEMO_DEFAULT_COMPONENTS 12
#define BTFLOD_DEMO_STR2(x) #x
#define BTFLOD_DEMO_STR(x) BTFLOD_DEMO_STR2(x)
inline constexpr int kDefaultDemoComponents = BTFLOD_DEMO_DEFAULT_COMPONENTS;
/// The default profile chooses each material's rank (up to kDefaultDemoComponents) from its
/// displayed images against this mean SSIM (docs/demo.md, "Default rank").
#define BTFLOD_DEMO_DEFAULT_RANK_TARGET 0.75
inline constexpr double kDefaultDemoRankTarget = BTFLOD_DEMO_DEFAULT_RANK_TARGET;
/// The value encoding of the default profile (docs/fidelity.md): its name for the usage text
/// and the value (the paper profile stays linear, as paper 000 factorises). ln(Y + 0.05) with
/// chroma over Y + 0.05: at C = 8 the last view's FMF against the raw BTF through the same rays
/// goes from SSIM 0.814 (linear) to 0.958 (log per channel 0.956, sqrt 0.943), tiles-3 from
/// 0.336 to 0.934, at the frame cost of C = 8.
#define BTFLOD_DEMO_DEFAULT_ENCODING_NAME "log_ycbcr"
inline constexpr ValueEncoding kDefaultDemoEncoding = ValueEncoding::log_ycbcr;
/// Floors of the default materials (default rank and encoding) against the raw BTF (FMF through
/// the same rays as the raw render; docs/fidelity.md): the whole last view, and each material
/// covering at least kMinMaterialPixels pixels of it. The whole-view floor is the fidelity goal
/// of the default profile; measured 0.956 whole and 0.932 for tiles-3, the worst material
/// (default run). The figure does not depend on streaming timing, so the margin covers only
/// arithmetic differences between machines.
inline constexpr double kDefaultRawSsimBound = 0.95;
inline constexpr double kDefaultRawMaterialSsimBound = 0.90;
inline constexpr uint64_t kMinMaterialPixels = 2000;

inline constexpr const char* kDemoUsage =
    "usage: btflod-demo --out DIR [--frames N] [--size N] [--materials N] [--backend gl|cpu]\n"
    "                   [--bandwidth KIB_PER_S] [--settle N] [--seed N] [--window] [--quiet]\n"
    "                   [--profile paper] [--memory SIZE] [--deflate] [--feedback-pass]\n"
    "                   [--keep-stores] [--inputs DIR] [--frame-size WxH] [--components C]\n"
    "                   [--material cloth|stone|leather|tiles] [--interreflection] [--cut]\n"
    "                   [--cache-format rgba16f|rgba8] [--rank-target S] [--brdf FILE.mbsdf]\n"
    "  Synthesises N small procedural BTFs (N x N texels, 23 x 23 directions), factorises them\n"
    "  (FMF; each material's rank chosen from its displayed images, up to C = " BTFLOD_DEMO_STR(
        BTFLOD_DEMO_DEFAULT_COMPONENTS) "), builds one\n"
    "  .bsvtf container each, then flies a camera through a scene of BTF-textured tori on a plane while one runtime Streamer streams tiles through throttled\n"
    "  sources, rendering BSVTF (and FMF as the converged reference) with the GL\n"
    "  backend. Writes DIR/frames/frame_NNNN.png, DIR/contact_sheet_frames.png,\n"
    "  DIR/report.html and DIR/report.json.\n"
    "  After the flight the camera holds the last view for up to --settle frames (60) while the\n"
    "  remaining tiles arrive; the demo fails unless SSIM rises over that phase.\n"
    "  --cut then cuts the camera to the first view and holds it until streaming is quiet:\n"
    "  frames, bytes and seconds until the image stays within SSIM 0.99 of its converged frame\n"
    "  (report.json \"cut\", docs/benchmarking.md).\n"
    "  During the flight the last torus changes material twice on the running Streamer, as a level\n"
    "  load would: at 1/3 of the flight a copy of the first material is added (a new Streamer\n"
    "  material), shown once ready, and the old one removed; at 2/3 its own material comes back the\n"
    "  same way (report.json \"material_swaps\"; flights under 12 frames or --no-swap: none).\n"
    "  --window shows each BSVTF frame in an X11 window (GL backend, needs DISPLAY; headless\n"
    "  otherwise); closing the window (or Escape) ends the flight early and writes the outputs.\n"
    "  --deflate codes the tiles with deflate (tile format 2, read by every client) instead of\n"
    "  zstd (format 3, the default: smaller tiles that decode faster).\n"
    "  --record-feedback FILE records every frame's feedback buffer as a trace (runtime/lod/feedback_trace.hpp)\n"
    "  --cache-format rgba8 (the default) keeps the tile cache as unorm8 with a per-slot offset and\n"
    "  scale (runtime/vt/cache_format.hpp), half the memory of rgba16f (the decoded values as halves);\n"
    "  --cache-format bc5 keeps it as two BC5 planes under the same per-slot map (runtime/vt/cache_bc5.hpp),\n"
    "  a quarter of rgba16f (needs T + 2B a multiple of 4 and BC texture support on the GPU).\n"
    "  Either way the report compares the two formats on the settled view's resident tiles (CPU\n"
    "  ray-caster, same rays).\n"
    "  --brdf FILE.mbsdf: every material's base reflectance is that measured BRDF (NVIDIA MBSDF, e.g.\n"
    "  the car paints of the shared data) under its mesostructure; names gain the file's stem.\n"
    "  --feedback-pass draws the feedback words in a pass of their own at 1/16 of the screen\n"
    "  (GPU path) instead of writing them from the BSVTF colour pass (the default).\n"
    "  for btflod-bench scheduler --trace FILE.\n"
    "  --profile paper: paper 000's configuration: 151 x 151 directions (ubo2014), FMF C = 100 (25\n"
    "  RGBA virtual textures per material), tiles T = 64 with a 4-texel border, a 56 x 56-slot cache\n"
    "  (4032^2 texels), 1280 x 720 frames; each material is synthesised view by view into a BTF store\n"
    "  (DIR/<name>.btfstore, halves) and factorised out of core within --memory (default 2G).\n"
    "  Defaults there: --size 64 --materials 3 --frames 24 --bandwidth 8192; --size 512 is the\n"
    "  paper's texel count (about 36 GB of store and hours of CPU per material: opt-in only).\n"
    "  Each store is deleted once its material is factorised, built and its raw-BTF reference pass\n"
    "  done, so one store is on disk at a time; --keep-stores keeps them. --inputs DIR reuses\n"
    "  prebuilt inputs: DIR/<name>.btfstore (e.g. cloth-0.btfstore, a symbolic link is fine; its own\n"
    "  texel count, never deleted) and DIR/<name>.fmf (C = 100) instead of synthesising/factorising.\n"
    "  --frame-size WxH renders W x H frames instead of the profile's (480x270, paper 1280x720).\n"
    "  --value-encoding linear|sqrt|log|log_ycbcr factorises the BTF values as they are, their square\n"
    "  root or ln(x + 0.05) (a dynamic-range reduction for glossy materials), or ln(Y + 0.05) with\n"
    "  chroma Cb, Cr over Y + 0.05 (decorrelated colour, as Bonn's DFMF); the shaders decode the sum\n"
    "  of eq. 5 (docs/fidelity.md). Default: " BTFLOD_DEMO_DEFAULT_ENCODING_NAME ".\n"
    "  Each material's FMF rank is the smallest of 4, 8, 12, 16 whose displayed (view, light) images\n"
    "  reach mean SSIM --rank-target S (default " BTFLOD_DEMO_STR(BTFLOD_DEMO_DEFAULT_RANK_TARGET) ") against\n"
    "  the raw BTF on the training views (offline/factor/fmf_rank.hpp); one program set of the largest C draws\n"
    "  them all. --components C alone sets one fixed rank for every material (1..128; paper 100);\n"
    "  with --rank-target it is the largest rank tried.\n"
    "  --material NAME synthesises every material as NAME (cloth, stone, leather or tiles; seed + index\n"
    "  still differs) instead of the four kinds in turn. --interreflection adds one bounce of diffuse\n"
    "  interreflection to the synthesis (offline/btf/synthesizer.hpp; slower). Neither applies to prebuilt\n"
    "  --inputs stores.\n"
    "  defaults: --frames 200 --size 32 --materials 4 --backend gl --bandwidth 96 --settle 60 --seed 1\n"
    "  --cache-format rgba8\n"
    "  --rank-target " BTFLOD_DEMO_STR(BTFLOD_DEMO_DEFAULT_RANK_TARGET) " (--components " BTFLOD_DEMO_STR(
        BTFLOD_DEMO_DEFAULT_COMPONENTS) " the largest)";

/// Parses argv. Returns the config, or nullopt after printing the problem (or the usage for
/// --help, with *exit_code = 0; otherwise 2).
inline std::optional<DemoConfig> parse_command_line(int argc, char** argv, int* exit_code) {
  DemoConfig cfg;
  *exit_code = 2;
  auto fail = [&](const std::string& msg) -> std::optional<DemoConfig> {
    std::fprintf(stderr, "btflod-demo: %s\n%s\n", msg.c_str(), kDemoUsage);
    return std::nullopt;
  };
  samples::Arguments args("btflod-demo", argc, argv);
  if (args.wants_help()) {
    std::puts(kDemoUsage);
    *exit_code = 0;
    return std::nullopt;
  }
  cfg.interreflection = args.flag("interreflection");
  cfg.window = args.flag("window");
  cfg.cut = args.flag("cut");
  cfg.no_swap = args.flag("no-swap");
  cfg.deflate = args.flag("deflate");
  cfg.separate_feedback_pass = args.flag("feedback-pass");
  cfg.keep_stores = args.flag("keep-stores");
  cfg.quiet = args.flag("quiet", 'q');
  cfg.out_dir = args.string("out", cfg.out_dir);
  if (const auto f = args.choice("cache-format", {"rgba16f", "rgba8", "rgba8_affine", "bc5", "bc5_affine"}))
    cfg.cache_format = *f == 0 ? CacheFormat::rgba16f : *f <= 2 ? CacheFormat::rgba8_affine : CacheFormat::bc5_affine;
  cfg.inputs_dir = args.string("inputs", cfg.inputs_dir);
  if (const auto size = args.value("frame-size")) {
    int w = 0, h = 0;
    char tail = 0;
    if (std::sscanf(size->c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w < 16 || h < 16 || w > 8192 || h > 8192)
      args.error("--frame-size " + *size + ": expected WxH, 16..8192 each");
    else
      cfg.frame_width = w, cfg.frame_height = h;
  }
  cfg.record_feedback = args.string("record-feedback", cfg.record_feedback);
  cfg.brdf_path = args.string("brdf", cfg.brdf_path);
  if (args.choice("profile", {"paper"})) cfg.profile = "paper";
  if (const auto bytes = args.byte_size("memory")) cfg.memory_bytes = *bytes;
  if (const auto n = args.optional_integer("size", 1, 4096)) cfg.size = static_cast<int>(*n), cfg.size_given = true;
  if (const auto n = args.optional_integer("frames", 0, 100000))
    cfg.frames = static_cast<int>(*n), cfg.frames_given = true;
  if (const auto n = args.optional_integer("materials", 1, 64))
    cfg.materials = static_cast<int>(*n), cfg.materials_given = true;
  cfg.settle = args.integer_as("settle", cfg.settle, 0, 100000);
  if (const auto b = args.choice("backend", {"gl", "cpu"})) cfg.backend = *b == 0 ? "gl" : "cpu";
  if (const auto n = args.optional_integer("bandwidth", 1, 1000000))  // KiB/s
    cfg.bandwidth_kib = static_cast<double>(*n), cfg.bandwidth_given = true;
  cfg.components = args.integer_as("components", cfg.components, 1, kMaxDemoComponents);
  if (const auto s = args.optional_number("rank-target", 0.0, 1.0)) cfg.rank_target = *s;  // 0: a fixed rank
  if (const auto n = args.optional_integer("seed", 0, 1ll << 62))
    cfg.seed = static_cast<uint64_t>(*n), cfg.seed_given = true;
  if (const auto v = args.value("value-encoding")) {
    ValueEncoding e = ValueEncoding::linear;
    if (parse_value_encoding(*v, e))
      cfg.value_encoding = e;
    else
      args.error("--value-encoding " + *v + ": expected linear, sqrt, log or log_ycbcr");
  }
  if (const auto v = args.value("material")) {
    if (const auto m = material_from_name(*v))
      cfg.material = *m;
    else
      args.error("--material " + *v + ": expected cloth, stone, leather or tiles");
  }
  if (!args.finish(0)) {
    std::fprintf(stderr, "%s\n", kDemoUsage);
    return std::nullopt;
  }
  if (cfg.out_dir.empty()) return fail("--out DIR is required");
  cfg.components_given = cfg.components != 0;
  if (cfg.components == 0) cfg.components = cfg.profile == "paper" ? 100 : kDefaultDemoComponents;
  if (cfg.profile == "paper" && cfg.rank_target > 0.0)
    return fail("--rank-target needs the default profile (the paper profile factorises out of core at a fixed C)");
  // --components alone fixes the rank; otherwise it bounds the chosen one.
  if (cfg.rank_target < 0.0)
    cfg.rank_target = cfg.profile == "paper" || cfg.components_given ? 0.0 : kDefaultDemoRankTarget;
  if (!cfg.inputs_dir.empty() && cfg.profile != "paper") return fail("--inputs needs --profile paper");
  if (cfg.profile == "paper") {
    if (!cfg.size_given) cfg.size = 64;
    if (!cfg.frames_given) cfg.frames = 24;
    if (!cfg.materials_given) cfg.materials = 3;
    if (!cfg.bandwidth_given) cfg.bandwidth_kib = 8192.0;
  } else if (cfg.size > 1024) {
    return fail("--size " + std::to_string(cfg.size) + ": expected 1..1024 (larger with --profile paper)");
  }
  return cfg;
}

}  // namespace btflod::demo
