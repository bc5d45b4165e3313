// btflod-convert build — an FMF factor file → the `.bsvtf` streaming container
// (docs/bsvtf_format.md): eigen-texture tile pyramid (offline/build/tile_pyramid.hpp), tiles coded coarse to
// fine as closed-loop residuals to their parents (runtime/codec/tile_codec.hpp), U in packets of 4.
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "command.hpp"
#include "common/bsvtf_input.hpp"
#include "common/progress_bar.hpp"

#include "btflod/core/file_io.hpp"
#include "btflod/core/half.hpp"
#include "btflod/offline/build/perceptual_tolerance.hpp"
#include "btflod/offline/build/tile_pyramid.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/fmf_stream.hpp"
#include "btflod/runtime/codec/container.hpp"

namespace {

using namespace btflod;

int run_build(convert::Options& opt) {
  const double quality = opt.number("quality", 50.0, 1.0, 100.0);
  const auto tile = static_cast<uint32_t>(opt.integer("tile", 64, 8, 1016));
  const auto border = static_cast<uint32_t>(opt.integer("border", 4, 1, 64));
  const bool per_component_flag = opt.flag("per-component");
  const std::string tolerance_name = opt.string("tolerance", per_component_flag ? "per-component" : "perceptual");
  const double exposure = opt.number("exposure", 1.0, 1e-6, 1e6);
  const bool perceptual = tolerance_name == "perceptual";
  const auto weight_quarters = static_cast<uint32_t>(
      opt.integer("weight-quarters", perceptual ? kPerceptualWeightQuarters : kJpegWeightQuarters, 0, 4));
  const bool wrap = opt.flag("wrap");
  const int deflate_level = static_cast<int>(opt.integer("deflate-level", 6, 0, 9));
  const bool deflate = opt.flag("deflate");
  const int zstd_level = static_cast<int>(opt.integer("zstd-level", 19, 1, 22));
  const bool quiet = opt.flag("quiet", 'q');
  if (!opt.finish()) return convert::kExitUsage;
  if (!perceptual && tolerance_name != "shared" && tolerance_name != "per-component") {
    std::fprintf(stderr, "btflod-convert build: --tolerance %s: expected perceptual, shared or per-component\n",
                 tolerance_name.c_str());
    return convert::kExitUsage;
  }
  if (opt.positional().size() != 2) {
    std::fprintf(stderr, "btflod-convert build: expected IN.fmf and OUT.bsvtf (got %zu arguments)\n",
                 opt.positional().size());
    return convert::kExitUsage;
  }
  if (!TileLayout{tile, border, 4}.valid()) {
    std::fprintf(stderr,
                 "btflod-convert build: --tile %u --border %u: T + 2B must be a multiple of 8 (T even, T >= 8)\n", tile,
                 border);
    return convert::kExitUsage;
  }
  const std::string in = opt.positional()[0], out = opt.positional()[1];
  const auto t0 = std::chrono::steady_clock::now();

  auto bytes = read_file_bytes(in);
  if (!bytes) {
    std::fprintf(stderr, "btflod-convert build: %s\n", bytes.message().c_str());
    return convert::kExitFailure;
  }
  auto fmf = Fmf::deserialize(*bytes);
  if (!fmf) {
    std::fprintf(stderr, "btflod-convert build: %s: %s\n", in.c_str(), fmf.message().c_str());
    return convert::kExitFailure;
  }
  const auto comps = static_cast<uint32_t>(fmf->components);
  const int w = fmf->shape.width, h = fmf->shape.height;

  // U stays in the FMF's view-major row order (eigen.row_order), which the metadata records.
  const EigenTextures eigen = eigen_textures_from_fmf(*fmf);
  auto pyramid = TilePyramid::build(eigen, tile, border, wrap ? TileEdge::wrap : TileEdge::clamp);
  if (!pyramid) {
    std::fprintf(stderr, "btflod-convert build: %s\n", pyramid.message().c_str());
    return convert::kExitFailure;
  }

  // The library's metadata for these eigen-textures (geometry, C, U's rows, the value encoding);
  // FMF rows are (view · n_light + light) · 3 + colour.
  const size_t slash = in.find_last_of('/');
  BsvtfMetadata md =
      bsvtf_metadata_for(eigen, *pyramid, direction_vectors(fmf->shape.lights), direction_vectors(fmf->shape.views),
                         slash == std::string::npos ? in : in.substr(slash + 1));
  md.light_set = fmf->shape.lights.name();
  md.view_set = fmf->shape.views.name();

  // Tiles (half texels from the pyramid, as float) with their eq. 8 weights.
  samples::BsvtfTileInputs inputs = samples::bsvtf_tiles_from_pyramid(*pyramid, md.level_count, tile, border);
  std::string tolerance_report = tolerance_name;
  if (perceptual) {
    PerceptualToleranceOptions po;
    po.exposure = {static_cast<float>(exposure), static_cast<float>(exposure), static_cast<float>(exposure)};
    po.row_order = AngularRowOrder::view_major;  // FMF rows: (view · n_light + light) · 3 + colour
    auto rep = perceptual_tolerance_scales(md, fmf->u, inputs.tiles, po);
    if (!rep) {
      std::fprintf(stderr, "btflod-convert build: %s\n", rep.message().c_str());
      return convert::kExitFailure;
    }
    char buf[160];
    std::snprintf(buf, sizeof buf, "perceptual (exposure %g, channel scales %.3g..%.3g of the shared tolerance)",
                  exposure, static_cast<double>(rep->min_channel_scale), static_cast<double>(rep->max_channel_scale));
    tolerance_report = buf;
  }

  samples::ProgressBar bar("build", stderr, !quiet);
  BsvtfBuildOptions options;
  options.quality = static_cast<float>(quality);
  options.deflate_level = deflate_level;
  if (deflate) options.entropy_coder = TileEntropyCoder::deflate;
  options.zstd_level = zstd_level;
  options.tolerance_reference =
      tolerance_name == "per-component" ? ToleranceReference::per_component : ToleranceReference::shared_max;
  options.weight_quarters = weight_quarters;
  options.progress = bar.callback();
  auto file = build_bsvtf(md, fmf->u, inputs.tiles, options);
  bar.finish();
  if (!file) {
    std::fprintf(stderr, "btflod-convert build: %s\n", file.message().c_str());
    return convert::kExitFailure;
  }
  if (auto s = write_file_bytes(out, *file); !s) {
    std::fprintf(stderr, "btflod-convert build: %s\n", s.message().c_str());
    return convert::kExitFailure;
  }
  const auto dir = read_bsvtf(*file);
  if (!dir) {  // never expected: the writer's output must read back
    std::fprintf(stderr, "btflod-convert build: written file does not read back: %s\n", dir.message().c_str());
    return convert::kExitFailure;
  }
  uint64_t tile_bytes = 0;
  for (const auto& e : dir->tiles) tile_bytes += e.size;
  const double raw =
      static_cast<double>(inputs.tiles.size()) * static_cast<double>(TileLayout{tile, border, 4}.sample_count()) * 2.0;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf(
      "%s: %dx%d, %u components, %u levels of %u+2x%u tiles -> %s: %zu bytes (%zu tiles, %llu tile bytes, %.2f:1 vs "
      "raw half tiles; directory %llu bytes; U %zu packets), quality %.0f, tolerances %s, weighting JPEG^(%u/4), "
      "%s tiles, %.2f s\n",
      in.c_str(), w, h, comps, md.level_count, tile, border, out.c_str(), file->size(), inputs.tiles.size(),
      static_cast<unsigned long long>(tile_bytes), raw / static_cast<double>(tile_bytes),
      static_cast<unsigned long long>(dir->header.directory_size), dir->packets.size(), quality,
      tolerance_report.c_str(), weight_quarters, options.entropy_coder == TileEntropyCoder::zstd ? "zstd" : "deflate",
      seconds);
  for (uint32_t l = 0; l < md.level_count; ++l)
    std::printf("  levels 0..%u: first %llu bytes\n", l, static_cast<unsigned long long>(dir->prefix_size(l)));
  return convert::kExitOk;
}

constexpr char kBuildUsage[] =
    "usage: btflod-convert build IN.fmf OUT.bsvtf [--quality Q] [--tile T] [--border B]\n"
    "                            [--tolerance perceptual|shared|per-component] [--exposure E]\n"
    "                            [--weight-quarters W] [--wrap] [--deflate [--deflate-level N]]\n"
    "                            [--zstd-level N] [--quiet]\n"
    "  IN is an FMF factor file (btflod-convert factor --method fmf).\n"
    "  --quality Q      1..100 (default 50): scales the block-RMS error tolerances like JPEG's\n"
    "                   quality (docs/bsvtf_format.md)\n"
    "  --tile T         interior texels per tile (default 64); --border B texels (default 4)\n"
    "  --tolerance      perceptual (default): every component of every tile gets an equal share\n"
    "                   of a CIELAB dE budget from its effect on the displayed colour\n"
    "                   (offline/build/perceptual_tolerance.hpp; quality 50 was invisible, p99 dE < 2.3,\n"
    "                   on the demo materials); shared: one tolerance from the largest component\n"
    "                   range (minimises the BTF's error); per-component: each range its own\n"
    "  --per-component  the same as --tolerance per-component\n"
    "  --exposure E     perceptual: display-linear value = E x BTF value, white = 1 (default 1)\n"
    "  --weight-quarters W  frequency weighting JPEG table^(W/4), 0..4 (default 1 with\n"
    "                   perceptual tolerances, else 4 = JPEG's table)\n"
    "  --wrap           the material repeats: outer tile borders wrap to the opposite edge\n"
    "                   (default: clamp; wrapped borders avoid a seam where uv repeats)\n"
    "  --deflate        entropy-code the tiles with deflate (tile format 2, the bytes of earlier\n"
    "                   versions, read by every client) instead of the default zstd (format 3:\n"
    "                   smaller tiles that decode faster; docs/bsvtf_format.md \"Entropy stage\")\n"
    "  --deflate-level  zlib level 0..9 (default 6)\n"
    "  --zstd-level     zstd level 1..22 (default 19)";

}  // namespace

BTFLOD_CONVERT_COMMAND(build, "code an FMF factor file into a .bsvtf streaming container (tiles, U packets, index)",
                       kBuildUsage, run_build);
