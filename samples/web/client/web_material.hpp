// btflod web client — what a client derives from a `.bsvtf` directory before any payload
// arrives: the direction sets, the angular lookup tables (paper 000 §4, the rasterised Delaunay
// triangulation in the parabolic map) and the U' texture layout. Shared by the WebAssembly
// client (web_client.cpp) and the native reference renderer (tools/web_reference.cpp), so both
// sides shade with the same tables.
#pragma once

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "btflod/core/result.hpp"
#include "btflod/runtime/angular/bsvtf_angular_tables.hpp"
#include "btflod/runtime/codec/container.hpp"

namespace btflod::web {

/// Angular lookup tables of one material as the shaders' two 2-layer textures want them
/// (BsvtfAngularTables: index_rgba / weight_rgba, layer 0 light, 1 view) and as the CPU looks
/// them up, built by the library from the container's direction sets (parabolic map, the web
/// shaders' parameterisation). Returns the library's errors for degenerate or non-finite
/// directions and a bad resolution. Allocates (set-up only).
inline Result<BsvtfAngularTables> build_angular_textures(const BsvtfMetadata& md, uint32_t resolution) {
  return build_bsvtf_angular_tables(
      md, AngularTableConfig{DirectionParameterisation::parabolic, AngularLookup::barycentric, resolution});
}

/// Checks that U has three linear RGB colour channels per (light, view) pair; its rows are
/// light-major or view-major (BsvtfMetadata::u_row_order), both handled by scatter_u_packet.
inline VoidResult check_u_layout(const BsvtfMetadata& md) {
  const uint64_t lights = md.light_directions.size() / 3, views = md.view_directions.size() / 3;
  if (md.color_channels != 3 || md.color_mode != ColorMode::linear_rgb)
    return make_error(Status::unsupported, "%s: colour channels %u mode %u, the web client shades linear RGB only",
                      md.material_name.c_str(), md.color_channels, static_cast<unsigned>(md.color_mode));
  if (md.u_rows != lights * views * 3)
    return make_error(Status::unsupported, "%s: U has %u rows, expected lights %llu × views %llu × 3",
                      md.material_name.c_str(), md.u_rows, static_cast<unsigned long long>(lights),
                      static_cast<unsigned long long>(views));
  return {};
}

/// Writes U packet g (floats: row r, component 4g + k at r·4 + k; rows in `packet_order`: the
/// container's u_row_order for unpack_bsvtf_packet's output, version 2's unspecified order read
/// as light-major as every producer wrote it; light-major for a Streamer's packet upload) into the
/// eigen_abrdfs texture array `rgba` (texel (light, view), layer c, rgb = colour; layout of
/// runtime/backend/backend.hpp pack_eigen_abrdfs_rgba: ((c · views + view) · lights + light) · 4), and
/// into E's light-major U `u` (((light · views + view) · 3 + colour) · C + c), both sized for
/// every component (`u` may be empty: then only `rgba` is written). Components past C
/// in the last packet are dropped. No allocation.
inline void scatter_u_packet(const BsvtfMetadata& md, uint32_t g, std::span<const float> packet, std::span<float> rgba,
                             std::span<float> u, AngularRowOrder packet_order) noexcept {
  const uint32_t lights = static_cast<uint32_t>(md.light_directions.size() / 3);
  const uint32_t views = static_cast<uint32_t>(md.view_directions.size() / 3);
  const uint32_t C = md.component_count;
  for (uint32_t k = 0; k < 4; ++k) {
    const uint32_t c = 4 * g + k;
    if (c >= C) break;
    const float scale = c < md.component_scales.size() ? md.component_scales[c] : 1.0f;
    for (uint32_t l = 0; l < lights; ++l)
      for (uint32_t v = 0; v < views; ++v)
        for (uint32_t col = 0; col < 3; ++col) {
          const size_t row = packet_order == AngularRowOrder::view_major
                                 ? (static_cast<size_t>(v) * lights + l) * 3 + col
                                 : (static_cast<size_t>(l) * views + v) * 3 + col;
          const float value = packet[row * 4 + k] * scale;
          rgba[((static_cast<size_t>(c) * views + v) * lights + l) * 4 + col] = value;
          if (!u.empty()) u[((static_cast<size_t>(l) * views + v) * 3 + col) * C + c] = value;
        }
  }
}

/// Result of decode_container_tiles.
struct DecodeCheck {
  uint64_t hash = 1469598103934665603ull;  ///< FNV-1a over the bits of every decoded sample, tiles in key order
  uint32_t tiles = 0;
  double decode_us = 0;   ///< total decode() time (inflate + reconstruction)
  double inflate_us = 0;  ///< total inflate_symbols() time (entropy stage alone)
  Status status = Status::success;
};

/// Decodes every tile of an in-memory container (parents before children: the index is sorted by
/// key, so coarse to fine per texture) `repeats` times with `backend` and hashes the last pass's
/// samples. The wasm client and the native reference run the same function: equal hashes mean
/// bit-identical decoders (wasm has the scalar inverse DCT only; the native AVX2/FMA twin rounds
/// differently, so the native side compares with allow_simd = false). Allocates (a test/benchmark helper, not a
/// per-frame path).
inline DecodeCheck decode_container_tiles(std::span<const uint8_t> file, InflateBackend backend, int repeats,
                                          bool allow_simd = true) {
  DecodeCheck r;
  auto dir = read_bsvtf(file);
  if (!dir) {
    r.status = dir.status();
    return r;
  }
  const TileLayout layout = dir->metadata.layout();
  TileDecoder decoder(layout, backend);
  decoder.set_simd(allow_simd);
  std::vector<float> decoded(dir->tiles.size() * layout.sample_count());
  using Clock = std::chrono::steady_clock;
  for (int pass = 0; pass < repeats; ++pass) {
    for (size_t i = 0; i < dir->tiles.size(); ++i) {
      const BsvtfTileEntry& e = dir->tiles[i];
      const std::span<const uint8_t> payload = file.subspan(e.offset, e.size);
      std::span<const float> parent;
      if (e.id.level > 0) {
        const BsvtfTileEntry* p = dir->find(e.id.parent());
        parent = std::span<const float>(
            decoded.data() + static_cast<size_t>(p - dir->tiles.data()) * layout.sample_count(), layout.sample_count());
      }
      std::span<float> out(decoded.data() + i * layout.sample_count(), layout.sample_count());
      const auto t0 = Clock::now();
      if (Status s = decoder.inflate_symbols(payload, parent, out); s != Status::success) {
        r.status = s;
        return r;
      }
      const auto t1 = Clock::now();
      if (Status s = decoder.decode(payload, parent, e.id.x & 1, e.id.y & 1, out); s != Status::success) {
        r.status = s;
        return r;
      }
      const auto t2 = Clock::now();
      r.inflate_us += std::chrono::duration<double, std::micro>(t1 - t0).count();
      r.decode_us += std::chrono::duration<double, std::micro>(t2 - t1).count();
      ++r.tiles;
    }
  }
  for (const float f : decoded) {
    uint32_t bits;
    std::memcpy(&bits, &f, 4);
    for (int k = 0; k < 4; ++k) {
      r.hash ^= (bits >> (8 * k)) & 0xffu;
      r.hash *= 1099511628211ull;
    }
  }
  return r;
}

}  // namespace btflod::web
