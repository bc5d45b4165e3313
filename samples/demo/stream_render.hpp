// btflod-demo — the streaming fly-through: per frame, the backend renders the feedback pass
// (paper 000 eq. 1–2) and the BSVTF image through the page table (eq. 3); one
// btflod::Streamer (runtime/streamer.hpp) serves every material: its update() turns the
// feedback into votes (eq. 9), plans add/swap operations (§5, P = w·v), hands decode jobs to a
// ThreadExecutor whose workers read the containers through THROTTLED sources, and returns this
// frame's tile uploads and page-table texels, which runtime/backend/streamer_outputs.hpp applies to the
// renderer. The same view is also rendered with FMF (eq. 5, every eigen-texture resident,
// uncompressed): that is the converged image the SSIM is measured against, and the frame time
// of both programs is measured on the same view in the same frame, in alternating order.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "btflod/core/thread_pool.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"
#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/backend/page_table_writes.hpp"
#include "btflod/runtime/backend/streamer_outputs.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/stream/file_source.hpp"
#include "btflod/runtime/stream/thread_executor.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"
#include "btflod/runtime/vt/cache_bc5.hpp"
#include "btflod/runtime/vt/tile_cache.hpp"
#include "materials.hpp"
#include "scene/analytic_demo_scene.hpp"
#include "scene/demo_scene.hpp"
#include "scene/view_camera.hpp"

namespace btflod::demo {

/// Streaming and rendering settings.
struct StreamSettings {
  uint32_t width = 480, height = 270;
  /// Feedback target = screen / 2^shift per axis (2: 1/16 of the pixels, one rotation cycle
  /// and vote window of 16 frames; 3 would make the window 64 frames, longer than the settle).
  uint32_t feedback_shift = 2;
  /// Tile cache (one layer): 128 slots of 40² texels, 1600 KiB RGBA16F (≤ 15 % of the four
  /// materials' RGBA32F V′; the 144-slot cache was 16.5 %). A power-of-two slot grid makes the
  /// shader's slot → origin arithmetic (eq. 3) shifts and masks.
  uint32_t slots_x = 16, slots_y = 8;
  double bytes_per_second = 256.0 * 1024;  ///< throttled link shared by all materials
  uint32_t latency_ms = 20;
  uint32_t uploads_per_frame = 16;
  /// A material swapped in mid-flight, as a level load would (0: never): at swap_out_frame the
  /// last scene slot gets a copy of material 0, streamed as a new Streamer material over
  /// material 0's link; at swap_back_frame it gets its own material again, streamed anew. Each
  /// swap adds the new material first, shows it once it is ready (roots and U′ loaded), then
  /// removes the old one (Streamer::add_material / remove_material; its GPU material destroyed).
  uint32_t swap_out_frame = 0, swap_back_frame = 0;
  /// Texel format of the tile cache (runtime/vt/cache_format.hpp): rgba16f, or rgba8_affine at half
  /// the memory (the Streamer's decode jobs quantise each tile with its own range).
  CacheFormat cache_format = CacheFormat::rgba16f;
};

/// Which demo material a scene slot shows and the Streamer material id it streams under.
struct ShownMaterial {
  uint32_t demo = 0;         ///< index into the demo's materials (textures, U′, tables)
  uint32_t streamer_id = 0;  ///< Streamer material id (feedback word, page-table layers)
};

/// One material swap on a live Streamer (StreamSettings::swap_out_frame).
struct SwapRecord {
  static constexpr int64_t kNever = -1;
  uint32_t slot = 0;                ///< scene slot whose material changed
  uint32_t demo = 0;                ///< demo material shown from then on
  uint32_t added_id = 0;            ///< its Streamer material id (add_material)
  uint32_t removed_id = 0;          ///< the id it replaced (remove_material once the new one was ready)
  uint32_t first_texture = 0;       ///< page-table layer of the added material
  uint32_t added_frame = 0;         ///< frame of add_material()
  int64_t shown_frame = kNever;     ///< frame the new material was ready and drawn (the old one removed)
  int64_t released_frame = kNever;  ///< frame of the old id's material_released event
  uint64_t bytes_before = 0;        ///< payload bytes read when it was added (bytes_read())
  uint64_t bytes_until_shown = 0;   ///< payload bytes read from adding to showing it (all materials)
};

/// What one frame measured.
struct FrameRecord {
  uint32_t frame = 0;
  uint64_t bytes_received = 0;  ///< verified payload bytes so far, all materials
  uint32_t tiles_delivered = 0;
  double occupancy = 0;  ///< used cache slots / slots
  double ssim = 0;       ///< BSVTF vs FMF (converged) render, sRGB-encoded, mean over RGB
  double rmse = 0;       ///< same pair, linear radiance
  double ms_bsvtf = 0;   ///< BSVTF colour pass with its feedback words (or + feedback pass), submit to read-back
  double ms_fmf = 0;     ///< FMF colour pass, submit to read-back
  uint32_t requests = 0, uploads = 0;
  uint32_t page_table_writes = 0;  ///< GPU page-table texels written after this frame (deltas)
  uint32_t swaps = 0;              ///< scheduler swap operations this frame
  uint32_t lod_bias = 0;           ///< scheduler's global LOD bias after this frame's plan
  bool settle = false;             ///< camera held at the last view (convergence phase)
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
  uint64_t bsvtf_bytes = 0;  ///< tile cache (its format, slot maps included) + page table R32UI with mips
  uint64_t cache_bytes = 0;  ///< the tile cache alone (texels + rgba8_affine's slot-map table)
  uint64_t u_bytes = 0;      ///< U' and lookup tables (the same for both, not counted above)
};

/// What the streaming loop needs from a renderer: the GPU Backend (GpuFrameRenderer) or the CPU
/// reference ray-caster of offline/render/cpu_reference.hpp (CpuFrameRenderer, the fallback).
class FrameRenderer {
 public:
  virtual ~FrameRenderer() = default;
  virtual std::string name() const = 0;
  /// Set-up: shaders/targets, meshes or shapes, materials. `cache` (the Streamer's) outlives
  /// the renderer.
  virtual VoidResult init(const ShaderConfig& config, const TileCache& cache,
                          const std::vector<DemoMaterial>& materials,
                          const std::vector<scene::SceneObject>& objects) = 0;
  /// Applies one Streamer::update()'s tile uploads and page-table writes.
  virtual Status apply(const StreamerOutputs& out) = 0;
  /// A Streamer material added while streaming (material `id` shows demo material `m`): the
  /// renderer creates what it draws it with. Set-up work, between frames.
  virtual VoidResult add_streamed(uint32_t /*id*/, const DemoMaterial& /*m*/) { return {}; }
  /// A removed Streamer material: the renderer releases what it drew it with. Between frames.
  virtual Status remove_streamed(uint32_t /*id*/) { return Status::success; }
  /// Scene slot `slot` shows `m` from the next frame on (init(): slot i shows material i as id i).
  void show(uint32_t slot, ShownMaterial m) { shown_.at(slot) = m; }
  /// What scene slot `slot` shows. Precondition: init() succeeded, slot < material count.
  ShownMaterial shown(uint32_t slot) const { return shown_[slot]; }
  /// Writes page-table texels (the page-table check's full rewrite).
  virtual Status write_page_table(std::span<const PageTableWrite> writes) = 0;
  /// True when the image depends on the writes above (GPU); the CPU reference reads the cache.
  virtual bool renders_page_table() const { return false; }
  /// BSVTF image + feedback words (screen / 2^shift) and the FMF image of the same view, with
  /// the time of each pass in ms; even frames render BSVTF first, odd frames FMF first (so
  /// neither pass always follows the streaming work). `params(m)` gives material m's uniforms.
  virtual VoidResult render(const scene::View& view, uint64_t frame, uint32_t feedback_shift,
                            const std::function<ShaderParams(uint32_t)>& params, Image<float>& bsvtf, Image<float>& fmf,
                            std::vector<uint32_t>& feedback, double& ms_bsvtf, double& ms_fmf) = 0;

