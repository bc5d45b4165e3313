// btflod-demo — the streaming fly-through: per frame, the backend renders the feedback pass
// (paper 000 eq. 1–2) and the BSVTF image through the page table (eq. 3); the feedback becomes
// votes (eq. 9), the scheduler plans add/swap operations (§5, P = w·v), the requested tiles are
// fetched from a THROTTLED source through the streaming pipeline (one .bsvtf container per
// material), decoded, uploaded into the cache slots the scheduler reserved, and the GPU page
// table is rewritten. The same view is then rendered with FMF (eq. 5, every eigen-texture
// resident, uncompressed): that is the converged image the SSIM is measured against, and the
// frame time of both programs is measured on the same view in the same run.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "btflod/backend/backend.hpp"
#include "btflod/backend/page_table_writes.hpp"
#include "btflod/core/half.hpp"
#include "btflod/lod/feedback.hpp"
#include "btflod/metrics/image_metrics.hpp"
#include "btflod/stream/pipeline.hpp"
#include "btflod/stream/tile_source.hpp"
#include "btflod/vt/scheduler.hpp"
#include "btflod/vt/tile_cache.hpp"
#include "btflod/vt/tile_pyramid.hpp"
#include "materials.hpp"
#include "scene/demo_scene.hpp"

namespace btflod::demo {

/// Streaming and rendering settings.
struct StreamSettings {
  uint32_t width = 320, height = 180;
  uint32_t feedback_shift = 3;             ///< feedback target = screen / 2^shift
  uint32_t slots_x = 8, slots_y = 8;       ///< tile cache (one layer)
  double bytes_per_second = 256.0 * 1024;  ///< throttled link shared by all materials
  uint32_t latency_ms = 20;
  uint32_t uploads_per_frame = 16;
};

/// What one frame measured.
struct FrameRecord {
  uint32_t frame = 0;
  uint64_t bytes_received = 0;  ///< verified payload bytes so far, all materials
  uint32_t tiles_delivered = 0;
  double occupancy = 0;         ///< used cache slots / slots
  double ssim = 0;              ///< BSVTF vs FMF (converged) render, sRGB-encoded, mean over RGB
  double rmse = 0;              ///< same pair, linear radiance
  double ms_bsvtf = 0;          ///< BSVTF colour pass + feedback pass, submit to read-back
  double ms_fmf = 0;            ///< FMF colour pass, submit to read-back
  uint32_t requests = 0, uploads = 0;
};

/// Linear RGBA radiance → sRGB-encoded RGB in [0, 1] (clamped), for SSIM and PNG.
inline Image<float> to_display(const Image<float>& rgba) {
  Image<float> out(rgba.width(), rgba.height(), 3);
  for (int y = 0; y < rgba.height(); ++y)
    for (int x = 0; x < rgba.width(); ++x)
      for (int c = 0; c < 3; ++c) {
        const float v = std::clamp(rgba.at(x, y, c), 0.0f, 1.0f);
        out.at(x, y, c) = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
      }
  return out;
}

/// Texture memory of the two representations as the backends allocate it.
struct MemoryFigures {
  uint64_t fmf_bytes = 0;    ///< Σ over materials of V' as RGBA32F arrays with a full mip chain
  uint64_t bsvtf_bytes = 0;  ///< tile cache RGBA16F + page table R32UI with mips
  uint64_t u_bytes = 0;      ///< U' and lookup tables (the same for both, not counted above)
};

/// The streaming renderer over a backend. Set-up allocates; frame() does the per-frame loop.
class StreamingRenderer {
 public:
  /// Creates meshes, materials, the VT set, cache, scheduler and one pipeline per material over a
  /// shared throttled link, and loads the pinned root tiles (blocking). Returns an error naming
  /// the failing step.
  static Result<std::unique_ptr<StreamingRenderer>> create(Backend& be, const std::vector<DemoMaterial>& materials,
                                                           const StreamSettings& s, uint32_t material_count_in_scene) {
    std::unique_ptr<StreamingRenderer> r(new StreamingRenderer(be, materials, s));
    if (auto e = r->init(material_count_in_scene); !e) return e.error();
    return r;
  }
  ~StreamingRenderer() {
    for (auto& p : pipelines_) p->shutdown();
  }

