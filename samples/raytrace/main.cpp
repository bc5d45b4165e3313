// btflod-raytrace — paper 003's interactive ray tracer with BTF materials (§4) on the CPU with
// Intel Embree 3: point lights with shadow rays, progressive area lights (eq. 4–5) and ambient
// occlusion (eq. 6–7), mirror reflections, any btflod representation per material, tiles
// rendered in parallel (the image does not depend on the thread count). It renders the demo's
// fly-through and a Cornell-like box, measures convergence against a many-sample reference and
// the scalability of paper 003 Fig. 6, and writes PNG frames, a contact sheet, report.json and
// report.html (inline SVG plots). `--check` runs the self-checks CTest uses.
//
//   btflod-raytrace --out DIR [--size 128] [--threads 2] [--seed 1] [--path-frames 12]
//                   [--still-frames 64] [--reference-frames 1024] [--convergence-frames 256]
//                   [--max-triangles 1000000] [--timing-frames 3] [--material-size 32]
//                   [--quick] [--check] [--no-scaling]
#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "btflod/core/thread_pool.hpp"
#include "btflod/offline/btf/image_io.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"
#include "btflod/offline/render/integrator.hpp"
#include "common/arguments.hpp"
#include "embree_tracer.hpp"
#include "raytrace_scenes.hpp"
#include "report.hpp"

namespace btflod::raytrace {
namespace {

using Clock = std::chrono::steady_clock;

struct Options {
  std::string out = "raytrace_out";
  uint32_t size = 128;
  unsigned threads = 2;
  uint64_t seed = 1;
  uint32_t path_frames = 12;
  uint32_t still_frames = 64;
  uint32_t reference_frames = 1024;
  uint32_t convergence_frames = 256;
  size_t max_triangles = 1000000;
  uint32_t timing_frames = 3;
  int material_size = 32;
  bool check = false;
  bool scaling = true;
};

// Parses argv (the samples' parser); nullopt after printing the problems. --quick sets small
// defaults that explicit options still override.
std::optional<Options> parse_options(int argc, char** argv) {
  Options o;
  samples::Arguments args("btflod-raytrace", argc, argv);
  if (args.flag("quick")) {
    o.size = 48, o.path_frames = 4, o.still_frames = 8, o.reference_frames = 64, o.convergence_frames = 16;
    o.max_triangles = 20000, o.timing_frames = 1, o.material_size = 16;
  }
  o.out = args.string("out", o.out);
  o.size = args.integer_as("size", o.size, 8, 4096);
  o.threads = args.integer_as("threads", o.threads, 1, 256);
  o.seed = args.unsigned_integer("seed", o.seed);
  o.path_frames = args.integer_as("path-frames", o.path_frames, 1, 10000);
  o.still_frames = args.integer_as("still-frames", o.still_frames, 1, 100000);
  o.reference_frames = args.integer_as("reference-frames", o.reference_frames, 4, 100000);
  o.convergence_frames = args.integer_as("convergence-frames", o.convergence_frames, 4, 100000);
  o.max_triangles = args.integer_as("max-triangles", o.max_triangles, 1000, 100000000);
  o.timing_frames = args.integer_as("timing-frames", o.timing_frames, 1, 1000);
  o.material_size = args.integer_as("material-size", o.material_size, 4, 256);
  o.check = args.flag("check");
  if (args.flag("no-scaling")) o.scaling = false;
  if (!args.finish(0)) return std::nullopt;
  return o;
}

// ---------------------------------------------------------------------------------------------
// Rendering frames over tiles.

/// Renders frames over 16 × 16 tiles on `threads` threads (the pool's workers plus the caller).
/// Per-tile ray counts are summed in tile order, so every figure is deterministic.
class FrameRenderer {
 public:
  explicit FrameRenderer(unsigned threads) : threads_(threads), pool_(threads > 1 ? threads - 1 : 1) {}

  /// One progressive frame: begin_frame(keys), every tile, end_frame(). Returns the rays traced.
  RayCounts frame(const RenderScene& scene, const EmbreeTracer& tracer, const PinholeCamera& cam,
                  const RenderSettings& settings, ProgressiveAccumulator& acc, const SceneKeys& keys,
                  ResetReason* reason = nullptr) {
    const ResetReason r = acc.begin_frame(keys);
    if (reason != nullptr) *reason = r;
    const uint32_t tx = (cam.width + kTile - 1) / kTile, ty = (cam.height + kTile - 1) / kTile;
    tile_counts_.assign(static_cast<size_t>(tx) * ty, RayCounts{});
    const auto body = [&](size_t begin, size_t end) {
      for (size_t t = begin; t < end; ++t) {
        const uint32_t x0 = static_cast<uint32_t>(t % tx) * kTile, y0 = static_cast<uint32_t>(t / tx) * kTile;
        render_pixels(scene, tracer, cam, settings, acc, x0, y0, std::min(x0 + kTile, cam.width),
                      std::min(y0 + kTile, cam.height), tile_counts_[t]);
      }
    };
    if (threads_ <= 1)
      body(0, tile_counts_.size());
    else
      pool_.parallel_for(0, tile_counts_.size(), 1, body);
    acc.end_frame();
    RayCounts total;
    for (const RayCounts& c : tile_counts_) total += c;
    return total;
  }

