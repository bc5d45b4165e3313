// btflod-demo — outputs of the streaming fly-through: report.json (every per-frame figure),
// report.html (inline SVG plots: SSIM vs bytes received, cache occupancy and error per frame,
// texture memory BSVTF vs FMF, frame time BSVTF vs FMF) and a PNG contact sheet of frames.
#pragma once

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "btflod/offline/btf/image_io.hpp"
#include "btflod/offline/factor/fmf_rank.hpp"
#include "cut_convergence.hpp"
#include "raw_reference.hpp"
#include "stream_render.hpp"

namespace btflod::demo {

/// Everything the report shows.
struct RunSummary {
  std::string backend;
  std::string command;
  uint32_t materials = 0, width = 0, height = 0, slots = 0, tiles = 0;
  uint64_t payload_bytes = 0;
  double bytes_per_second = 0;
  double seconds_prepare = 0, seconds_flight = 0;
  std::vector<std::string> material_names;
  std::vector<double> fmf_errors;
  MemoryFigures memory;
  std::vector<FrameRecord> frames;
  uint64_t page_table_writes = 0;     ///< GPU page-table texels written (start-up + deltas)
  uint64_t full_page_table_size = 0;  ///< texels of one full rewrite of every table
  uint32_t full_rewrites = 0;         ///< full rewrites (start-up, delta overflows)
  std::string page_table_check;       ///< "equal" or the first difference from a rebuild
  // The configuration (paper 000 §7 for --profile paper) and each material's files.
  std::string profile = "default";
  /// Where the feedback words come from: "colour pass" (bsvtf_feedback), "feedback pass"
  /// (--feedback-pass) or "cpu" (the CPU renderer's ray caster).
  std::string feedback_words = "colour pass";
  bool components_default = true;         ///< C is the profile's default (no --components)
  std::string value_encoding = "linear";  ///< the FMF's value encoding (--value-encoding)
  /// components: the programs' C (the largest material rank); rank_target: the displayed-image
  /// SSIM each material's rank was chosen for (0: one fixed rank).
  uint32_t components = 0, tile_size = 0, border = 0, slots_x = 0, slots_y = 0, directions = 0, texels = 0;
  double rank_target = 0.0;
  std::vector<uint32_t> material_components;  ///< each material's rank C_m
  /// Each material's candidate ranks tried: (C, training-view SSIM, held-out SSIM).
  std::vector<std::vector<FmfRankPoint>> rank_curves;
  std::vector<uint64_t> store_bytes, fmf_half_bytes, bsvtf_bytes;
  std::vector<double> seconds_synthesis, seconds_factor, seconds_build;
  std::vector<double> seconds_error, seconds_raw;  ///< error pass, raw-BTF reference pass per material
  std::vector<uint32_t> material_texels;           ///< per material (a prebuilt store has its own)
  std::vector<uint8_t> store_prebuilt, fmf_prebuilt;
  bool transient_stores = false;  ///< each store deleted after its raw-BTF pass (paper profile)
  uint64_t disk_peak_bytes = 0;   ///< peak bytes in the output folder (demo::DiskMeter)
  uint64_t disk_min_free_bytes = 0;
  /// --cut: frames, bytes and seconds to converge after a camera cut (cut_convergence.hpp).
  CutConvergence cut;
  /// Materials swapped on the live Streamer during the flight (StreamSettings::swap_out_frame),
  /// and how many were planned.
  std::vector<SwapRecord> swaps;
  size_t planned_swaps = 0;
  /// The last view against a render of the RAW tabulated BTF (raw_reference.hpp).
  struct RawComparison {
    bool done = false;
    std::string note;  ///< why it was not done
    ImageError bsvtf_gpu, fmf_gpu, fmf_cpu;
    /// Against the GPU-filter-matched raw render (RawReference::raw_gpu_filter): the GPU images
    /// and the FMF through the same filter on the CPU (the factorisation error alone under the
    /// GPU's filtering); fmf_gpu_vs_cpu_filter compares the two FMF renders (the rasteriser).
    bool gpu_filter = false;
    std::string gpu_filter_note;
    ImageError bsvtf_gpu_f, fmf_gpu_f, fmf_cpu_f, fmf_gpu_vs_cpu_f;
    /// Per material (the pixels whose pixel-centre ray hits it): the FMF through the same rays as
    /// the raw render (the factorisation error alone) and, with gpu_filter, the streamed BSVTF and
    /// the resident FMF against the raw BTF through the GPU's filter. Each ImageError::filter says
    /// which rays and filter.
    struct PerMaterial {
      ImageError fmf_cpu, bsvtf_gpu_f, fmf_gpu_f;
    };
    std::vector<PerMaterial> per_material;
    double seconds = 0;
    uint64_t bytes_read = 0;
    uint32_t supersample = 1;
  } raw;
  /// The tile cache's format (--cache-format), and the two formats compared on the settled
  /// view's resident tiles (StreamingRenderer::render_cache_format_on_cpu: CPU ray-caster, same
  /// rays, tiles and page table): rgba8_affine against rgba16f (whole view and per material), and
  /// each against the raw BTF.
  struct CacheFormatComparison {
    bool done = false;
    std::string note;  ///< why it was not done
    std::string format = "rgba16f";
    uint64_t bytes_rgba16f = 0, bytes_rgba8 = 0;  ///< the cache texture (rgba8: with its slot-map table)
    ImageError rgba8_vs_rgba16f, rgba16f_vs_raw, rgba8_vs_raw;
    /// The two-plane BC5 layout (runtime/vt/cache_bc5.hpp) through its reference decoder: not a
    /// GPU path yet, the error such a cache would add.
    uint64_t bytes_bc5 = 0;
    ImageError bc5_vs_rgba16f, bc5_vs_raw;
    std::vector<ImageError> per_material_bc5;
    std::vector<ImageError> per_material;  ///< rgba8_affine vs rgba16f over each material's pixels
    double seconds = 0;
  } cache_format;

