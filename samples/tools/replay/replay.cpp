// btflod-replay — replay harness for the sparse virtual texture path (paper 000 §5).
//
// A camera path over a scene of four FMF materials (a plane, a sphere, two tori), each encoded
// into a `.bsvtf` container (offline/build/bsvtf_build.hpp) served from memory. Per frame the CPU reference
// renders the feedback buffer (decimated, rotating sample) and hands it to one btflod::Streamer
// (runtime/streamer.hpp: votes of eq. 9, add/swap within the budgets, decode jobs run by pump());
// its tile uploads go into a CPU copy of the cache, and the ABRDF error E of eq. 7 (against FMF
// with everything resident, uncompressed) is measured on every pixel. A tile requested in one
// update is decoded by pump() and uploaded by the next update. Bytes are the containers' real
// payload bytes. Three strategies run on the same path in one run:
//   weighted    paper 000: P = w·v, swap cost eq. 10           (cache of S slots)
//   votes-only  P = v, cost = v·levels (LibVT/Unreal-style)      (same cache)
//   distance    range-based mip (paper 001 §3.4), no cache limit (every needed tile loaded)
// Eigen-textures are synthetic but shaped like an SVD: component c has amplitude ∝ 1/(c+1), and
// the materials mix smooth and detailed regions, so tiles differ in how much error they remove.
//
// Usage: btflod-replay [--frames N] [--width W] [--height H] [--decimation D] [--texture M]
//                      [--components C] [--slots-x X] [--slots-y Y] [--uploads U]
//                      [--doc docs/vt.md] [--check-determinism]
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "btflod/offline/build/bsvtf_build.hpp"
#include "btflod/offline/build/tile_pyramid.hpp"
#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/runtime/backend/streamer_outputs.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/lod/lod_selector.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"
#include "common/arguments.hpp"
#include "common/doc_block.hpp"
#include "common/hash32.hpp"

using namespace btflod;

