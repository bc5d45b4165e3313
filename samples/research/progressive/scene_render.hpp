// btflod-progressive and btflod-visibility: the demo scene rendered on the CPU from a material's
// tiles (samples/research/progressive/progressive.cpp describes the renderer: per pixel the level the
// feedback pass requests, eq. 1; the deepest held tile at or above it, bilinear inside its
// bordered tile, eq. 3; shade_fmf's 9-tap angular combination, eq. 5). Shared by both programs.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "btflod/core/color.hpp"
#include "btflod/offline/build/tile_pyramid.hpp"
#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/lod/lod_selector.hpp"
#include "btflod/runtime/shader/shader_config.hpp"
#include "materials.hpp"
#include "scene/analytic_demo_scene.hpp"
#include "scene/demo_scene.hpp"
#include "scene/view_camera.hpp"

namespace btflod::progressive {

/// What both programs choose: materials, their preparation, the image and views.
struct SceneOptions {
  std::string out;
  uint32_t materials = 3;
  uint32_t components = 16;  // 4 RGBA virtual textures per material
  uint32_t size = 32;
  uint32_t repeat = 8;
  float quality = 60.0f;
  TileEntropyCoder entropy_coder = default_tile_entropy_coder();  // --deflate: deflate (tile format 2)
  uint32_t tile_size = 32;
  uint32_t width = 256, height = 144;
  uint32_t views = 3;
};

// ---------------------------------------------------------------------------------------------
// Materials: containers, decoded tiles, byte sizes.

struct Material {
  demo::DemoMaterial demo;
  BsvtfDirectory dir;
  TilePyramid pyramid;                                   // for w (eq. 8) and energies (§6)
  std::vector<std::vector<std::vector<float>>> decoded;  // [k][flat] decoded samples
  std::vector<std::vector<uint32_t>> tile_bytes;         // [k][flat] compressed payload bytes
  std::vector<uint32_t> packet_bytes;                    // [k] U packet bytes
};

// Decodes every tile of the container `file` (its directory `dir`, read from it) coarse to fine
// against the decoded parent (closed loop, paper 000 §6) into m.decoded, and the payload sizes
// into m.tile_bytes; m.pyramid gives the level table.
inline VoidResult decode_tiles(Material& m, std::span<const uint8_t> file, const BsvtfDirectory& dir) {
  const BsvtfMetadata& md = dir.metadata;
  const VtLevelTable& lv = m.pyramid.levels();
  const uint32_t textures = md.texture_count();
  const TileLayout layout = md.layout();
  TileDecoder decoder(layout);
  m.decoded.assign(textures, std::vector<std::vector<float>>(lv.tile_count()));
  m.tile_bytes.assign(textures, std::vector<uint32_t>(lv.tile_count(), 0));
  for (uint32_t k = 0; k < textures; ++k)
    for (uint32_t l = 0; l < md.level_count; ++l)
      for (uint32_t y = 0; y < lv.tiles_y[l]; ++y)
        for (uint32_t x = 0; x < lv.tiles_x[l]; ++x) {
          const TileId id{k, l, x, y};
          const BsvtfTileEntry* e = dir.find(id);
          if (e == nullptr)
            return make_error(Status::bad_data, "%s: tile (%u, %u, %u, %u) missing", m.demo.name.c_str(), k, l, x, y);
          const std::span<const uint8_t> payload(file.data() + e->offset, e->size);
          if (verify_bsvtf_payload(e->size, e->crc, payload) != Status::success)
            return make_error(Status::bad_data, "%s: tile (%u, %u, %u, %u) fails its checksum", m.demo.name.c_str(), k,
                              l, x, y);
          const uint32_t flat = lv.index(l, x, y);
          std::vector<float>& out = m.decoded[k][flat];
          out.resize(layout.sample_count());
          std::span<const float> parent;
          if (l > 0) parent = m.decoded[k][lv.index(id.parent())];
          if (decoder.decode(payload, parent, x & 1u, y & 1u, out) != Status::success)
            return make_error(Status::bad_data, "%s: tile (%u, %u, %u, %u): %s", m.demo.name.c_str(), k, l, x, y,
                              decoder.message());
          m.tile_bytes[k][flat] = e->size;
        }
  return {};
}

inline Result<Material> load_material(uint32_t index, const SceneOptions& o) {
  demo::MaterialSettings ms;
  ms.size = static_cast<int>(o.size);
  ms.repeat = o.repeat;
  ms.components = o.components;
  ms.quality = o.quality;
  ms.entropy_coder = o.entropy_coder;
  ms.tile_size = o.tile_size;
  auto dm = demo::prepare_material(index, ms, o.out);
  if (!dm) return dm.error();
  Material m;
  m.demo = std::move(*dm);
  auto dir = read_bsvtf(m.demo.bsvtf);
  if (!dir) return make_error(dir.status(), "%s: %s", m.demo.bsvtf_path.c_str(), dir.message().c_str());
  m.dir = std::move(*dir);
  const BsvtfMetadata& md = m.dir.metadata;
  auto pyr = TilePyramid::build(m.demo.eigen, md.tile_size, md.border);
  if (!pyr) return pyr.error();
  m.pyramid = std::move(*pyr);
  const uint32_t textures = md.texture_count();
  if (auto d = decode_tiles(m, m.demo.bsvtf, m.dir); !d) return d.error();
  for (const BsvtfPacketEntry& p : m.dir.packets) m.packet_bytes.push_back(p.size);
  if (m.packet_bytes.size() != textures)
    return make_error(Status::bad_data, "%s: %zu U packets for %u virtual textures", m.demo.name.c_str(),
                      m.packet_bytes.size(), textures);
  return m;
}

// Bilinear sample of a decoded bordered tile of level `level` at texture coordinates (u, v),
// paper 000 eq. 3 addressing inside the tile (the border makes the 2×2 footprint stay inside).
inline void sample_tile(const Material& m, uint32_t k, uint32_t level, uint32_t flat, float u, float v, float* out) {
  const VtGeometry& g = m.pyramid.geometry();
  const VtLevelTable& lv = m.pyramid.levels();
  const float inv = 1.0f / static_cast<float>(1u << (g.finest_level - level));
  const float s = u * static_cast<float>(g.width) * inv, t = v * static_cast<float>(g.height) * inv;
  const uint32_t tx = lv.tile(k, flat).x, ty = lv.tile(k, flat).y;
  const uint32_t stored = g.stored_size();
  const float cx = s - static_cast<float>(tx * g.tile_size) + static_cast<float>(g.border) - 0.5f;
  const float cy = t - static_cast<float>(ty * g.tile_size) + static_cast<float>(g.border) - 0.5f;
  const float x0f = std::floor(cx), y0f = std::floor(cy);
  const float ax = cx - x0f, ay = cy - y0f;
  const uint32_t x0 = std::min(static_cast<uint32_t>(std::max(x0f, 0.0f)), stored - 2);
  const uint32_t y0 = std::min(static_cast<uint32_t>(std::max(y0f, 0.0f)), stored - 2);
  const float* p00 = m.decoded[k][flat].data() + (static_cast<size_t>(y0) * stored + x0) * 4;
  const float* p01 = p00 + static_cast<size_t>(stored) * 4;
  for (int c = 0; c < 4; ++c) {
    const float top = p00[c] + (p00[4 + c] - p00[c]) * ax;
    const float bot = p01[c] + (p01[4 + c] - p01[c]) * ax;
    out[c] = top + (bot - top) * ay;
  }
}

// ---------------------------------------------------------------------------------------------
// The scene, one fixed view, per-pixel data that do not change while streaming.

struct World {
  const SceneOptions& opt;
  std::vector<Material> materials;
  VtSet set;
  Scene scene;
  glm::vec3 light_dir = glm::normalize(glm::vec3(0.5f, 0.8f, 0.35f));  // the demo's sun
  glm::vec3 light_color{2.2f, 2.1f, 2.0f};
  uint64_t total_bytes = 0;  // every tile payload + every U packet

