// btflod-progressive — progressive quality vs bytes received for three streaming orders.
//
// Materials are synthesised (offline/btf/synthesizer.hpp), factorised with FMF (paper 000 eq. 4–5), cut
// into tile pyramids and ENCODED into .bsvtf containers with the real codec — all through the
// demo's prepare_material() (samples/demo/materials.hpp). Every payload is then decoded once,
// coarse to fine against its decoded parent (the closed-loop residual codec, paper 000 §6), so
// the client renders exactly what it would decode. A fixed view of the demo scene (the analytic
// twin of samples/scene/demo_scene.hpp that the CPU fallback of the demo ray-casts) is rendered
// by the CPU reference (offline/render/cpu_reference.hpp: ray casting, feedback words, shade_fmf's
// 9-tap angular combination) from the tiles and U packets that have arrived. One simulated link
// carries a fixed number of bytes per frame; "bytes" are compressed tile payload bytes plus U
// packet bytes exactly as stored in the containers, in every order:
//   (a) priority  btflod's runtime (btflod::Streamer): feedback (eq. 1–2) → votes (eq. 9) →
//                 add/swap with P = w·v (§5.2) and U' packets streamed by their §6 priority;
//                 its asynchronous reads (AsyncTileSource) go onto the link in the order it
//                 starts them, arrivals complete them, pump() decodes and the next update()
//                 hands the tiles out. The pinned root tiles are the first bytes on the link.
//   (b) component paper 004 §5: principal components streamed one by one. btflod packs four
//                 components into one RGBA virtual texture (as paper 004 does in its PNGs), so
//                 the unit is the group g = components 4g … 4g+3: for g = 0, 1, …: for every
//                 material its U packet g, then every tile of virtual texture g level by level
//                 (coarse to fine — a tile is coded as a residual of its parent and cannot be
//                 decoded without it), visible or not.
//   (c) coarse-to-fine  every tile of level 0 of every virtual texture, then level 1, …
//                 regardless of visibility; U packet g of a material goes with its first tile.
// Rendering a frame: per pixel, the level the feedback pass would request (eq. 1, DerivativeLod);
// per group g whose U packet has arrived, the deepest arrived tile at or above that level
// (bilinear inside its bordered tile, eq. 3 addressing); groups without a packet or a tile
// contribute 0 (shade_fmf). Converged image = every tile + every packet, same renderer.
// SSIM (offline/metrics/image_metrics.hpp, Wang 2004, mean over RGB) of each frame against the converged
// image of the same view, on display values: linear radiance clamped to [0, 1] and sRGB-encoded
// (data range 1), like the demo's report. Single-threaded where it matters: no thread races the result.
//
// Usage: btflod-progressive --out DIR [--materials N] [--components C] [--size N] [--repeat R]
//            [--quality Q] [--width W] [--height H] [--views V] [--bytes-per-frame B]
//            [--frames-to-all F] [--decimation D] [--max-frames N] [--doc docs/progressive.md]
//            [--svg PATH] [--check-determinism] [--deflate]
// --deflate codes the tiles with deflate (tile format 2) instead of the default zstd (format 3).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "btflod/core/color.hpp"
#include "btflod/offline/build/tile_pyramid.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"
#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/lod/lod_selector.hpp"
#include "btflod/runtime/shader/shader_config.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"
#include "common/arguments.hpp"
#include "common/doc_block.hpp"
#include "materials.hpp"
#include "scene/demo_scene.hpp"
#include "scene_render.hpp"

using namespace btflod;
using namespace btflod::progressive;

