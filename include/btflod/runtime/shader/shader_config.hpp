// btflod — plain configuration structs and GPU data encodings shared by the GLSL generators
// (runtime/shader/glsl_generator.hpp) and the backends (runtime/backend/backend.hpp).
//
// Everything here is API-neutral: no GL or Vulkan header. The encodings (page-table entry,
// feedback word, slot placement, uniform block) are the contract between the CPU side that
// fills textures and the generated shaders that read them; docs/shaders.md describes them.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "btflod/core/result.hpp"
#include "btflod/core/value_transform.hpp"
#include "btflod/runtime/shader/std140.hpp"
#include "btflod/runtime/vt/cache_config.hpp"

namespace btflod {

/// Shading-language dialect a generator emits.
enum class GlslTarget : unsigned char {
  gl450_core,  ///< `#version 450 core`, explicit bindings, OpenGL 4.5 core
  vulkan450,   ///< `#version 450` for glslc/glslangValidator -V: set = 0, explicit locations
  es300,       ///< `#version 300 es` (WebGL 2): no binding qualifiers; samplers set by name
};

/// Mapping of a hemisphere direction (local frame, z = normal) to the unit square [0,1]².
/// Mirrors angular/: parabolic p = (x, y) / (1 + z) mapped from [−1,1]² to [0,1]²;
/// elevated concentric = Shirley–Chiu concentric map with z = 1 − r² (paper 002 §6.1).
enum class DirectionParameterisation : unsigned char { parabolic, elevated_concentric };

/// How the angular lookup tables are used in a shader.
enum class AngularLookup : unsigned char {
  barycentric,  ///< 3 light × 3 view indices blended by barycentric weights (paper 000 §4: 9 taps)
  nearest,      ///< the index with the largest weight only (1 tap per direction)
};

/// Angular lookup tables (paper 000 §4, after [ND06]): a square index texture (3 direction
/// indices per texel, RGBA32UI, .w unused) and a weight texture (3 barycentric weights, RGBA32F),
/// rastered over the parameterised unit square. Both are 2-layer array textures: layer 0 for the
/// light directions, layer 1 for the view directions.
struct AngularTableConfig {
  DirectionParameterisation parameterisation = DirectionParameterisation::parabolic;
  AngularLookup lookup = AngularLookup::barycentric;
  uint32_t resolution = 64;  ///< texels per side of each table
};

/// Bit layout of the packed 32-bit feedback word (paper 000 §3, eq. 1–2: tile index i, level l,
/// texture τ). The defaults are runtime/lod/feedback.hpp's word (pack_feedback: x 9 bits at 0, y 9 at 9,
/// level 4 at 18, material 10 at 22, kFeedbackNone = 0xffffffff); the fields are configurable so
/// a host with another word layout can still use the generated shaders. `empty_word` is the
/// clear value for pixels no streamed material covers. The shader clamps the level to what the
/// x/y/level fields can hold (runtime/lod/feedback.hpp: "the feedback pass then clamps its level to 9").
struct FeedbackWordLayout {
  uint32_t x_shift = 0, x_bits = 9;
  uint32_t y_shift = 9, y_bits = 9;
  uint32_t level_shift = 18, level_bits = 4;
  uint32_t texture_shift = 22, texture_bits = 10;
  uint32_t empty_word = 0xffffffffu;

