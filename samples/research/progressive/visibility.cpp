// btflod-visibility — is the tile codec's loss visible in rendered images? The target:
// "compression at least 1.3× paper 000's 6:1 at a quality where the rendered difference is
// invisible (state the PSNR)".
//
// The demo's materials (synthesised, FMF-factorised: samples/demo/materials.hpp) and scene are
// rendered by the CPU reference (scene_render.hpp, the renderer of btflod-progressive) twice per
// view: from the UNCOMPRESSED eigen-texture tiles of the tile pyramid (wrapped borders, as the
// containers are built) and from the tiles of a .bsvtf built at quality Q and decoded coarse to
// fine (closed loop). Both renders use every tile (the converged state), the same per-pixel
// level (feedback pass, eq. 1) and the same float U, so the only difference is the codec. Both
// are tone-mapped as the demo writes its frames: linear radiance clamped to [0, 1], sRGB-encoded
// to 8 bits (offline/btf/image_io.hpp linear_to_srgb8_image). Per quality and material (its pixels over
// all views) it reports:
//   ratio      raw half-float tiles / coded tile payloads (as `btflod-convert info` prints), and
//              the whole container file against raw halves of its tiles and U;
//   BTF PSNR   20 log10(peak / RMSE) of the BTF reconstructed at the finest level, from the
//              eigen-texture error (U has orthonormal columns: a texel's squared BTF error over
//              its m rows is Σ_c e_c²); peak = the largest reconstructed BTF value;
//   image      PSNR of the 8-bit images (peak 255), SSIM (Wang 2004, mean of the RGB maps over
//              the material's pixels), CIELAB ΔE*ab (CIE76, D65, from the 8-bit values decoded
//              back to linear) mean and 99th percentile, and the fraction of pixels whose 8-bit
//              value differs in any channel.
// Visibility criterion (stated, --max-p99-de, default 2.3): the 99th percentile of ΔE*ab below
// 2.3, the just-noticeable difference commonly cited after Sharma (Digital Color Imaging
// Handbook, 2003; Mahy et al. 1994): 99 % of the pixels differ by less than one JND. A stricter
// column (p99 < 1.0) is reported beside it. The report names, per material, the highest tile
// compression ratio that meets the criterion, and the highest ratio that meets it on at least
// two materials.
//
// Usage: btflod-visibility --out DIR [--qualities 5,10,25,50] [--materials N] [--components C]
//            [--size N] [--repeat R] [--tile T] [--width W] [--height H] [--views V]
//            [--default-quality] [--per-component-tolerance] [--luminance-tolerance] [--perceptual]
//            [--weight-quarters Q] [--scene-directions N [--scene-prior P]] [--deflate | --zstd] [--rendered]
//            [--dead-zone T]
//            [--luminance-percentile P] [--luminance-floor F] [--max-p99-de X] [--check]
//            [--doc docs/codec_measurements.md]
//   --per-component-tolerance  build with ToleranceReference::per_component (default shared_max)
//   --luminance-tolerance  also scale each tile's tolerance by (max(y_tile, F·y_peak)/y_peak)^(2/3)
//                      (samples/common/bsvtf_input.hpp apply_luminance_tolerance; y_tile = the
//                      P-quantile of |v_0| over the tile, defaults P = 0.1, F = 0.05)
//   --luminance-white W  display-referred variant (implies --luminance-tolerance): the absolute
//                      tolerance follows (Y/W)^(2/3) relative to the display white W, the same for
//                      every material (the images are clamped to [0, 1]: W = 1)
//   --luminance-as-floor  use the luminance tolerance as a floor under the reference's own
//                      (BsvtfTileInput::tolerance_min_scale; with --per-component-tolerance:
//                      max(per-component tolerance, display-referred tolerance))
//   --perceptual       perceptual tolerances (offline/build/perceptual_tolerance.hpp
//                      perceptual_tolerance_scales, exposure = the scene's sun colour): each
//                      component of each tile gets an equal share of a ΔE*ab budget;
//                      --dark-floor F, --reference-de E, --gain-power P, --direction-samples N,
//                      --light-cos-power / --view-cos-power X tune it (library defaults otherwise)
//   --scene-directions N  (with --perceptual) direction weights from the pixels of N training
//                      views of the camera path (t = (2j+1)/2N, never the evaluation views);
//                      --scene-prior P mixes the cosine model under them with share P in [0, 1)
//                      (ViewingConditions::direction_prior)
//   --weight-quarters Q  frequency weighting JPEG table^(Q/4) (0..4; default 1 with --perceptual
//                      as btflod-convert build, else 4; BsvtfBuildOptions::weight_quarters)
//   --default-quality  measure only BsvtfBuildOptions' default quality (btflod-convert build's too)
//   --deflate          entropy-code the tiles with deflate (tile format 2) instead of the default
//                      zstd (format 3; --zstd says so explicitly; BsvtfBuildOptions::entropy_coder)
//   --rendered         (implies --perceptual) build with build_bsvtf_rendered
//                      (samples/research/progressive/rendered_rate_control.hpp): every tile position's tolerances
//                      rescaled until its texture-space p99 ΔE*ab is the target at the quality;
//                      --rendered-target X (at quality 50), --rendered-quantile Q,
//                      --rendered-passes N, --rendered-footprint F tune it; with --scene-directions the error is
//                      measured under the training views' direction histogram
//   --dead-zone T      AC rounding threshold T in [0.5, 1) (BsvtfBuildOptions::ac_rounding_threshold)
//   --level-scale S    level l's tolerances × S^(l − finest level) (S > 1: coarser levels finer)
//   --check            exit 1 unless every listed quality meets the criterion on every material.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "btflod/offline/btf/image_io.hpp"
#include "btflod/offline/build/perceptual_tolerance.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"
#include "common/arguments.hpp"
#include "common/bsvtf_input.hpp"
#include "common/doc_block.hpp"
#include "rendered_rate_control.hpp"
#include "scene_render.hpp"