 protected:
  void show_identity(size_t slots) {
    shown_.resize(slots);
    for (uint32_t i = 0; i < slots; ++i) shown_[i] = ShownMaterial{i, i};
  }
  std::vector<ShownMaterial> shown_;  // per scene slot
};

inline double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// The GPU path: generated shaders on a Backend (samples/gl, samples/vulkan).
class GpuFrameRenderer final : public FrameRenderer {
 public:
  explicit GpuFrameRenderer(Backend& be) : be_(be) {}
  std::string name() const override { return be_.name(); }
  VoidResult init(const ShaderConfig& config, const TileCache& cache, const std::vector<DemoMaterial>& materials,
                  const std::vector<scene::SceneObject>& objects) override {
    if (auto e = be_.init(config, cache.set().texture_count()); !e) return e.error();
    for (const auto& o : objects) {
      auto h = be_.create_mesh(MeshData{o.vertices, o.indices});
      if (!h) return h.error();
      meshes_.push_back(*h);
      material_of_.push_back(o.material);
    }
    // FMF materials by demo material; BSVTF materials by Streamer id (created as 0 … n−1, room
    // for the ids add_material() hands out later).
    bsvtf_mats_.assign(cache.set().material_count(), MaterialHandle{});
    for (size_t i = 0; i < materials.size(); ++i) {
      auto a = be_.create_material(materials[i].data(true));
      if (!a) return a.error();
      fmf_mats_.push_back(*a);
      if (auto e = add_streamed(static_cast<uint32_t>(i), materials[i]); !e) return e;
    }
    show_identity(materials.size());
    return {};
  }
  VoidResult add_streamed(uint32_t id, const DemoMaterial& m) override {
    if (id >= bsvtf_mats_.size() || bsvtf_mats_[id].id != 0)
      return make_error(Status::invalid_argument, "Streamer material %u: no room or already created", id);
    auto b = be_.create_material(m.data(false));
    if (!b) return b.error();
    bsvtf_mats_[id] = *b;
    return {};
  }
  Status remove_streamed(uint32_t id) override {
    if (id >= bsvtf_mats_.size()) return Status::invalid_argument;
    const Status s = be_.destroy_material(bsvtf_mats_[id]);
    bsvtf_mats_[id] = MaterialHandle{};
    return s;
  }
  Status apply(const StreamerOutputs& out) override { return apply_streamer_outputs(be_, out, bsvtf_mats_); }
  Status write_page_table(std::span<const PageTableWrite> writes) override {
    return be_.apply_page_table_writes(writes);
  }
  bool renders_page_table() const override { return true; }
  /// Called after each BSVTF colour pass, outside both timings, while its image is the
  /// backend's colour target (the demo's --window presents it there).
  void set_after_bsvtf(std::function<void()> f) { after_bsvtf_ = std::move(f); }
  /// Draws the feedback words in a pass of their own at the feedback resolution (the GPU path of
  /// paper 000 §5) instead of writing them from the colour pass (ShaderProgram::bsvtf_feedback).
  void set_separate_feedback_pass(bool on) { separate_feedback_pass_ = on; }
  VoidResult render(const scene::View& view, uint64_t frame, uint32_t shift,
                    const std::function<ShaderParams(uint32_t)>& params, Image<float>& bsvtf, Image<float>& fmf,
                    std::vector<uint32_t>& feedback, double& ms_bsvtf, double& ms_fmf) override {
    FrameDesc desc;
    desc.width = view.width;
    desc.height = view.height;
    desc.feedback_width = (view.width + (1u << shift) - 1) >> shift;
    desc.feedback_height = (view.height + (1u << shift) - 1) >> shift;
    desc.clear_color[0] = 0.45f, desc.clear_color[1] = 0.55f, desc.clear_color[2] = 0.7f, desc.clear_color[3] = 1.0f;
    if ((frame & 1) == 0) {
      if (auto e = render_bsvtf(desc, frame, shift, params, bsvtf, feedback, ms_bsvtf); !e) return e;
      return render_fmf(desc, params, fmf, ms_fmf);
    }
    if (auto e = render_fmf(desc, params, fmf, ms_fmf); !e) return e;
    return render_bsvtf(desc, frame, shift, params, bsvtf, feedback, ms_bsvtf);
  }