namespace {

struct Options {
  uint32_t frames = 120;
  uint32_t width = 320;
  uint32_t height = 180;
  uint32_t decimation = 4;
  uint32_t texture = 512;
  uint32_t components = 16;
  uint32_t slots_x = 8;  // 48 slots for 16 virtual textures: the cache limit matters
  uint32_t slots_y = 6;
  uint32_t uploads = 8;
  std::string doc;
  bool check_determinism = false;
};

bool parse(int argc, char** argv, Options& o) {
  samples::Arguments args("btflod-replay", argc, argv);
  o.frames = args.integer_as("frames", o.frames, 1, 1000000);
  o.width = args.integer_as("width", o.width, 1, 1000000);
  o.height = args.integer_as("height", o.height, 1, 1000000);
  o.decimation = args.integer_as("decimation", o.decimation, 1, 1000000);
  o.texture = args.integer_as("texture", o.texture, 64, 1000000);
  o.components = args.integer_as("components", o.components, 1, 1000000);
  o.slots_x = args.integer_as("slots-x", o.slots_x, 1, 1000000);
  o.slots_y = args.integer_as("slots-y", o.slots_y, 1, 1000000);
  o.uploads = args.integer_as("uploads", o.uploads, 1, 1000000);
  o.check_determinism = args.flag("check-determinism");
  o.doc = args.string("doc", o.doc);
  return args.finish(0);
}

// Tileable value noise in [−1, 1] with `cells` lattice cells across the texture.
float value_noise(uint32_t seed, float x, float y, uint32_t cells) {
  const float fx = x * static_cast<float>(cells), fy = y * static_cast<float>(cells);
  const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
  const float ax = fx - static_cast<float>(x0), ay = fy - static_cast<float>(y0);
  const auto lattice = [&](int ix, int iy) {
    const uint32_t cx =
        static_cast<uint32_t>((ix % static_cast<int>(cells) + static_cast<int>(cells)) % static_cast<int>(cells));
    const uint32_t cy =
        static_cast<uint32_t>((iy % static_cast<int>(cells) + static_cast<int>(cells)) % static_cast<int>(cells));
    return static_cast<float>(samples::hash32(seed ^ samples::hash32(cx * 73856093u ^ cy * 19349663u)) & 0xffffu) /
               32767.5f -
           1.0f;
  };
  const float sx = ax * ax * (3 - 2 * ax), sy = ay * ay * (3 - 2 * ay);
  const float top = lattice(x0, y0) + (lattice(x0 + 1, y0) - lattice(x0, y0)) * sx;
  const float bot = lattice(x0, y0 + 1) + (lattice(x0 + 1, y0 + 1) - lattice(x0, y0 + 1)) * sx;
  return top + (bot - top) * sy;
}

// Eigen-textures shaped like an SVD of a BTF: amplitude 1/(c+1); coarse structure everywhere and
// fine detail only where the material's detail mask says so (so w varies across tiles).
EigenTextures synth_material(uint32_t material, uint32_t size, uint32_t components) {
  EigenTextures e;
  e.textures.resize(static_cast<int>(size), static_cast<int>(size), static_cast<int>(components));
  e.light_count = 1;
  e.view_count = 1;
  e.angular.assign(3 * components, 0.0f);
  for (uint32_t c = 0; c < components; ++c)
    e.angular[c] = e.angular[components + c] = e.angular[2 * components + c] = 1.0f;
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x) {
      const float u = (static_cast<float>(x) + 0.5f) / static_cast<float>(size);
      const float v = (static_cast<float>(y) + 0.5f) / static_cast<float>(size);
      float detail = 1.0f;
      switch (material) {
        case 0:
          detail = 0.5f + 0.5f * value_noise(7, u, v, 2);
          break;  // patchy
        case 1:
          detail = u < 0.5f ? 0.05f : 1.0f;
          break;  // smooth | detailed
        case 2:
          detail = std::pow(0.5f + 0.5f * value_noise(11, u, v, 3), 4.0f);
          break;  // sparse spots
        default:
          detail = 0.3f;
          break;  // uniformly mild
      }
      for (uint32_t c = 0; c < components; ++c) {
        const uint32_t seed = material * 1000u + c * 17u + 1u;
        const float coarse = value_noise(seed, u, v, 4) + 0.5f * value_noise(seed + 1, u, v, 8);
        const float fine = value_noise(seed + 2, u, v, size / 8) + 0.5f * value_noise(seed + 3, u, v, size / 4);
        const float comp_detail = material == 3 ? (c >= components / 2 ? 3.0f : 0.2f) : 1.0f;  // late comps busy
        e.textures.at(static_cast<int>(x), static_cast<int>(y), static_cast<int>(c)) =
            (coarse + detail * comp_detail * fine) / static_cast<float>(c + 1);
      }
    }
  return e;
}

struct World {
  Options opt;
  std::vector<TilePyramid> pyramids;
  VtSet set;
  // The same materials as `.bsvtf` containers (what the Streamer reads) and their directories.
  std::vector<std::vector<uint8_t>> files;
  std::vector<BsvtfDirectory> dirs;
  Scene scene;
  std::vector<float> reference_distance;  // per material: d0 of the range-based LOD

  explicit World(const Options& o) : opt(o) {
    for (uint32_t m = 0; m < 4; ++m) {
      const EigenTextures e = synth_material(m, o.texture, o.components);
      auto p = TilePyramid::build(e);
      BsvtfFromEigenOptions bo;
      bo.light_directions = {0.0f, 0.0f, 1.0f};
      bo.view_directions = {0.0f, 0.0f, 1.0f};
      auto file = build_bsvtf_from_eigen_textures(e, bo);
      if (!p.ok() || !file.ok()) {
        std::fprintf(stderr, "btflod-replay: %s\n", (!p.ok() ? p.error() : file.error()).message.c_str());
        std::exit(2);
      }
      auto dir = read_bsvtf(*file);
      if (!dir.ok()) {
        std::fprintf(stderr, "btflod-replay: %s\n", dir.error().message.c_str());
        std::exit(2);
      }
      files.push_back(std::move(*file));
      dirs.push_back(std::move(*dir));
      pyramids.push_back(std::move(p.value()));
      const uint32_t id = set.add_material(pyramids.back().geometry(), pyramids.back().texture_count());
      pyramids.back().copy_weights_to(set, id);
    }
    scene.add(Shape::plane(0, {-4, 0, -4}, {1, 0, 0}, {0, 0, 1}, 8.0f, 8.0f, {4, 4}));
    scene.add(Shape::sphere(1, {0, 1.0f, 0}, 1.0f, {4, 2}));
    scene.add(Shape::torus(2, {2.2f, 0.45f, 0.6f}, 0.8f, 0.35f, {6, 2}));
    scene.add(Shape::torus(3, {-2.0f, 0.45f, -1.0f}, 0.7f, 0.35f, {6, 2}));
    // d0: distance at which one finest texel covers one pixel (head-on), per material.
    const float pixel_angle = 2.0f * std::tan(degrees_to_radians(45.0f) * 0.5f) / static_cast<float>(o.height);
    const float texels = static_cast<float>(o.texture);
    const float texel_world[4] = {8.0f / 4.0f / texels, kTwoPi * 1.0f / 4.0f / texels, kTwoPi * 0.8f / 6.0f / texels,
                                  kTwoPi * 0.7f / 6.0f / texels};
    for (float t : texel_world) reference_distance.push_back(t / pixel_angle);
  }