using namespace btflod;
using namespace btflod::progressive;

namespace {

struct Options : SceneOptions {
  std::vector<float> qualities{5, 10, 15, 25, 35, 50, 75};
  double max_p99_de = 2.3;
  ToleranceReference tolerance = ToleranceReference::shared_max;
  bool luminance = false;
  float luminance_percentile = 0.1f;
  float luminance_floor = 0.05f;
  float luminance_white = 0.0f;     // > 0: display-referred variant
  bool luminance_as_floor = false;  // --luminance-as-floor
  bool perceptual = false;          // --perceptual: perceptual_tolerance_scales
  PerceptualToleranceOptions perceptual_options;
  uint32_t weight_quarters = 99;       // --weight-quarters (JPEG table exponent × 4); 99: 1 with --perceptual, else 4
  uint32_t scene_direction_views = 0;  // > 0: direction weights from that many training views
  bool rendered = false;               // --rendered: build_bsvtf_rendered (implies --perceptual)
  float ac_rounding = 0.5f;            // --dead-zone: BsvtfBuildOptions::ac_rounding_threshold
  float level_scale = 1.0f;            // --level-scale S: level l's tolerances × S^(l − finest level)
  RenderedRateOptions rendered_options;
  bool check = false;
  std::string doc;
  Options() {
    materials = 4;
    components = 16;
    size = 64;
    repeat = 4;
    tile_size = 64;
    quality = 50;
    // 768×432: every level of the 3-level pyramid covers a good share of the pixels (at 256×144
    // the finest level is hardly shown, so its loss would barely count).
    width = 768;
    height = 432;
  }
};

uint32_t bo_weight_quarters(const Options& o) {
  return o.weight_quarters <= kJpegWeightQuarters ? o.weight_quarters
         : o.perceptual                           ? kPerceptualWeightQuarters
                                                  : kJpegWeightQuarters;
}

bool parse(int argc, char** argv, Options& o) {
  samples::Arguments args("btflod-visibility", argc, argv);
  // A number option that, when given, also turns on the mode it tunes (`*mode = true`).
  const auto tune = [&](std::string_view name, float& out, double lo, double hi, bool* mode, bool* mode2 = nullptr) {
    if (const auto x = args.optional_number(name, lo, hi)) {
      out = static_cast<float>(*x);
      if (mode) *mode = true;
      if (mode2) *mode2 = true;
    }
  };
  const auto tune_u32 = [&](std::string_view name, uint32_t& out, long long lo, long long hi, bool* mode,
                            bool* mode2 = nullptr) {
    if (const auto x = args.optional_integer(name, lo, hi)) {
      out = static_cast<uint32_t>(*x);
      if (mode) *mode = true;
      if (mode2) *mode2 = true;
    }
  };
  constexpr double kBelowOne = 0.99999999, kPositive = 1e-12, kLarge = 999999.0;
  o.out = args.string("out", o.out);
  o.doc = args.string("doc", o.doc);
  o.check = args.flag("check");
  if (args.flag("default-quality")) o.qualities = {BsvtfBuildOptions{}.quality};  // what build_bsvtf and the CLI use
  o.materials = args.integer_as("materials", o.materials, 2, 4);
  o.components = args.integer_as("components", o.components, 4, 32);
  o.size = args.integer_as("size", o.size, 8, 128);
  o.repeat = args.integer_as("repeat", o.repeat, 1, 32);
  o.tile_size = args.integer_as("tile", o.tile_size, 8, 256);
  o.width = args.integer_as("width", o.width, 16, 1920);
  o.height = args.integer_as("height", o.height, 16, 1080);
  o.views = args.integer_as("views", o.views, 1, 8);
  if (args.flag("per-component-tolerance")) o.tolerance = ToleranceReference::per_component;
  if (args.flag("luminance-as-floor")) o.luminance_as_floor = o.luminance = true;
  if (args.flag("luminance-tolerance")) o.luminance = true;
  if (args.flag("perceptual")) o.perceptual = true;
  tune("reference-de", o.perceptual_options.reference_delta_e, 0.0, kLarge, &o.perceptual);
  tune("dark-floor", o.perceptual_options.dark_floor, 0.0, kLarge, &o.perceptual);
  tune("light-cos-power", o.perceptual_options.light_cosine_power, 0.0, 64.0, &o.perceptual);
  tune("view-cos-power", o.perceptual_options.view_cosine_power, 0.0, 64.0, &o.perceptual);
  tune("gain-power", o.perceptual_options.gain_power, 0.125, 64.0, &o.perceptual);
  o.weight_quarters = args.integer_as("weight-quarters", o.weight_quarters, 0, 4);
  if (args.flag("zstd")) o.entropy_coder = TileEntropyCoder::zstd;
  if (args.flag("deflate")) o.entropy_coder = TileEntropyCoder::deflate;
  tune("dead-zone", o.ac_rounding, 0.5, kBelowOne, nullptr);
  tune("level-scale", o.level_scale, kPositive, 15.999999, nullptr);
  if (args.flag("rendered")) o.rendered = o.perceptual = true;
  tune_u32("rendered-footprint", o.rendered_options.error.texel_footprint, 1, 5, &o.rendered, &o.perceptual);
  tune_u32("rendered-passes", o.rendered_options.passes, 0, 16, &o.rendered, &o.perceptual);
  tune("rendered-target", o.rendered_options.target_at_quality50, kPositive, kLarge, &o.rendered, &o.perceptual);
  tune("rendered-quantile", o.rendered_options.error.quantile, kPositive, 1.0, &o.rendered, &o.perceptual);
  tune_u32("scene-directions", o.scene_direction_views, 1, 64, &o.perceptual);
  if (const auto x = args.optional_number("scene-prior", 0.0, kBelowOne))
    o.perceptual_options.direction_prior = o.rendered_options.error.direction_prior = static_cast<float>(*x);
  tune_u32("direction-samples", o.perceptual_options.direction_samples, 1, 1 << 20, &o.perceptual);
  tune("luminance-white", o.luminance_white, kPositive, kLarge, &o.luminance);
  tune("luminance-percentile", o.luminance_percentile, 0.0, 1.0, nullptr);
  tune("luminance-floor", o.luminance_floor, kPositive, 1.0, nullptr);
  if (const auto x = args.optional_number("max-p99-de", kPositive, 1e300)) o.max_p99_de = *x;
  if (const auto qualities = args.list("qualities")) {
    o.qualities.clear();
    for (const std::string& item : *qualities) {
      char* end = nullptr;
      const double q = std::strtod(item.c_str(), &end);
      if (*end != '\0' || !(q >= 1 && q <= 100)) args.error("--qualities " + item + ": expected numbers in [1, 100]");
      o.qualities.push_back(static_cast<float>(q));
    }
  }
  if (!args.finish(0)) return false;
  if (o.out.empty()) {
    std::fprintf(stderr, "btflod-visibility: --out DIR is required\n");
    return false;
  }
  if (o.perceptual_options.direction_prior > 0.0f && o.scene_direction_views == 0) {
    std::fprintf(stderr,
                 "btflod-visibility: --scene-prior needs --scene-directions (it mixes under their histogram)\n");
    return false;
  }
  return true;
}

// The uncompressed tiles of one material, the codec's inputs.
struct Reference {
  TilePyramid pyramid;  // wrapped borders, as prepare_material builds the container
  samples::BsvtfTileInputs inputs;
  std::vector<std::vector<std::vector<float>>> tiles;  // [k][flat]
  double btf_peak = 0;
};

Result<Reference> make_reference(const Material& m, uint32_t base_size) {
  const BsvtfMetadata& md = m.dir.metadata;
  auto pyr = TilePyramid::build(m.demo.eigen, md.tile_size, md.border, TileEdge::wrap);
  if (!pyr) return pyr.error();
  Reference r;
  r.pyramid = std::move(*pyr);
  r.inputs = samples::bsvtf_tiles_from_pyramid(r.pyramid, md.level_count, md.tile_size, md.border);
  const VtLevelTable& lv = m.pyramid.levels();
  r.tiles.assign(md.texture_count(), std::vector<std::vector<float>>(lv.tile_count()));
  for (const BsvtfTileInput& t : r.inputs.tiles)
    r.tiles[t.id.texture][lv.index(t.id.level, t.id.x, t.id.y)].assign(t.samples.begin(), t.samples.end());
  // BTF peak: the largest U·v over the material's base_size² texels (the virtual texture repeats them).
  const uint32_t C = m.demo.components;
  const size_t rows = m.demo.u.size() / C;
  const Image<float>& e = m.demo.eigen_textures;
  const int n = static_cast<int>(std::min<uint32_t>(base_size, static_cast<uint32_t>(std::min(e.width(), e.height()))));
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      for (size_t row = 0; row < rows; ++row) {
        double s = 0;
        for (uint32_t c = 0; c < C; ++c)
          s += static_cast<double>(m.demo.u[row * C + c]) * e.at(x, y, static_cast<int>(c));
        r.btf_peak = std::max(r.btf_peak, s);
      }
  return r;
}

struct Stats {  // one (quality, material)
  double ratio_tiles = 0, ratio_file = 0, btf_psnr = 0;
  double psnr = 0, ssim = 0, de_mean = 0, de_p99 = 0, changed = 0;
  size_t pixels = 0;
};

// Accumulates image statistics of one material over several views.
struct Accumulator {
  double se = 0, ssim = 0;
  size_t samples = 0, ssim_count = 0, pixels = 0, changed = 0;
  std::vector<double> de;