 private:
  // Each feedback texel takes one screen pixel of its 2^shift × 2^shift block, a different one
  // every frame (runtime/lod/feedback.hpp's feedback_sample_offset). By default the BSVTF colour pass
  // writes every pixel's word (bsvtf_feedback) and the backend reads back that pixel of each
  // block: no second pass over the geometry. With a separate feedback pass (1/2^shift of the
  // screen, paper 000 §5) it is drawn for every mesh first, then the colour pass: one
  // render-target switch per frame instead of two per mesh (on llvmpipe each switch flushes the
  // binned scene); its projection is shifted by the offset from the texel centre.
  // The streaming loop sums the votes over the 4^shift frames of one rotation cycle
  // (VoteCounter::accumulate): single-frame votes of a rotating position differ from frame to
  // frame and kept a full cache swapping at a fixed view (SSIM oscillating 0.91-0.96 over the
  // settle phase), which is why the demo had gone back to fixed positions before.
  VoidResult render_bsvtf(const FrameDesc& desc, uint64_t frame, uint32_t shift,
                          const std::function<ShaderParams(uint32_t)>& params, Image<float>& bsvtf,
                          std::vector<uint32_t>& feedback, double& ms) {
    const uint32_t d = 1u << shift;
    uint32_t dx = 0, dy = 0;
    feedback_sample_offset(frame, d, dx, dy);
    const float fd = static_cast<float>(d);
    const glm::vec2 jitter{
        (0.5f - (static_cast<float>(dx) + 0.5f) / fd) * 2.0f / static_cast<float>(desc.feedback_width),
        (0.5f - (static_cast<float>(dy) + 0.5f) / fd) * 2.0f / static_cast<float>(desc.feedback_height)};
    const glm::mat4 shift_ndc = glm::translate(glm::mat4(1.0f), glm::vec3(jitter, 0.0f));
    FrameDesc frame_desc = desc;
    frame_desc.feedback_sample_x = dx;
    frame_desc.feedback_sample_y = dy;
    const auto t0 = std::chrono::steady_clock::now();
    if (be_.begin_frame(frame_desc) != Status::success) return make_error(Status::io_error, "begin_frame failed");
    for (size_t i = 0; separate_feedback_pass_ && i < meshes_.size(); ++i) {
      ShaderParams p = params(material_of_[i]);
      p.model_view_proj = shift_ndc * glm::mat4(p.model_view_proj);
      p.lod.y = static_cast<float>(shift);
      if (be_.draw_feedback(meshes_[i], p) != Status::success)
        return make_error(Status::io_error, "draw_feedback failed");
    }
    for (size_t i = 0; i < meshes_.size(); ++i) {
      const uint32_t slot = material_of_[i];
      const ShaderProgram program = separate_feedback_pass_ ? ShaderProgram::bsvtf : ShaderProgram::bsvtf_feedback;
      if (be_.draw(program, meshes_[i], bsvtf_mats_[shown_[slot].streamer_id], params(slot)) != Status::success)
        return make_error(Status::io_error, "draw (bsvtf) failed");
    }
    if (be_.end_frame() != Status::success) return make_error(Status::io_error, "end_frame failed");
    if (be_.read_color(bsvtf.view()) != Status::success) return make_error(Status::io_error, "read_color failed");
    ms = ms_since(t0);
    be_.wait_idle();
    if (after_bsvtf_) after_bsvtf_();
    FeedbackFrame fb;
    feedback.clear();
    while (be_.poll_feedback(fb)) feedback.assign(fb.words.begin(), fb.words.end());
    return {};
  }
  VoidResult render_fmf(const FrameDesc& desc, const std::function<ShaderParams(uint32_t)>& params, Image<float>& fmf,
                        double& ms) {
    const auto t0 = std::chrono::steady_clock::now();
    if (be_.begin_frame(desc) != Status::success) return make_error(Status::io_error, "begin_frame failed");
    for (size_t i = 0; i < meshes_.size(); ++i) {
      const uint32_t slot = material_of_[i];
      if (be_.draw(ShaderProgram::fmf, meshes_[i], fmf_mats_[shown_[slot].demo], params(slot)) != Status::success)
        return make_error(Status::io_error, "draw (fmf) failed");
    }
    if (be_.end_frame() != Status::success) return make_error(Status::io_error, "end_frame failed");
    if (be_.read_color(fmf.view()) != Status::success) return make_error(Status::io_error, "read_color failed");
    ms = ms_since(t0);
    be_.wait_idle();
    FeedbackFrame fb;
    while (be_.poll_feedback(fb)) {
    }  // the FMF pass draws no feedback: drop its (empty) readback
    return {};
  }

