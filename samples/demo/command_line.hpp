// btflod-demo — command line: DemoConfig and its parser.
#pragma once

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <string_view>

#include "btflod/btf/heightfield.hpp"

namespace btflod::demo {

struct DemoConfig {
  std::string out_dir;                            ///< --out DIR (required)
  int size = 16;                                  ///< --size N texels (square)
  int frames = 8;                                 ///< --frames N headless frames
  SynthMaterial material = SynthMaterial::cloth;  ///< --material NAME
  uint64_t seed = 1;                              ///< --seed N
  int components = 32;                            ///< --components K (DFMF, per channel)
  bool interreflection = false;                   ///< --interreflection
  bool quiet = false;                             ///< --quiet: no progress bars
};

inline constexpr const char* kDemoUsage =
    "usage: btflod-demo --out DIR [--size N] [--frames N] [--material cloth|stone|leather|tiles]\n"
    "                   [--seed N] [--components K] [--interreflection] [--quiet]\n"
    "  Synthesises a small BTF (UBO2003 81 x 81 directions), writes it as a Bonn DFMF file, reads\n"
    "  it back, prints a summary (shape, directions, value range, read-back error) and writes\n"
    "  DIR/contact_sheet.png and N frames DIR/frames/frame_NNNN.png.\n"
    "  defaults: --size 16 --frames 8 --material cloth --seed 1 --components 32";

/// Parses argv. Returns the config, or nullopt after printing the problem (or the usage for
/// --help, with *exit_code = 0; otherwise 2).
inline std::optional<DemoConfig> parse_command_line(int argc, char** argv, int* exit_code) {
  DemoConfig cfg;
  *exit_code = 2;
  auto fail = [&](const std::string& msg) -> std::optional<DemoConfig> {
    std::fprintf(stderr, "btflod-demo: %s\n%s\n", msg.c_str(), kDemoUsage);
    return std::nullopt;
  };
  auto parse_int = [](const char* s, long long lo, long long hi, long long* out) {
    errno = 0;
    char* end = nullptr;
    const long long v = std::strtoll(s, &end, 10);
    if (errno != 0 || end == s || *end != '\0' || v < lo || v > hi) return false;
    *out = v;
    return true;
  };
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    if (a == "--help" || a == "-h") {
      std::puts(kDemoUsage);
      *exit_code = 0;
      return std::nullopt;
    }
    if (a == "--interreflection") {
      cfg.interreflection = true;
      continue;
    }
    if (a == "--quiet" || a == "-q") {
      cfg.quiet = true;
      continue;
    }
    if (i + 1 >= argc) return fail("option " + std::string(a) + " needs a value (or is unknown)");
    const char* value = argv[++i];
    long long n = 0;
    if (a == "--out") {
      cfg.out_dir = value;
    } else if (a == "--size") {
      if (!parse_int(value, 1, 1024, &n)) return fail("--size " + std::string(value) + ": expected 1..1024");
      cfg.size = static_cast<int>(n);
    } else if (a == "--frames") {
      if (!parse_int(value, 0, 100000, &n)) return fail("--frames " + std::string(value) + ": expected 0..100000");
      cfg.frames = static_cast<int>(n);
    } else if (a == "--components") {
      if (!parse_int(value, 1, 4096, &n)) return fail("--components " + std::string(value) + ": expected 1..4096");
      cfg.components = static_cast<int>(n);
    } else if (a == "--seed") {
      if (!parse_int(value, 0, (1ll << 62), &n)) return fail("--seed " + std::string(value) + ": expected >= 0");
      cfg.seed = static_cast<uint64_t>(n);
    } else if (a == "--material") {
      auto m = material_from_name(value);
      if (!m) return fail("--material " + std::string(value) + ": expected cloth, stone, leather or tiles");
      cfg.material = *m;
    } else {
      return fail("unknown option " + std::string(a));
    }
  }
  if (cfg.out_dir.empty()) return fail("--out DIR is required");
  return cfg;
}

}  // namespace btflod::demo