  Camera camera(uint32_t frame) const {
    Camera cam;
    cam.width = opt.width;
    cam.height = opt.height;
    const float t = static_cast<float>(frame) / static_cast<float>(std::max(opt.frames, 2u) - 1);
    const float angle = 0.3f + 4.0f * t;
    const float radius = 4.0f + 2.5f * std::sin(3.0f * t);
    cam.position = {radius * std::cos(angle), 1.2f + 1.0f * std::sin(2.0f * t), radius * std::sin(angle)};
    cam.target = {0.0f, 0.6f, 0.0f};
    return cam;
  }
};

// Per frame: hits and the "everything resident" reference (finest level) for every pixel.
struct FrameData {
  std::vector<SurfaceHit> hits;
  std::vector<float> reference;  // per pixel, per virtual texture of its material (≤ kMaxVts), 4 floats
  uint32_t max_vts = 0;
  std::vector<uint32_t> feedback;
};

void prepare_frame(const World& w, const Camera& cam, uint64_t frame, FrameData& fd) {
  const size_t n = static_cast<size_t>(cam.width) * cam.height;
  fd.max_vts = 0;
  for (const auto& p : w.pyramids) fd.max_vts = std::max(fd.max_vts, p.texture_count());
  fd.hits.resize(n);
  fd.reference.assign(n * fd.max_vts * 4, 0.0f);
  for_each_pixel_hit(w.scene, cam, [&](uint32_t x, uint32_t y, float, float, const SurfaceHit& h) {
    const size_t i = static_cast<size_t>(y) * cam.width + x;
    fd.hits[i] = h;
    if (!h.hit) return;
    const TilePyramid& p = w.pyramids[h.material];
    for (uint32_t k = 0; k < p.texture_count(); ++k)
      p.sample(k, p.geometry().finest_level, h.texcoord.x, h.texcoord.y, &fd.reference[(i * fd.max_vts + k) * 4]);
  });
  const uint32_t d = w.opt.decimation;
  fd.feedback.assign(static_cast<size_t>((cam.width + d - 1) / d) * ((cam.height + d - 1) / d), kFeedbackNone);
  render_feedback(w.scene, cam, w.set, DerivativeLod{}, d, frame, fd.feedback);
}

// Mean over covered pixels of E (eq. 7) summed over the material's virtual textures.
template <class Approx>
double frame_error(const World& w, const FrameData& fd, Approx&& approx) {
  double sum = 0.0;
  uint64_t pixels = 0;
  for (size_t i = 0; i < fd.hits.size(); ++i) {
    const SurfaceHit& h = fd.hits[i];
    if (!h.hit) continue;
    const uint32_t vts = w.pyramids[h.material].texture_count();
    double e = 0.0;
    for (uint32_t k = 0; k < vts; ++k) {
      float got[4];
      approx(i, h, k, got);
      const float* ref = &fd.reference[(i * fd.max_vts + k) * 4];
      for (int c = 0; c < 4; ++c) e += static_cast<double>(ref[c] - got[c]) * (ref[c] - got[c]);
    }
    sum += e;
    ++pixels;
  }
  return pixels ? sum / static_cast<double>(pixels) : 0.0;
}