  /// Renders frame f of `frames` and streams; writes the two images (RGBA linear).
  Result<FrameRecord> frame(uint32_t f, uint32_t frames, Image<float>& bsvtf_img, Image<float>& fmf_img) {
    FrameRecord rec;
    rec.frame = f;
    const scene::View view = scene::camera_path(f, frames, s_.width, s_.height);
    const ShaderParams base = scene::view_params(view, glm::vec3(0.5f, 0.8f, 0.35f), glm::vec3(2.2f, 2.1f, 2.0f));
    FrameDesc desc;
    desc.width = s_.width;
    desc.height = s_.height;
    desc.feedback_width = (s_.width + (1u << s_.feedback_shift) - 1) >> s_.feedback_shift;
    desc.feedback_height = (s_.height + (1u << s_.feedback_shift) - 1) >> s_.feedback_shift;
    desc.clear_color[0] = 0.45f, desc.clear_color[1] = 0.55f, desc.clear_color[2] = 0.7f, desc.clear_color[3] = 1.0f;
    // BSVTF pass (colour + feedback).
    auto t0 = std::chrono::steady_clock::now();
    if (be_.begin_frame(desc) != Status::success) return make_error(Status::io_error, "begin_frame failed");
    for (size_t i = 0; i < objects_.size(); ++i) {
      const uint32_t m = objects_[i].material;
      ShaderParams p = material_params(base, m);
      p.lod.y = static_cast<float>(s_.feedback_shift);
      if (be_.draw_feedback(meshes_[i], p) != Status::success) return make_error(Status::io_error, "draw_feedback failed");
      if (be_.draw(ShaderProgram::bsvtf, meshes_[i], bsvtf_mats_[m], material_params(base, m)) != Status::success)
        return make_error(Status::io_error, "draw (bsvtf) failed");
    }
    if (be_.end_frame() != Status::success) return make_error(Status::io_error, "end_frame failed");
    if (be_.read_color(bsvtf_img.view()) != Status::success) return make_error(Status::io_error, "read_color failed");
    rec.ms_bsvtf = ms_since(t0);
    be_.wait_idle();
    FeedbackFrame fb;
    bool have = false;
    while (be_.poll_feedback(fb)) {
      feedback_.assign(fb.words.begin(), fb.words.end());
      have = true;
    }
    // FMF pass (the converged reference).
    t0 = std::chrono::steady_clock::now();
    if (be_.begin_frame(desc) != Status::success) return make_error(Status::io_error, "begin_frame failed");
    for (size_t i = 0; i < objects_.size(); ++i) {
      const uint32_t m = objects_[i].material;
      if (be_.draw(ShaderProgram::fmf, meshes_[i], fmf_mats_[m], material_params(base, m)) != Status::success)
        return make_error(Status::io_error, "draw (fmf) failed");
    }
    if (be_.end_frame() != Status::success) return make_error(Status::io_error, "end_frame failed");
    if (be_.read_color(fmf_img.view()) != Status::success) return make_error(Status::io_error, "read_color failed");
    rec.ms_fmf = ms_since(t0);
    be_.wait_idle();
    while (be_.poll_feedback(fb)) {
    }  // the FMF pass draws no feedback: drop its (empty) readback

    // Streaming: votes → plan → requests → pipeline → uploads → page table.
    if (have) votes_->count(feedback_, 1u << (2 * s_.feedback_shift), sched_->lod_bias());
    const auto requests = sched_->plan(*votes_, f);
    rec.requests = static_cast<uint32_t>(requests.size());
    for (const TileRequest& q : requests) {
      if (q.u_packet) {  // U is loaded up front (stream_u_columns = false): nothing to fetch
        if (sched_->begin_decode(q.id)) sched_->finish_decode(q.id);
        continue;
      }
      const uint32_t m = set_.material_of(q.tile.texture);
      const TileId local{q.tile.texture - set_.material(m).first_texture, q.tile.level, q.tile.x, q.tile.y};
      outstanding_[m].push_back(StreamItem::for_tile(local));
      request_of_[m][local.key()] = q.id;
    }
    for (uint32_t m = 0; m < pipelines_.size(); ++m) {
      pipelines_[m]->request(outstanding_[m]);
      pipelines_[m]->deliver(s_.uploads_per_frame, [&](const StreamDelivery& d) {
        const auto it = request_of_[m].find(d.item.key());
        if (it == request_of_[m].end()) return;
        std::vector<uint16_t>& texels = staging_[it->second];
        texels.resize(d.samples.size());
        float_to_half(d.samples, texels);
        if (sched_->begin_decode(it->second)) sched_->finish_decode(it->second);
        forget(m, it->first);
      });
      pipelines_[m]->drain_events([&](const PipelineEvent& e) {
        if (!e.skipped) return;
        const auto it = request_of_[m].find(e.item.key());
        if (it == request_of_[m].end()) return;
        sched_->cancel(it->second);
        forget(m, it->first);
      });
    }
    Status upload_status = Status::success;
    rec.uploads = sched_->apply_uploads([&](const TileRequest& q) {
      if (q.u_packet) return;
      const TileUpload up{q.slot, staging_[q.id]};
      if (be_.upload_tiles({&up, 1}) != Status::success) upload_status = Status::io_error;
    });
    if (upload_status != Status::success) return make_error(upload_status, "upload_tiles failed");
    if (auto e = write_page_tables(); !e) return e.error();
    for (const auto& p : pipelines_) {
      const PipelineProgress pr = p->progress();
      rec.bytes_received += pr.bytes_received;
      rec.tiles_delivered += pr.tiles_delivered;
    }
    rec.occupancy = static_cast<double>(cache_->used_count()) / static_cast<double>(cache_->slot_count());
    const Image<float> a = to_display(bsvtf_img), b = to_display(fmf_img);
    rec.ssim = mean_ssim(a.view(), b.view());
    rec.rmse = rmse(bsvtf_img.view(), fmf_img.view());
    return rec;
  }