  Backend& be_;
  std::function<void()> after_bsvtf_;
  bool separate_feedback_pass_ = false;
  std::vector<MeshHandle> meshes_;
  std::vector<uint32_t> material_of_;       // scene slot per mesh
  std::vector<MaterialHandle> fmf_mats_;    // per demo material
  std::vector<MaterialHandle> bsvtf_mats_;  // per Streamer material id
};

/// The CPU fallback: the analytic scene (plane + tori) ray-cast by offline/render/cpu_reference.hpp,
/// feedback by render_feedback (eq. 1–2), BSVTF through CpuCacheTexture (eq. 3, the deepest
/// resident tile), FMF from V' at the finest level (bilinear, repeat), both shaded by
/// shade_fmf's 9 taps with the same lookup tables as the shaders. Rows run on the thread pool.
class CpuFrameRenderer final : public FrameRenderer {
 public:
  static constexpr uint32_t kMaxComponents = 256;  ///< C the shading loop holds (64 RGBA groups)
  CpuFrameRenderer() = default;
  /// Keeps its cache texture in `format` instead of the Streamer cache's (the cache-format
  /// comparison fills it with upload_tile_values()).
  explicit CpuFrameRenderer(CacheFormat format) : format_override_(true), format_(format) {}
  std::string name() const override { return "CPU reference (offline/render/cpu_reference.hpp ray-caster)"; }
  VoidResult init(const ShaderConfig& config, const TileCache& cache, const std::vector<DemoMaterial>& materials,
                  const std::vector<scene::SceneObject>&) override {
    set_ = &cache.set();
    cache_ = &cache;
    materials_ = &materials;
    config_ = config;
    texture_ = std::make_unique<CpuCacheTexture>(cache, format_override_ ? format_ : cache.config().format);
    for (const DemoMaterial& m : materials)
      if (m.components > kMaxComponents)
        return make_error(Status::unsupported, "%s: C = %u, the CPU reference shades at most %u components",
                          m.name.c_str(), m.components, kMaxComponents);
    scene_ = scene::analytic_demo_scene(static_cast<uint32_t>(materials.size()));
    show_identity(materials.size());
    return {};
  }
  // Tiles into the cache texture; the ray-caster samples the tile cache's own page table.
  Status apply(const StreamerOutputs& out) override {
    return forward_streamer_outputs(
        out,
        [&](std::span<const TileUpload> tiles) noexcept {
          for (const TileUpload& t : tiles)
            if (!texture_->upload(*cache_, t.slot, t.texels, t.unorm8, t.map, t.bc5)) return Status::invalid_argument;
          return Status::success;
        },
        [](std::span<const PageTableWrite>) noexcept { return Status::success; });
  }
  Status write_page_table(std::span<const PageTableWrite>) override {
    return Status::success;
  }  // reads the cache's table
  VoidResult render(const scene::View& view, uint64_t frame, uint32_t shift,
                    const std::function<ShaderParams(uint32_t)>& params, Image<float>& bsvtf, Image<float>& fmf,
                    std::vector<uint32_t>& feedback, double& ms_bsvtf, double& ms_fmf) override {
    const Camera cam = scene::to_camera(view);
    const ShaderParams p = params(0);
    auto t0 = std::chrono::steady_clock::now();
    const uint32_t d = 1u << shift;
    feedback.assign(static_cast<size_t>((view.width + d - 1) / d) * ((view.height + d - 1) / d), kFeedbackNone);
    render_feedback(scene_, cam, *set_, DerivativeLod{}, d, frame, feedback);
    shade(cam, p, true, bsvtf);
    ms_bsvtf = ms_since(t0);
    t0 = std::chrono::steady_clock::now();
    shade(cam, p, false, fmf);
    ms_fmf = ms_since(t0);
    return {};
  }
  /// Puts a decoded tile (`values`: (T+2B)² × 4 floats) into `slot` of the cache texture,
  /// converted to its format as the Streamer's decode jobs do. False on a size or slot mismatch.
  /// With `bc5`, the values pass through the two-plane BC5 layout first (runtime/vt/cache_bc5.hpp:
  /// encoded, then decoded by the reference decoder and mapped) into an rgba16f texture: the image
  /// a BC5 cache would give, up to the halves' rounding.
  bool upload_tile_values(uint32_t slot, std::span<const float> values, bool bc5 = false) {
    if (bc5) {
      const uint32_t side = cache_->set().levels_of(0).geometry.stored_size();  // T + 2B, as the slot
      std::vector<uint8_t> scratch(values.size()), blocks(cache_bc5_tile_bytes(side));
      const CacheSlotMap map = encode_cache_tile_bc5(values, side, scratch, blocks);
      std::vector<float> decoded(values.size());
      decode_cache_tile_bc5(blocks, side, map, decoded);
      std::vector<uint16_t> h(values.size());
      float_to_half(decoded, h);
      return texture_->format() == CacheFormat::rgba16f && texture_->upload(*cache_, slot, h);
    }
    if (texture_->format() == CacheFormat::rgba8_affine) {
      std::vector<uint8_t> q(values.size());
      const CacheSlotMap map = encode_cache_tile_unorm8(values, q);
      return texture_->upload(*cache_, slot, q, map);
    }
    std::vector<uint16_t> h(values.size());
    float_to_half(values, h);
    return texture_->upload(*cache_, slot, h);
  }
  /// The BSVTF image of `view` alone (no feedback, no FMF pass).
  void render_bsvtf(const scene::View& view, const ShaderParams& params, Image<float>& bsvtf) const {
    shade(scene::to_camera(view), params, true, bsvtf);
  }

 private:
  void shade(const Camera& cam, const ShaderParams& p, bool bsvtf, Image<float>& out) const {
    const auto pixel = [&](uint32_t x, uint32_t y, float, float, const SurfaceHit& h) {
      const int xi = static_cast<int>(x), yi = static_cast<int>(y);
      if (!h.hit) {
        out.at(xi, yi, 0) = 0.45f, out.at(xi, yi, 1) = 0.55f, out.at(xi, yi, 2) = 0.7f, out.at(xi, yi, 3) = 1.0f;
        return;
      }
      float comps[kMaxComponents];
      const ShownMaterial shown = shown_[h.material];  // h.material: the scene slot
      const DemoMaterial& m = (*materials_)[shown.demo];
      const uint32_t groups = (m.components + 3) / 4;
      if (bsvtf) {
        for (uint32_t g = 0; g < groups; ++g)
          texture_->sample(*cache_, set_->material(shown.streamer_id).first_texture + g, h.texcoord.x, h.texcoord.y,
                           comps + 4 * g);
      } else {
        sample_repeat_bilinear(m.eigen_textures, h.texcoord, std::span<float>(comps, 4 * groups));
      }
      const AngularTablesData tables = m.angular_tables();
      const AngularSample ls = angular_table_sample(tables, 0, DirectionParameterisation::parabolic, false,
                                                    to_local(h, glm::normalize(glm::vec3(p.light))));
      const AngularSample vs = angular_table_sample(tables, 1, DirectionParameterisation::parabolic, false,
                                                    to_local(h, glm::normalize(view_eye(cam) - h.position)));
      const glm::vec3 rgb =
          shade_fmf(m.eigen, ls, vs, std::span<const float>(comps, m.components)) * glm::vec3(p.light_color);
      for (int c = 0; c < 3; ++c) out.at(xi, yi, c) = rgb[c];
      out.at(xi, yi, 3) = 1.0f;
    };
    for_each_pixel_hit(scene_, cam, pixel, &default_thread_pool());
  }
  static glm::vec3 view_eye(const Camera& c) { return c.position; }

  const VtSet* set_ = nullptr;
  const TileCache* cache_ = nullptr;
  const std::vector<DemoMaterial>* materials_ = nullptr;
  ShaderConfig config_;
  Scene scene_;
  std::unique_ptr<CpuCacheTexture> texture_;
  bool format_override_ = false;
  CacheFormat format_ = CacheFormat::rgba16f;
};

/// The streaming renderer over a FrameRenderer: one btflod::Streamer for every material
/// (runtime/streamer.hpp), its decode jobs on a ThreadExecutor, each container behind its own
/// throttled link. Set-up allocates; frame() renders, calls Streamer::update() once and applies
/// its outputs (runtime/backend/streamer_outputs.hpp).
class StreamingRenderer {
 public:
  /// Creates the renderer's resources and the Streamer over one throttled link per material,
  /// and loads every pinned root tile and U′ packet (update() + pump() on this thread, before
  /// any worker exists). Returns an error naming the failing step. `renderer` and `materials`
  /// must outlive the object.
  static Result<std::unique_ptr<StreamingRenderer>> create(FrameRenderer& renderer,
                                                           const std::vector<DemoMaterial>& materials,
                                                           const StreamSettings& s) {
    std::unique_ptr<StreamingRenderer> r(new StreamingRenderer(renderer, materials, s));
    if (auto e = r->init(); !e) return e.error();
    return r;
  }