  /// Finest level whose tile indices and level number fit the fields.
  constexpr uint32_t max_level() const noexcept {
    uint32_t m = x_bits < y_bits ? x_bits : y_bits;
    const uint32_t lmax = level_bits >= 5 ? 31u : (1u << level_bits) - 1u;
    return m < lmax ? m : lmax;
  }
};

/// Decoded feedback word.
struct FeedbackSample {
  uint32_t texture = 0;
  uint32_t level = 0;  ///< paper 000 level, 0 = coarsest
  uint32_t x = 0;
  uint32_t y = 0;
  friend constexpr bool operator==(const FeedbackSample&, const FeedbackSample&) = default;
};

namespace detail {
constexpr uint32_t low_mask(uint32_t bits) noexcept { return bits >= 32 ? 0xffffffffu : ((1u << bits) - 1u); }
}  // namespace detail

/// Packs a feedback sample (fields are masked to their widths). Same arithmetic as the shader.
/// Thread-safe, noexcept.
constexpr uint32_t pack_feedback_word(const FeedbackWordLayout& l, FeedbackSample s) noexcept {
  return ((s.x & detail::low_mask(l.x_bits)) << l.x_shift) | ((s.y & detail::low_mask(l.y_bits)) << l.y_shift) |
         ((s.level & detail::low_mask(l.level_bits)) << l.level_shift) |
         ((s.texture & detail::low_mask(l.texture_bits)) << l.texture_shift);
}
/// Unpacks a feedback word. The caller checks `word != layout.empty_word` first.
/// Safe for any input value (untrusted words decode to in-range fields).
constexpr FeedbackSample unpack_feedback_word(const FeedbackWordLayout& l, uint32_t word) noexcept {
  return FeedbackSample{(word >> l.texture_shift) & detail::low_mask(l.texture_bits),
                        (word >> l.level_shift) & detail::low_mask(l.level_bits),
                        (word >> l.x_shift) & detail::low_mask(l.x_bits),
                        (word >> l.y_shift) & detail::low_mask(l.y_bits)};
}

// The page-table entry (pack_page_entry, unpack_page_entry_slot/level) is runtime/vt/cache_config.hpp's:
// the tile cache writes it and the shaders read it.

/// Virtual-texture (BSVTF) layout as the shaders see it.
///
/// Eigen-textures: C components packed 4 per RGBA texel ("component groups"); group g of
/// material m is virtual texture `page_table_layer = first_layer(m) + g`.
/// Tile cache: a 2D-array texture of `cache_layers` layers, each slots_x × slots_y slots of
/// (tile_size + 2·border)² texels; slot s lives in layer s / (slots_x·slots_y), column
/// (s mod slots_x·slots_y) mod slots_x, row (s mod slots_x·slots_y) / slots_x.
/// Page table: a R32UI 2D-array texture (one layer per virtual texture) of 2^finest_level
/// texels per side at mip 0 and finest_level + 1 mips. For a material whose own finest level is
/// L_m ≤ finest_level (ShaderParams::vt_extent.z), mip m = L_m − level holds, for each tile
/// (x, y) of that level (top-left tiles_x × tiles_y texels used), the entry of the tile the
/// cache uses for it (itself or its nearest resident ancestor), see pack_page_entry.
/// Addressing: level-l texel coordinate s = uv · (M, N) · 2^(l − L_m) with uv wrapped to [0,1)
/// (runtime/vt/vt_layout.hpp geometry: tiles on a grid aligned to the origin, M×N need not be square).
/// The cache shape (tile size, border, slots, layers) is runtime/vt/cache_config.hpp's CacheConfig, the
/// same type the tile cache, the scheduler and the runtime are configured with.
struct VirtualTextureConfig : CacheConfig {
  uint32_t finest_level = 4;  ///< largest L of any material: the page table has L + 1 mips
  bool trilinear = true;      ///< blend levels ⌊λ⌋ and ⌊λ⌋+1 when both are resident
  FeedbackWordLayout feedback;
};

/// Texel origin (top-left of the padded slot, border included) and layer of a cache slot: the
/// tile cache's placement (runtime/vt/cache_config.hpp), one definition for the bookkeeping and shaders.
using SlotPlacement = CacheSlotPlacement;
/// Where slot `slot` lives in the cache texture (cache_slot_placement of the cache shape).
/// Precondition: slot < config.slot_count(). constexpr, noexcept.
constexpr SlotPlacement slot_placement(const VirtualTextureConfig& c, uint32_t slot) noexcept {
  return cache_slot_placement(c, slot);
}

/// Laplacian-pyramid LOD (paper 001 §3.4, eq. 7).
/// Textures: eigen Laplacian BRDFs, 2D array RGBA32F, texel (light, view), layer = k·C + j;
/// PCA weight maps, mipmapped 2D array RGBA, layer = j / 4, mip k = pyramid level k;
/// mean, 2D RGBA32F texel (light, view) (tabulated stand-in for the fitted μ'_{λmax}).
struct LaplacianLodConfig {
  uint32_t max_level = 4;    ///< λmax
  bool ycbcr_output = true;  ///< reconstructed values are YCbCr (paper 001 §3.1) → convert to RGB
};

/// Local PCA with the 3D-texture layout of paper 002 §6.2.
/// Textures: cluster index per texel (R32UI 2D, nearest); PCA weights α/s per texel (2D array
/// RGBA32F, layer = j / 4, scales folded in); eigen-BRDF volume (3D RGBA, linear filtering):
/// x = (j + s_v)/(C+1) with j = 0 the cluster mean, y = (k + t_v)/clusters,
/// z = (i + s_l)/n(t_l) for the discretised t_l index i — one manual lerp in t_l.
struct LpcaConfig {
  uint32_t clusters = 8;
  uint32_t grid_resolution = 16;  ///< R: samples per side of s_v, t_v, s_l and the count n(t_l)
};

/// PCA over groups of k neighbouring views (paper 004 §4.3.2, §6.3): L = [m | UΣ] per group,
/// R = [1; Vᵀ]. Textures: L as a 2D array RGBA (spatial), layer = group·(C+1) + c, c = 0 the
/// mean; R as 2D R32F, texel (c, light + light_count·view).
struct PcaViewsConfig {
  uint32_t views_per_group = 1;  ///< k (1 = PCA-RF; all views = PCA-BTF)
  uint32_t light_count = 81;
};

/// SPMM (paper 003 eq. 1–3) texture layout parameters (docs/shaders.md, "spmm"). Textures: per
/// texel RGBA32UI 2D array `spmm_texels` (layer k < slots: x = global basis index or 0xffffffff,
/// yzw = α rgb as float bits, occupied slots first; layer slots + g: the cluster id and the
/// residual coefficients, 4 per texel); the dictionary `spmm_dictionary` (RGBA32F 2D, 2 texels
/// per basis, kSpmmBasesPerRow bases per row: (model id, κ0, κ1, κ2), (n_j, 0)); the residual
/// table `spmm_residual` (RGBA32F 2D array, texel (light, view), layer cluster·(P+1) + i: i = 0
/// the mean ε̄, i ≥ 1 component b_{i−1}).
struct SpmmShaderConfig {
  uint32_t slots = 4;                ///< weight slots per texel (Spmm::slots), 1..64
  uint32_t residual_components = 4;  ///< N_PCA stored per cluster (Spmm::residual_components), 0..64
};

/// Bases per row of the SPMM dictionary texture (2 RGBA32F texels each: 256 texels wide).
inline constexpr uint32_t kSpmmBasesPerRow = 128;
/// Texels of `spmm_texels` layer `slots` and up: the cluster id, then the residual coefficients.
constexpr uint32_t spmm_residual_layers(uint32_t residual_components) noexcept {
  return (residual_components + 1 + 3) / 4;
}
/// The SPMM residual switch of ShaderParams::ids.w (paper 003 §5.2, Table 4): 0 = the mean and
/// every stored component, 1 = no residual ("no-RES", the interactive path while the camera
/// moves), 2 + n = the mean and the first n components (clamped to the stored N_PCA in the shader).
/// Precondition: n ≥ 0 when residual is true; n < 0 means every stored component.
constexpr uint32_t spmm_residual_mode(bool residual, int n_pca) noexcept {
  return !residual ? 1u : n_pca < 0 ? 0u : 2u + static_cast<uint32_t>(n_pca);
}

/// All parameters of the generated programs.
struct ShaderConfig {
  /// C: eigen-texture components (FMF / BSVTF / PCA / LPCA / Laplacian). FMF and BSVTF
  /// programs draw materials of any C_m ≤ C (ShaderParams::vt_extent.w).
  uint32_t components = 8;
  AngularTableConfig angular;
  VirtualTextureConfig vt;
  LaplacianLodConfig laplacian;
  LpcaConfig lpca;
  PcaViewsConfig pca;
  SpmmShaderConfig spmm;
  /// The encoding of the FMF/BSVTF materials drawn with these programs (EigenTextures::transform,
  /// the container's value_transform): eq. 5's sum is decoded with it (core/value_transform.hpp).
  ValueTransform value_transform{};