  /// Embree's raw rate: the primary rays of `cam` through rtcIntersect1 only (no shading),
  /// `passes` times, same tiles and threads. Returns rays per second.
  double raw_intersect_rate(const EmbreeTracer& tracer, const PinholeCamera& cam, uint32_t passes) {
    const uint32_t tx = (cam.width + kTile - 1) / kTile, ty = (cam.height + kTile - 1) / kTile;
    std::vector<uint32_t> hits(static_cast<size_t>(tx) * ty, 0);
    const auto body = [&](size_t begin, size_t end) {
      for (size_t t = begin; t < end; ++t) {
        const uint32_t x0 = static_cast<uint32_t>(t % tx) * kTile, y0 = static_cast<uint32_t>(t / tx) * kTile;
        for (uint32_t y = y0; y < std::min(y0 + kTile, cam.height); ++y)
          for (uint32_t x = x0; x < std::min(x0 + kTile, cam.width); ++x)
            hits[t] +=
                tracer.intersect(cam.ray(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f)).hit ? 1 : 0;
      }
    };
    const auto t0 = Clock::now();
    for (uint32_t p = 0; p < passes; ++p) {
      if (threads_ <= 1)
        body(0, hits.size());
      else
        pool_.parallel_for(0, hits.size(), 1, body);
    }
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    return static_cast<double>(cam.width) * cam.height * passes / std::max(s, 1e-9);
  }

 private:
  static constexpr uint32_t kTile = 16;
  unsigned threads_;
  ThreadPool pool_;
  std::vector<RayCounts> tile_counts_;
};

SceneKeys keys_for(const OwnedScene& s, const PinholeCamera& cam, bool moving) {
  // A moving camera renders at interactive quality; stopping must restart the sums too.
  return SceneKeys{hash_camera(cam) ^ (moving ? 0x6A09E667F3BCC909ull : 0), s.geometry_key,
                   hash_light_geometry(s.points, s.areas)};
}

Image<float> resolve(const OwnedScene& s, const ProgressiveAccumulator& acc) {
  Image<float> img(static_cast<int>(acc.width()), static_cast<int>(acc.height()), 3);
  acc.resolve(s.areas, s.ambient, img.view());
  return img;
}

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// ---------------------------------------------------------------------------------------------
// Materials.

struct Materials {
  std::vector<NamedBtf> btfs;  ///< 0 stone/fmf, 1 cloth/pca-k, 2 leather/laplacian, 3 tiles/lpca,
                               ///< 4.. stone in pca-k, laplacian, lpca, spmm (per-representation runs)
  double seconds = 0;