namespace {

struct Options : SceneOptions {
  uint64_t bytes_per_frame = 0;  // 0: total bytes / frames_to_all
  uint32_t frames_to_all = 200;
  uint32_t decimation = 4;
  uint32_t max_frames = 1000;
  std::string doc, svg;
  bool check_determinism = false;
};

// This program's World is always built from an Options (main): its own settings.
const Options& options_of(const World& w) { return static_cast<const Options&>(w.opt); }

bool parse(int argc, char** argv, Options& o) {
  samples::Arguments args("btflod-progressive", argc, argv);
  o.out = args.string("out", o.out);
  o.doc = args.string("doc", o.doc);
  o.svg = args.string("svg", o.svg);
  o.materials = args.integer_as("materials", o.materials, 1, 4);
  o.components = args.integer_as("components", o.components, 1, 32);
  o.size = args.integer_as("size", o.size, 8, 128);
  o.repeat = args.integer_as("repeat", o.repeat, 1, 32);
  o.width = args.integer_as("width", o.width, 16, 1920);
  o.height = args.integer_as("height", o.height, 16, 1080);
  o.views = args.integer_as("views", o.views, 1, 8);
  o.frames_to_all = args.integer_as("frames-to-all", o.frames_to_all, 4, 100000);
  o.decimation = args.integer_as("decimation", o.decimation, 1, 16);
  o.max_frames = args.integer_as("max-frames", o.max_frames, 4, 1000000);
  if (const auto q = args.optional_integer("quality", 1, 100)) o.quality = static_cast<float>(*q);
  o.bytes_per_frame = args.integer_as("bytes-per-frame", o.bytes_per_frame, 1, 1ll << 40);
  o.check_determinism = args.flag("check-determinism");
  if (args.flag("deflate")) o.entropy_coder = TileEntropyCoder::deflate;
  if (!args.finish(0)) return false;
  if (o.out.empty()) {
    std::fprintf(stderr, "btflod-progressive: --out DIR is required\n");
    return false;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// The link and the three orders.

struct LinkItem {
  uint32_t material = 0, k = 0, flat = 0;
  bool packet = false;
  uint32_t bytes = 0;
  // Strategy (a): the Streamer's asynchronous read this item carries (offset in the container,
  // destination, ticket for Streamer::complete_read).
  uint64_t offset = 0;
  uint8_t* destination = nullptr;
  uint64_t ticket = 0;
};

// A FIFO over a link that carries `per_frame` bytes per frame; an item arrives when its last
// byte has been carried. bytes() counts every byte carried (partial items included).
class Link {
 public:
  explicit Link(uint64_t per_frame) : per_frame_(per_frame) {}
  void push(const LinkItem& i) { queue_.push_back(i); }
  bool idle() const { return queue_.empty(); }
  uint64_t bytes() const { return carried_total_; }
  template <class F>
  void frame(F&& arrived) {
    uint64_t budget = per_frame_;
    while (budget > 0 && !queue_.empty()) {
      const uint64_t need = queue_.front().bytes - front_done_;
      if (need <= budget) {
        budget -= need;
        carried_total_ += need;
        front_done_ = 0;
        const LinkItem i = queue_.front();
        queue_.pop_front();
        arrived(i);
      } else {
        front_done_ += budget;
        carried_total_ += budget;
        budget = 0;
      }
    }
  }

 private:
  uint64_t per_frame_;
  std::deque<LinkItem> queue_;
  uint64_t front_done_ = 0;
  uint64_t carried_total_ = 0;
};

struct Sample {
  uint32_t frame = 0;
  uint64_t bytes = 0;
  double ssim = 0;
};

struct Run {
  std::string name;
  std::vector<Sample> samples;
  std::vector<uint64_t> order;  // arrival order (material, k, flat, packet) for determinism
};
double frame_ssim(const Image<float>& linear, const Image<float>& converged_display) {
  const Image<float> d = to_display(linear);
  return mean_ssim(d.view(), converged_display.view());
}

uint64_t order_key(const LinkItem& i) {
  return (static_cast<uint64_t>(i.material) << 48) | (static_cast<uint64_t>(i.k) << 40) |
         (static_cast<uint64_t>(i.flat) << 1) | (i.packet ? 1u : 0u);
}

// Strategies (b) and (c): a fixed order, pushed onto the link at once.
Run run_fixed(const World& w, const Camera& cam, const std::vector<Pixel>& px, const Image<float>& converged,
              const std::vector<LinkItem>& order, const std::string& name, uint64_t per_frame) {
  Run r;
  r.name = name;
  Link link(per_frame);
  for (const LinkItem& i : order) link.push(i);
  ClientState cs(w);
  double ssim = frame_ssim(render(w, cam, px, cs), converged);
  for (uint32_t f = 0; f < options_of(w).max_frames && !link.idle(); ++f) {
    bool changed = false;
    link.frame([&](const LinkItem& i) {
      if (i.packet)
        cs.packet[i.material][i.k] = 1;
      else
        cs.tile[i.material][i.k][i.flat] = 1;
      r.order.push_back(order_key(i));
      changed = true;
    });
    if (changed) ssim = frame_ssim(render(w, cam, px, cs), converged);  // same state, same image
    r.samples.push_back({f, link.bytes(), ssim});
  }
  return r;
}

// Appends what material mi sends of component group k at level l: its U packet first (with
// level 0), then the level's tiles in row order.
void append_group_level(const World& w, uint32_t mi, uint32_t k, uint32_t l, std::vector<LinkItem>& out) {
  const Material& m = w.materials[mi];
  const VtLevelTable& lv = m.pyramid.levels();
  if (l == 0) out.push_back({mi, k, 0, true, m.packet_bytes[k]});
  for (uint32_t y = 0; y < lv.tiles_y[l]; ++y)
    for (uint32_t x = 0; x < lv.tiles_x[l]; ++x) {
      const uint32_t flat = lv.index(l, x, y);
      out.push_back({mi, k, flat, false, m.tile_bytes[k][flat]});
    }
}

std::vector<LinkItem> component_order(const World& w) {
  std::vector<LinkItem> out;
  uint32_t groups = 0, levels = 0;
  for (const Material& m : w.materials) {
    groups = std::max<uint32_t>(groups, static_cast<uint32_t>(m.decoded.size()));
    levels = std::max(levels, m.pyramid.geometry().level_count());
  }
  for (uint32_t k = 0; k < groups; ++k)
    for (uint32_t l = 0; l < levels; ++l)
      for (uint32_t mi = 0; mi < w.materials.size(); ++mi) {
        const Material& m = w.materials[mi];
        if (k >= m.decoded.size() || l >= m.pyramid.geometry().level_count()) continue;
        append_group_level(w, mi, k, l, out);
      }
  return out;
}

std::vector<LinkItem> level_order(const World& w) {
  std::vector<LinkItem> out;
  uint32_t levels = 0;
  for (const Material& m : w.materials) levels = std::max(levels, m.pyramid.geometry().level_count());
  for (uint32_t l = 0; l < levels; ++l)
    for (uint32_t mi = 0; mi < w.materials.size(); ++mi) {
      const Material& m = w.materials[mi];
      if (l >= m.pyramid.geometry().level_count()) continue;
      for (uint32_t k = 0; k < m.decoded.size(); ++k) append_group_level(w, mi, k, l, out);
    }
  return out;
}

// Strategy (a)'s I/O: the Streamer's reads of one material's container go onto the link as they
// are started (AsyncTileSource); the link completes them when their last byte is carried.
class LinkSource final : public AsyncTileSource {
 public:
  LinkSource(Link& link, uint32_t material, const Material& m) : link_(link) {
    const BsvtfMetadata& md = m.dir.metadata;
    for (const BsvtfTileEntry& e : m.dir.tiles)
      items_[e.offset] = LinkItem{material, e.id.texture, m.pyramid.levels().index(e.id), false, e.size};
    for (uint32_t k = 0; k < m.dir.packets.size() && k < md.texture_count(); ++k)
      items_[m.dir.packets[k].offset] = LinkItem{material, k, 0, true, m.dir.packets[k].size};
  }
  bool start_read(uint64_t offset, std::span<uint8_t> out, uint64_t ticket) noexcept override {
    const auto it = items_.find(offset);
    if (it == items_.end() || it->second.bytes != out.size()) return false;
    LinkItem i = it->second;
    i.offset = offset;
    i.destination = out.data();
    i.ticket = ticket;
    link_.push(i);
    return true;
  }

 private:
  Link& link_;
  std::map<uint64_t, LinkItem> items_;  // by container offset
};

// Strategy (a): btflod's runtime (runtime/streamer.hpp) driven by the feedback of the rendered
// view, its reads served by the link. Per frame: the link completes reads, pump() decodes them,
// update() takes this frame's feedback, hands out the tiles and U′ packets that became ready
// (the client now holds them) and plans the next requests, whose reads go onto the link.
Result<Run> run_priority(const World& w, const Camera& cam, const std::vector<Pixel>& px, const Image<float>& converged,
                         uint64_t per_frame) {
  Run r;
  r.name = "priority";
  uint32_t tiles = 0, textures = 0;
  uint64_t tile_sum = 0;
  for (const Material& m : w.materials) {
    textures += static_cast<uint32_t>(m.decoded.size());
    for (const auto& tb : m.tile_bytes)
      for (uint32_t b : tb) {
        ++tiles;
        tile_sum += b;
      }
  }
  Link link(per_frame);
  std::vector<std::unique_ptr<LinkSource>> sources;
  std::vector<StreamerMaterial> materials;
  for (uint32_t mi = 0; mi < w.materials.size(); ++mi) {
    sources.push_back(std::make_unique<LinkSource>(link, mi, w.materials[mi]));
    materials.push_back(StreamerMaterial{&w.materials[mi].dir, nullptr, sources.back().get()});
  }
  StreamerConfig cfg;
  // Every tile fits: the comparison is about order, not about eviction (docs/progressive.md).
  const uint32_t side = static_cast<uint32_t>(std::ceil(std::sqrt(static_cast<double>(tiles)))) + 1;
  const BsvtfMetadata& md0 = w.materials.front().dir.metadata;
  cfg.cache = CacheConfig{side, side, 1u << 16, md0.tile_size, md0.border, 1};
  SchedulerConfig& sc = cfg.scheduler;
  sc.mode = PriorityMode::weighted;
  // Requests in flight: about two frames of link bytes, so that priorities decide what goes
  // next instead of a long FIFO (at least 4).
  const uint64_t mean_tile = std::max<uint64_t>(tile_sum / std::max(tiles, 1u), 1);
  sc.budgets.requests_in_flight = static_cast<uint32_t>(std::clamp<uint64_t>(2 * per_frame / mean_tile + 4, 4, 4096));
  sc.budgets.tiles_decoding = sc.budgets.requests_in_flight;
  sc.budgets.uploads_per_frame = sc.budgets.requests_in_flight;
  sc.budgets.bytes_in_flight = 1ull << 40;
  sc.stream_u_columns = true;  // §6: U' packets are streamed by priority, not loaded up front
  sc.max_lod_bias = 0;         // the link is the limit here; a coarser LOD under overload is another experiment
  const uint32_t d = options_of(w).decimation;
  cfg.vote_window_frames = 1;  // one frame's feedback, each word standing for its d × d block (eq. 9)
  cfg.vote_weight = d * d;
  cfg.root_jobs = textures;  // the pinned root tiles of every virtual texture are the first bytes on the link
  cfg.payload_cache_bytes = std::max<uint64_t>(w.total_bytes * 2, 1u << 20);  // a parent's payload is never re-read
  auto created = Streamer::create(materials, cfg);
  if (!created) return created.error();
  Streamer streamer = std::move(*created);
  std::vector<StreamerTileUpload> tile_out(streamer.tile_uploads_bound());
  std::vector<StreamerPacketUpload> packet_out(streamer.packet_uploads_bound());
  std::vector<PageTableWrite> writes(1u << 16);
  std::vector<ResidencyEvent> events(4096);
  ClientState cs(w);
  std::vector<uint32_t> feedback(static_cast<size_t>((cam.width + d - 1) / d) * ((cam.height + d - 1) / d),
                                 kFeedbackNone);
  uint32_t quiet = 0;
  double ssim = frame_ssim(render(w, cam, px, cs), converged);
  for (uint32_t f = 0; f < options_of(w).max_frames; ++f) {
    link.frame([&](const LinkItem& i) {
      r.order.push_back(order_key(i));
      const std::vector<uint8_t>& file = w.materials[i.material].demo.bsvtf;
      std::memcpy(i.destination, file.data() + i.offset, i.bytes);
      streamer.complete_read(i.ticket, Status::success);
    });
    streamer.pump();
    // This frame's feedback → votes → uploads of what is decoded, then the next requests.
    render_feedback(w.scene, cam, w.set, DerivativeLod{}, d, f, feedback);
    StreamerOutputs out{tile_out, packet_out, writes, events};
    if (const Status st = streamer.update(feedback, out); st != Status::success)
      return make_error(st, "progressive: Streamer::update failed");
    for (size_t i = 0; i < out.event_count; ++i)
      if (events[i].kind == ResidencyEventKind::tile_failed || events[i].kind == ResidencyEventKind::packet_failed)
        return make_error(events[i].status, "progressive: a read or decode failed");
    bool changed = false;
    for (size_t i = 0; i < out.tile_upload_count; ++i) {
      const TileId t = tile_out[i].tile;
      const uint32_t m = w.set.material_of(t.texture);
      cs.tile[m][t.texture - w.set.material(m).first_texture][w.set.levels_of(t.texture).index(t)] = 1;
      changed = true;
    }
    for (size_t i = 0; i < out.packet_upload_count; ++i) {
      cs.packet[packet_out[i].material][packet_out[i].packet] = 1;
      changed = true;
    }
    if (changed) ssim = frame_ssim(render(w, cam, px, cs), converged);  // same state, same image
    r.samples.push_back({f, link.bytes(), ssim});
    // Done when nothing was asked for over a whole rotation of the feedback sample and the link is idle.
    const bool idle = streamer.scheduler().frame().requests == 0 && link.idle() &&
                      streamer.scheduler().requests_in_flight() == 0 && streamer.jobs_in_flight() == 0;
    quiet = idle ? quiet + 1 : 0;
    if (quiet > d * d + 1) break;
  }
  return r;
}

// ---------------------------------------------------------------------------------------------
// Reporting.

std::string bytes_to_reach(const Run& r, double threshold, uint64_t* out = nullptr) {
  for (const Sample& s : r.samples)
    if (s.ssim >= threshold) {
      if (out) *out = s.bytes;
      char b[64];
      std::snprintf(b, sizeof b, "%.1f KiB", static_cast<double>(s.bytes) / 1024.0);
      return b;
    }
  char b[96];
  std::snprintf(
      b, sizeof b, "not reached (max %.4f)", r.samples.empty() ? 0.0 : [&] {
        double mx = 0;
        for (const Sample& s : r.samples) mx = std::max(mx, s.ssim);
        return mx;
      }());
  return b;
}

struct ViewResult {
  uint32_t view = 0;
  double coverage = 0;  // fraction of pixels showing a material
  std::vector<Run> runs;
};

// Small multiples, one panel per view: x = bytes received (log scale), y = −log10(1 − SSIM)
// ("nines": 0.9 → 1, 0.99 → 2; capped at 0.999) so that the 0.95 and 0.99 crossings are visible.
std::string svg_plot(const std::vector<ViewResult>& views) {
  const int pw = 300, ph = 200, ml = 46, mt = 28, gap = 20;
  const int W = static_cast<int>(views.size()) * (pw + ml + gap) + gap, H = ph + mt + 70;
  const char* colours[] = {"#d62728", "#1f77b4", "#2ca02c"};
  const double top = 3.0;  // SSIM 0.999
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
    << "' font-family='sans-serif' font-size='11'>\n<rect width='100%' height='100%' fill='white'/>\n";
  for (size_t v = 0; v < views.size(); ++v) {
    const int x0 = gap + static_cast<int>(v) * (pw + ml + gap) + ml, y0 = mt;
    uint64_t max_bytes = 1, min_bytes = ~0ull;
    for (const Run& r : views[v].runs)
      for (const Sample& smp : r.samples) {
        max_bytes = std::max(max_bytes, smp.bytes);
        if (smp.bytes > 0) min_bytes = std::min(min_bytes, smp.bytes);
      }
    const double lx0 = std::log10(static_cast<double>(std::min(min_bytes, max_bytes))),
                 lx1 = std::log10(static_cast<double>(max_bytes));
    const auto X = [&](uint64_t b) {
      const double l = std::log10(static_cast<double>(std::max<uint64_t>(b, 1)));
      return x0 + std::clamp((l - lx0) / std::max(lx1 - lx0, 1e-9), 0.0, 1.0) * pw;
    };
    const auto Y = [&](double q) {
      return y0 + (1.0 - std::clamp(-std::log10(std::max(1.0 - q, 1e-3)), 0.0, top) / top) * ph;
    };
    s << "<text x='" << x0 << "' y='" << y0 - 10 << "'>view " << views[v].view << " ("
      << static_cast<int>(100 * views[v].coverage + 0.5) << "% of pixels textured)</text>\n";
    s << "<rect x='" << x0 << "' y='" << y0 << "' width='" << pw << "' height='" << ph
      << "' fill='none' stroke='#888'/>\n";
    for (double t : {0.5, 0.9, 0.95, 0.99, 0.999}) {
      const bool key = t == 0.95 || t == 0.99;
      s << "<line x1='" << x0 << "' x2='" << x0 + pw << "' y1='" << Y(t) << "' y2='" << Y(t) << "' stroke='"
        << (key ? "#999" : "#ddd") << "' stroke-dasharray='4 3'/><text x='" << x0 - 4 << "' y='" << Y(t) + 4
        << "' text-anchor='end'>" << t << "</text>\n";
    }
    for (double kib = 1; kib * 1024.0 <= static_cast<double>(max_bytes); kib *= 4) {
      const uint64_t b = static_cast<uint64_t>(kib * 1024.0);
      if (b < min_bytes) continue;
      s << "<line x1='" << X(b) << "' x2='" << X(b) << "' y1='" << y0 + ph << "' y2='" << y0 + ph + 4
        << "' stroke='#888'/><text x='" << X(b) << "' y='" << y0 + ph + 15 << "' text-anchor='middle'>" << kib
        << "</text>\n";
    }
    s << "<text x='" << x0 + pw / 2 << "' y='" << y0 + ph + 30
      << "' text-anchor='middle'>KiB received (log scale)</text>\n";
    for (size_t i = 0; i < views[v].runs.size(); ++i) {
      s << "<polyline fill='none' stroke-width='1.5' stroke='" << colours[i % 3] << "' points='";
      for (const Sample& smp : views[v].runs[i].samples) s << X(smp.bytes) << ',' << Y(smp.ssim) << ' ';
      s << "'/>\n";
    }
  }
  for (size_t i = 0; i < views.front().runs.size(); ++i)
    s << "<rect x='" << gap + ml + static_cast<int>(i) * 220 << "' y='" << H - 20 << "' width='14' height='4' fill='"
      << colours[i % 3] << "'/><text x='" << gap + ml + static_cast<int>(i) * 220 + 18 << "' y='" << H - 15 << "'>"
      << views.front().runs[i].name << "</text>\n";
  s << "<text x='" << W - gap << "' y='" << H - 15
    << "' text-anchor='end'>y: SSIM vs converged, axis −log10(1 − SSIM)</text>\n";
  s << "</svg>\n";
  return s.str();
}

bool write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  return static_cast<bool>(out);
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, o)) return 2;
  const samples::MeasuredRun run("btflod-progressive", argc, argv, o.out);
  if (run.folder_error()) {
    std::fprintf(stderr, "btflod-progressive: %s: cannot create: %s\n", o.out.c_str(),
                 run.folder_error().message().c_str());
    return 1;
  }
  World w(o);
  if (auto e = w.init(); !e) {
    std::fprintf(stderr, "btflod-progressive: %s\n", e.message().c_str());
    return 1;
  }
  uint64_t packets = 0, tiles = 0, tile_bytes = 0, packet_bytes = 0;
  for (const Material& m : w.materials) {
    for (const auto& tb : m.tile_bytes)
      for (uint32_t b : tb) ++tiles, tile_bytes += b;
    for (uint32_t b : m.packet_bytes) ++packets, packet_bytes += b;
  }
  const uint64_t per_frame =
      o.bytes_per_frame ? o.bytes_per_frame : (w.total_bytes + o.frames_to_all - 1) / o.frames_to_all;
  const Material& m0 = w.materials.front();
  std::printf(
      "btflod progressive: %u materials, %ux%u texels, C = %u (%zu RGBA virtual textures each), T = %u, B = %u, "
      "%u levels, quality %.0f\n",
      o.materials, m0.pyramid.geometry().width, m0.pyramid.geometry().height, o.components, m0.decoded.size(),
      m0.pyramid.geometry().tile_size, m0.pyramid.geometry().border, m0.pyramid.geometry().level_count(),
      static_cast<double>(o.quality));
  std::printf(
      "  data        %llu tiles, %.1f KiB compressed (raw RGBA16F %.1f KiB); %llu U packets, %.1f KiB; total %.1f "
      "KiB\n",
      static_cast<unsigned long long>(tiles), static_cast<double>(tile_bytes) / 1024.0,
      static_cast<double>(tiles * m0.pyramid.tile_bytes()) / 1024.0, static_cast<unsigned long long>(packets),
      static_cast<double>(packet_bytes) / 1024.0, static_cast<double>(w.total_bytes) / 1024.0);
  std::printf("  link        %llu bytes per frame; %ux%u pixels; feedback 1/%u; prepared in %.1f s\n",
              static_cast<unsigned long long>(per_frame), o.width, o.height, o.decimation, run.seconds());