  constexpr uint32_t component_groups() const noexcept { return (components + 3) / 4; }
};

/// Uniform block `BtflodParams` (std140, binding 0) mirrored byte for byte. Matrices are
/// column-major; the members are plain std140 types (runtime/shader/std140.hpp) that convert to and from
/// the engine's math types (glm::mat4, glm::vec4, glm::uvec4). The backends upload it as one
/// uniform buffer. Conventions are OpenGL's for every target: clip z in [−w, w] (the Vulkan
/// vertex shader remaps it to [0, w]) and NDC y = +1 at the top of the image (the Vulkan backend
/// uses a negative-height viewport).
struct alignas(16) ShaderParams {
  Float4x4 model_view_proj;                    ///< identity by default
  Float4x4 model;                              ///< identity by default
  Float4 camera_pos{0.0f, 0.0f, 1.0f, 1.0f};   ///< world position of the eye (xyz)
  Float4 light{0.0f, 0.0f, 1.0f, 0.0f};        ///< w = 0: direction towards the light; w = 1: position
  Float4 light_color{1.0f, 1.0f, 1.0f, 1.0f};  ///< rgb radiance scale
  /// x: LOD bias in levels; y: log2(screen size / feedback size); z: range-LOD distance scale
  /// (paper 001: λ = log2(distance·z)); w: unused.
  Float4 lod{0.0f, 0.0f, 1.0f, 0.0f};
  /// BSVTF / feedback: x, y = M, N (finest-level texels of this material), z = its finest level
  /// L_m (≤ VirtualTextureConfig::finest_level). FMF / BSVTF: w = the components eq. 5 sums,
  /// C_m ≤ ShaderConfig::components (0: the programs' C), so one program of the largest C draws
  /// materials of every rank; the backends set it to the material's C_m, or to the caller's
  /// 1 … C_m − 1 to draw the first components only (backend.hpp params_for_material()).
  Float4 vt_extent{256.0f, 256.0f, 2.0f, 0.0f};
  /// x: page-table layer of component group 0 of this material; y: texture id written to the
  /// feedback word; z: debug view (0 = shaded, 1 = raw component group 0); w: SPMM residual
  /// switch (spmm_residual_mode()).
  UInt4 ids{0u, 0u, 0u, 0u};
};
static_assert(sizeof(ShaderParams) == 224, "ShaderParams must match the std140 block in the shaders");
// std140 offsets of the block in the shaders (GLSL 4.50 §7.6.2.2: mat4 = 4 × 16 bytes, vec4 16).
static_assert(offsetof(ShaderParams, model) == 64, "ShaderParams must match the std140 block in the shaders");
static_assert(offsetof(ShaderParams, camera_pos) == 128, "ShaderParams must match the std140 block in the shaders");
static_assert(offsetof(ShaderParams, light) == 144, "ShaderParams must match the std140 block in the shaders");
static_assert(offsetof(ShaderParams, light_color) == 160, "ShaderParams must match the std140 block in the shaders");
static_assert(offsetof(ShaderParams, lod) == 176, "ShaderParams must match the std140 block in the shaders");
static_assert(offsetof(ShaderParams, vt_extent) == 192, "ShaderParams must match the std140 block in the shaders");
static_assert(offsetof(ShaderParams, ids) == 208, "ShaderParams must match the std140 block in the shaders");

/// Binding points (GL binding = Vulkan set 0 binding = ES texture unit) used by every program.
enum class ShaderBinding : uint32_t {
  params = 0,           ///< uniform block BtflodParams
  eigen_abrdfs = 1,     ///< FMF/BSVTF U: sampler2DArray, texel (light, view), layer c, rgb
  angular_index = 2,    ///< usampler2DArray, 2 layers (light, view)
  angular_weight = 3,   ///< sampler2DArray, 2 layers (light, view)
  eigen_textures = 4,   ///< FMF V: sampler2DArray, layer = component group, hardware filtered
  tile_cache = 5,       ///< BSVTF cache: sampler2DArray, linear, no mips
  page_table = 6,       ///< BSVTF page table: usampler2DArray with mips
  laplacian_eigen = 7,  ///< paper 001 eigen Laplacian BRDFs
  laplacian_weights = 8,
  laplacian_mean = 9,
  lpca_cluster = 10,  ///< paper 002 cluster index
  lpca_weights = 11,
  lpca_volume = 12,
  pca_l = 13,            ///< paper 004 L = [m | UΣ]
  pca_r = 14,            ///< paper 004 R = [1; Vᵀ]
  spmm_texels = 15,      ///< paper 003: per-texel slots (basis index, α) and residual coefficients
  spmm_dictionary = 16,  ///< paper 003 eq. 2: model id, κ_j, n_j of every cluster's basis functions
  spmm_residual = 17,    ///< paper 003 eq. 3: ε̄ and b_i per cluster over the measured directions
  direction_rings = 18,  ///< paper 004 §4.4: uniform block <prefix>DirectionRings (ring_search)
  slot_map = 19,         ///< BSVTF rgba8_affine and bc5_affine caches: usampler2D RGBA32UI, one texel per slot
                         ///< (runtime/vt/cache_format.hpp)
};

/// Vertex attribute locations of every generated vertex shader.
enum class VertexAttribute : uint32_t { position = 0, normal = 1, tangent = 2, uv = 3 };

/// CPU twin of the shaders' direction → unit-square mapping (used to build lookup tables and
/// reference images). Directions below the horizon are clamped to it (z = max(z, 0), then
/// renormalised); a zero vector maps to the centre. Returns coordinates in [0,1]².
/// Thread-safe, noexcept. Float3 and Float2 convert from and to glm::vec3 and glm::vec2.
inline Float2 shader_direction_to_unit_square(DirectionParameterisation p, Float3 d) noexcept {
  d.z = std::max(d.z, 0.0f);
  const float len = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  if (!(len > 1e-20f)) return Float2(0.5f, 0.5f);
  d = Float3(d.x / len, d.y / len, d.z / len);
  if (p == DirectionParameterisation::parabolic) {
    return Float2(d.x / (1.0f + d.z) * 0.5f + 0.5f, d.y / (1.0f + d.z) * 0.5f + 0.5f);
  }
  // Elevated concentric (paper 002): disk radius r = sqrt(1 − z), so the disk point is
  // (x, y) · r / |(x, y)| = (x, y) / sqrt(1 + z); then the inverse Shirley–Chiu map.
  const float disk_scale = std::sqrt(1.0f + d.z);
  const Float2 disk(d.x / disk_scale, d.y / disk_scale);
  const float r = std::sqrt(disk.x * disk.x + disk.y * disk.y);
  if (r < 1e-7f) return Float2(0.5f, 0.5f);
  constexpr float kQuarter = 0.78539816339744831f;
  float phi = std::atan2(disk.y, disk.x);
  if (phi < -kQuarter) phi += 8.0f * kQuarter;
  float a, b;
  if (phi < kQuarter) {
    a = r;
    b = phi * a / kQuarter;
  } else if (phi < 3.0f * kQuarter) {
    b = r;
    a = -(phi - 2.0f * kQuarter) * b / kQuarter;
  } else if (phi < 5.0f * kQuarter) {
    a = -r;
    b = (phi - 4.0f * kQuarter) * a / kQuarter;
  } else {
    b = -r;
    a = -(phi - 6.0f * kQuarter) * b / kQuarter;
  }
  return Float2(a * 0.5f + 0.5f, b * 0.5f + 0.5f);
}

/// Lookup-table texel the shaders read for a unit-square coordinate (nearest, clamped).
/// Thread-safe, noexcept. Precondition: resolution ≥ 1.
inline Int2 shader_table_texel(Float2 unit, uint32_t resolution) noexcept {
  const int res = static_cast<int>(resolution);
  const int x = static_cast<int>(std::floor(unit.x * static_cast<float>(res)));
  const int y = static_cast<int>(std::floor(unit.y * static_cast<float>(res)));
  return Int2(std::clamp(x, 0, res - 1), std::clamp(y, 0, res - 1));
}

/// Checks a configuration before generation. Returns invalid_argument with the offending field
/// (what, expected vs found) or success. Safe for any values.
inline VoidResult validate_shader_config(const ShaderConfig& c) {
  // Up to 128: paper 000 §7 renders C = 100 (25 RGBA groups).
  if (c.components == 0 || c.components > 128)
    return make_error(Status::invalid_argument, "shader config: components = %u, expected 1..128", c.components);
  if (!c.value_transform.valid())
    return make_error(Status::invalid_argument, "shader config: value_transform is not valid (log offset must be > 0)");
  if (c.angular.resolution == 0 || c.angular.resolution > 4096)
    return make_error(Status::invalid_argument, "shader config: angular.resolution = %u, expected 1..4096",
                      c.angular.resolution);
  const VirtualTextureConfig& v = c.vt;
  if (v.tile_size == 0 || v.tile_size > 1024 || v.border == 0 || v.border > v.tile_size)
    return make_error(Status::invalid_argument,
                      "shader config: tile_size = %u, border = %u, expected 1..1024, 1..tile_size", v.tile_size,
                      v.border);
  if (v.slots_x == 0 || v.slots_y == 0 || v.cache_layers == 0 ||
      static_cast<uint64_t>(v.slots_x) * v.slots_y * v.cache_layers > kPageEntrySlotMask + 1ull)
    return make_error(Status::invalid_argument, "shader config: cache %u×%u×%u slots, expected 1..2^24 slots",
                      v.slots_x, v.slots_y, v.cache_layers);
  if (v.format != CacheFormat::rgba16f && v.format != CacheFormat::rgba8_affine && v.format != CacheFormat::bc5_affine)
    return make_error(Status::invalid_argument, "shader config: vt.format = %u is not a cache format",
                      static_cast<unsigned>(v.format));
  if (!v.slot_side_fits_format())
    return make_error(Status::invalid_argument,
                      "shader config: a bc5_affine cache needs a slot side T+2B that is a multiple of 4, found %u",
                      v.padded_tile_size());
  if (v.finest_level > 15)
    return make_error(Status::invalid_argument, "shader config: vt.finest_level = %u, expected ≤ 15", v.finest_level);
  const FeedbackWordLayout& f = v.feedback;
  const uint32_t shifts[4] = {f.x_shift, f.y_shift, f.level_shift, f.texture_shift};
  const uint32_t bits[4] = {f.x_bits, f.y_bits, f.level_bits, f.texture_bits};
  uint64_t used = 0;
  for (int i = 0; i < 4; ++i) {
    if (bits[i] == 0 || shifts[i] + bits[i] > 32)
      return make_error(Status::invalid_argument, "shader config: feedback field %d at bit %u width %u exceeds 32 bits",
                        i, shifts[i], bits[i]);
    const uint64_t m = ((1ull << bits[i]) - 1ull) << shifts[i];
    if (used & m) return make_error(Status::invalid_argument, "shader config: feedback field %d overlaps another", i);
    used |= m;
  }
  if (c.laplacian.max_level > 15)
    return make_error(Status::invalid_argument, "shader config: laplacian.max_level = %u, expected ≤ 15",
                      c.laplacian.max_level);
  if (c.lpca.clusters == 0 || c.lpca.grid_resolution < 2)
    return make_error(Status::invalid_argument, "shader config: lpca clusters = %u, grid = %u, expected ≥ 1, ≥ 2",
                      c.lpca.clusters, c.lpca.grid_resolution);
  if (c.spmm.slots == 0 || c.spmm.slots > 64 || c.spmm.residual_components > 64)
    return make_error(Status::invalid_argument,
                      "shader config: spmm slots = %u, residual_components = %u, expected 1..64, 0..64", c.spmm.slots,
                      c.spmm.residual_components);
  if (c.pca.views_per_group == 0 || c.pca.light_count == 0)
    return make_error(Status::invalid_argument,
                      "shader config: pca views_per_group = %u, light_count = %u, expected ≥ 1", c.pca.views_per_group,
                      c.pca.light_count);
  return {};
}

}  // namespace btflod