  /// SurfaceMaterials: the four mixed BTFs then a mirror (index 4).
  std::vector<SurfaceMaterial> mixed() const {
    std::vector<SurfaceMaterial> m;
    for (int i = 0; i < 4; ++i) m.push_back(SurfaceMaterial::textured(*btfs[static_cast<size_t>(i)].material));
    m.push_back(SurfaceMaterial::mirror(glm::vec3(0.85f)));
    return m;
  }
  /// Stone in representation r on every BTF slot, then the mirror.
  std::vector<SurfaceMaterial> stone(Representation r) const {
    const NamedBtf* b = &btfs[0];
    for (const NamedBtf& n : btfs)
      if (n.name.rfind("stone/", 0) == 0 && n.representation == r) b = &n;
    std::vector<SurfaceMaterial> m(4, SurfaceMaterial::textured(*b->material));
    m.push_back(SurfaceMaterial::mirror(glm::vec3(0.85f)));
    return m;
  }
};

Result<Materials> prepare_materials(const Options& o) {
  Materials m;
  const auto t0 = Clock::now();
  const SynthMaterial kinds[4] = {SynthMaterial::stone, SynthMaterial::cloth, SynthMaterial::leather,
                                  SynthMaterial::tiles};
  for (int i = 0; i < 4; ++i) {
    auto b = make_btf(kinds[i], kAllRepresentations[i], o.material_size, o.seed + static_cast<uint64_t>(i));
    if (!b) return b.error();
    m.btfs.push_back(std::move(*b));
  }
  for (size_t i = 1; i < std::size(kAllRepresentations); ++i) {
    auto b = make_btf(SynthMaterial::stone, kAllRepresentations[i], o.material_size, o.seed);
    if (!b) return b.error();
    m.btfs.push_back(std::move(*b));
  }
  m.seconds = seconds_since(t0);
  return m;
}

// ---------------------------------------------------------------------------------------------
// Experiments.

struct FrameRecord {
  std::string name;
  double ms = 0;
  uint64_t rays = 0;
  uint32_t accumulated = 0;
  std::string reset;
};

const char* reset_name(ResetReason r) {
  switch (r) {
    case ResetReason::none:
      return "none";
    case ResetReason::first_frame:
      return "first";
    case ResetReason::camera:
      return "camera";
    case ResetReason::geometry:
      return "geometry";
    case ResetReason::light_position:
      return "light-position";
  }
  return "?";
}

struct ConvergenceCurve {
  std::string term;
  std::vector<double> frames, rmse, ssim;
  double reference_seconds = 0;
};

/// RMSE and SSIM against a `reference_frames`-sample reference (another seed) after 1, 2, 4, …
/// accumulated frames, for one progressive term of the Cornell box.
Result<ConvergenceCurve> convergence(const Options& o, const Materials& mats, FrameRenderer& fr, bool area_term,
                                     uint32_t size, uint32_t reference_frames, uint32_t max_frames) {
  OwnedScene s =
      cornell_box({SurfaceMaterial::textured(*mats.btfs[3].material), SurfaceMaterial::textured(*mats.btfs[1].material),
                   SurfaceMaterial::textured(*mats.btfs[2].material), SurfaceMaterial::mirror(glm::vec3(0.85f))},
                  0, 1, 2, 3);
  if (!area_term) s.ambient.radiance = glm::vec3(1.0f);
  auto tracer = EmbreeTracer::build(s.meshes, o.threads);
  if (!tracer) return tracer.error();
  const PinholeCamera cam = cornell_camera(size, size);
  RenderSettings rs;
  rs.area_lights = area_term;
  rs.ambient_occlusion = !area_term;
  ConvergenceCurve c;
  c.term = area_term ? "area light" : "ambient occlusion";
  ProgressiveAccumulator ref, acc;
  if (auto a = ref.allocate(size, size, 1); !a) return a.error();
  if (auto a = acc.allocate(size, size, 1); !a) return a.error();
  RenderSettings rs_ref = rs;
  rs_ref.seed = o.seed + 1000003;
  const auto t0 = Clock::now();
  for (uint32_t f = 0; f < reference_frames; ++f)
    fr.frame(s.view(), **tracer, cam, rs_ref, ref, keys_for(s, cam, false));
  c.reference_seconds = seconds_since(t0);
  const Image<float> reference = resolve(s, ref);
  rs.seed = o.seed;
  uint32_t next = 1;
  for (uint32_t f = 1; f <= max_frames; ++f) {
    fr.frame(s.view(), **tracer, cam, rs, acc, keys_for(s, cam, false));
    if (f == next) {
      const Image<float> img = resolve(s, acc);
      c.frames.push_back(f);
      c.rmse.push_back(rmse(img.view(), reference.view()));
      c.ssim.push_back(mean_ssim(img.view(), reference.view()));
      next *= 2;
    }
  }
  return c;
}

struct ScalingPoint {
  double x = 0;
  std::string label;
  double ms = 0;
  uint64_t rays = 0;
  size_t triangles = 0;
  double build_ms = 0;
  double btf_share = 0;
};

/// Fastest frame time (full quality, fixed camera) of `frames` progressive frames after one
/// warm-up frame; also the share of pixels whose primary hit is a BTF.
Result<ScalingPoint> time_scene(const Options& o, FrameRenderer& fr, const OwnedScene& s, const RenderSettings& rs,
                                double x, std::string label) {
  ScalingPoint p;
  p.x = x;
  p.label = std::move(label);
  p.triangles = s.triangle_count();
  const auto tb = Clock::now();
  auto tracer = EmbreeTracer::build(s.meshes, o.threads);
  if (!tracer) return tracer.error();
  p.build_ms = 1e3 * seconds_since(tb);
  const PinholeCamera cam = path_camera(0, 2, o.size, o.size);
  ProgressiveAccumulator acc;
  if (auto a = acc.allocate(o.size, o.size, static_cast<uint32_t>(s.areas.size())); !a) return a.error();
  fr.frame(s.view(), **tracer, cam, rs, acc, keys_for(s, cam, false));  // warm-up
  std::vector<double> ms;
  for (uint32_t f = 0; f < o.timing_frames; ++f) {
    const auto t0 = Clock::now();
    p.rays = fr.frame(s.view(), **tracer, cam, rs, acc, keys_for(s, cam, false)).total();
    ms.push_back(1e3 * seconds_since(t0));
  }
  p.ms = *std::min_element(ms.begin(), ms.end());  // load from other processes only adds time
  uint64_t btf = 0;
  for (uint32_t y = 0; y < cam.height; ++y)
    for (uint32_t x2 = 0; x2 < cam.width; ++x2) {
      const TraceHit h = (*tracer)->intersect(cam.ray(static_cast<float>(x2) + 0.5f, static_cast<float>(y) + 0.5f));
      if (h.hit && s.materials[s.meshes[h.mesh].material].kind == SurfaceMaterial::Kind::btf) ++btf;
    }
  p.btf_share = static_cast<double>(btf) / (static_cast<double>(cam.width) * cam.height);
  return p;
}

struct Scaling {
  std::vector<ScalingPoint> lights, triangles, materials, share, representations;
  double full_rays_per_second = 0, raw_rays_per_second = 0;
  uint64_t full_frame_rays = 0;
  double full_frame_ms = 0;
};

Result<Scaling> scalability(const Options& o, const Materials& mats, FrameRenderer& fr) {
  Scaling sc;
  uint32_t seg = 96, sides = 48;
  RenderSettings full;
  full.seed = o.seed;
  // Point lights 1–8, area light and AO off (the per-light cost alone).
  RenderSettings points_only = full;
  points_only.area_lights = false;
  points_only.ambient_occlusion = false;
  for (uint32_t n = 1; n <= 8; ++n) {
    auto p = time_scene(o, fr, demo_scene(mats.mixed(), 4, seg, sides, n), points_only, n, std::to_string(n));
    if (!p) return p.error();
    std::printf("  point lights %u: %.2f ms\n", n, p->ms);
    sc.lights.push_back(*p);
  }
  // Triangles 10k–1M (the tori's tessellation), full model with 2 point lights.
  for (size_t t : {size_t{10000}, size_t{30000}, size_t{100000}, size_t{300000}, size_t{1000000}}) {
    if (t > o.max_triangles) break;
    torus_tessellation(t, seg, sides);
    auto p =
        time_scene(o, fr, demo_scene(mats.mixed(), 4, seg, sides, 2), full, static_cast<double>(t), std::to_string(t));
    if (!p) return p.error();
    std::printf("  triangles %zu: %.2f ms (BVH build %.1f ms)\n", p->triangles, p->ms, p->build_ms);
    sc.triangles.push_back(*p);
  }
  seg = 96, sides = 48;
  // Visible BTF materials 1–4: the same geometry, slot i shows BTF i mod k.
  for (uint32_t k = 1; k <= 4; ++k) {
    std::vector<SurfaceMaterial> m = mats.mixed();
    for (uint32_t i = 0; i < 4; ++i) m[i] = m[i % k];
    auto p = time_scene(o, fr, demo_scene(m, 4, seg, sides, 2), full, k, std::to_string(k));
    if (!p) return p.error();
    std::printf("  visible materials %u: %.2f ms\n", k, p->ms);
    sc.materials.push_back(*p);
  }
  // Share of BTF pixels: none, tori only, ground only, all.
  const char* share_names[] = {"none", "tori", "ground", "all"};
  for (int cfg = 0; cfg < 4; ++cfg) {
    std::vector<SurfaceMaterial> m = mats.mixed();
    const SurfaceMaterial grey = SurfaceMaterial::lambertian(glm::vec3(0.5f));
    if (cfg == 0 || cfg == 2) m[1] = m[2] = m[3] = grey;
    if (cfg == 0 || cfg == 1) m[0] = grey;
    auto p = time_scene(o, fr, demo_scene(m, 4, seg, sides, 2), full, cfg, share_names[cfg]);
    if (!p) return p.error();
    p->x = p->btf_share;
    std::printf("  BTF share %s (%.0f%%): %.2f ms\n", share_names[cfg], 100 * p->btf_share, p->ms);
    sc.share.push_back(*p);
  }
  // Frame time per representation: stone in each representation on every BTF slot.
  for (Representation r : kAllRepresentations) {
    auto p = time_scene(o, fr, demo_scene(mats.stone(r), 4, seg, sides, 2), full, 0, representation_name(r));
    if (!p) return p.error();
    std::printf("  representation %s: %.2f ms\n", representation_name(r), p->ms);
    sc.representations.push_back(*p);
  }
  {
    std::vector<SurfaceMaterial> m(4, SurfaceMaterial::lambertian(glm::vec3(0.5f)));
    m.push_back(SurfaceMaterial::mirror(glm::vec3(0.85f)));
    auto p = time_scene(o, fr, demo_scene(m, 4, seg, sides, 2), full, 0, "lambertian");
    if (!p) return p.error();
    std::printf("  no BTF (Lambertian): %.2f ms\n", p->ms);
    sc.representations.push_back(*p);
  }
  // Rays per second of full frames next to Embree's raw rtcIntersect1 rate on the same scene.
  {
    const OwnedScene s = demo_scene(mats.mixed(), 4, seg, sides, 2);
    auto tracer = EmbreeTracer::build(s.meshes, o.threads);
    if (!tracer) return tracer.error();
    const PinholeCamera cam = path_camera(0, 2, o.size, o.size);
    ProgressiveAccumulator acc;
    if (auto a = acc.allocate(o.size, o.size, 1); !a) return a.error();
    fr.frame(s.view(), **tracer, cam, full, acc, keys_for(s, cam, false));
    const uint32_t n = std::max<uint32_t>(4, o.timing_frames * 2);
    uint64_t rays = 0;
    const auto t0 = Clock::now();
    for (uint32_t f = 0; f < n; ++f)
      rays += fr.frame(s.view(), **tracer, cam, full, acc, keys_for(s, cam, false)).total();
    const double secs = seconds_since(t0);
    sc.full_rays_per_second = static_cast<double>(rays) / secs;
    sc.full_frame_rays = rays / n;
    sc.full_frame_ms = 1e3 * secs / n;
    sc.raw_rays_per_second = fr.raw_intersect_rate(**tracer, cam, n * 3);
    std::printf("  rays/s: full frames %.3g, Embree rtcIntersect1 alone %.3g (%.2fx)\n", sc.full_rays_per_second,
                sc.raw_rays_per_second, sc.raw_rays_per_second / sc.full_rays_per_second);
  }
  return sc;
}

// ---------------------------------------------------------------------------------------------
// Report.

void json_points(std::ostream& j, const char* name, const std::vector<ScalingPoint>& v, bool last = false) {
  j << "  \"" << name << "\": [";
  for (size_t i = 0; i < v.size(); ++i)
    j << (i ? ", " : "") << "{\"x\": " << v[i].x << ", \"label\": \"" << v[i].label << "\", \"ms\": " << v[i].ms
      << ", \"rays\": " << v[i].rays << ", \"triangles\": " << v[i].triangles << ", \"build_ms\": " << v[i].build_ms
      << ", \"btf_share\": " << v[i].btf_share << "}";
  j << "]" << (last ? "\n" : ",\n");
}

demo::detail_report::Series series(const std::string& name, const std::string& color,
                                   const std::vector<ScalingPoint>& v, bool log_x = false) {
  demo::detail_report::Series s{name, color, {}, {}};
  for (const auto& p : v) s.x.push_back(log_x ? std::log10(p.x) : p.x), s.y.push_back(p.ms);
  return s;
}

VoidResult write_report(const Options& o, const Materials& mats, const std::vector<FrameRecord>& frames,
                        const std::vector<ConvergenceCurve>& conv, const Scaling* sc,
                        const std::vector<FrameRecord>& events) {
  std::ostringstream j;
  j << "{\n  \"size\": " << o.size << ", \"threads\": " << o.threads << ", \"seed\": " << o.seed
    << ", \"material_size\": " << o.material_size << ", \"material_seconds\": " << mats.seconds << ",\n";
  j << "  \"materials\": [";
  for (size_t i = 0; i < mats.btfs.size(); ++i) j << (i ? ", " : "") << "\"" << mats.btfs[i].name << "\"";
  j << "],\n  \"frames\": [";
  for (size_t i = 0; i < frames.size(); ++i)
    j << (i ? ",\n    " : "\n    ") << "{\"name\": \"" << frames[i].name << "\", \"ms\": " << frames[i].ms
      << ", \"rays\": " << frames[i].rays << ", \"accumulated\": " << frames[i].accumulated << ", \"reset\": \""
      << frames[i].reset << "\"}";
  j << "],\n  \"reset_events\": [";
  for (size_t i = 0; i < events.size(); ++i)
    j << (i ? ", " : "") << "{\"event\": \"" << events[i].name << "\", \"reset\": \"" << events[i].reset
      << "\", \"accumulated\": " << events[i].accumulated << "}";
  j << "],\n  \"convergence\": [";
  for (size_t i = 0; i < conv.size(); ++i) {
    j << (i ? ",\n    " : "\n    ") << "{\"term\": \"" << conv[i].term
      << "\", \"reference_frames\": " << o.reference_frames << ", \"reference_seconds\": " << conv[i].reference_seconds
      << ", \"points\": [";
    for (size_t k = 0; k < conv[i].frames.size(); ++k)
      j << (k ? ", " : "") << "{\"frames\": " << conv[i].frames[k] << ", \"rmse\": " << conv[i].rmse[k]
        << ", \"ssim\": " << conv[i].ssim[k] << "}";
    j << "]}";
  }
  j << "]";
  if (sc != nullptr) {
    j << ",\n  \"scaling\": {\n";
    json_points(j, "point_lights", sc->lights);
    json_points(j, "triangles", sc->triangles);
    json_points(j, "visible_materials", sc->materials);
    json_points(j, "btf_share", sc->share);
    json_points(j, "representations", sc->representations);
    j << "  \"full_frame_ms\": " << sc->full_frame_ms << ", \"full_frame_rays\": " << sc->full_frame_rays
      << ", \"full_rays_per_second\": " << sc->full_rays_per_second
      << ", \"embree_raw_rays_per_second\": " << sc->raw_rays_per_second
      << ", \"shading_overhead_ratio\": " << sc->raw_rays_per_second / sc->full_rays_per_second << "\n  }";
  }
  j << "\n}\n";
  const std::string jp = (std::filesystem::path(o.out) / "report.json").string();
  {
    std::ofstream f(jp);
    f << j.str();
    if (!f) return make_error(Status::io_error, "cannot write %s", jp.c_str());
  }

  using demo::detail_report::line_chart;
  using demo::detail_report::Series;
  std::ostringstream h;
  h << "<!doctype html><html><head><meta charset='utf-8'><title>btflod-raytrace</title>"
    << "<style>body{font-family:sans-serif;max-width:1200px;margin:20px auto}img{image-rendering:pixelated}"
    << "td,th{padding:2px 8px;text-align:right}</style></head><body>\n";
  h << "<h1>btflod-raytrace</h1><p>Paper 003 §4 on the CPU with Embree: " << o.size << "×" << o.size << " pixels, "
    << o.threads << " threads, seed " << o.seed << ". Materials (" << o.material_size
    << "² texels, 23×23 directions): ";
  for (size_t i = 0; i < mats.btfs.size(); ++i) h << (i ? ", " : "") << mats.btfs[i].name;
  h << ".</p>\n<h2>Frames</h2><p><img src='contact_sheet.png'></p><p><img src='cornell_64.png' width='" << 2 * o.size
    << "'> <img src='still_final.png' width='" << 2 * o.size << "'></p>\n";
  if (!conv.empty()) {
    std::vector<Series> rm, ss;
    const char* colors[] = {"#d62728", "#1f77b4"};
    for (size_t i = 0; i < conv.size(); ++i) {
      Series a{conv[i].term, colors[i % 2], {}, {}}, b{conv[i].term, colors[i % 2], {}, {}};
      for (size_t k = 0; k < conv[i].frames.size(); ++k) {
        a.x.push_back(std::log2(conv[i].frames[k]));
        a.y.push_back(conv[i].rmse[k]);
        b.x.push_back(std::log2(conv[i].frames[k]));
        b.y.push_back(conv[i].ssim[k]);
      }
      rm.push_back(a), ss.push_back(b);
    }
    h << "<h2>Convergence (Cornell box, vs " << o.reference_frames << "-frame reference)</h2>\n"
      << line_chart("RMSE vs accumulated frames", "log2(frames)", "RMSE", rm)
      << line_chart("SSIM vs accumulated frames", "log2(frames)", "SSIM", ss) << "\n<table><tr><th>term</th>";
    for (double f : conv[0].frames) h << "<th>" << f << "</th>";
    h << "</tr>";
    for (const auto& c : conv) {
      h << "<tr><td>" << c.term << " RMSE</td>";
      for (double v : c.rmse) h << "<td>" << demo::detail_report::fmt(v) << "</td>";
      h << "</tr><tr><td>" << c.term << " SSIM</td>";
      for (double v : c.ssim) h << "<td>" << demo::detail_report::fmt(v) << "</td>";
      h << "</tr>";
    }
    h << "</table>\n";
  }
  if (sc != nullptr) {
    h << "<h2>Scalability (paper 003 Fig. 6)</h2>\n"
      << line_chart("frame time vs point lights", "point lights", "ms", {series("point lights", "#1f77b4", sc->lights)})
      << line_chart("frame time vs triangles", "log10(triangles)", "ms",
                    {series("triangles", "#d62728", sc->triangles, true)})
      << line_chart("frame time vs visible BTF materials", "materials", "ms",
                    {series("materials", "#2ca02c", sc->materials)})
      << line_chart("frame time vs share of BTF pixels", "share", "ms", {series("BTF share", "#9467bd", sc->share)});
    std::vector<std::tuple<std::string, double, std::string>> bars;
    for (const auto& p : sc->representations) bars.emplace_back(p.label, p.ms, "#8c564b");
    h << demo::detail_report::bar_chart("frame time per representation (stone, equal resolution)", "ms", bars);
    h << "<p>Rays per second, full frames (shading, all terms): " << demo::detail_report::fmt(sc->full_rays_per_second)
      << "; Embree rtcIntersect1 alone on the same scene and camera: "
      << demo::detail_report::fmt(sc->raw_rays_per_second) << " — ratio "
      << demo::detail_report::fmt(sc->raw_rays_per_second / sc->full_rays_per_second) << ".</p>\n";
  }
  h << "<h2>Accumulation resets</h2><table><tr><th>event</th><th>reset</th><th>N after</th></tr>";
  for (const auto& e : events)
    h << "<tr><td>" << e.name << "</td><td>" << e.reset << "</td><td>" << e.accumulated << "</td></tr>";
  h << "</table></body></html>\n";
  const std::string hp = (std::filesystem::path(o.out) / "report.html").string();
  std::ofstream f(hp);
  f << h.str();
  if (!f) return make_error(Status::io_error, "cannot write %s", hp.c_str());
  return {};
}

// ---------------------------------------------------------------------------------------------
// Runs.

/// The event sequence of §4.1 on the Cornell box: which events reset the accumulation.
Result<std::vector<FrameRecord>> reset_events(const Options& o, const Materials& mats, FrameRenderer& fr,
                                              uint32_t size) {
  OwnedScene s =
      cornell_box({SurfaceMaterial::textured(*mats.btfs[3].material), SurfaceMaterial::textured(*mats.btfs[1].material),
                   SurfaceMaterial::textured(*mats.btfs[2].material), SurfaceMaterial::mirror(glm::vec3(0.85f))},
                  0, 1, 2, 3);
  s.points.push_back(PointLight{{0.6f, 1.6f, 0.6f}, glm::vec3(0.5f)});
  auto tracer = EmbreeTracer::build(s.meshes, o.threads);
  if (!tracer) return tracer.error();
  PinholeCamera cam = cornell_camera(size, size);
  ProgressiveAccumulator acc;
  if (auto a = acc.allocate(size, size, 1); !a) return a.error();
  RenderSettings rs;
  rs.seed = o.seed;
  std::vector<FrameRecord> ev;
  const auto step = [&](const char* name, int frames) {
    for (int f = 0; f < frames; ++f) {
      ResetReason r = ResetReason::none;
      fr.frame(s.view(), **tracer, cam, rs, acc, keys_for(s, cam, false), &r);
      if (f == 0) ev.push_back(FrameRecord{name, 0, 0, 0, reset_name(r)});
    }
    ev.back().accumulated = acc.frames();
  };
  step("start", 4);
  step("nothing changes", 4);
  s.areas[0].radiance *= 2.0f;
  step("area light radiance x2", 4);
  s.points[0].intensity *= 0.5f;
  step("point light intensity x0.5", 4);
  s.ambient.radiance *= 2.0f;
  step("ambient radiance x2", 4);
  s.areas[0].corner.x += 0.05f;
  step("area light moves", 4);
  s.points[0].position.z -= 0.1f;
  step("point light moves", 4);
  cam.eye.x += 0.01f;
  step("camera moves", 4);
  ++s.geometry_key;  // an edit of the geometry (a deformed mesh would bump it)
  step("geometry changes", 4);
  return ev;
}

/// Fly-through of the demo scene then still accumulation at the last view; Cornell box frames.
Result<std::vector<FrameRecord>> render_frames(const Options& o, const Materials& mats, FrameRenderer& fr,
                                               std::vector<Image<float>>& sheet) {
  std::vector<FrameRecord> rec;
  const std::filesystem::path out(o.out);
  OwnedScene s = demo_scene(mats.mixed(), 4, 96, 48, 2);
  if (auto v = validate_render_scene(s.view()); !v) return v.error();
  auto tracer = EmbreeTracer::build(s.meshes, o.threads);
  if (!tracer) return tracer.error();
  ProgressiveAccumulator acc;
  if (auto a = acc.allocate(o.size, o.size, 1); !a) return a.error();
  RenderSettings moving;
  moving.seed = o.seed;
  moving.quality = ShadeQuality::interactive;  // paper 003 §5.4: cheaper shading while moving
  RenderSettings still = moving;
  still.quality = ShadeQuality::full;
  char name[64];
  for (uint32_t f = 0; f < o.path_frames; ++f) {
    const PinholeCamera cam = path_camera(f, o.path_frames, o.size, o.size);
    ResetReason r = ResetReason::none;
    const auto t0 = Clock::now();
    const RayCounts c = fr.frame(s.view(), **tracer, cam, moving, acc, keys_for(s, cam, true), &r);
    const double ms = 1e3 * seconds_since(t0);
    std::snprintf(name, sizeof name, "path_%03u.png", f);
    const Image<float> img = resolve(s, acc);
    if (auto w = write_png_srgb((out / name).string(), img.view()); !w) return w.error();
    rec.push_back(FrameRecord{name, ms, c.total(), acc.frames(), reset_name(r)});
    if (sheet.size() < 8) sheet.push_back(img);
  }
  const PinholeCamera cam = path_camera(o.path_frames - 1, o.path_frames, o.size, o.size);
  for (uint32_t f = 1; f <= o.still_frames; ++f) {
    ResetReason r = ResetReason::none;
    const auto t0 = Clock::now();
    const RayCounts c = fr.frame(s.view(), **tracer, cam, still, acc, keys_for(s, cam, false), &r);
    const double ms = 1e3 * seconds_since(t0);
    const bool keep = (f & (f - 1)) == 0 || f == o.still_frames;
    std::snprintf(name, sizeof name, "still_%04u.png", f);
    if (keep) {
      const Image<float> img = resolve(s, acc);
      if (auto w = write_png_srgb((out / name).string(), img.view()); !w) return w.error();
      if (f == 1 || f == 4 || f == o.still_frames) sheet.push_back(img);
      if (f == o.still_frames)
        if (auto w = write_png_srgb((out / "still_final.png").string(), img.view()); !w) return w.error();
    }
    rec.push_back(FrameRecord{name, ms, c.total(), acc.frames(), reset_name(r)});
  }
  // Cornell box, full model.
  OwnedScene box =
      cornell_box({SurfaceMaterial::textured(*mats.btfs[3].material), SurfaceMaterial::textured(*mats.btfs[1].material),
                   SurfaceMaterial::textured(*mats.btfs[2].material), SurfaceMaterial::mirror(glm::vec3(0.85f))},
                  0, 1, 2, 3);
  auto btracer = EmbreeTracer::build(box.meshes, o.threads);
  if (!btracer) return btracer.error();
  const PinholeCamera bcam = cornell_camera(o.size, o.size);
  ProgressiveAccumulator bacc;
  if (auto a = bacc.allocate(o.size, o.size, 1); !a) return a.error();
  for (uint32_t f = 1; f <= 64; ++f) {
    ResetReason r = ResetReason::none;
    const auto t0 = Clock::now();
    const RayCounts c = fr.frame(box.view(), **btracer, bcam, still, bacc, keys_for(box, bcam, false), &r);
    const double ms = 1e3 * seconds_since(t0);
    std::snprintf(name, sizeof name, "cornell_%u.png", f);
    if (f == 1 || f == 4 || f == 64) {
      const Image<float> img = resolve(box, bacc);
      if (auto w = write_png_srgb((out / name).string(), img.view()); !w) return w.error();
      sheet.push_back(img);
    }
    rec.push_back(FrameRecord{name, ms, c.total(), bacc.frames(), reset_name(r)});
  }
  return rec;
}

// ---------------------------------------------------------------------------------------------
// Self-checks (CTest).

struct Checker {
  int failed = 0;
  void expect(bool ok, const std::string& what) {
    std::printf("check %-58s %s\n", what.c_str(), ok ? "ok" : "FAILED");
    if (!ok) ++failed;
  }
};

int run_checks(const Options& o, const Materials& mats) {
  Checker ck;
  FrameRenderer fr1(1), frn(std::max(2u, o.threads));
  // 1. Embree hits against analytic geometry: a plane and a finely tessellated sphere.
  {
    OwnedScene s;
    s.materials = {SurfaceMaterial::lambertian(glm::vec3(0.5f))};
    const glm::vec3 c(0.3f, 1.2f, -0.2f);
    const float r = 0.9f;
    s.add(make_quad({-3, 0, 3}, {6, 0, 0}, {0, 0, -6}, {1, 1}, 8), 0);
    s.add(make_uv_sphere(c, r, 256, 128), 0);
    auto tracer = EmbreeTracer::build(s.meshes, o.threads);
    ck.expect(static_cast<bool>(tracer), "embree builds the analytic scene");
    if (!tracer) return 1;
    const float tess = r * (1.0f - std::cos(kPi / 128.0f)) * 1.05f;
    const PinholeCamera cam = [&] {
      PinholeCamera k;
      k.eye = {0.5f, 3.0f, 4.0f};
      k.target = c;
      k.width = k.height = o.size;
      return k;
    }();
    int plane_bad = 0, sphere_bad = 0, plane_n = 0, sphere_n = 0;
    for (uint32_t y = 0; y < cam.height; ++y)
      for (uint32_t x = 0; x < cam.width; ++x) {
        const TraceRay ray = cam.ray(x + 0.5f, y + 0.5f);
        const TraceHit h = (*tracer)->intersect(ray);
        if (!h.hit) continue;
        const SurfacePoint p = interpolate_surface(s.meshes[h.mesh], h, ray.direction);
        if (h.mesh == 0) {
          ++plane_n;
          const float t = -ray.origin.y / ray.direction.y;
          plane_bad +=
              (std::abs(h.t - t) > 1e-4f * t || std::abs(p.position.y) > 1e-5f || p.frame.n.y < 0.999999f) ? 1 : 0;
        } else {
          ++sphere_n;
          const glm::vec3 radial = glm::normalize(p.position - c);
          sphere_bad +=
              (std::abs(glm::length(p.position - c) - r) > tess || glm::dot(p.frame.n, radial) < 0.9999f) ? 1 : 0;
        }
      }
    ck.expect(plane_n > 100 && plane_bad == 0,
              "plane hits: exact t, position and normal (" + std::to_string(plane_n) + ")");
    ck.expect(sphere_n > 100 && sphere_bad == 0,
              "sphere hits: on the sphere, normal radial (" + std::to_string(sphere_n) + ")");
  }
  // 2. Embree agrees with the brute-force oracle on the Cornell box.
  const auto box = [&] {
    return cornell_box(
        {SurfaceMaterial::textured(*mats.btfs[3].material), SurfaceMaterial::textured(*mats.btfs[1].material),
         SurfaceMaterial::textured(*mats.btfs[2].material), SurfaceMaterial::mirror(glm::vec3(0.85f))},
        0, 1, 2, 3);
  };
  OwnedScene s = box();
  auto tracer = EmbreeTracer::build(s.meshes, o.threads);
  if (!tracer) return 1;
  {
    const BruteForceTracer brute(s.meshes);
    const PinholeCamera cam = cornell_camera(o.size, o.size);
    int bad = 0;
    for (uint32_t y = 0; y < cam.height; ++y)
      for (uint32_t x = 0; x < cam.width; ++x) {
        const TraceRay ray = cam.ray(x + 0.5f, y + 0.5f);
        const TraceHit a = (*tracer)->intersect(ray), b = brute.intersect(ray);
        bad += (a.hit != b.hit || (a.hit && std::abs(a.t - b.t) > 1e-4f * std::max(1.0f, b.t))) ? 1 : 0;
      }
    ck.expect(bad == 0, "embree closest hits match the brute-force tracer");
  }
  // 3. Bit-identical replays, any thread count.
  {
    const PinholeCamera cam = cornell_camera(o.size, o.size);
    RenderSettings rs;
    rs.seed = o.seed;
    std::vector<Image<float>> imgs;
    for (int run = 0; run < 3; ++run) {
      ProgressiveAccumulator acc;
      (void)acc.allocate(o.size, o.size, 1);
      for (int f = 0; f < 6; ++f)
        (run == 2 ? frn : fr1).frame(s.view(), **tracer, cam, rs, acc, keys_for(s, cam, false));
      imgs.push_back(resolve(s, acc));
    }
    const size_t bytes = imgs[0].size() * sizeof(float);
    ck.expect(std::memcmp(imgs[0].data(), imgs[1].data(), bytes) == 0, "replay is bit-identical");
    ck.expect(std::memcmp(imgs[0].data(), imgs[2].data(), bytes) == 0,
              "1 thread and " + std::to_string(std::max(2u, o.threads)) + " threads give the same bits");
  }
  // 4. Resets exactly on camera, geometry and light-position changes.
  {
    auto ev = reset_events(o, mats, fr1, o.size);
    ck.expect(static_cast<bool>(ev), "reset event sequence renders");
    if (ev) {
      const char* want[] = {"first",          "none",           "none",   "none",    "none",
                            "light-position", "light-position", "camera", "geometry"};
      bool ok = ev->size() == 9;
      for (size_t i = 0; ok && i < 9; ++i) ok = (*ev)[i].reset == want[i];
      ck.expect(ok, "resets on camera/geometry/light position only, not on radiance");
      ck.expect(ok && (*ev)[4].accumulated == 20, "radiance changes keep accumulating (N = 20)");
    }
  }
  // 5. Convergence: RMSE after 64 frames at most 1/3 of RMSE after 4.
  {
    auto c = convergence(o, mats, frn, true, o.size, o.reference_frames, 64);
    if (c && c->frames.size() >= 7) {
      const double e4 = c->rmse[2], e64 = c->rmse[6];
      char b[96];
      std::snprintf(b, sizeof b, "area light rmse(64) %.4g <= rmse(4) %.4g / 3", e64, e4);
      ck.expect(e64 <= e4 / 3.0, b);
    } else {
      ck.expect(false, "convergence run");
    }
    auto a = convergence(o, mats, frn, false, o.size, o.reference_frames, 64);
    if (a && a->frames.size() >= 7) {
      char b[96];
      std::snprintf(b, sizeof b, "AO rmse(64) %.4g <= rmse(4) %.4g / 3", a->rmse[6], a->rmse[2]);
      ck.expect(a->rmse[6] <= a->rmse[2] / 3.0, b);
    } else {
      ck.expect(false, "AO convergence run");
    }
  }
  // 6. Bad geometry is refused before Embree sees it.
  {
    OwnedScene bad = box();
    bad.data[5].vertices[3].position[1] = std::nanf("");
    auto t = EmbreeTracer::build(bad.meshes, 1);
    ck.expect(!t && t.message().find("NaN") != std::string::npos && t.message().find("mesh 5") != std::string::npos,
              "NaN vertex rejected: " + (t ? std::string("accepted") : t.message()));
    OwnedScene degenerate = box();
    degenerate.data[0].indices[1] = degenerate.data[0].indices[0];
    auto d = EmbreeTracer::build(degenerate.meshes, 1);
    ck.expect(!d && d.message().find("degenerate") != std::string::npos,
              "degenerate triangle rejected: " + (d ? std::string("accepted") : d.message()));
  }
  std::printf(ck.failed == 0 ? "checks passed\n" : "checks FAILED (%d)\n", ck.failed);
  return ck.failed == 0 ? 0 : 1;
}

int run(int argc, char** argv) {
  const std::optional<Options> opts = parse_options(argc, argv);
  if (!opts) return 2;
  const Options& o = *opts;
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec) {
    std::fprintf(stderr, "btflod-raytrace: cannot create %s: %s\n", o.out.c_str(), ec.message().c_str());
    return 1;
  }
  const auto t_start = Clock::now();
  auto mats = prepare_materials(o);
  if (!mats) {
    std::fprintf(stderr, "btflod-raytrace: materials: %s\n", mats.message().c_str());
    return 1;
  }
  std::printf("materials: %zu BTFs (%d^2 texels) in %.1f s\n", mats->btfs.size(), o.material_size, mats->seconds);
  if (o.check) return run_checks(o, *mats);