  /// Frame time of the two programs over one run: both are rendered every frame (alternating
  /// which goes first), so load from other processes hits both alike. Medians over the frames
  /// from `kWarmupFrames` on (the first frames JIT-compile shader variants), and the median and
  /// quartiles of the per-frame ratio t_fmf / t_bsvtf (BSVTF frame rate over FMF frame rate).
  struct FrameTimes {
    size_t frames = 0;
    double ms_bsvtf = 0, ms_fmf = 0;
    double ratio = 0, ratio_q1 = 0, ratio_q3 = 0;
  };
  static constexpr size_t kWarmupFrames = 3;
  FrameTimes frame_times() const {
    FrameTimes t;
    std::vector<double> r;
    for (size_t i = std::min(kWarmupFrames, frames.size() / 2); i < frames.size(); ++i)
      if (frames[i].ms_bsvtf > 0 && frames[i].ms_fmf > 0) r.push_back(frames[i].ms_fmf / frames[i].ms_bsvtf);
    t.frames = r.size();
    if (r.empty()) return t;
    std::sort(r.begin(), r.end());
    t.ratio = r[r.size() / 2];
    t.ratio_q1 = r[r.size() / 4];
    t.ratio_q3 = r[(3 * r.size()) / 4];
    const size_t first = std::min(kWarmupFrames, frames.size() / 2);
    t.ms_bsvtf = median(&FrameRecord::ms_bsvtf, first);
    t.ms_fmf = median(&FrameRecord::ms_fmf, first);
    return t;
  }

  double median(double FrameRecord::*field, size_t first = 0) const {
    std::vector<double> v;
    for (size_t i = first; i < frames.size(); ++i) v.push_back(frames[i].*field);
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  }
};

namespace detail_report {

/// "8" for one fixed rank; "4/8/16/12 (each material's, chosen for displayed-image SSIM 0.90)".
inline std::string ranks(const RunSummary& r) {
  if (r.rank_target <= 0.0 || r.material_components.empty()) return std::to_string(r.components);
  std::string s;
  for (size_t i = 0; i < r.material_components.size(); ++i)
    s += (i ? "/" : "") + std::to_string(r.material_components[i]);
  char b[96];
  std::snprintf(b, sizeof b, " (each material's, chosen for displayed-image SSIM %.2f)", r.rank_target);
  return s + b;
}

struct Series {
  std::string name;
  std::string color;
  std::vector<double> x, y;
};

inline std::string fmt(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}

/// A line chart as inline SVG: axes with min/max labels, one polyline per series, legend.
inline std::string line_chart(const std::string& title, const std::string& xlabel, const std::string& ylabel,
                              const std::vector<Series>& series, double ymin_hint = 0.0) {
  const double W = 560, H = 300, L = 60, R = 150, T = 30, B = 45;
  double x0 = 1e300, x1 = -1e300, y0 = ymin_hint, y1 = -1e300;
  for (const auto& s : series)
    for (size_t i = 0; i < s.x.size(); ++i) {
      x0 = std::min(x0, s.x[i]), x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]), y1 = std::max(y1, s.y[i]);
    }
  if (!(x1 > x0)) x1 = x0 + 1;
  if (!(y1 > y0)) y1 = y0 + 1;
  const auto px = [&](double x) { return L + (x - x0) / (x1 - x0) * (W - L - R); };
  const auto py = [&](double y) { return H - B - (y - y0) / (y1 - y0) * (H - T - B); };
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
    << "' font-family='sans-serif' font-size='11'>\n";
  s << "<text x='" << W / 2 - R / 2 << "' y='18' text-anchor='middle' font-size='13' font-weight='bold'>" << title
    << "</text>\n";
  s << "<rect x='" << L << "' y='" << T << "' width='" << W - L - R << "' height='" << H - T - B
    << "' fill='#fafafa' stroke='#999'/>\n";
  for (int k = 1; k < 4; ++k) {
    const double yy = T + (H - T - B) * k / 4.0;
    s << "<line x1='" << L << "' x2='" << W - R << "' y1='" << yy << "' y2='" << yy << "' stroke='#e0e0e0'/>\n";
  }
  s << "<text x='" << L << "' y='" << H - B + 14 << "'>" << fmt(x0) << "</text>";
  s << "<text x='" << W - R << "' y='" << H - B + 14 << "' text-anchor='end'>" << fmt(x1) << "</text>";
  s << "<text x='" << (L + W - R) / 2 << "' y='" << H - 8 << "' text-anchor='middle'>" << xlabel << "</text>\n";
  s << "<text x='" << L - 4 << "' y='" << py(y0) << "' text-anchor='end'>" << fmt(y0) << "</text>";
  s << "<text x='" << L - 4 << "' y='" << py(y1) + 8 << "' text-anchor='end'>" << fmt(y1) << "</text>";
  s << "<text transform='translate(14," << (T + H - B) / 2 << ") rotate(-90)' text-anchor='middle'>" << ylabel
    << "</text>\n";
  int row = 0;
  for (const auto& se : series) {
    s << "<polyline fill='none' stroke-width='2' stroke='" << se.color << "' points='";
    for (size_t i = 0; i < se.x.size(); ++i) s << px(se.x[i]) << "," << py(se.y[i]) << " ";
    s << "'/>\n";
    const double ly = T + 12 + 16 * row++;
    s << "<line x1='" << W - R + 10 << "' x2='" << W - R + 30 << "' y1='" << ly << "' y2='" << ly << "' stroke='"
      << se.color << "' stroke-width='3'/><text x='" << W - R + 34 << "' y='" << ly + 4 << "'>" << se.name
      << "</text>\n";
  }
  s << "</svg>\n";
  return s.str();
}