struct Result {
  std::string name;
  std::vector<double> error;      // per frame
  std::vector<double> occupancy;  // per frame, used / slots
  uint64_t bytes = 0;
  uint64_t swaps = 0, adds = 0, budget_hits = 0, visible_missing = 0;
  std::vector<uint64_t> schedule;  // request keys in order (for determinism)
};

// One cache-limited strategy (weighted or votes-only): a Streamer over the four containers.
class CachedStrategy {
 public:
  CachedStrategy(const World& w, PriorityMode mode) : w_(w) {
    result_.name = mode == PriorityMode::weighted ? "weighted (paper 000: P = w·v)" : "votes-only (P = v)";
    for (size_t m = 0; m < w.files.size(); ++m) {
      sources_.push_back(std::make_unique<MemorySource>(std::span<const uint8_t>(w.files[m])));
      materials_.push_back(StreamerMaterial{&w.dirs[m], sources_.back().get(), nullptr});
    }
    StreamerConfig cfg;
    cfg.cache = CacheConfig{w.opt.slots_x, w.opt.slots_y, 1u << 16, kDefaultTileSize, kDefaultTileBorder, 1};
    cfg.scheduler.mode = mode;
    cfg.scheduler.budgets.uploads_per_frame = w.opt.uploads;
    cfg.scheduler.budgets.requests_in_flight = 2 * w.opt.uploads;
    // One frame's feedback, each word standing for the d × d pixels of its block (eq. 9).
    cfg.vote_window_frames = 1;
    cfg.vote_weight = w.opt.decimation * w.opt.decimation;
    cfg.root_jobs = w.set.texture_count();
    auto s = Streamer::create(materials_, cfg);
    if (!s.ok()) {
      std::fprintf(stderr, "btflod-replay: %s\n", s.error().message.c_str());
      std::exit(2);
    }
    streamer_ = std::make_unique<Streamer>(std::move(*s));
    texture_ = std::make_unique<CpuCacheTexture>(streamer_->cache());
    tiles_.resize(streamer_->tile_uploads_bound());
    packets_.resize(streamer_->packet_uploads_bound());
    writes_.resize(4096);
    events_.resize(64);
    // Start-up: the pinned roots and the U′ packets load before the first measured frame.
    for (int i = 0; i < 64 && !all_ready(); ++i) update({});
    if (!all_ready()) {
      std::fprintf(stderr, "btflod-replay: the materials did not become ready\n");
      std::exit(3);
    }
  }

  void frame(const FrameData& fd, uint64_t f) {
    update(fd.feedback);
    const SchedulerCounters& c = streamer_->scheduler().frame();
    result_.swaps += c.swaps;
    result_.adds += c.adds;
    result_.budget_hits += c.budget_hits();
    result_.visible_missing += c.visible_missing;
    result_.bytes = streamer_->scheduler().total().bytes_requested;
    const TileCache& cache = streamer_->cache();
    result_.occupancy.push_back(static_cast<double>(cache.used_count()) / cache.slot_count());
    result_.error.push_back(frame_error(w_, fd, [&](size_t, const SurfaceHit& h, uint32_t k, float* out) {
      texture_->sample(cache, w_.set.material(h.material).first_texture + k, h.texcoord.x, h.texcoord.y, out);
    }));
    std::string why;
    if (!cache.check_invariants(&why)) {
      std::fprintf(stderr, "btflod-replay: cache invariant broken at frame %llu: %s\n",
                   static_cast<unsigned long long>(f), why.c_str());
      std::exit(3);
    }
  }
  const Result& result() const { return result_; }