  /// Renders frame f (camera at path position view_frame of `frames`) and streams; writes the
  /// two images (RGBA linear).
  Result<FrameRecord> frame(uint32_t f, uint32_t view_frame, uint32_t frames, Image<float>& bsvtf_img,
                            Image<float>& fmf_img) {
    FrameRecord rec;
    rec.frame = f;
    current_frame_ = f;
    if (auto e = start_planned_swap(f); !e) return e.error();
    const scene::View view = scene::camera_path(view_frame, frames, s_.width, s_.height);
    const ShaderParams base = scene::view_params(view, glm::vec3(0.5f, 0.8f, 0.35f), glm::vec3(2.2f, 2.1f, 2.0f));
    if (auto e = renderer_.render(
            view, f, s_.feedback_shift, [&](uint32_t m) { return material_params(base, m); }, bsvtf_img, fmf_img,
            feedback_, rec.ms_bsvtf, rec.ms_fmf);
        !e)
      return e.error();

    // Streaming: one update() — votes summed over the last 4^shift frames (one rotation of the
    // feedback sample position), plan, decode jobs handed to the workers, and this frame's
    // tile uploads and page-table texels — applied to the renderer.
    if (auto e = update(feedback_); !e) return e.error();
    if (auto e = finish_swap(f); !e) return e.error();
    const SchedulerCounters& fc = streamer_.scheduler().frame();
    rec.requests = static_cast<uint32_t>(fc.requests);
    rec.swaps = static_cast<uint32_t>(fc.swaps);
    rec.lod_bias = streamer_.scheduler().lod_bias();
    rec.uploads = static_cast<uint32_t>(last_uploads_);
    rec.page_table_writes = static_cast<uint32_t>(last_page_table_writes_);
    rec.bytes_received = streamer_.bytes_read();
    rec.tiles_delivered = tiles_delivered_;
    rec.occupancy =
        static_cast<double>(streamer_.cache().used_count()) / static_cast<double>(streamer_.cache().slot_count());
    const Image<float> a = to_display(bsvtf_img), b = to_display(fmf_img);
    rec.ssim = mean_ssim(a.view(), b.view());
    rec.rmse = rmse(bsvtf_img.view(), fmf_img.view());
    return rec;
  }

  /// Payload bytes of all containers (tiles and U′ packets: the whole data set).
  uint64_t total_payload_bytes() const {
    uint64_t n = 0;
    for (const BsvtfDirectory& d : directories_) {
      for (const BsvtfTileEntry& t : d.tiles) n += t.size;
      for (const BsvtfPacketEntry& p : d.packets) n += p.size;
    }
    return n;
  }
  const MemoryFigures& memory() const noexcept { return memory_; }
  /// Frames over which the votes are summed (one rotation cycle of the feedback sample position).
  uint32_t vote_window_frames() const noexcept { return streamer_.votes().window_frames(); }
  /// The feedback words of the last frame (screen / 2^feedback_shift per axis; --record-feedback).
  const std::vector<uint32_t>& last_feedback() const noexcept { return feedback_; }
  /// Tiles requested by the scheduler and not yet uploaded.
  size_t pending_tiles() const noexcept { return streamer_.scheduler().requests_in_flight(); }
  /// Tiles or U′ packets that failed to arrive or decode (residency events) since set-up.
  uint64_t failures() const noexcept { return failures_; }
  uint32_t slot_count() const noexcept { return streamer_.cache().slot_count(); }
  uint32_t tile_count() const noexcept { return static_cast<uint32_t>(full_page_table_size()); }
  /// The material swaps started so far (StreamSettings::swap_out_frame), and how many are planned.
  const std::vector<SwapRecord>& swaps() const noexcept { return swaps_; }
  size_t planned_swaps() const noexcept { return swap_plan_.size(); }

 private:
  StreamingRenderer(FrameRenderer& renderer, const std::vector<DemoMaterial>& materials, const StreamSettings& s)
      : renderer_(renderer), materials_(materials), s_(s) {}

  const VtSet& set() const noexcept { return streamer_.cache().set(); }

  // Uniforms of scene slot `slot`: its demo material's extent, its Streamer id and layers.
  ShaderParams material_params(const ShaderParams& base, uint32_t slot) const {
    ShaderParams p = base;
    const ShownMaterial shown = renderer_.shown(slot);
    const DemoMaterial& d = materials_[shown.demo];
    p.vt_extent = glm::vec4(static_cast<float>(d.eigen_textures.width()), static_cast<float>(d.eigen_textures.height()),
                            static_cast<float>(d.finest_level), 0.0f);
    p.ids = glm::uvec4(streamer_.first_texture(shown.streamer_id), shown.streamer_id, 0u, 0u);
    return p;
  }

  // A planned swap whose frame has come (and none under way): the new material is added to the
  // live Streamer — it streams its roots and U′ while the old one is still drawn. The previous
  // swap's removed id must have been released first (material_released: its last job ended):
  // the Streamer's capacity holds one material more than are shown, so adding earlier finds no
  // free id when a loaded machine runs that id's jobs late.
  VoidResult start_planned_swap(uint32_t f) {
    if (next_swap_ >= swap_plan_.size() || f < swap_plan_[next_swap_].frame || pending_swap_) return {};
    if (!swaps_.empty() && swaps_.back().released_frame == SwapRecord::kNever) return {};
    const PlannedSwap plan = swap_plan_[next_swap_++];
    uint32_t id = 0;
    const char* why = "";
    const StreamerMaterial m{&directories_[plan.demo], throttled_[plan.demo].get(), nullptr};
    if (const Status st = streamer_.add_material(m, id, &why); st != Status::success)
      return make_error(st, "frame %u: add_material(%s) failed: %s", f, materials_[plan.demo].name.c_str(), why);
    if (auto e = renderer_.add_streamed(id, materials_[plan.demo]); !e) return e;
    for (uint32_t t = streamer_.first_texture(id); t < streamer_.first_texture(id) + streamer_.texture_count(id); ++t)
      page_mirror_[t].assign(set().levels_of(t).tile_count(), 0u);
    SwapRecord r;
    r.slot = plan.slot, r.demo = plan.demo, r.added_id = id, r.removed_id = renderer_.shown(plan.slot).streamer_id;
    r.first_texture = streamer_.first_texture(id), r.added_frame = f, r.bytes_before = streamer_.bytes_read();
    swaps_.push_back(r);
    pending_swap_ = true;
    return {};
  }