/// Horizontal bars (label, value, colour) as inline SVG.
inline std::string bar_chart(const std::string& title, const std::string& unit,
                             const std::vector<std::tuple<std::string, double, std::string>>& bars) {
  const double W = 560, L = 190, bar = 26, T = 30;
  const double H = T + bars.size() * (bar + 10) + 10;
  double vmax = 1e-30;
  for (const auto& b : bars) vmax = std::max(vmax, std::get<1>(b));
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
    << "' font-family='sans-serif' font-size='11'>\n";
  s << "<text x='" << W / 2 << "' y='18' text-anchor='middle' font-size='13' font-weight='bold'>" << title
    << "</text>\n";
  double y = T;
  for (const auto& [label, value, color] : bars) {
    const double w = value / vmax * (W - L - 90);
    s << "<text x='" << L - 6 << "' y='" << y + bar * 0.65 << "' text-anchor='end'>" << label << "</text>";
    s << "<rect x='" << L << "' y='" << y << "' width='" << w << "' height='" << bar << "' fill='" << color << "'/>";
    s << "<text x='" << L + w + 6 << "' y='" << y + bar * 0.65 << "'>" << fmt(value) << " " << unit << "</text>\n";
    y += bar + 10;
  }
  s << "</svg>\n";
  return s.str();
}

/// Paper 000 Table 2 (frame rate and GPU memory per scene, their GTX 680) and Table 1's 512²
/// row (file sizes): the figures the report sets beside this run's.
struct PaperScene {
  const char* scene;
  double fps_bsvtf, fps_bsvtf_sd, fps_fmf, fps_fmf_sd;  ///< fps_fmf < 0: not given (did not fit)
  const char* gpu_bsvtf;
  const char* gpu_fmf;
};
inline constexpr PaperScene kPaperTable2[] = {
    {"1: 100 BTFs, 180K triangles", 34, 10, -1, 0, "1.7 GB", "6.2 GB"},
    {"2: 15 BTFs, 3.7M triangles", 10, 2, -1, 0, "483 MB", "6.6 GB"},
    {"3: 4 BTFs, 2.3M triangles", 18, 5, -1, 0, "229 MB", "3.2 GB"},
    {"4: 5 BTFs, 4.6K triangles", 72, 16, 106, 23, "244 MB", "316 MB"},
    {"5: 1 BTF, 50K triangles", 46, 9, 69, 14, "181 MB", "0.8 GB"},
    {"6: 1 BTF, 1.1M triangles", 24, 3, 29, 6, "181 MB", "0.8 GB"},
};

inline std::string mib(double bytes) {
  char b[64];
  if (bytes >= 1073741824.0)
    std::snprintf(b, sizeof b, "%.2f GiB", bytes / 1073741824.0);
  else
    std::snprintf(b, sizeof b, "%.1f MiB", bytes / 1048576.0);
  return b;
}

inline uint64_t sum(const std::vector<uint64_t>& v) {
  uint64_t n = 0;
  for (uint64_t x : v) n += x;
  return n;
}

/// One comparison with the raw BTF as a JSON object (SSIM and PSNR of the sRGB images, RMSE of
/// the linear ones, ΔE*ab mean and p99, pixels compared, and the rays and filter of both images).
inline std::string image_error_json(const ImageError& x) {
  char t[384];
  std::snprintf(t, sizeof t,
                "{\"ssim\": %.5f, \"psnr_db\": %.3f, \"rmse\": %.6f, \"delta_e_mean\": %.3f, \"delta_e_p99\": %.3f, "
                "\"pixels\": %llu, \"filter\": ",
                x.ssim, x.psnr, x.rmse, x.de_mean, x.de_p99, static_cast<unsigned long long>(x.pixels));
  std::string out = t;
  out += '"';
  for (const char c : x.filter) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"}";
}