 private:
  bool all_ready() const {
    for (uint32_t m = 0; m < streamer_->material_count(); ++m)
      if (!streamer_->material_ready(m)) return false;
    return true;
  }
  // One update: tiles into the CPU cache texture (the renderer reads the cache's own page
  // table, so page-table writes and U′ packets need no copy here), then this frame's decode
  // jobs on this thread.
  void update(std::span<const uint32_t> feedback) {
    StreamerOutputs out{tiles_, packets_, writes_, events_};
    Status st = streamer_->update(feedback, out);
    if (st == Status::success)
      st = forward_streamer_outputs(
          out,
          [&](std::span<const TileUpload> batch) noexcept {
            for (const TileUpload& t : batch)
              if (!texture_->upload(streamer_->cache(), t.slot, t.texels)) return Status::invalid_argument;
            return Status::success;
          },
          [](std::span<const PageTableWrite>) noexcept { return Status::success; });
    if (st != Status::success) {
      std::fprintf(stderr, "btflod-replay: update failed: %s\n", status_name(st));
      std::exit(3);
    }
    for (size_t i = 0; i < out.tile_upload_count; ++i) result_.schedule.push_back(tiles_[i].tile.key());
    for (size_t i = 0; i < out.event_count; ++i)
      if (events_[i].kind == ResidencyEventKind::tile_failed || events_[i].kind == ResidencyEventKind::packet_failed) {
        std::fprintf(stderr, "btflod-replay: a read or decode failed: %s\n", status_name(events_[i].status));
        std::exit(3);
      }
    streamer_->pump();
  }

  const World& w_;
  Result result_;
  std::vector<std::unique_ptr<MemorySource>> sources_;
  std::vector<StreamerMaterial> materials_;
  std::unique_ptr<Streamer> streamer_;
  std::unique_ptr<CpuCacheTexture> texture_;
  std::vector<StreamerTileUpload> tiles_;
  std::vector<StreamerPacketUpload> packets_;
  std::vector<PageTableWrite> writes_;
  std::vector<ResidencyEvent> events_;
};

// Range-based mip selection (paper 001 §3.4), every tile it touches is loaded: no cache limit.
class DistanceStrategy {
 public:
  explicit DistanceStrategy(const World& w) : w_(w) {
    result_.name = "distance mip, no cache limit";
    for (uint32_t t = 0; t < w.set.texture_count(); ++t) loaded_.emplace_back(w.set.levels_of(t).tile_count(), 0);
  }
  void frame(const FrameData& fd, const Camera& cam) {
    uint64_t used = 0;
    result_.error.push_back(frame_error(w_, fd, [&](size_t, const SurfaceHit& h, uint32_t k, float* out) {
      const TilePyramid& p = w_.pyramids[h.material];
      const VtGeometry& g = p.geometry();
      RangeLod lod;
      lod.reference_distance = w_.reference_distance[h.material];
      const uint32_t level = feedback_level(lod.level(LodInput{1, 1, h.t}, g.finest_level), g.finest_level);
      p.sample(k, level, h.texcoord.x, h.texcoord.y, out);
      // Account the tile once (for every virtual texture of the material).
      const uint32_t tex = w_.set.material(h.material).first_texture + k;
      const VtLevelTable& lv = w_.set.levels_of(tex);
      const float scale = static_cast<float>(g.tile_size << (g.finest_level - level));
      const uint32_t tx = std::min(static_cast<uint32_t>(h.texcoord.x * g.width / scale), lv.tiles_x[level] - 1);
      const uint32_t ty = std::min(static_cast<uint32_t>(h.texcoord.y * g.height / scale), lv.tiles_y[level] - 1);
      uint8_t& flag = loaded_[tex][lv.index(level, tx, ty)];
      if (!flag) {
        flag = 1;
        result_.bytes += w_.dirs[h.material].find(TileId{k, level, tx, ty})->size;  // payload bytes
      }
    }));
    (void)cam;
    for (const auto& l : loaded_)
      for (uint8_t f : l) used += f;
    result_.occupancy.push_back(static_cast<double>(used));  // tiles held (no limit)
  }
  const Result& result() const { return result_; }

 private:
  const World& w_;
  Result result_;
  std::vector<std::vector<uint8_t>> loaded_;
};

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

