// The one configuration the Filament materials (matgen.cpp, at build time), the textures and the
// Streamer (main.cpp, at run time) share. btflod's shaders bake C, the angular table size and the
// cache shape in as constants, so a change here regenerates the materials.
#pragma once

#include "btflod/runtime/shader/shader_config.hpp"

namespace sample {

inline constexpr uint32_t kComponents = 8;  // C of every material (one Filament material per C)
inline constexpr uint32_t kTexels = 256;    // M = N of the procedural materials
inline constexpr uint32_t kTileSize = 32;   // T → finest level 3 (8 × 8 tiles)
inline constexpr uint32_t kFinestLevel = 3;

/// `format`: the tile cache's texel format (rgba8_affine: the compact cache, its own bsvtf material).
inline btflod::ShaderConfig shader_config(btflod::CacheFormat format = btflod::CacheFormat::rgba16f) {
  btflod::ShaderConfig c;
  c.components = kComponents;
  c.angular.parameterisation = btflod::DirectionParameterisation::parabolic;
  c.angular.lookup = btflod::AngularLookup::barycentric;
  c.angular.resolution = 32;
  c.vt.tile_size = kTileSize;
  c.vt.border = 4;
  c.vt.slots_x = 16;  // 16 × 16 = 256 slots of 40² texels: 640 × 640 RGBA16F, 3.1 MiB
  c.vt.slots_y = 16;
  c.vt.cache_layers = 1;  // one layer: the CPU reference (CpuCacheTexture) mirrors one
  c.vt.finest_level = kFinestLevel;
  c.vt.trilinear = true;
  c.vt.format = format;
  return c;
}

}  // namespace sample