/// report.json's "configuration", "files", "raw_reference" and "paper000" members.
inline std::string config_and_raw_json(const RunSummary& r) {
  std::ostringstream o;
  char b[768];
  std::snprintf(b, sizeof b,
                "  \"configuration\": {\"profile\": \"%s\", \"directions\": %u, \"components\": %u, "
                "\"components_default\": %s, \"rank_target_ssim\": %.3f, \"value_encoding\": \"%s\", "
                "\"tile_size\": %u, \"border\": %u, \"cache_slots_x\": %u, \"cache_slots_y\": %u, "
                "\"material_texels\": %u, \"feedback_words\": \"%s\"},\n",
                r.profile.c_str(), r.directions, r.components, r.components_default ? "true" : "false", r.rank_target,
                r.value_encoding.c_str(), r.tile_size, r.border, r.slots_x, r.slots_y, r.texels,
                r.feedback_words.c_str());
  o << b << "  \"files\": [";
  for (size_t i = 0; i < r.store_bytes.size(); ++i) {
    std::snprintf(
        b, sizeof b,
        "%s{\"material\": \"%s\", \"raw_store_bytes\": %llu, \"fmf_half_bytes\": %llu, \"bsvtf_bytes\": %llu, "
        "\"seconds_synthesis\": %.2f, \"seconds_factor\": %.2f, \"seconds_build\": %.2f",
        i ? ", " : "", r.material_names[i].c_str(), static_cast<unsigned long long>(r.store_bytes[i]),
        static_cast<unsigned long long>(r.fmf_half_bytes[i]), static_cast<unsigned long long>(r.bsvtf_bytes[i]),
        r.seconds_synthesis[i], r.seconds_factor[i], r.seconds_build[i]);
    o << b;
    if (i < r.material_components.size()) o << ", \"components\": " << r.material_components[i];
    if (i < r.rank_curves.size() && !r.rank_curves[i].empty()) {
      o << ", \"rank_curve\": [";
      for (size_t k = 0; k < r.rank_curves[i].size(); ++k) {
        const FmfRankPoint& p = r.rank_curves[i][k];
        std::snprintf(b, sizeof b, "%s{\"components\": %d, \"training_ssim\": %.4f, \"held_out_ssim\": %.4f}",
                      k ? ", " : "", p.components, p.training_ssim, p.held_out_ssim);
        o << b;
      }
      o << "]";
    }
    if (i < r.seconds_raw.size() && i < r.material_texels.size() && i < r.store_prebuilt.size()) {
      std::snprintf(b, sizeof b,
                    ", \"texels\": %u, \"seconds_error_pass\": %.2f, \"seconds_raw_reference_pass\": %.2f, "
                    "\"store_prebuilt\": %s, \"fmf_prebuilt\": %s",
                    r.material_texels[i], r.seconds_error[i], r.seconds_raw[i], r.store_prebuilt[i] ? "true" : "false",
                    r.fmf_prebuilt[i] ? "true" : "false");
      o << b;
    }
    o << "}";
  }
  o << "],\n";
  std::snprintf(b, sizeof b,
                "  \"disk\": {\"transient_stores\": %s, \"peak_bytes_in_output_folder\": %llu, "
                "\"min_free_bytes\": %llu},\n",
                r.transient_stores ? "true" : "false", static_cast<unsigned long long>(r.disk_peak_bytes),
                static_cast<unsigned long long>(r.disk_min_free_bytes));
  o << b;
  if (r.raw.done) {
    const auto e = [&](const char* name, const ImageError& x, bool last) {
      return "\"" + std::string(name) + "\": " + image_error_json(x) + (last ? "" : ", ");
    };
    o << "  \"raw_reference\": {" << e("bsvtf_gpu", r.raw.bsvtf_gpu, false) << e("fmf_gpu", r.raw.fmf_gpu, false)
      << e("fmf_cpu", r.raw.fmf_cpu, false);
    if (r.raw.gpu_filter)
      o << "\"gpu_filter\": {" << e("bsvtf_gpu", r.raw.bsvtf_gpu_f, false) << e("fmf_gpu", r.raw.fmf_gpu_f, false)
        << e("fmf_cpu", r.raw.fmf_cpu_f, false) << e("fmf_gpu_vs_fmf_cpu", r.raw.fmf_gpu_vs_cpu_f, true) << "}, ";
    else
      o << "\"gpu_filter\": {\"not_done\": \"" << r.raw.gpu_filter_note << "\"}, ";
    o << "\"per_material\": [";
    for (size_t i = 0; i < r.raw.per_material.size(); ++i) {
      const auto& pm = r.raw.per_material[i];
      o << (i ? ", " : "") << "{\"material\": \"" << (i < r.material_names.size() ? r.material_names[i] : "")
        << "\", \"fmf_relative_error\": " << fmt(i < r.fmf_errors.size() ? r.fmf_errors[i] : 0.0) << ", "
        << e("fmf_cpu", pm.fmf_cpu, !r.raw.gpu_filter);
      if (r.raw.gpu_filter)
        o << e("bsvtf_gpu_gpu_filter", pm.bsvtf_gpu_f, false) << e("fmf_gpu_gpu_filter", pm.fmf_gpu_f, true);
      o << "}";
    }
    o << "], ";
    std::snprintf(b, sizeof b, "\"supersample\": %u, \"store_bytes_read\": %llu, \"seconds\": %.2f},\n",
                  r.raw.supersample, static_cast<unsigned long long>(r.raw.bytes_read), r.raw.seconds);
    o << b;
  } else {
    o << "  \"raw_reference\": {\"not_done\": \"" << r.raw.note << "\"},\n";
  }
  if (r.cache_format.done) {
    const RunSummary::CacheFormatComparison& c = r.cache_format;
    std::snprintf(
        b, sizeof b,
        "  \"cache_format\": {\"format\": \"%s\", \"cache_bytes_rgba16f\": %llu, \"cache_bytes_rgba8\": %llu, "
        "\"seconds\": %.2f, ",
        c.format.c_str(), static_cast<unsigned long long>(c.bytes_rgba16f),
        static_cast<unsigned long long>(c.bytes_rgba8), c.seconds);
    o << b << "\"rgba8_vs_rgba16f\": " << image_error_json(c.rgba8_vs_rgba16f)
      << ", \"rgba16f_vs_raw\": " << image_error_json(c.rgba16f_vs_raw)
      << ", \"rgba8_vs_raw\": " << image_error_json(c.rgba8_vs_raw) << ", \"per_material_rgba8_vs_rgba16f\": [";
    for (size_t i = 0; i < c.per_material.size(); ++i)
      o << (i ? ", " : "") << "{\"material\": \"" << (i < r.material_names.size() ? r.material_names[i] : "")
        << "\", \"error\": " << image_error_json(c.per_material[i]) << "}";
    o << "], \"bc5\": {\"cache_bytes\": " << c.bytes_bc5 << ", \"vs_rgba16f\": " << image_error_json(c.bc5_vs_rgba16f)
      << ", \"vs_raw\": " << image_error_json(c.bc5_vs_raw) << ", \"per_material_vs_rgba16f\": [";
    for (size_t i = 0; i < c.per_material_bc5.size(); ++i)
      o << (i ? ", " : "") << "{\"material\": \"" << (i < r.material_names.size() ? r.material_names[i] : "")
        << "\", \"error\": " << image_error_json(c.per_material_bc5[i]) << "}";
    o << "]}},\n";
  } else {
    o << "  \"cache_format\": {\"format\": \"" << r.cache_format.format << "\", \"not_done\": \"" << r.cache_format.note
      << "\"},\n";
  }
  const RunSummary::FrameTimes ft = r.frame_times();
  std::snprintf(
      b, sizeof b,
      "  \"paper000\": {\"table2_bsvtf_fps_over_fmf_fps\": {\"scene4\": %.3f, \"scene5\": %.3f, \"scene6\": %.3f, "
      "\"this_run\": %.3f}, \"this_run_fps_bsvtf\": %.3f, \"this_run_fps_fmf\": %.3f, "
      "\"this_run_gpu_bytes_bsvtf\": %llu, \"this_run_gpu_bytes_fmf\": %llu, "
      "\"table1_512_bytes\": {\"uncompressed\": 33e9, \"fmf\": 63e6, \"bsvtf\": 53e6}, "
      "\"hardware\": \"paper: GeForce GTX 680 (4 GB); this run: %s\"},\n",
      72.0 / 106.0, 46.0 / 69.0, 24.0 / 29.0, ft.ratio, ft.ms_bsvtf > 0 ? 1000.0 / ft.ms_bsvtf : 0.0,
      ft.ms_fmf > 0 ? 1000.0 / ft.ms_fmf : 0.0,
      static_cast<unsigned long long>(r.memory.bsvtf_bytes + r.memory.u_bytes),
      static_cast<unsigned long long>(r.memory.fmf_bytes + r.memory.u_bytes), r.backend.c_str());
  o << b;
  return o.str();
}