  // Once the added material is ready it is drawn, and the one it replaces is removed from the
  // Streamer (its slots and layers free at once, its id once its last job ended) and the GPU.
  VoidResult finish_swap(uint32_t f) {
    if (!pending_swap_) return {};
    SwapRecord& r = swaps_.back();
    if (streamer_.material_failed(r.added_id))
      return make_error(Status::io_error, "frame %u: the swapped-in material %u failed", f, r.added_id);
    if (!streamer_.material_ready(r.added_id)) return {};
    renderer_.show(r.slot, ShownMaterial{r.demo, r.added_id});
    if (const Status st = streamer_.remove_material(r.removed_id); st != Status::success)
      return make_error(st, "frame %u: remove_material(%u) failed", f, r.removed_id);
    if (const Status st = renderer_.remove_streamed(r.removed_id); st != Status::success)
      return make_error(st, "frame %u: the renderer could not release material %u", f, r.removed_id);
    r.shown_frame = f;
    r.bytes_until_shown = streamer_.bytes_read() - r.bytes_before;
    pending_swap_ = false;
    return {};
  }

  // One Streamer::update() and its outputs applied to the renderer. The page-table writes are
  // also kept in a CPU mirror of the GPU table, for check_page_tables_against_rebuild().
  VoidResult update(std::span<const uint32_t> feedback) {
    StreamerOutputs out{tile_uploads_, packet_uploads_, page_writes_, events_};
    if (const Status st = streamer_.update(feedback, out); st != Status::success)
      return make_error(st, "Streamer::update failed");
    if (const Status st = renderer_.apply(out); st != Status::success)
      return make_error(st, "applying the frame's outputs failed (%zu tiles, %zu page-table texels)",
                        out.tile_upload_count, out.page_table_write_count);
    for (size_t i = 0; i < out.page_table_write_count; ++i) {
      const PageTableWrite& w = page_writes_[i];
      page_mirror_[w.tile.texture][mirror_index(w.tile)] = w.entry;
    }
    for (size_t i = 0; i < out.event_count; ++i) {
      const ResidencyEvent& e = events_[i];
      failures_ += e.kind == ResidencyEventKind::tile_failed || e.kind == ResidencyEventKind::packet_failed;
      if (e.kind == ResidencyEventKind::material_released)
        for (SwapRecord& r : swaps_)
          if (r.removed_id == e.material && r.shown_frame != SwapRecord::kNever &&
              r.released_frame == SwapRecord::kNever)
            r.released_frame = static_cast<int64_t>(current_frame_);
    }
    last_uploads_ = out.tile_upload_count;
    last_page_table_writes_ = out.page_table_write_count;
    tiles_delivered_ += static_cast<uint32_t>(out.tile_upload_count);
    total_page_table_writes_ += out.page_table_write_count;
    return {};
  }

  size_t mirror_index(const TileId& t) const { return set().levels_of(t.texture).index(t); }

  // The entry the BSVTF shader ends up sampling at tile t (level l, not the finest) for finest
  // tile f below it, from page table `table` (function of a tile): btflod_vt_fetch's rule, its
  // own entry when it is at level l, else the deeper of it and f's.
  template <class Table>
  static uint32_t sampled_entry(const Table& table, const TileId& t, const TileId& f) {
    const uint32_t e = table(t);
    if (unpack_page_entry_level(e) == t.level) return e;
    const uint32_t ef = table(f);
    return unpack_page_entry_level(ef) > unpack_page_entry_level(e) ? ef : e;
  }

 public:
  /// Page-table texels written since set-up (the Streamer's writes: the initial upload of every
  /// texel, then only texels whose value changed), full-table rewrites among them (the initial
  /// upload), and the writes one full rewrite of every table takes.
  uint64_t total_page_table_writes() const noexcept { return total_page_table_writes_; }
  uint32_t full_rewrites() const noexcept { return 1; }
  size_t full_page_table_size() const noexcept {
    size_t n = 0;
    for (uint32_t t = 0; t < set().texture_count(); ++t) n += set().levels_of(t).tile_count();
    return n;
  }