  /// Payload bytes of all containers (the whole data set).
  uint64_t total_payload_bytes() const {
    uint64_t n = 0;
    for (const auto& p : pipelines_) n += p->progress().bytes_total;
    return n;
  }
  const MemoryFigures& memory() const noexcept { return memory_; }
  uint32_t slot_count() const noexcept { return cache_->slot_count(); }
  uint32_t tile_count() const noexcept {
    uint32_t n = 0;
    for (uint32_t t = 0; t < set_.texture_count(); ++t) n += set_.levels_of(t).tile_count();
    return n;
  }

 private:
  StreamingRenderer(Backend& be, const std::vector<DemoMaterial>& materials, const StreamSettings& s)
      : be_(be), materials_(materials), s_(s) {}

  static double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }

  ShaderParams material_params(const ShaderParams& base, uint32_t m) const {
    ShaderParams p = base;
    const DemoMaterial& d = materials_[m];
    p.vt_extent = glm::vec4(static_cast<float>(d.eigen_textures.width()), static_cast<float>(d.eigen_textures.height()),
                            static_cast<float>(d.finest_level), 0.0f);
    p.ids = glm::uvec4(set_.material(m).first_texture, m, 0u, 0u);
    return p;
  }

  void forget(uint32_t m, uint64_t key) {
    request_of_[m].erase(key);
    auto& o = outstanding_[m];
    o.erase(std::remove_if(o.begin(), o.end(), [&](const StreamItem& i) { return i.key() == key; }), o.end());
  }