  FrameRenderer fr(o.threads);
  std::vector<Image<float>> sheet;
  auto frames = render_frames(o, *mats, fr, sheet);
  if (!frames) {
    std::fprintf(stderr, "btflod-raytrace: %s\n", frames.message().c_str());
    return 1;
  }
  std::printf("frames: %zu rendered, PNGs in %s (%.1f s)\n", frames->size(), o.out.c_str(), seconds_since(t_start));
  if (auto w = demo::write_frame_sheet((std::filesystem::path(o.out) / "contact_sheet.png").string(), sheet); !w) {
    std::fprintf(stderr, "btflod-raytrace: %s\n", w.message().c_str());
    return 1;
  }
  std::vector<ConvergenceCurve> conv;
  for (bool area : {true, false}) {
    auto c = convergence(o, *mats, fr, area, o.size, o.reference_frames, o.convergence_frames);
    if (!c) {
      std::fprintf(stderr, "btflod-raytrace: %s\n", c.message().c_str());
      return 1;
    }
    std::printf("convergence %s (reference %u frames, %.1f s):", c->term.c_str(), o.reference_frames,
                c->reference_seconds);
    for (size_t k = 0; k < c->frames.size(); ++k) std::printf(" %g:%.4f/%.3f", c->frames[k], c->rmse[k], c->ssim[k]);
    std::printf("\n");
    conv.push_back(std::move(*c));
  }
  auto events = reset_events(o, *mats, fr, std::min<uint32_t>(o.size, 64));
  if (!events) {
    std::fprintf(stderr, "btflod-raytrace: %s\n", events.message().c_str());
    return 1;
  }
  for (const auto& e : *events)
    std::printf("event %-28s reset %-15s N %u\n", e.name.c_str(), e.reset.c_str(), e.accumulated);
  Scaling sc;
  if (o.scaling) {
    std::printf("scalability (%u x %u, fastest of %u frames):\n", o.size, o.size, o.timing_frames);
    auto s = scalability(o, *mats, fr);
    if (!s) {
      std::fprintf(stderr, "btflod-raytrace: %s\n", s.message().c_str());
      return 1;
    }
    sc = std::move(*s);
  }
  if (auto w = write_report(o, *mats, *frames, conv, o.scaling ? &sc : nullptr, *events); !w) {
    std::fprintf(stderr, "btflod-raytrace: %s\n", w.message().c_str());
    return 1;
  }
  std::printf("report written to %s/report.html (%.1f s)\n", o.out.c_str(), seconds_since(t_start));
  return 0;
}

}  // namespace
}  // namespace btflod::raytrace

int main(int argc, char** argv) { return btflod::raytrace::run(argc, argv); }