/// The report's HTML sections: the raw-BTF comparison and paper 000 Tables 1–2 beside this run.
inline std::string raw_and_paper_html(const RunSummary& r) {
  std::ostringstream h;
  char row[1024];
  h << "<h2>Against the raw BTF</h2>\n";
  if (!r.raw.done) {
    h << "<p>Not computed: " << r.raw.note << "</p>\n";
  } else {
    std::snprintf(row, sizeof row,
                  "<p>The last (settled) view rendered from the <b>raw tabulated BTF</b> (each material's store, one "
                  "sequential pass, %s read in %.1f s): CPU ray-caster, %u×%u rays per pixel, finest level, bilinear "
                  "texels, the shaders' 3×3 angular taps, and again with one ray per pixel centre through the GPU's "
                  "filter (OpenGL's level of detail, trilinear over box-filtered mips). <i>FMF (CPU)</i> is the same "
                  "rays and taps through U·V′, so its error is the factorisation's alone. Every row names the rays "
                  "and the filter of both images; only the last two compare images filtered differently.</p>\n",
                  mib(static_cast<double>(r.raw.bytes_read)).c_str(), r.raw.seconds, r.raw.supersample,
                  r.raw.supersample);
    h << row
      << "<table><tr><th>image vs raw-BTF render</th><th>rays and filter</th><th>SSIM (sRGB)</th><th>PSNR dB "
         "(sRGB)</th><th>ΔE*ab mean</th><th>ΔE*ab p99</th><th>RMSE (linear)</th></tr>";
    // The CPU fallback renders the "GPU" images with the reference ray-caster: say which.
    const bool cpu_renderer = r.feedback_words == "cpu";
    const auto line = [&](std::string name, const ImageError& e) {
      if (cpu_renderer)
        for (size_t at; (at = name.find("(GPU)")) != std::string::npos;) name.replace(at, 5, "(CPU renderer)");
      std::snprintf(row, sizeof row,
                    "<tr><td>%s</td><td>%s</td><td>%.4f</td><td>%.2f</td><td>%.2f</td><td>%.2f</td><td>%.5f</td></tr>",
                    name.c_str(), e.filter.c_str(), e.ssim, e.psnr, e.de_mean, e.de_p99, e.rmse);
      h << row;
    };
    line("FMF (CPU): the factorisation error alone", r.raw.fmf_cpu);
    if (r.raw.gpu_filter) {
      line("BSVTF streamed, settled (GPU)", r.raw.bsvtf_gpu_f);
      line("FMF, everything resident (GPU)", r.raw.fmf_gpu_f);
      line("FMF (CPU): the factorisation error alone", r.raw.fmf_cpu_f);
      line("FMF (GPU) vs FMF (CPU), not the raw BTF: rasteriser vs ray-caster", r.raw.fmf_gpu_vs_cpu_f);
    }
    h << "<tr><th colspan='7'>different filters (not a like-for-like comparison: the GPU's trilinear mips "
         "against the raw render's supersampled box filter)</th></tr>\n";
    line("BSVTF streamed, settled (GPU)", r.raw.bsvtf_gpu);
    line("FMF, everything resident (GPU)", r.raw.fmf_gpu);
    h << "</table>\n";
    if (!r.raw.per_material.empty()) {
      h << "<h3>Per material (pixels whose centre ray hits it)</h3>\n<p>The relative error ‖BTF − U·V′ᵀ‖<sub>F</sub> / "
           "‖BTF‖<sub>F</sub> is over every sample of the material; a few bright samples (e.g. mirror highlights) can "
           "hold most of its energy, so a small relative error can still lose what a viewer sees. The image figures "
           "are what the last view shows.</p>\n<table><tr><th>material</th><th>relative error (Frobenius)</th>"
           "<th>pixels</th><th>FMF SSIM</th><th>FMF PSNR dB</th><th>FMF ΔE*ab mean</th><th>FMF ΔE*ab p99</th>";
      if (r.raw.gpu_filter) h << "<th>BSVTF SSIM</th><th>BSVTF ΔE*ab p99</th>";
      h << "</tr>\n";
      for (size_t i = 0; i < r.raw.per_material.size(); ++i) {
        const auto& pm = r.raw.per_material[i];
        std::snprintf(row, sizeof row,
                      "<tr><td>%s</td><td>%.3f</td><td>%llu</td><td>%.4f</td><td>%.2f</td><td>%.2f</td><td>%.2f</td>",
                      i < r.material_names.size() ? r.material_names[i].c_str() : "",
                      i < r.fmf_errors.size() ? r.fmf_errors[i] : 0.0,
                      static_cast<unsigned long long>(pm.fmf_cpu.pixels), pm.fmf_cpu.ssim, pm.fmf_cpu.psnr,
                      pm.fmf_cpu.de_mean, pm.fmf_cpu.de_p99);
        h << row;
        if (r.raw.gpu_filter) {
          std::snprintf(row, sizeof row, "<td>%.4f</td><td>%.2f</td>", pm.bsvtf_gpu_f.ssim, pm.bsvtf_gpu_f.de_p99);
          h << row;
        }
        h << "</tr>\n";
      }
      h << "</table>\n<p>FMF: " << r.raw.per_material.front().fmf_cpu.filter << ".";
      if (r.raw.gpu_filter) h << " BSVTF: " << r.raw.per_material.front().bsvtf_gpu_f.filter << ".";
      h << "</p>\n";
    }
    h << "<p><img src='reference_raw.png' alt='raw BTF render'> <img src='reference_fmf_cpu.png' alt='FMF "
         "CPU "
         "render'></p>\n";
  }
  const RunSummary::FrameTimes ft = r.frame_times();
  h << "<h2>Paper 000 Table 2 beside this run</h2>\n<p>Their figures are on an NVIDIA GeForce GTX 680 (4 GB) at "
       "1280×720; ours on <b>"
    << r.backend << "</b> (" << r.width << "×" << r.height
    << "; llvmpipe is a CPU rasteriser sharing 2 cores with the streaming work), so absolute frame rates are not "
       "comparable; the BSVTF/FMF ratio and the memory are.</p>\n";
  h << "<table><tr><th>scene</th><th>FPS BSVTF</th><th>FPS FMF</th><th>BSVTF/FMF</th><th>GPU memory BSVTF</th><th>GPU "
       "memory FMF</th></tr>";
  for (const PaperScene& p : kPaperTable2) {
    char fmf[64] = "–", ratio[64] = "–";
    if (p.fps_fmf > 0) {
      std::snprintf(fmf, sizeof fmf, "%.0f ± %.0f", p.fps_fmf, p.fps_fmf_sd);
      std::snprintf(ratio, sizeof ratio, "%.2f", p.fps_bsvtf / p.fps_fmf);
    }
    std::snprintf(
        row, sizeof row,
        "<tr><td>paper %s (GTX 680)</td><td>%.0f ± %.0f</td><td>%s</td><td>%s</td><td>%s</td><td>%s</td></tr>", p.scene,
        p.fps_bsvtf, p.fps_bsvtf_sd, fmf, ratio, p.gpu_bsvtf, p.gpu_fmf);
    h << row;
  }
  std::snprintf(
      row, sizeof row,
      "<tr><td><b>this run</b>: %u BTFs (%s) on %s</td><td>%.2f</td><td>%.2f</td><td>%.2f (quartiles %.2f–%.2f)</td>"
      "<td>%s (cache %s + page tables, U′ and tables %s)</td><td>%s (V′ RGBA32F + mips, U′ and tables)</td></tr>",
      r.materials, r.profile.c_str(), r.backend.c_str(), ft.ms_bsvtf > 0 ? 1000.0 / ft.ms_bsvtf : 0.0,
      ft.ms_fmf > 0 ? 1000.0 / ft.ms_fmf : 0.0, ft.ratio, ft.ratio_q1, ft.ratio_q3,
      mib(static_cast<double>(r.memory.bsvtf_bytes + r.memory.u_bytes)).c_str(),
      mib(static_cast<double>(r.memory.bsvtf_bytes)).c_str(), mib(static_cast<double>(r.memory.u_bytes)).c_str(),
      mib(static_cast<double>(r.memory.fmf_bytes + r.memory.u_bytes)).c_str());
  h << row << "</table>\n";
  h << "<p>File sizes per material (paper 000 Table 1, 512² row: uncompressed 33 GB, FMF 63 MB, BSVTF 53 MB):</p>"
       "<table><tr><th>material</th><th>raw BTF store</th><th>FMF (U, V′ as halves)</th><th>.bsvtf</th><th>synthesis "
       "s</th>"
       "<th>factorisation s</th><th>.bsvtf build s</th></tr>";
  for (size_t i = 0; i < r.store_bytes.size(); ++i) {
    std::snprintf(row, sizeof row,
                  "<tr><td>%s (%u² texels, %u×%u "
                  "directions)</td><td>%s</td><td>%s</td><td>%s</td><td>%.1f</td><td>%.1f</td><td>%.1f</td></tr>",
                  r.material_names[i].c_str(), i < r.material_texels.size() ? r.material_texels[i] : r.texels,
                  r.directions, r.directions, mib(static_cast<double>(r.store_bytes[i])).c_str(),
                  mib(static_cast<double>(r.fmf_half_bytes[i])).c_str(),
                  mib(static_cast<double>(r.bsvtf_bytes[i])).c_str(), r.seconds_synthesis[i], r.seconds_factor[i],
                  r.seconds_build[i]);
    h << row;
  }
  h << "</table>\n";
  std::snprintf(
      row, sizeof row, "<p>Disk: at most %s in the output folder (%s), at least %s free.</p>\n",
      mib(static_cast<double>(r.disk_peak_bytes)).c_str(),
      r.transient_stores ? "each store deleted after its raw-BTF pass: one store at a time" : "every store kept",
      mib(static_cast<double>(r.disk_min_free_bytes)).c_str());
  h << row;
  return h.str();
}

}  // namespace detail_report