std::string report(const Options& o, const World& w, const Result& a, const Result& b, const Result& c,
                   const std::string& command) {
  std::ostringstream s;
  char line[512];
  uint32_t tiles = 0;
  for (uint32_t t = 0; t < w.set.texture_count(); ++t) tiles += w.set.levels_of(t).tile_count();
  std::snprintf(
      line, sizeof line,
      "Scene: 4 materials (plane, sphere, 2 tori), %u×%u texels, C = %u → %u virtual textures, %u tiles "
      "in all, streamed from .bsvtf containers through one btflod::Streamer; cache %u×%u = %u slots; %u frames "
      "at %u×%u, feedback 1/%u with rotating sample; %u uploads/frame.\n\n",
      o.texture, o.texture, o.components, w.set.texture_count(), tiles, o.slots_x, o.slots_y, o.slots_x * o.slots_y,
      o.frames, o.width, o.height, o.decimation, o.uploads);
  s << line;
  s << "Command: `" << command << "`\n\n";
  s << "| strategy | mean E per frame | E, last frame | mean E, 2nd half | MB requested (payload bytes) | mean "
       "occupancy |\n";
  s << "|---|---|---|---|---|---|\n";
  for (const Result* r : {&a, &b, &c}) {
    const std::vector<double> second(r->error.begin() + static_cast<ptrdiff_t>(r->error.size() / 2), r->error.end());
    const bool unlimited = r == &c;
    std::snprintf(line, sizeof line, "| %s | %.5f | %.5f | %.5f | %.2f | %s |\n", r->name.c_str(), mean(r->error),
                  r->error.empty() ? 0.0 : r->error.back(), mean(second), static_cast<double>(r->bytes) / 1048576.0,
                  unlimited ? (std::to_string(static_cast<uint64_t>(r->occupancy.empty() ? 0 : r->occupancy.back())) +
                               " tiles (no limit)")
                                  .c_str()
                            : (std::to_string(static_cast<int>(100.0 * mean(r->occupancy) + 0.5)) + " %").c_str());
    s << line;
  }
  std::snprintf(
      line, sizeof line,
      "\nweighted: %llu adds, %llu swaps, %llu budget hits; votes-only: %llu adds, %llu swaps, %llu budget hits.\n",
      static_cast<unsigned long long>(a.adds), static_cast<unsigned long long>(a.swaps),
      static_cast<unsigned long long>(a.budget_hits), static_cast<unsigned long long>(b.adds),
      static_cast<unsigned long long>(b.swaps), static_cast<unsigned long long>(b.budget_hits));
  s << line;
  const double ratio = mean(b.error) > 0 ? mean(a.error) / mean(b.error) : 0.0;
  std::snprintf(line, sizeof line, "Weighted / votes-only mean E: %.3f (%s).\n", ratio,
                ratio < 0.999   ? "the paper's priority wins at equal cache size"
                : ratio > 1.001 ? "the paper's priority does NOT win here"
                                : "a tie: the cache limit was not reached or both chose the same tiles");
  s << line;
  return s.str();
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, o)) return 2;
  const std::string command = samples::command_line("btflod-replay", argc, argv);

  const World w(o);
  CachedStrategy weighted(w, PriorityMode::weighted), votes_only(w, PriorityMode::votes_only);
  std::unique_ptr<CachedStrategy> again;
  if (o.check_determinism) again = std::make_unique<CachedStrategy>(w, PriorityMode::weighted);
  DistanceStrategy distance(w);
  FrameData fd;
  for (uint32_t f = 0; f < o.frames; ++f) {
    const Camera cam = w.camera(f);
    prepare_frame(w, cam, f, fd);
    weighted.frame(fd, f);
    votes_only.frame(fd, f);
    if (again) again->frame(fd, f);
    distance.frame(fd, cam);
  }
  const std::string text = report(o, w, weighted.result(), votes_only.result(), distance.result(), command);
  std::fputs(text.c_str(), stdout);
  if (again) {
    const bool same =
        again->result().error == weighted.result().error && again->result().schedule == weighted.result().schedule;
    std::printf("deterministic: %s (%zu requests replayed)\n", same ? "yes" : "NO", weighted.result().schedule.size());
    if (!same) return 1;
  }
  if (!o.doc.empty() && !samples::replace_doc_block(o.doc, "replay", text)) {
    std::fprintf(stderr, "btflod-replay: cannot write %s\n", o.doc.c_str());
    return 1;
  }
  return 0;
}