  std::vector<ViewResult> results;
  bool deterministic = true, converged_ok = true;
  std::ostringstream csv;
  csv << "view,strategy,frame,bytes,ssim\n";
  for (uint32_t v = 0; v < o.views; ++v) {
    const Camera cam = w.camera(v);
    const std::vector<Pixel> px = prepare_view(w, cam);
    const Image<float> converged = to_display(render(w, cam, px, ClientState(w, true)));
    ViewResult vr;
    vr.view = v;
    size_t covered = 0;
    for (const Pixel& p : px) covered += p.hit ? 1 : 0;
    vr.coverage = static_cast<double>(covered) / static_cast<double>(px.size());
    auto a = run_priority(w, cam, px, converged, per_frame);
    if (!a) {
      std::fprintf(stderr, "btflod-progressive: %s\n", a.message().c_str());
      return 1;
    }
    vr.runs.push_back(std::move(*a));
    vr.runs.push_back(run_fixed(w, cam, px, converged, component_order(w), "component", per_frame));
    vr.runs.push_back(run_fixed(w, cam, px, converged, level_order(w), "coarse-to-fine", per_frame));
    if (o.check_determinism) {
      auto again = run_priority(w, cam, px, converged, per_frame);
      if (!again || again->order != vr.runs[0].order || again->samples.size() != vr.runs[0].samples.size())
        deterministic = false;
      else
        for (size_t i = 0; i < again->samples.size(); ++i)
          if (again->samples[i].ssim != vr.runs[0].samples[i].ssim ||
              again->samples[i].bytes != vr.runs[0].samples[i].bytes)
            deterministic = false;
    }
    // The priority order must end at (or within SSIM 0.01 of) the converged image: it has every
    // tile the view votes for. The fixed orders carry every byte and must end exactly there.
    if (vr.runs[0].samples.empty() || vr.runs[0].samples.back().ssim < 0.99) {
      std::fprintf(stderr, "btflod-progressive: view %u priority stream ended at SSIM %.4f (< 0.99)\n", v,
                   vr.runs[0].samples.empty() ? 0.0 : vr.runs[0].samples.back().ssim);
      converged_ok = false;
    }
    for (size_t i = 1; i < vr.runs.size(); ++i) {
      const Run& r = vr.runs[i];
      if (r.samples.empty() || r.samples.back().bytes != w.total_bytes || !(r.samples.back().ssim > 0.999999)) {
        std::fprintf(stderr, "btflod-progressive: view %u %s ended at %llu of %llu bytes, SSIM %.6f\n", v,
                     r.name.c_str(), static_cast<unsigned long long>(r.samples.empty() ? 0 : r.samples.back().bytes),
                     static_cast<unsigned long long>(w.total_bytes), r.samples.empty() ? 0.0 : r.samples.back().ssim);
        converged_ok = false;
      }
    }
    for (const Run& r : vr.runs)
      for (const Sample& s : r.samples) {
        char line[160];
        std::snprintf(line, sizeof line, "%u,%s,%u,%llu,%.6f\n", v, r.name.c_str(), s.frame,
                      static_cast<unsigned long long>(s.bytes), s.ssim);
        csv << line;
      }
    std::printf("  view %u      %.0f%% of pixels textured\n", v, 100.0 * vr.coverage);
    for (const Run& r : vr.runs)
      std::printf("    %-15s SSIM 0.95 at %-26s 0.99 at %-26s final %.4f after %.1f KiB (%zu frames)\n", r.name.c_str(),
                  bytes_to_reach(r, 0.95).c_str(), bytes_to_reach(r, 0.99).c_str(), r.samples.back().ssim,
                  static_cast<double>(r.samples.back().bytes) / 1024.0, r.samples.size());
    results.push_back(std::move(vr));
  }
  const std::string csv_path = (std::filesystem::path(o.out) / "progressive.csv").string();
  const std::string svg_path = o.svg.empty() ? (std::filesystem::path(o.out) / "progressive.svg").string() : o.svg;
  if (!write_text(csv_path, csv.str()) || !write_text(svg_path, svg_plot(results))) {
    std::fprintf(stderr, "btflod-progressive: cannot write %s / %s\n", csv_path.c_str(), svg_path.c_str());
    return 1;
  }
  std::printf("  wrote       %s, %s (%.1f s)\n", csv_path.c_str(), svg_path.c_str(), run.seconds());