/// Writes DIR/report.json. Returns an io_error naming the file on failure.
inline VoidResult write_report_json(const std::string& path, const RunSummary& r) {
  std::ofstream o(path, std::ios::binary | std::ios::trunc);
  if (!o) return make_error(Status::io_error, "%s: cannot open for writing", path.c_str());
  char b[512];
  o << "{\n  \"backend\": \"" << r.backend << "\",\n";
  std::snprintf(
      b, sizeof b,
      "  \"materials\": %u,\n  \"width\": %u,\n  \"height\": %u,\n  \"cache_slots\": %u,\n  \"tiles_total\": %u,\n"
      "  \"payload_bytes_total\": %llu,\n  \"link_bytes_per_second\": %.0f,\n  \"seconds_prepare\": %.3f,\n"
      "  \"seconds_flight\": %.3f,\n",
      r.materials, r.width, r.height, r.slots, r.tiles, static_cast<unsigned long long>(r.payload_bytes),
      r.bytes_per_second, r.seconds_prepare, r.seconds_flight);
  o << b;
  o << "  \"fmf_relative_error\": [";
  for (size_t i = 0; i < r.fmf_errors.size(); ++i) o << (i ? ", " : "") << detail_report::fmt(r.fmf_errors[i]);
  o << "],\n";
  std::snprintf(
      b, sizeof b,
      "  \"memory\": {\"fmf_texture_bytes\": %llu, \"bsvtf_texture_bytes\": %llu, \"bsvtf_over_fmf\": %.4f, "
      "\"shared_u_and_tables_bytes\": %llu},\n",
      static_cast<unsigned long long>(r.memory.fmf_bytes), static_cast<unsigned long long>(r.memory.bsvtf_bytes),
      r.memory.fmf_bytes ? static_cast<double>(r.memory.bsvtf_bytes) / static_cast<double>(r.memory.fmf_bytes) : 0.0,
      static_cast<unsigned long long>(r.memory.u_bytes));
  o << b;
  const RunSummary::FrameTimes ft = r.frame_times();
  std::snprintf(
      b, sizeof b,
      "  \"frame_time\": {\"median_ms_bsvtf\": %.3f, \"median_ms_fmf\": %.3f, \"bsvtf_fps_over_fmf_fps\": %.4f, "
      "\"ratio_q1\": %.4f, \"ratio_q3\": %.4f, \"frames\": %zu, "
      "\"over\": \"median of per-frame t_fmf/t_bsvtf; both rendered every frame, alternating order, after %zu warm-up "
      "frames; "
      "BSVTF includes its feedback pass\"},\n",
      ft.ms_bsvtf, ft.ms_fmf, ft.ratio, ft.ratio_q1, ft.ratio_q3, ft.frames, RunSummary::kWarmupFrames);
  o << b;
  std::snprintf(b, sizeof b,
                "  \"page_table\": {\"writes\": %llu, \"full_rewrite_size\": %llu, \"full_rewrites\": %u, "
                "\"frames\": %zu, \"check_vs_rebuild\": \"%s\"},\n",
                static_cast<unsigned long long>(r.page_table_writes),
                static_cast<unsigned long long>(r.full_page_table_size), r.full_rewrites, r.frames.size(),
                r.page_table_check.c_str());
  o << b;
  o << detail_report::config_and_raw_json(r);
  if (r.cut.done) {
    const CutConvergence& c = r.cut;
    std::snprintf(
        b, sizeof b,
        "  \"cut\": {\"from_view\": %u, \"to_view\": %u, \"ssim_threshold\": %.2f, \"frames_to_threshold\": %u, "
        "\"bytes_to_threshold\": %llu, \"tiles_to_threshold\": %u, \"seconds_to_threshold\": %.3f, \"frames_run\": %u, "
        "\"quiet\": %s, "
        "\"bytes_to_quiet\": %llu, \"first_frame_ssim\": %.5f, \"ssim\": [",
        c.from_view, c.to_view, c.threshold, c.frames_to_threshold,
        static_cast<unsigned long long>(c.bytes_to_threshold), c.tiles_to_threshold, c.seconds_to_threshold,
        c.frames_run, c.quiet ? "true" : "false", static_cast<unsigned long long>(c.bytes_to_quiet), c.first_ssim);
    o << b;
    for (size_t i = 0; i < c.ssim.size(); ++i) o << (i ? ", " : "") << detail_report::fmt(c.ssim[i]);
    o << "]},\n";
  }
  o << "  \"material_swaps\": {\"planned\": " << r.planned_swaps << ", \"swaps\": [";
  for (size_t i = 0; i < r.swaps.size(); ++i) {
    const SwapRecord& w = r.swaps[i];
    std::snprintf(b, sizeof b,
                  "%s\n    {\"slot\": %u, \"material\": \"%s\", \"added_id\": %u, \"removed_id\": %u, "
                  "\"first_texture\": %u, \"added_frame\": %u, \"shown_frame\": %lld, \"released_frame\": %lld, "
                  "\"bytes_until_shown\": %llu}",
                  i ? "," : "", w.slot, w.demo < r.material_names.size() ? r.material_names[w.demo].c_str() : "?",
                  w.added_id, w.removed_id, w.first_texture, w.added_frame, static_cast<long long>(w.shown_frame),
                  static_cast<long long>(w.released_frame), static_cast<unsigned long long>(w.bytes_until_shown));
    o << b;
  }
  o << (r.swaps.empty() ? "" : "\n  ") << "]},\n";
  o << "  \"frames\": [\n";
  for (size_t i = 0; i < r.frames.size(); ++i) {
    const FrameRecord& f = r.frames[i];
    std::snprintf(
        b, sizeof b,
        "    {\"frame\": %u, \"bytes_received\": %llu, \"tiles_delivered\": %u, \"occupancy\": %.4f, \"ssim\": %.5f, "
        "\"rmse\": %.6f, \"ms_bsvtf\": %.3f, \"ms_fmf\": %.3f, \"requests\": %u, \"uploads\": %u, "
        "\"page_table_writes\": %u, \"swaps\": %u, \"lod_bias\": %u, \"settle\": %s}%s\n",
        f.frame, static_cast<unsigned long long>(f.bytes_received), f.tiles_delivered, f.occupancy, f.ssim, f.rmse,
        f.ms_bsvtf, f.ms_fmf, f.requests, f.uploads, f.page_table_writes, f.swaps, f.lod_bias,
        f.settle ? "true" : "false", i + 1 < r.frames.size() ? "," : "");
    o << b;
  }
  o << "  ]\n}\n";
  if (!o) return make_error(Status::io_error, "%s: write failed", path.c_str());
  return {};
}