  /// Checks that the page table built from the Streamer's writes equals a from-scratch rebuild
  /// as far as the shader can tell: for every texel of every level, the CPU mirror of the GPU
  /// table (every write applied) and gpu_page_entry() of the cache give the same sampled entry
  /// (own entry when resident at its level, else the deeper of it and the finest entry), and
  /// mip 0 is identical. Then, on a GPU renderer, renders `view_frame` with the written table,
  /// rewrites every table from scratch, renders again and requires identical images. Returns
  /// the first difference (texture, level, tile, entries) or the largest pixel difference.
  VoidResult check_page_tables_against_rebuild(uint32_t view_frame, uint32_t frames, Image<float>& a, Image<float>& b) {
    if (streamer_.pending_page_table_writes() != 0)
      return make_error(Status::invalid_argument, "%zu page-table writes still wait for output capacity",
                        streamer_.pending_page_table_writes());
    const TileCache& cache = streamer_.cache();
    for (uint32_t t = 0; t < set().texture_count(); ++t) {
      const VtLevelTable& lv = set().levels_of(t);
      const uint32_t L = lv.finest_level();
      const auto mirror = [&](const TileId& id) { return page_mirror_[t][lv.index(id)]; };
      const auto rebuild = [&](const TileId& id) { return gpu_page_entry(cache, id); };
      for (uint32_t i = 0; i < lv.tile_count(); ++i) {
        const TileId id = lv.tile(t, i);
        if (id.level == L) {
          if (mirror(id) != rebuild(id))
            return make_error(Status::invalid_argument,
                              "page table %u: finest tile (%u,%u) holds 0x%08x, rebuild 0x%08x", t, id.x, id.y,
                              mirror(id), rebuild(id));
          continue;
        }
        const uint32_t side = 1u << (L - id.level);
        for (uint32_t y = id.y * side; y < std::min((id.y + 1) * side, lv.tiles_y[L]); ++y)
          for (uint32_t x = id.x * side; x < std::min((id.x + 1) * side, lv.tiles_x[L]); ++x) {
            const TileId f{t, L, x, y};
            const uint32_t m = sampled_entry(mirror, id, f), r = sampled_entry(rebuild, id, f);
            if (m != r)
              return make_error(
                  Status::invalid_argument,
                  "page table %u: level %u tile (%u,%u) over finest (%u,%u) samples 0x%08x, rebuild 0x%08x", t,
                  id.level, id.x, id.y, x, y, m, r);
          }
      }
    }
    if (!renderer_.renders_page_table()) return {};
    const scene::View view = scene::camera_path(view_frame, frames, s_.width, s_.height);
    const ShaderParams base = scene::view_params(view, glm::vec3(0.5f, 0.8f, 0.35f), glm::vec3(2.2f, 2.1f, 2.0f));
    const auto params = [&](uint32_t m) { return material_params(base, m); };
    std::vector<uint32_t> feedback;
    double ms_a = 0, ms_b = 0;
    if (auto e = renderer_.render(view, 0, s_.feedback_shift, params, a, b, feedback, ms_a, ms_b); !e) return e;
    Image<float> delta_built = a;
    std::vector<PageTableWrite> writes;
    for (uint32_t t = 0; t < set().texture_count(); ++t) append_full_page_table_writes(cache, t, writes);
    if (renderer_.write_page_table(writes) != Status::success)
      return make_error(Status::io_error, "page-table rebuild failed (%zu writes)", writes.size());
    for (const PageTableWrite& w : writes) page_mirror_[w.tile.texture][mirror_index(w.tile)] = w.entry;
    if (auto e = renderer_.render(view, 0, s_.feedback_shift, params, a, b, feedback, ms_a, ms_b); !e) return e;
    float worst = 0.0f;
    int wx = 0, wy = 0;
    for (int y = 0; y < a.height(); ++y)
      for (int x = 0; x < a.width(); ++x)
        for (int c = 0; c < 4; ++c) {
          const float d = std::abs(a.at(x, y, c) - delta_built.at(x, y, c));
          if (d > worst || std::isnan(d)) worst = std::isnan(d) ? 1e30f : d, wx = x, wy = y;
        }
    if (worst != 0.0f)
      return make_error(Status::invalid_argument,
                        "BSVTF image with the delta-built page table differs from the rebuilt one by %g at (%d,%d)",
                        static_cast<double>(worst), wx, wy);
    return {};
  }

  /// The view at path position `view_frame` of `frames` on the CPU ray-caster, with the
  /// Streamer's resident tiles in cache format `format`: every used slot's tile decoded again
  /// from its container (decode_bsvtf_tile) and converted as the decode jobs convert it, sampled
  /// through the Streamer cache's page table. Two calls with different formats differ in the
  /// cache format alone (same rays, tiles and page table). Set-up cost (a CPU render).
  /// `bc5` (with format rgba16f): the tiles as the two-plane BC5 layout gives them back.
  VoidResult render_cache_format_on_cpu(CacheFormat format, uint32_t view_frame, uint32_t frames, Image<float>& out,
                                        bool bc5 = false) {
    CpuFrameRenderer cpu(format);
    ShaderConfig config = shader_config_;
    config.vt.format = format;
    if (auto e = cpu.init(config, streamer_.cache(), materials_, objects_); !e) return e;
    std::vector<int64_t> demo_of(set().material_count(), -1);  // Streamer id → demo material shown
    for (uint32_t slot = 0; slot < materials_.size(); ++slot) {
      const ShownMaterial m = renderer_.shown(slot);
      cpu.show(slot, m);
      if (m.streamer_id < demo_of.size()) demo_of[m.streamer_id] = m.demo;
    }
    const TileCache& cache = streamer_.cache();
    TileDecoder decoder(directories_.front().metadata.layout());
    std::vector<float> scratch(decoder.layout().sample_count()), values(decoder.layout().sample_count());
    for (uint32_t s = 0; s < cache.slot_count(); ++s) {
      const SlotInfo& info = cache.slot(s);
      if (info.state != SlotInfo::State::used) continue;
      const uint32_t id = set().material_of(info.tile.texture);
      if (id >= demo_of.size() || demo_of[id] < 0) continue;  // a material no slot shows
      const uint32_t demo = static_cast<uint32_t>(demo_of[id]);
      const TileId local{info.tile.texture - streamer_.first_texture(id), info.tile.level, info.tile.x, info.tile.y};
      if (const Status st =
              decode_bsvtf_tile(directories_[demo], materials_[demo].bsvtf, local, decoder, scratch, values);
          st != Status::success)
        return make_error(st, "%s: tile (%u, %u, %u, %u) does not decode: %s", materials_[demo].name.c_str(),
                          local.texture, local.level, local.x, local.y, decoder.message());
      if (!cpu.upload_tile_values(s, values, bc5))
        return make_error(Status::invalid_argument, "slot %u: upload failed", s);
    }
    const scene::View view = scene::camera_path(view_frame, frames, s_.width, s_.height);
    const ShaderParams base = scene::view_params(view, glm::vec3(0.5f, 0.8f, 0.35f), glm::vec3(2.2f, 2.1f, 2.0f));
    cpu.render_bsvtf(view, material_params(base, 0), out);
    return {};
  }