  void add(const Image<uint8_t>& a, const Image<uint8_t>& b, const std::vector<Pixel>& px, uint32_t material) {
    const float* lin = srgb8_to_linear_table();
    const int w = a.width(), h = a.height();
    Image<float> fa(w, h, 3), fb(w, h, 3);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          fa.at(x, y, c) = a.at(x, y, c) / 255.0f;
          fb.at(x, y, c) = b.at(x, y, c) / 255.0f;
        }
    const auto mine = [&](int x, int y) {
      const Pixel& p = px[static_cast<size_t>(y) * w + x];
      return p.hit && p.material == material;
    };
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        if (!mine(x, y)) continue;
        ++pixels;
        bool diff = false;
        for (int c = 0; c < 3; ++c) {
          const double d = static_cast<double>(a.at(x, y, c)) - b.at(x, y, c);
          se += d * d;
          diff = diff || d != 0;
        }
        samples += 3;
        changed += diff ? 1 : 0;
        const auto la = linear_srgb_to_lab(lin[a.at(x, y, 0)], lin[a.at(x, y, 1)], lin[a.at(x, y, 2)]);
        const auto lb = linear_srgb_to_lab(lin[b.at(x, y, 0)], lin[b.at(x, y, 1)], lin[b.at(x, y, 2)]);
        de.push_back(std::sqrt((la[0] - lb[0]) * (la[0] - lb[0]) + (la[1] - lb[1]) * (la[1] - lb[1]) +
                               (la[2] - lb[2]) * (la[2] - lb[2])));
      }
    // SSIM maps cover the pixels whose whole window lies inside the image (centre at +r).
    const SsimOptions so;
    const int r = std::max(0, std::min({so.radius, (w - 1) / 2, (h - 1) / 2}));
    for (int c = 0; c < 3; ++c) {
      int mw = 0;
      const std::vector<double> map = ssim_map(fa.view(), fb.view(), c, so, &mw);
      for (size_t i = 0; i < map.size(); ++i) {
        const int x = static_cast<int>(i % static_cast<size_t>(mw)) + r,
                  y = static_cast<int>(i / static_cast<size_t>(mw)) + r;
        if (!mine(x, y)) continue;
        ssim += map[i];
        ++ssim_count;
      }
    }
  }

  void finish(Stats& s) {
    s.pixels = pixels;
    const double mse = samples ? se / static_cast<double>(samples) : 0;
    s.psnr = mse > 0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : INFINITY;
    s.ssim = ssim_count ? ssim / static_cast<double>(ssim_count) : 1.0;
    s.changed = pixels ? static_cast<double>(changed) / static_cast<double>(pixels) : 0;
    double sum = 0;
    for (double d : de) sum += d;
    s.de_mean = de.empty() ? 0 : sum / static_cast<double>(de.size());
    if (!de.empty()) {
      const size_t k =
          std::min(de.size() - 1, static_cast<size_t>(std::ceil(0.99 * static_cast<double>(de.size()))) - 1);
      std::nth_element(de.begin(), de.begin() + static_cast<std::ptrdiff_t>(k), de.end());
      s.de_p99 = de[k];
    }
  }
};

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, o)) return 2;
  const samples::MeasuredRun run("btflod-visibility", argc, argv, o.out);
  World w(o);
  if (auto e = w.init(); !e) {
    std::fprintf(stderr, "btflod-visibility: %s\n", e.message().c_str());
    return 1;
  }
  std::vector<Reference> refs;
  std::vector<std::vector<float>> scene_hist(w.materials.size());  // --scene-directions histograms
  std::ostringstream luminance_scales;
  for (const Material& m : w.materials) {
    auto r = make_reference(m, o.size);
    if (!r) {
      std::fprintf(stderr, "btflod-visibility: %s\n", r.message().c_str());
      return 1;
    }
    if (o.luminance) {
      samples::apply_luminance_tolerance(r->inputs, m.dir.metadata.tile_size, m.dir.metadata.border,
                                         o.luminance_percentile, o.luminance_floor, m.demo.u, m.demo.components,
                                         o.luminance_white);
      if (o.luminance_as_floor)  // the luminance tolerance as a floor under the reference's
        for (BsvtfTileInput& t : r->inputs.tiles) t.tolerance_min_scale = t.tolerance_scale, t.tolerance_scale = 1.0f;
      float lo = 1e30f, hi = 0.0f;
      for (const BsvtfTileInput& t : r->inputs.tiles) {
        const float x = o.luminance_as_floor ? t.tolerance_min_scale : t.tolerance_scale;
        lo = std::min(lo, x), hi = std::max(hi, x);
      }
      std::printf("%s: luminance tolerance scales %.3f .. %.3f\n", m.demo.name.c_str(), static_cast<double>(lo),
                  static_cast<double>(hi));
      luminance_scales << " " << m.demo.name << " " << fmt("%.3f", lo) << (lo == hi ? "" : "–" + fmt("%.3f", hi))
                       << ";";
    }
    if (o.perceptual) {
      PerceptualToleranceOptions po = o.perceptual_options;
      po.exposure = {w.light_color.r, w.light_color.g, w.light_color.b};  // the scene's sun, clamped at 1
      std::vector<float> hist;
      if (o.scene_direction_views > 0) {
        // Training views t = (2j + 1) / 2N on the camera path: never the evaluation views
        // (t = 0, 1/2, 1 for 3 views; N even keeps 1/2 out).
        const uint32_t n = o.scene_direction_views;
        hist.assign(size_t{m.demo.light_count} * m.demo.view_count, 0.0f);
        const uint32_t mi = static_cast<uint32_t>(&m - w.materials.data());
        for (uint32_t j = 0; j < n; ++j) {
          const Camera cam = scene::to_camera(scene::camera_path(2 * j + 1, 2 * n + 1, o.width, o.height));
          for (const Pixel& p : prepare_view(w, cam))
            if (p.hit && p.material == mi) accumulate_direction_weights(p.light, p.view, m.demo.view_count, hist);
        }
        po.direction_weights = hist;
        scene_hist[mi] = hist;  // --rendered measures its error under the same directions
      }
      BsvtfMetadata md = m.dir.metadata;
      md.component_ranges.clear();  // the ranges build_bsvtf will use (from the tiles)
      auto rep = perceptual_tolerance_scales(md, m.demo.u, r->inputs.tiles, po);
      if (!rep) {
        std::fprintf(stderr, "btflod-visibility: %s\n", rep.message().c_str());
        return 1;
      }
      std::printf("%s: perceptual channel scales %.4f .. %.4f (R = %.3g); gains", m.demo.name.c_str(),
                  static_cast<double>(rep->min_channel_scale), static_cast<double>(rep->max_channel_scale),
                  static_cast<double>(rep->largest_range));
      for (float gc : rep->component_gain) std::printf(" %.3g", static_cast<double>(gc));
      std::printf("\n");
      luminance_scales << " " << m.demo.name << " " << fmt("%.4f", rep->min_channel_scale) << "–"
                       << fmt("%.4f", rep->max_channel_scale) << ";";
    }
    if (o.level_scale != 1.0f)  // --level-scale S: level l's tolerances × S^(l − finest level)
      for (BsvtfTileInput& t : r->inputs.tiles)
        t.tolerance_scale *=
            std::pow(o.level_scale, static_cast<float>(t.id.level) - (m.dir.metadata.level_count - 1.0f));
    refs.push_back(std::move(*r));
  }
  std::vector<Camera> cams;
  std::vector<std::vector<Pixel>> pxs;
  for (uint32_t v = 0; v < o.views; ++v) {
    cams.push_back(w.camera(v));
    pxs.push_back(prepare_view(w, cams.back()));
  }
  const ClientState all(w, true);
  const auto render_all = [&] {
    std::vector<Image<uint8_t>> out;
    for (uint32_t v = 0; v < o.views; ++v) out.push_back(linear_to_srgb8_image(render(w, cams[v], pxs[v], all).view()));
    return out;
  };
  for (size_t mi = 0; mi < w.materials.size(); ++mi) w.materials[mi].decoded = refs[mi].tiles;
  const std::vector<Image<uint8_t>> reference = render_all();
  if (auto wr = write_png_srgb((std::filesystem::path(o.out) / "visibility_reference_view0.png").string(),
                               srgb8_to_linear_image(reference[0].view()).view());
      !wr)
    std::fprintf(stderr, "btflod-visibility: %s\n", wr.message().c_str());

  const Material& m0 = w.materials.front();
  std::printf(
      "btflod visibility: %u materials, %ux%u texels, C = %u, T = %u, B = %u, %u levels; %u views of %ux%u; "
      "criterion: p99 dE*ab < %.2f\n",
      o.materials, m0.pyramid.geometry().width, m0.pyramid.geometry().height, o.components, m0.dir.metadata.tile_size,
      m0.dir.metadata.border, m0.dir.metadata.level_count, o.views, o.width, o.height, o.max_p99_de);
  std::ostringstream peaks;
  peaks << "BTF peaks (the PSNR reference):";
  for (size_t mi = 0; mi < w.materials.size(); ++mi)
    peaks << " " << w.materials[mi].demo.name << " " << fmt("%.3g", refs[mi].btf_peak)
          << (mi + 1 < w.materials.size() ? "," : ".");
  std::printf("%s\n", peaks.str().c_str());
  std::ostringstream table;
  table << "| quality | material | tile ratio | file ratio | BTF PSNR | image PSNR | SSIM | ΔE*ab mean | ΔE*ab p99 | "
           "pixels changed | "
           "p99 < 1 | criterion |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  std::printf("%7s %-10s %9s %9s %9s %10s %8s %8s %8s %8s %s\n", "quality", "material", "tiles", "file", "BTF PSNR",
              "img PSNR", "SSIM", "dE mean", "dE p99", "changed", "invisible");
  bool check_ok = true;
  std::vector<double> best(w.materials.size(), 0.0);  // highest passing tile ratio per material
  std::vector<float> best_q(w.materials.size(), 0.0f);
  std::vector<std::vector<std::pair<double, bool>>> per_q;  // [q][material] (ratio, pass)
  for (float q : o.qualities) {
    std::vector<Stats> stats(w.materials.size());
    for (size_t mi = 0; mi < w.materials.size(); ++mi) {
      Material& m = w.materials[mi];
      const Reference& ref = refs[mi];
      BsvtfBuildOptions bo;
      bo.quality = q;
      bo.tolerance_reference = o.tolerance;
      bo.weight_quarters = bo_weight_quarters(o);
      bo.entropy_coder = o.entropy_coder;
      bo.ac_rounding_threshold = o.ac_rounding;
      RenderedRateReport rr;
      RenderedRateOptions ro = o.rendered_options;
      ro.error.exposure = {w.light_color.r, w.light_color.g, w.light_color.b};
      if (!scene_hist[mi].empty()) ro.error.direction_weights = scene_hist[mi];
      auto file = o.rendered ? build_bsvtf_rendered(m.dir.metadata, m.demo.u, ref.inputs.tiles, bo, ro, &rr)
                             : build_bsvtf(m.dir.metadata, m.demo.u, ref.inputs.tiles, bo);
      if (o.rendered && file) {
        std::printf("  %s q%.0f: rendered p%.0f target %.3f; per pass max/min", m.demo.name.c_str(),
                    static_cast<double>(q), 100.0 * ro.error.quantile, static_cast<double>(rr.target));
        for (size_t pi = 0; pi < rr.pass_max.size(); ++pi)
          std::printf(" %.3f/%.3f", static_cast<double>(rr.pass_max[pi]), static_cast<double>(rr.pass_min[pi]));
        std::printf("; scales %.3f..%.3f", static_cast<double>(rr.min_scale), static_cast<double>(rr.max_scale));
        // RenderedRateReport::block_spread: what a per-block step could gain.
        size_t blocks = 0;
        for (size_t n : rr.block_spread) blocks += n;
        std::printf("; blocks by tile p99 / block p99:");
        for (size_t k = 0; k < rr.block_spread.size(); ++k)
          std::printf(" %s%.3g %.1f%%", k < kRenderedBlockSpreadEdges.size() ? "<" : ">=",
                      static_cast<double>(kRenderedBlockSpreadEdges[std::min(k, kRenderedBlockSpreadEdges.size() - 1)]),
                      blocks ? 100.0 * static_cast<double>(rr.block_spread[k]) / static_cast<double>(blocks) : 0.0);
        std::printf("\n");
      }
      if (!file) {
        std::fprintf(stderr, "btflod-visibility: %s\n", file.message().c_str());
        return 1;
      }
      auto dir = read_bsvtf(*file);
      if (!dir) {
        std::fprintf(stderr, "btflod-visibility: %s\n", dir.message().c_str());
        return 1;
      }
      if (auto d = decode_tiles(m, *file, *dir); !d) {
        std::fprintf(stderr, "btflod-visibility: %s\n", d.message().c_str());
        return 1;
      }
      Stats& s = stats[mi];
      uint64_t tile_bytes = 0, tiles = 0;
      for (const auto& e : dir->tiles) tile_bytes += e.size, ++tiles;
      const double raw_tiles = static_cast<double>(tiles * m.pyramid.tile_bytes());
      s.ratio_tiles = raw_tiles / static_cast<double>(tile_bytes);
      s.ratio_file = (raw_tiles + 2.0 * static_cast<double>(m.demo.u.size())) / static_cast<double>(file->size());
      // BTF error at the finest level, interior texels only (each texel once).
      const BsvtfMetadata& md = dir->metadata;
      const VtLevelTable& lv = m.pyramid.levels();
      const uint32_t fl = md.level_count - 1, S = md.layout().stored_size(), B = md.border, T = md.tile_size;
      double se = 0;
      size_t texels = 0;
      for (uint32_t k = 0; k < md.texture_count(); ++k)
        for (uint32_t ty = 0; ty < lv.tiles_y[fl]; ++ty)
          for (uint32_t tx = 0; tx < lv.tiles_x[fl]; ++tx) {
            const uint32_t flat = lv.index(fl, tx, ty);
            const std::vector<float>& a = ref.tiles[k][flat];
            const std::vector<float>& b = m.decoded[k][flat];
            for (uint32_t y = B; y < B + T; ++y)
              for (uint32_t x = B; x < B + T; ++x) {
                for (uint32_t c = 0; c < 4; ++c) {
                  const double d = static_cast<double>(a[(y * S + x) * 4 + c]) - b[(y * S + x) * 4 + c];
                  se += d * d;
                }
                if (k == 0) ++texels;
              }
          }
      const double rmse_btf = std::sqrt(se / (static_cast<double>(texels) * static_cast<double>(md.u_rows)));
      s.btf_psnr = 20.0 * std::log10(ref.btf_peak / rmse_btf);
    }
    const std::vector<Image<uint8_t>> coded = render_all();
    per_q.emplace_back();
    for (size_t mi = 0; mi < w.materials.size(); ++mi) {
      Accumulator acc;
      for (uint32_t v = 0; v < o.views; ++v) acc.add(reference[v], coded[v], pxs[v], static_cast<uint32_t>(mi));
      Stats& s = stats[mi];
      acc.finish(s);
      const bool pass = s.pixels > 0 && s.de_p99 < o.max_p99_de;
      per_q.back().push_back({s.ratio_tiles, pass});
      if (pass && s.ratio_tiles > best[mi]) best[mi] = s.ratio_tiles, best_q[mi] = q;
      if (!pass) check_ok = false;
      const std::string& name = w.materials[mi].demo.name;
      std::printf("%7.0f %-10s %8.2f:1 %8.2f:1 %6.1f dB %7.1f dB %8.5f %8.3f %8.3f %7.2f%% %s (%zu px)\n",
                  static_cast<double>(q), name.c_str(), s.ratio_tiles, s.ratio_file, s.btf_psnr, s.psnr, s.ssim,
                  s.de_mean, s.de_p99, 100.0 * s.changed, pass ? "yes" : "NO", s.pixels);
      table << "| " << fmt("%.0f", q) << " | " << name << " | " << fmt("%.2f:1", s.ratio_tiles) << " | "
            << fmt("%.2f:1", s.ratio_file) << " | " << fmt("%.1f dB", s.btf_psnr) << " | " << fmt("%.1f dB", s.psnr)
            << " | " << fmt("%.5f", s.ssim) << " | " << fmt("%.3f", s.de_mean) << " | " << fmt("%.3f", s.de_p99)
            << " | " << fmt("%.2f %%", 100.0 * s.changed) << " | " << (s.de_p99 < 1.0 ? "yes" : "no") << " | "
            << (pass ? "**yes**" : "no") << " |\n";
    }
  }
  // The highest ratio that meets the criterion on at least two materials: for each quality that
  // passes on ≥ 2 materials, the second-best passing ratio at it (both of those materials reach it).
  double two = 0, every = 0;  // every: the lowest ratio at a quality that passes on every material
  float two_q = 0, every_q = 0;
  for (size_t qi = 0; qi < per_q.size(); ++qi) {
    std::vector<double> passing;
    for (const auto& [ratio, pass] : per_q[qi])
      if (pass) passing.push_back(ratio);
    if (passing.size() == per_q[qi].size() && *std::min_element(passing.begin(), passing.end()) > every)
      every = *std::min_element(passing.begin(), passing.end()), every_q = o.qualities[qi];
    if (passing.size() < 2) continue;
    std::sort(passing.rbegin(), passing.rend());
    if (passing[1] > two) two = passing[1], two_q = o.qualities[qi];
  }
  std::ostringstream summary;
  summary << "Highest tile ratio with p99 ΔE*ab < " << fmt("%.2f", o.max_p99_de) << ":";
  for (size_t mi = 0; mi < w.materials.size(); ++mi)
    summary << " " << w.materials[mi].demo.name << " "
            << (best[mi] > 0 ? fmt("%.2f:1", best[mi]) + " (q" + fmt("%.0f", best_q[mi]) + ")" : std::string("none"))
            << ";";
  summary << " on at least two materials: "
          << (two > 0 ? fmt("%.2f:1", two) + " (q" + fmt("%.0f", two_q) + ")" : std::string("none"))
          << "; on every material at one quality: "
          << (every > 0 ? fmt("%.2f:1", every) + " (q" + fmt("%.0f", every_q) + ")" : std::string("none")) << ".\n";
  std::printf("%s  (%.1f s)\n", summary.str().c_str(), run.seconds());
  if (!o.doc.empty()) {
    std::ostringstream doc;
    doc << "Tolerances: "
        << (o.tolerance == ToleranceReference::shared_max ? "`shared_max` (the default)" : "`per_component`")
        << (o.luminance ? " × per-tile luminance scale (P = " + fmt("%.2f", o.luminance_percentile) +
                              ", F = " + fmt("%.2f", o.luminance_floor) +
                              (o.luminance_white > 0 ? ", display-referred, white = " + fmt("%g", o.luminance_white)
                                                     : std::string()) +
                              "; scales per material:" + luminance_scales.str() + ")"
                        : std::string())
        << (o.perceptual ? " × perceptual channel scales (offline/build/perceptual_tolerance.hpp, library defaults" +
                               std::string(o.scene_direction_views > 0
                                               ? ", direction weights from " + std::to_string(o.scene_direction_views) +
                                                     " training views"
                                               : "") +
                               ", exposure = the sun's colour; range per material:" + luminance_scales.str() + ")"
                         : std::string())
        << ", frequency weighting JPEG^(" << bo_weight_quarters(o) << "/4)"
        << (o.entropy_coder == TileEntropyCoder::zstd ? ", tiles coded with zstd" : ", tiles coded with deflate")
        << ". Command: `" << run.command() << "` (" << fmt("%.0f", run.seconds()) << " s). " << o.materials
        << " materials, " << m0.pyramid.geometry().width << "×" << m0.pyramid.geometry().height << " texels (" << o.size
        << "² repeated " << o.repeat << "×" << o.repeat << "), C = " << o.components
        << ", T = " << m0.dir.metadata.tile_size << ", B = " << m0.dir.metadata.border << ", "
        << m0.dir.metadata.level_count << " levels; " << o.views << " views of " << o.width << "×" << o.height
        << "; statistics over each material's pixels in all views. " << peaks.str() << "\n\n"
        << table.str() << "\n"
        << summary.str();
    const bool shared = o.tolerance == ToleranceReference::shared_max;
    const std::string marker =
        o.perceptual
            ? std::string(o.scene_direction_views > 0 ? "visibility-perceptual-scene" : "visibility-perceptual")
            : std::string(shared ? "visibility" : "visibility-per-component") + (o.luminance ? "-luminance" : "");
    if (!samples::replace_doc_block(o.doc, marker, doc.str())) {
      std::fprintf(stderr, "btflod-visibility: cannot write %s\n", o.doc.c_str());
      return 1;
    }
  }
  if (o.check) {
    std::printf("check: %s\n", check_ok ? "every quality meets the criterion on every material" : "FAILED");
    return check_ok ? 0 : 1;
  }
  return 0;
}