/// Writes DIR/report.html with the four plots and a short table.
inline VoidResult write_report_html(const std::string& path, const RunSummary& r) {
  using detail_report::Series;
  std::vector<double> frame, mb, ssim, occ, rmse, tb, tf;
  for (const FrameRecord& f : r.frames) {
    frame.push_back(f.frame);
    mb.push_back(static_cast<double>(f.bytes_received) / 1048576.0);
    ssim.push_back(f.ssim);
    occ.push_back(100.0 * f.occupancy);
    rmse.push_back(f.rmse);
    tb.push_back(f.ms_bsvtf);
    tf.push_back(f.ms_fmf);
  }
  const RunSummary::FrameTimes ft = r.frame_times();
  std::ostringstream h;
  h << "<!doctype html><html><head><meta charset='utf-8'><title>btflod demo report</title>"
       "<style>body{font-family:sans-serif;max-width:1180px;margin:20px auto;color:#222}"
       "div.g{display:flex;flex-wrap:wrap;gap:16px}td,th{padding:2px 10px;text-align:left}</style></head><body>\n";
  h << "<h1>btflod demo: streaming BTF fly-through</h1>\n<p>Backend: <b>" << r.backend << "</b>. " << r.materials
    << " synthesised materials (" << r.texels << "² texels, " << r.directions << "×" << r.directions
    << " directions, FMF C = " << detail_report::ranks(r) << ", T = " << r.tile_size << " + " << r.border
    << "-texel border; profile " << r.profile << "), " << r.frames.size() << " frames at " << r.width << "×" << r.height
    << ", cache of " << r.slots << " slots for " << r.tiles << " tiles, tiles streamed through a throttled link of "
    << detail_report::fmt(r.bytes_per_second / 1024.0) << " KiB/s (" << detail_report::fmt(r.payload_bytes / 1024.0)
    << " KiB of tiles in all). Command: <code>" << r.command << "</code></p>\n";
  h << "<table><tr><th>figure</th><th>BSVTF</th><th>FMF</th><th>ratio</th></tr>";
  char row[512];
  std::snprintf(row, sizeof row, "<tr><td>texture memory</td><td>%.1f KiB</td><td>%.1f KiB</td><td>%.1f %%</td></tr>",
                r.memory.bsvtf_bytes / 1024.0, r.memory.fmf_bytes / 1024.0,
                r.memory.fmf_bytes ? 100.0 * r.memory.bsvtf_bytes / r.memory.fmf_bytes : 0.0);
  h << row;
  std::snprintf(row, sizeof row,
                "<tr><td>median frame time (%zu frames, both programs every frame, alternating order)</td>"
                "<td>%.2f ms (incl. feedback words from the %s)</td><td>%.2f ms</td>"
                "<td>BSVTF at %.2f× the FMF frame rate (median per-frame ratio; quartiles %.2f–%.2f)</td></tr>",
                ft.frames, ft.ms_bsvtf, r.feedback_words.c_str(), ft.ms_fmf, ft.ratio, ft.ratio_q1, ft.ratio_q3);
  h << row;
  std::snprintf(row, sizeof row,
                "<tr><td>GPU page-table texels written</td><td>%llu (cache deltas; %u full rewrite(s))</td>"
                "<td>%llu per frame if rewritten whole</td><td>check vs rebuild: %s</td></tr>",
                static_cast<unsigned long long>(r.page_table_writes), r.full_rewrites,
                static_cast<unsigned long long>(r.full_page_table_size), r.page_table_check.c_str());
  h << row;
  std::snprintf(row, sizeof row, "<tr><td>final SSIM vs FMF render</td><td>%.4f</td><td>1</td><td></td></tr></table>\n",
                r.frames.empty() ? 0.0 : r.frames.back().ssim);
  h << row;
  h << "<div class='g'>\n";
  h << detail_report::line_chart("SSIM vs converged (FMF) image", "MiB of tiles received", "SSIM",
                                 {Series{"BSVTF frame", "#1f77b4", mb, ssim}}, std::min(0.0, 0.0));
  h << detail_report::line_chart("Cache occupancy per frame", "frame", "% of slots used",
                                 {Series{"occupancy", "#2ca02c", frame, occ}});
  h << detail_report::line_chart("Error per frame (RMSE vs FMF)", "frame", "RMSE (linear radiance)",
                                 {Series{"RMSE", "#d62728", frame, rmse}});
  h << detail_report::line_chart(
      "Frame time, same view", "frame", "ms",
      {Series{"BSVTF (+feedback)", "#1f77b4", frame, tb}, Series{"FMF", "#ff7f0e", frame, tf}});
  h << detail_report::bar_chart("Texture memory", "KiB",
                                {{"FMF (V' RGBA32F + mips)", r.memory.fmf_bytes / 1024.0, "#ff7f0e"},
                                 {"BSVTF (cache + page table)", r.memory.bsvtf_bytes / 1024.0, "#1f77b4"}});
  h << "</div>\n<p><img src='contact_sheet_frames.png' alt='frames'></p>\n";
  h << detail_report::raw_and_paper_html(r);
  h << "<p>Materials:";
  for (size_t i = 0; i < r.material_names.size(); ++i)
    h << " " << r.material_names[i]
      << " (FMF C = " << (i < r.material_components.size() ? r.material_components[i] : r.components)
      << ", relative error " << detail_report::fmt(r.fmf_errors[i]) << ")";
  h << ".</p></body></html>\n";
  std::ofstream o(path, std::ios::binary | std::ios::trunc);
  o << h.str();
  if (!o) return make_error(Status::io_error, "%s: cannot write", path.c_str());
  return {};
}

/// A contact sheet of up to 12 frames (every n-th), each at half size, 4 per row.
inline VoidResult write_frame_sheet(const std::string& path, const std::vector<Image<float>>& frames) {
  if (frames.empty()) return {};
  const int cols = 4, rows = static_cast<int>((frames.size() + 3) / 4);
  const int w = frames[0].width() / 2, h = frames[0].height() / 2, gap = 4;
  Image<float> sheet(cols * (w + gap) + gap, rows * (h + gap) + gap, 3, 1.0f);
  for (size_t i = 0; i < frames.size(); ++i) {
    const int x0 = gap + static_cast<int>(i % 4) * (w + gap), y0 = gap + static_cast<int>(i / 4) * (h + gap);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c)
          sheet.at(x0 + x, y0 + y, c) =
              0.25f * (frames[i].at(2 * x, 2 * y, c) + frames[i].at(2 * x + 1, 2 * y, c) +
                       frames[i].at(2 * x, 2 * y + 1, c) + frames[i].at(2 * x + 1, 2 * y + 1, c));
  }
  return write_png_srgb(path, sheet.view());
}

}  // namespace btflod::demo