 private:
  VoidResult init() {
    const DemoMaterial& first = materials_.front();
    ShaderConfig config;
    // One program set draws every material: C = the largest rank, each draw sums its own
    // material's C_m (ShaderParams::vt_extent.w, filled by the backend).
    config.components = 0;
    for (const DemoMaterial& m : materials_) config.components = std::max(config.components, m.components);
    config.value_transform = first.eigen.transform;  // every material of a run shares it
    config.angular.parameterisation = DirectionParameterisation::parabolic;
    config.angular.lookup = AngularLookup::barycentric;
    config.angular.resolution = first.angular_resolution;
    uint32_t finest = 0;
    for (const auto& m : materials_) finest = std::max(finest, m.finest_level);
    // The containers' directories: geometry, C, tile weights w and energies, payload sizes.
    for (const DemoMaterial& m : materials_) {
      auto dir = read_bsvtf(m.bsvtf);
      if (!dir) return make_error(dir.status(), "%s: %s", m.bsvtf_path.c_str(), dir.message().c_str());
      directories_.push_back(std::move(*dir));
    }
    StreamerConfig sc;
    sc.cache = CacheConfig{s_.slots_x,
                           s_.slots_y,
                           1u << 16,
                           directories_.front().metadata.tile_size,
                           directories_.front().metadata.border,
                           1,
                           s_.cache_format};
    sc.scheduler.budgets.uploads_per_frame = s_.uploads_per_frame;
    sc.scheduler.budgets.requests_in_flight = 4 * s_.uploads_per_frame;
    sc.scheduler.budgets.tiles_decoding = 4 * s_.uploads_per_frame;
    sc.vote_window_frames = 1u << (2 * s_.feedback_shift);
    // Streaming: one throttled link per container, each over its share (1/n) of the bandwidth.
    std::vector<StreamerMaterial> streamer_materials;
    for (size_t m = 0; m < materials_.size(); ++m) {
      sources_.push_back(std::make_unique<MemorySource>(std::span<const uint8_t>(materials_[m].bsvtf)));
      throttled_.push_back(std::make_unique<ThrottledSource>(
          *sources_.back(), s_.bytes_per_second / static_cast<double>(materials_.size()),
          std::chrono::microseconds(s_.latency_ms * 1000)));
      streamer_materials.push_back(StreamerMaterial{&directories_[m], throttled_.back().get(), nullptr});
    }
    // Room for the swaps: every material plus the one swapped in live at once.
    if (s_.swap_out_frame > 0) {
      const uint32_t slot = static_cast<uint32_t>(materials_.size() - 1);
      swap_plan_.push_back(PlannedSwap{s_.swap_out_frame, slot, 0});
      if (s_.swap_back_frame > s_.swap_out_frame) swap_plan_.push_back(PlannedSwap{s_.swap_back_frame, slot, slot});
      std::vector<StreamerMaterial> candidates = streamer_materials;
      candidates.push_back(streamer_materials.front());
      sc.capacity = streamer_capacity_for(candidates, static_cast<uint32_t>(candidates.size()));
    }
    auto streamer = Streamer::create(streamer_materials, sc);
    if (!streamer) return streamer.error();
    streamer_ = std::move(*streamer);
    static_cast<CacheConfig&>(config.vt) = sc.cache;
    config.vt.finest_level = finest;
    shader_config_ = config;
    objects_ = scene::make_demo_scene(static_cast<uint32_t>(materials_.size()));
    if (auto e = renderer_.init(config, streamer_.cache(), materials_, objects_); !e) return e.error();
    // Texture memory as a GPU backend allocates it.
    for (const DemoMaterial& m : materials_) {
      const uint64_t groups = (m.components + 3) / 4;
      uint64_t mips = 0;
      for (uint64_t w = static_cast<uint64_t>(m.eigen_textures.width()),
                    h = static_cast<uint64_t>(m.eigen_textures.height());
           ; w = std::max<uint64_t>(w / 2, 1), h = std::max<uint64_t>(h / 2, 1)) {
        mips += w * h;
        if (w == 1 && h == 1) break;
      }
      memory_.fmf_bytes += mips * groups * 16;  // RGBA32F
      memory_.u_bytes +=
          m.u.size() / m.components * groups * 16 + 2ull * m.angular_resolution * m.angular_resolution * 32;
    }
    uint64_t pt = 0;
    for (uint32_t l = 0; l <= finest; ++l) pt += (1ull << l) * (1ull << l);
    memory_.cache_bytes = config.vt.cache_bytes() + config.vt.slot_map_bytes();
    memory_.bsvtf_bytes = memory_.cache_bytes + pt * 4 * set().texture_count();
    // Caller-owned outputs, sized once: every page-table texel fits (the first update writes
    // them all).
    tile_uploads_.resize(streamer_.tile_uploads_bound());
    packet_uploads_.resize(streamer_.packet_uploads_bound());
    page_writes_.resize(full_page_table_size());
    events_.resize(256);
    page_mirror_.resize(set().texture_count());
    for (uint32_t t = 0; t < set().texture_count(); ++t) page_mirror_[t].assign(set().levels_of(t).tile_count(), 0u);
    // Pinned roots and U′ packets: the Streamer queued them at creation; run their jobs on this
    // thread until every material reports material_ready (each pump() blocks on the throttled
    // links while it reads; no sleeping, no polling of a clock).
    bool ready = false;
    for (uint32_t round = 0; round < 100000 && !ready; ++round) {
      if (auto e = update({}); !e) return e.error();
      ready = true;
      for (uint32_t m = 0; m < streamer_.material_count(); ++m)
        ready = ready && (!streamer_.material_live(m) || streamer_.material_ready(m));
      if (failures_ > 1000)
        return make_error(Status::io_error, "root tiles or U′ packets failed %llu times",
                          static_cast<unsigned long long>(failures_));
      if (!ready) streamer_.pump();
    }
    if (!ready) return make_error(Status::io_error, "root tiles or U′ packets did not arrive");
    // From now on the decode jobs run on worker threads (mostly waiting on the throttled links).
    executor_ = std::make_unique<ThreadExecutor>(streamer_.jobs(), static_cast<unsigned>(materials_.size()));
    return {};
  }

  FrameRenderer& renderer_;
  const std::vector<DemoMaterial>& materials_;
  StreamSettings s_;
  std::vector<BsvtfDirectory> directories_;
  std::vector<std::unique_ptr<MemorySource>> sources_;
  std::vector<std::unique_ptr<ThrottledSource>> throttled_;
  Streamer streamer_;
  std::unique_ptr<ThreadExecutor> executor_;  // declared after streamer_: joined before it goes
  std::vector<StreamerTileUpload> tile_uploads_;
  std::vector<StreamerPacketUpload> packet_uploads_;
  std::vector<PageTableWrite> page_writes_;
  std::vector<ResidencyEvent> events_;
  std::vector<uint32_t> feedback_;
  std::vector<std::vector<uint32_t>> page_mirror_;  // per texture: every GPU page-table texel written so far
  size_t last_uploads_ = 0, last_page_table_writes_ = 0;
  uint32_t tiles_delivered_ = 0;
  uint64_t total_page_table_writes_ = 0, failures_ = 0;
  std::vector<scene::SceneObject> objects_;
  MemoryFigures memory_;
  ShaderConfig shader_config_;  // the programs' configuration (the cache-format comparison)
  struct PlannedSwap {
    uint32_t frame = 0, slot = 0, demo = 0;
  };
  std::vector<PlannedSwap> swap_plan_;
  size_t next_swap_ = 0;
  bool pending_swap_ = false;
  std::vector<SwapRecord> swaps_;
  uint32_t current_frame_ = 0;  // the frame() being streamed (a swap's release frame)
};

}  // namespace btflod::demo
