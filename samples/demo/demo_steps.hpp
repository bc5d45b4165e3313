// btflod-demo — the steps of the demo, each a plain function over a DemoConfig, so main() stays
// a short list of calls that later steps extend (factorise, build the tile pyramid, stream,
// render frames) without restructuring.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "btflod/btf/synthesizer.hpp"
#include "btflod/core/image_io.hpp"
#include "command_line.hpp"
#include "common/btf_files.hpp"
#include "common/progress_bar.hpp"

namespace btflod::demo {

/// Wall-clock seconds of a step, for the summary.
class Stopwatch {
 public:
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

/// Step 1: synthesise the demo material (procedural mesostructure, UBO2003 × UBO2003).
inline Result<BtfFloat> synthesize_material(const DemoConfig& cfg) {
  auto meso = make_mesostructure(cfg.material, cfg.size, cfg.size, cfg.seed);
  if (!meso) return meso.error();
  SynthesisOptions opts;
  opts.interreflection = cfg.interreflection;
  samples::ProgressBar bar("demo: synthesise", stderr, !cfg.quiet);
  opts.progress = bar.callback();
  return synthesize_btf(*meso, opts);
}

/// What write_and_read_back() found.
struct ReadBack {
  bool done = false;       ///< false when no writer is compiled in (the demo goes on)
  std::string path;
  uintmax_t file_bytes = 0;
  BtfFloat btf;            ///< the material as read back from the file
  double rmse = 0.0;       ///< over all samples
  double max_abs = 0.0;
  double relative = 0.0;   ///< rmse / rms of the original
};

/// Step 2: write the material (Bonn DFMF .btf) and read it back through the library's reader.
/// Returns an error when writing or reading fails; ReadBack::done = false when this build has
/// no writer (Status::unsupported).
inline Result<ReadBack> write_and_read_back(const DemoConfig& cfg, const BtfFloat& btf) {
  ReadBack rb;
  rb.path = (std::filesystem::path(cfg.out_dir) / "material.btf").string();
  samples::SaveOptions save;
  save.components = std::min(cfg.components, btf.width() * btf.height());
  samples::ProgressBar bar("demo: write", stderr, !cfg.quiet);
  save.progress = bar.callback();
  auto saved = samples::save_btf(btf, rb.path, save);
  bar.finish();
  if (!saved) {
    if (saved.status() == Status::unsupported) return rb;
    return saved.error();
  }
  std::error_code ec;
  rb.file_bytes = std::filesystem::file_size(rb.path, ec);
  auto loaded = samples::load_btf(rb.path);
  if (!loaded) return loaded.error();
  rb.btf = std::move(*loaded);
  if (rb.btf.width() != btf.width() || rb.btf.height() != btf.height() || rb.btf.view_count() != btf.view_count() ||
      rb.btf.light_count() != btf.light_count())
    return make_error(Status::bad_data, "%s: read back %dx%d with %zu x %zu directions, wrote %dx%d with %zu x %zu",
                      rb.path.c_str(), rb.btf.width(), rb.btf.height(), rb.btf.view_count(), rb.btf.light_count(),
                      btf.width(), btf.height(), btf.view_count(), btf.light_count());
  double se = 0.0, ss = 0.0;
  const auto a = btf.samples();
  const auto b = rb.btf.samples();
  for (size_t i = 0; i < a.size(); ++i) {
    const double d = static_cast<double>(b[i]) - a[i];
    se += d * d;
    ss += static_cast<double>(a[i]) * a[i];
    rb.max_abs = std::max(rb.max_abs, std::abs(d));
  }
  rb.rmse = std::sqrt(se / static_cast<double>(a.size()));
  rb.relative = ss > 0.0 ? std::sqrt(se / ss) : 0.0;
  rb.done = true;
  return rb;
}

/// Step 3: the summary on stdout.
inline void print_summary(const DemoConfig& cfg, const BtfFloat& btf, double synth_seconds, const ReadBack& rb) {
  std::printf("btflod demo: %s material, seed %llu\n", material_name(cfg.material),
              static_cast<unsigned long long>(cfg.seed));
  std::printf("  shape       %d x %d texels, %zu views (%s) x %zu lights (%s), 3 channels, %.1f MiB as float\n",
              btf.width(), btf.height(), btf.view_count(), btf.views().name().c_str(), btf.light_count(),
              btf.lights().name().c_str(), static_cast<double>(btf.size_bytes()) / (1024.0 * 1024.0));
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  double mean[3] = {0, 0, 0};
  const auto s = btf.samples();
  for (size_t i = 0; i < s.size(); ++i) {
    const size_t c = i % 3;
    lo[c] = std::min(lo[c], s[i]);
    hi[c] = std::max(hi[c], s[i]);
    mean[c] += s[i];
  }
  for (double& m : mean) m /= static_cast<double>(s.size() / 3);
  std::printf("  values      rho*cos(theta_l), linear RGB: R [%.4f, %.4f] mean %.4f, G [%.4f, %.4f] mean %.4f, "
              "B [%.4f, %.4f] mean %.4f\n",
              static_cast<double>(lo[0]), static_cast<double>(hi[0]), mean[0], static_cast<double>(lo[1]),
              static_cast<double>(hi[1]), mean[1], static_cast<double>(lo[2]), static_cast<double>(hi[2]), mean[2]);
  std::printf("  synthesis   %.2f s on %u threads\n", synth_seconds, default_thread_pool().thread_count());
  if (rb.done) {
    std::printf("  file        %s, %ju bytes (Bonn DFMF, %d components per channel)\n", rb.path.c_str(),
                rb.file_bytes, std::min(cfg.components, btf.width() * btf.height()));
    std::printf("  read back   RMSE %.3g, max |error| %.3g, relative RMSE %.3g%%\n", rb.rmse, rb.max_abs,
                100.0 * rb.relative);
  } else {
    std::printf("  file        not written: this build has no Bonn .btf writer\n");
  }
}

/// Index of the direction nearest to (theta, phi) in degrees.
inline size_t nearest_direction(const DirectionSet& set, float theta_deg, float phi_deg) {
  return set.nearest(direction_from_spherical(degrees_to_radians(theta_deg), degrees_to_radians(phi_deg)));
}

/// Step 4: a PNG contact sheet: rows are views (θ = 0, 30, 60, 75°), columns are lights
/// (from above, then 45° and 75° from the right and from the top); each cell shows the
/// material tiled 2 × 2 (so seams would show), magnified to at least 64 px, exposure ×π (a
/// white Lambertian lit from above maps to 1), sRGB.
inline Result<std::string> write_contact_sheet(const DemoConfig& cfg, const BtfFloat& btf) {
  const float view_thetas[] = {0, 30, 60, 75};
  const float light_tp[][2] = {{0, 0}, {45, 0}, {75, 0}, {45, 90}, {75, 90}};
  const int rows = 4, cols = 5;
  const int w = btf.width(), h = btf.height();
  const int zoom = std::max(1, 64 / std::max(w, h));
  const int cell_w = 2 * w * zoom, cell_h = 2 * h * zoom, gap = 4;
  Image<float> sheet(cols * (cell_w + gap) + gap, rows * (cell_h + gap) + gap, 3, 0.2f);
  for (int r = 0; r < rows; ++r) {
    const size_t v = nearest_direction(btf.views(), view_thetas[r], 0.0f);
    for (int c = 0; c < cols; ++c) {
      const size_t l = nearest_direction(btf.lights(), light_tp[c][0], light_tp[c][1]);
      const auto img = btf.image(v, l);
      const int x0 = gap + c * (cell_w + gap), y0 = gap + r * (cell_h + gap);
      for (int y = 0; y < cell_h; ++y)
        for (int x = 0; x < cell_w; ++x)
          for (int ch = 0; ch < 3; ++ch)
            sheet.at(x0 + x, y0 + y, ch) = kPi * img.at((x / zoom) % w, (y / zoom) % h, ch);
    }
  }
  const std::string path = (std::filesystem::path(cfg.out_dir) / "contact_sheet.png").string();
  auto ok = write_png_srgb(path, sheet.view());
  if (!ok) return ok.error();
  return path;
}

/// Step 5 (headless frames): the material seen from above under a light circling at 45°,
/// `frames` PNG images (nearest measured light direction; angular interpolation and the
/// streaming renderer come in later steps). Returns the number written.
inline Result<int> write_frames(const DemoConfig& cfg, const BtfFloat& btf) {
  const auto dir = std::filesystem::path(cfg.out_dir) / "frames";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return make_error(Status::io_error, "%s: cannot create: %s", dir.string().c_str(), ec.message().c_str());
  const size_t v = nearest_direction(btf.views(), 0.0f, 0.0f);
  const int zoom = std::max(1, 128 / std::max(btf.width(), btf.height()));
  for (int f = 0; f < cfg.frames; ++f) {
    const float phi = 360.0f * static_cast<float>(f) / static_cast<float>(std::max(cfg.frames, 1));
    const size_t l = nearest_direction(btf.lights(), 45.0f, phi);
    const auto img = btf.image(v, l);
    Image<float> frame(btf.width() * zoom, btf.height() * zoom, 3);
    for (int y = 0; y < frame.height(); ++y)
      for (int x = 0; x < frame.width(); ++x)
        for (int ch = 0; ch < 3; ++ch) frame.at(x, y, ch) = kPi * img.at(x / zoom, y / zoom, ch);
    char name[32];
    std::snprintf(name, sizeof name, "frame_%04d.png", f);
    auto ok = write_png_srgb((dir / name).string(), frame.view());
    if (!ok) return ok.error();
  }
  return cfg.frames;
}

}  // namespace btflod::demo