  explicit World(const SceneOptions& o) : opt(o) {}

  VoidResult init() {
    for (uint32_t i = 0; i < opt.materials; ++i) {
      auto m = load_material(i, opt);
      if (!m) return m.error();
      materials.push_back(std::move(*m));
    }
    for (uint32_t mi = 0; mi < materials.size(); ++mi) {
      const Material& m = materials[mi];
      set.add_material(m.pyramid.geometry(), m.pyramid.texture_count());
      m.pyramid.copy_weights_to(set, mi);
      for (const auto& tb : m.tile_bytes)
        for (uint32_t b : tb) total_bytes += b;
      for (uint32_t b : m.packet_bytes) total_bytes += b;
    }
    scene = scene::analytic_demo_scene(static_cast<uint32_t>(materials.size()));
    return {};
  }

  Camera camera(uint32_t view) const {
    return scene::to_camera(scene::camera_path(view, opt.views, opt.width, opt.height));
  }
};

struct Pixel {
  bool hit = false;
  uint32_t material = 0;
  uint32_t level = 0;  // the level the feedback pass requests here (eq. 1)
  float u = 0, v = 0;
  AngularSample light, view;
};

// Angular lookup of the shaders (parabolic map, rasterised Delaunay tables, paper 000 §4).
inline AngularSample lookup(const demo::DemoMaterial& m, int layer, glm::vec3 dir) {
  return angular_table_sample(m.angular_tables(), layer, DirectionParameterisation::parabolic, false, dir);
}

inline std::vector<Pixel> prepare_view(const World& w, const Camera& cam) {
  std::vector<Pixel> px(static_cast<size_t>(cam.width) * cam.height);
  for_each_pixel_hit(w.scene, cam, [&](uint32_t x, uint32_t y, float fx, float fy, const SurfaceHit& h) {
    Pixel& p = px[static_cast<size_t>(y) * cam.width + x];
    const uint32_t word = feedback_word(cam, h, fx, fy, w.set, DerivativeLod{});
    if (!h.hit || word == kFeedbackNone) return;
    const demo::DemoMaterial& m = w.materials[h.material].demo;
    p.hit = true;
    p.material = h.material;
    p.level = unpack_feedback(word).level;
    p.u = h.texcoord.x;
    p.v = h.texcoord.y;
    p.light = lookup(m, 0, to_local(h, w.light_dir));
    p.view = lookup(m, 1, to_local(h, glm::normalize(cam.position - h.position)));
  });
  return px;
}

// What the client holds.
struct ClientState {
  std::vector<std::vector<std::vector<uint8_t>>> tile;  // [material][k][flat]
  std::vector<std::vector<uint8_t>> packet;             // [material][k]