  VoidResult write_page_tables() {
    writes_.clear();
    for (uint32_t t = 0; t < set_.texture_count(); ++t) append_full_page_table_writes(*cache_, t, writes_);
    cache_->clear_deltas();
    if (be_.apply_page_table_writes(writes_) != Status::success)
      return make_error(Status::io_error, "apply_page_table_writes failed (%zu writes)", writes_.size());
    return {};
  }

  VoidResult init(uint32_t scene_materials) {
    const DemoMaterial& first = materials_.front();
    ShaderConfig config;
    config.components = first.components;
    config.angular.parameterisation = DirectionParameterisation::parabolic;
    config.angular.lookup = AngularLookup::barycentric;
    config.angular.resolution = first.angular_resolution;
    uint32_t finest = 0;
    for (const auto& m : materials_) finest = std::max(finest, m.finest_level);
    // VT set from the containers' geometry and weights (what a client knows before streaming).
    for (const DemoMaterial& m : materials_) {
      auto dir = read_bsvtf(m.bsvtf);
      if (!dir) return make_error(dir.status(), "%s: %s", m.bsvtf_path.c_str(), dir.message().c_str());
      const BsvtfMetadata& md = dir->metadata;
      const VtGeometry g = VtGeometry::make(md.width, md.height, md.tile_size, md.border);
      const uint32_t id = set_.add_material(g, md.texture_count());
      (void)id;
      tile_size_ = md.tile_size;
      border_ = md.border;
    }
    // Weights w for the scheduler (paper 000 eq. 8), from the material's tile pyramid.
    for (uint32_t mi = 0; mi < materials_.size(); ++mi) {
      auto pyr = TilePyramid::build(materials_[mi].eigen, tile_size_, border_);
      if (!pyr) return pyr.error();
      pyr->copy_weights_to(set_, mi);
    }
    config.vt.tile_size = tile_size_;
    config.vt.border = border_;
    config.vt.slots_x = s_.slots_x;
    config.vt.slots_y = s_.slots_y;
    config.vt.cache_layers = 1;
    config.vt.finest_level = finest;
    if (auto e = be_.init(config, set_.texture_count()); !e) return e.error();
    auto cache = TileCache::create(set_, TileCacheConfig{s_.slots_x, s_.slots_y, 1u << 16});
    if (!cache) return cache.error();
    cache_ = std::make_unique<TileCache>(std::move(*cache));
    SchedulerConfig sc;
    sc.budgets.uploads_per_frame = s_.uploads_per_frame;
    sc.budgets.requests_in_flight = 4 * s_.uploads_per_frame;
    sc.budgets.tiles_decoding = 4 * s_.uploads_per_frame;
    sc.tile_bytes = static_cast<uint64_t>(TileLayout{tile_size_, border_, 4}.sample_count()) * 2;
    auto sched = Scheduler::create(*cache_, sc);
    if (!sched) return sched.error();
    sched_ = std::make_unique<Scheduler>(std::move(*sched));
    votes_ = std::make_unique<VoteCounter>(vote_layouts(set_));
    staging_.resize(sc.budgets.requests_in_flight);
    outstanding_.resize(materials_.size());
    request_of_.resize(materials_.size());
    // Scene, meshes, materials.
    objects_ = scene::make_demo_scene(scene_materials);
    for (const auto& o : objects_) {
      auto h = be_.create_mesh(MeshData{o.vertices, o.indices});
      if (!h) return h.error();
      meshes_.push_back(*h);
    }
    for (const DemoMaterial& m : materials_) {
      auto a = be_.create_material(m.data(true));
      if (!a) return a.error();
      fmf_mats_.push_back(*a);
      auto b = be_.create_material(m.data(false));
      if (!b) return b.error();
      bsvtf_mats_.push_back(*b);
      const uint64_t groups = (m.components + 3) / 4;
      uint64_t mips = 0;
      for (uint64_t w = static_cast<uint64_t>(m.eigen_textures.width()), h = static_cast<uint64_t>(m.eigen_textures.height());;
           w = std::max<uint64_t>(w / 2, 1), h = std::max<uint64_t>(h / 2, 1)) {
        mips += w * h;
        if (w == 1 && h == 1) break;
      }
      memory_.fmf_bytes += mips * groups * 16;  // RGBA32F
      memory_.u_bytes += m.u.size() / m.components * groups * 16 + 2ull * m.angular_resolution * m.angular_resolution * 32;
    }
    uint64_t pt = 0;
    for (uint32_t l = 0; l <= finest; ++l) pt += (1ull << l) * (1ull << l);
    memory_.bsvtf_bytes = static_cast<uint64_t>(config.vt.cache_width()) * config.vt.cache_height() * 8 +
                          pt * 4 * set_.texture_count();
    // Streaming: one pipeline per container, each over its share (1/n) of the throttled link.
    for (const DemoMaterial& m : materials_) {
      sources_.push_back(std::make_unique<MemorySource>(std::span<const uint8_t>(m.bsvtf)));
    }
    for (auto& src : sources_) {
      throttled_.push_back(std::make_unique<ThrottledSource>(*src, s_.bytes_per_second / static_cast<double>(sources_.size()),
                                                             std::chrono::microseconds(s_.latency_ms * 1000)));
      PipelineConfig pc;
      pc.worker_threads = 1;
      pc.ready_capacity = 4 * s_.uploads_per_frame;
      auto p = StreamingPipeline::open(*throttled_.back(), pc);
      if (!p) return p.error();
      pipelines_.push_back(std::move(*p));
    }
    // Pinned roots: fetch through the pipeline (blocking, bounded) and upload.
    for (uint32_t m = 0; m < materials_.size(); ++m) {
      const VtMaterial& vm = set_.material(m);
      std::vector<StreamItem> roots;
      for (uint32_t k = 0; k < vm.texture_count; ++k) roots.push_back(StreamItem::for_tile(TileId{k, 0, 0, 0}));
      pipelines_[m]->request(roots);
      uint32_t got = 0;
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
      while (got < vm.texture_count && std::chrono::steady_clock::now() < deadline) {
        Status st = Status::success;
        pipelines_[m]->deliver(roots.size(), [&](const StreamDelivery& d) {
          std::vector<uint16_t> texels(d.samples.size());
          float_to_half(d.samples, texels);
          const TileId global{vm.first_texture + d.item.tile.texture, 0, 0, 0};
          const TileUpload up{cache_->slot_of(global), texels};
          if (be_.upload_tiles({&up, 1}) != Status::success) st = Status::io_error;
          ++got;
        });
        if (st != Status::success) return make_error(st, "root tile upload failed");
        if (got < vm.texture_count) std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
      if (got < vm.texture_count) return make_error(Status::io_error, "%s: root tiles did not arrive", materials_[m].name.c_str());
      pipelines_[m]->request({});
    }
    return write_page_tables();
  }

  Backend& be_;
  const std::vector<DemoMaterial>& materials_;
  StreamSettings s_;
  uint32_t tile_size_ = 32, border_ = 4;
  VtSet set_;
  std::unique_ptr<TileCache> cache_;
  std::unique_ptr<Scheduler> sched_;
  std::unique_ptr<VoteCounter> votes_;
  std::vector<std::unique_ptr<MemorySource>> sources_;
  std::vector<std::unique_ptr<ThrottledSource>> throttled_;
  std::vector<std::unique_ptr<StreamingPipeline>> pipelines_;
  std::vector<std::vector<StreamItem>> outstanding_;
  std::vector<std::unordered_map<uint64_t, uint32_t>> request_of_;
  std::vector<std::vector<uint16_t>> staging_;
  std::vector<uint32_t> feedback_;
  std::vector<PageTableWrite> writes_;
  std::vector<scene::SceneObject> objects_;
  std::vector<MeshHandle> meshes_;
  std::vector<MaterialHandle> fmf_mats_, bsvtf_mats_;
  MemoryFigures memory_;
};

}  // namespace btflod::demo