  // The results block of docs/progressive.md.
  std::ostringstream doc;
  char line[512];
  std::snprintf(
      line, sizeof line,
      "Command: `%s` (%.0f s on this machine).\n\n"
      "Data: %u materials, %ux%u texels, C = %u → %zu RGBA virtual textures each, T = %u, B = %u, %u levels, "
      "codec quality %.0f, %s: %llu tiles = %.1f KiB compressed (%.1f KiB as raw RGBA16F) + %llu U packets = %.1f KiB; "
      "all bytes %.1f KiB. Link: %llu bytes per frame. Image %ux%u, feedback 1/%u.\n\n",
      run.command().c_str(), run.seconds(), o.materials, m0.pyramid.geometry().width, m0.pyramid.geometry().height,
      o.components, m0.decoded.size(), m0.pyramid.geometry().tile_size, m0.pyramid.geometry().border,
      m0.pyramid.geometry().level_count(), static_cast<double>(o.quality),
      o.entropy_coder == TileEntropyCoder::zstd ? "zstd" : "deflate", static_cast<unsigned long long>(tiles),
      static_cast<double>(tile_bytes) / 1024.0, static_cast<double>(tiles * m0.pyramid.tile_bytes()) / 1024.0,
      static_cast<unsigned long long>(packets), static_cast<double>(packet_bytes) / 1024.0,
      static_cast<double>(w.total_bytes) / 1024.0, static_cast<unsigned long long>(per_frame), o.width, o.height,
      o.decimation);
  doc << line;
  doc << "| view | strategy | bytes to SSIM 0.95 | bytes to SSIM 0.99 | final SSIM | bytes at the end "
         "|\n|---|---|---|---|---|---|\n";
  for (const ViewResult& vr : results)
    for (const Run& r : vr.runs) {
      std::snprintf(line, sizeof line, "| %u (%.0f%% textured) | %s | %s | %s | %.4f | %.1f KiB |\n", vr.view,
                    100.0 * vr.coverage, r.name.c_str(), bytes_to_reach(r, 0.95).c_str(),
                    bytes_to_reach(r, 0.99).c_str(), r.samples.back().ssim,
                    static_cast<double>(r.samples.back().bytes) / 1024.0);
      doc << line;
    }
  doc << "\nBytes relative to priority (a), per view:";
  for (const ViewResult& vr : results) {
    doc << " view " << vr.view << ":";
    for (double t : {0.95, 0.99}) {
      uint64_t a = 0;
      bytes_to_reach(vr.runs[0], t, &a);
      for (size_t i = 1; i < vr.runs.size(); ++i) {
        uint64_t b = 0;
        const bool reached = bytes_to_reach(vr.runs[i], t, &b).find("not") == std::string::npos;
        if (a > 0 && reached)
          std::snprintf(line, sizeof line, " %s %.2f× to %.2f%s", vr.runs[i].name.c_str(),
                        static_cast<double>(b) / static_cast<double>(a), t, i + 1 < vr.runs.size() ? "," : "");
        else
          std::snprintf(line, sizeof line, " %s n/a to %.2f%s", vr.runs[i].name.c_str(), t,
                        i + 1 < vr.runs.size() ? "," : "");
        doc << line;
      }
      doc << (t < 0.99 ? ";" : ".");
    }
  }
  doc << "\n";
  if (!o.doc.empty() && !samples::replace_doc_block(o.doc, "progressive", doc.str())) {
    std::fprintf(stderr, "btflod-progressive: cannot write %s\n", o.doc.c_str());
    return 1;
  }
  if (o.check_determinism) std::printf("deterministic: %s\n", deterministic ? "yes" : "NO");
  if (!deterministic || !converged_ok) return 1;
  std::printf("checks passed\n");
  return 0;
}