  explicit ClientState(const World& w, bool everything = false) {
    for (const Material& m : w.materials) {
      tile.emplace_back(m.decoded.size(), std::vector<uint8_t>(m.pyramid.levels().tile_count(), everything ? 1 : 0));
      packet.emplace_back(m.decoded.size(), everything ? 1 : 0);
    }
  }
};

// Linear RGB image of the view from what the client holds.
inline Image<float> render(const World& w, const Camera& cam, const std::vector<Pixel>& px, const ClientState& cs) {
  Image<float> img(static_cast<int>(cam.width), static_cast<int>(cam.height), 3);
  float comps[4 * 32];
  for (uint32_t y = 0; y < cam.height; ++y)
    for (uint32_t x = 0; x < cam.width; ++x) {
      const Pixel& p = px[static_cast<size_t>(y) * cam.width + x];
      const int xi = static_cast<int>(x), yi = static_cast<int>(y);
      if (!p.hit) {
        img.at(xi, yi, 0) = 0.45f, img.at(xi, yi, 1) = 0.55f, img.at(xi, yi, 2) = 0.7f;  // the demo's sky
        continue;
      }
      const Material& m = w.materials[p.material];
      const VtLevelTable& lv = m.pyramid.levels();
      const VtGeometry& g = m.pyramid.geometry();
      const uint32_t groups = static_cast<uint32_t>(m.decoded.size());
      for (uint32_t k = 0; k < groups; ++k) {
        float* out = comps + 4 * k;
        out[0] = out[1] = out[2] = out[3] = 0.0f;
        if (!cs.packet[p.material][k]) continue;
        for (int32_t l = static_cast<int32_t>(p.level); l >= 0; --l) {
          const uint32_t level = static_cast<uint32_t>(l);
          const float scale = static_cast<float>(g.tile_size << (g.finest_level - level));
          const uint32_t tx =
              std::min(static_cast<uint32_t>(p.u * static_cast<float>(g.width) / scale), lv.tiles_x[level] - 1);
          const uint32_t ty =
              std::min(static_cast<uint32_t>(p.v * static_cast<float>(g.height) / scale), lv.tiles_y[level] - 1);
          const uint32_t flat = lv.index(level, tx, ty);
          if (!cs.tile[p.material][k][flat]) continue;
          sample_tile(m, k, level, flat, p.u, p.v, out);
          break;
        }
      }
      const glm::vec3 rgb =
          shade_fmf(m.demo.eigen, p.light, p.view, std::span<const float>(comps, m.demo.components)) * w.light_color;
      for (int c = 0; c < 3; ++c) img.at(xi, yi, c) = rgb[c];
    }
  return img;
}

// Linear radiance → display values in [0, 1]: clamped, sRGB-encoded (core/color.hpp), as the
// demo's report does.
inline Image<float> to_display(const Image<float>& linear) {
  Image<float> out(linear.width(), linear.height(), 3);
  for (int y = 0; y < linear.height(); ++y)
    for (int x = 0; x < linear.width(); ++x)
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = linear_to_srgb(linear.at(x, y, c));
  return out;
}

}  // namespace btflod::progressive
