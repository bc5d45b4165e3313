// btflod — the abstract rendering backend: what a GPU API (or the CPU reference) must offer so
// that btflod can stream and shade BTFs with the generated shaders (runtime/shader/glsl_generator.hpp).
//
// No GL or Vulkan header here. samples/gl (OpenGL 4.5 + EGL) and samples/vulkan (Vulkan 1.3,
// headless) implement it. offline/render/cpu_reference.hpp is not a Backend: it is the CPU renderer
// with the shaders' arithmetic that the golden tests compare both against.
// The data formats are those of runtime/shader/shader_config.hpp: page-table entries
// (pack_page_entry), slot placement (slot_placement), the feedback word (FeedbackWordLayout),
// the uniform block (ShaderParams). docs/shaders.md walks through a frame.
//
// Threading: a backend object is used from one thread (the one that created it). Calls that run
// per frame (upload_tiles, upload_u_packets, apply_page_table_writes, begin_frame, draw, draw_feedback, end_frame,
// poll_feedback) do not allocate after set-up, never block on the GPU and return a Status.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "btflod/core/half.hpp"
#include "btflod/core/image.hpp"
#include "btflod/core/result.hpp"
#include "btflod/runtime/shader/glsl_generator.hpp"
#include "btflod/runtime/shader/shader_config.hpp"
#include "btflod/runtime/vt/cache_format.hpp"
#include "btflod/runtime/vt/tile_cache.hpp"
#include "btflod/runtime/vt/tile_id.hpp"

namespace btflod {

/// One vertex of a mesh: position and local frame in object space, texture coordinate.
/// tangent.w = ±1 is the handedness of the bitangent (b = cross(n, t) · w).
struct MeshVertex {
  float position[3];
  float normal[3];
  float tangent[4];
  float uv[2];
};
static_assert(sizeof(MeshVertex) == 48);

/// Triangle list. Precondition: every index < vertices.size().
struct MeshData {
  std::span<const MeshVertex> vertices;
  std::span<const uint32_t> indices;
};

/// Angular lookup tables (paper 000 §4): for light (layer 0) and view (layer 1), res × res
/// texels, row-major (row = unit-square y), 3 direction indices and 3 barycentric weights per
/// texel. Built by angular/ (e.g. a rasterised Delaunay triangulation); the shader reads the
/// texel shader_table_texel(shader_direction_to_unit_square(d), res).
struct AngularTablesData {
  uint32_t resolution = 0;
  std::span<const uint32_t> light_index;  ///< res² · 3
  std::span<const float> light_weight;    ///< res² · 3
  std::span<const uint32_t> view_index;   ///< res² · 3
  std::span<const float> view_weight;     ///< res² · 3
};

/// An FMF material (paper 000 eq. 5): U' with E's EigenTextures layout
/// (runtime/vt/vt_layout.hpp: u[((light · view_count + view) · 3 + colour) · C + c]) and optionally the
/// eigen-textures V' (M × N texels, C channels, Σ folded in) for the fmf program. A material used
/// only with the bsvtf program leaves eigen_textures empty: its V' comes from the tile cache.
struct FmfMaterialData {
  uint32_t components = 0;  ///< C_m, 1 … ShaderConfig::components (draws set ShaderParams::vt_extent.w to it)
  uint32_t light_count = 0;
  uint32_t view_count = 0;
  std::span<const float> eigen_abrdfs;    ///< light_count · view_count · 3 · C floats
  ImageView<const float> eigen_textures;  ///< M × N × C, or empty
  bool mipmaps = true;                    ///< build a mip chain for V' (hardware trilinear)
  AngularTablesData angular;
  /// The encoding of U'·V'ᵀ (EigenTextures::transform); must equal ShaderConfig::value_transform,
  /// which the programs decode with.
  ValueTransform transform{};
  /// Cache pool whose texture its bsvtf and bsvtf_feedback draws read (Backend::add_cache_pool;
  /// the Streamer's material_pool() of the material). 0: init()'s cache.
  uint32_t cache_pool = 0;
};

/// One tile to copy into a cache slot: (T + 2B)² RGBA texels (4 components), row-major,
/// border included — the layout of offline/build/tile_pyramid.hpp's tiles — in the cache's format
/// (VirtualTextureConfig::format): `texels` for rgba16f, `unorm8` and the slot's `map` for
/// rgba8_affine (runtime/vt/cache_format.hpp; encode_cache_tile_unorm8() makes them from half texels),
/// `bc5` and the slot's `map` for bc5_affine (runtime/vt/cache_bc5.hpp's two-plane layout;
/// encode_cache_tile_bc5() makes them).
struct TileUpload {
  uint32_t slot = 0;                  ///< < VirtualTextureConfig::slot_count()
  std::span<const uint16_t> texels;   ///< rgba16f: (T + 2B)² · 4 half bits
  std::span<const uint8_t> unorm8{};  ///< rgba8_affine: (T + 2B)² · 4 bytes
  CacheSlotMap map{};                 ///< rgba8_affine, bc5_affine: value = offset + scale · unorm
  /// bc5_affine: cache_bc5_tile_bytes(T + 2B) = (T + 2B)² · 2 bytes, plane 0 (components 0, 1)
  /// then plane 1 (components 2, 3), each (T + 2B)² / 16 BC5 blocks in row-major block order.
  std::span<const uint8_t> bc5{};
  /// Cache pool (StreamerTileUpload::pool) whose cache texture holds `slot`; a backend with one
  /// cache serves pool 0 only.
  uint32_t pool = 0;
};

/// Checks a tile upload against the cache: slot in range and the texels of the cache's format,
/// (T + 2B)² · 4 of them for rgba16f and rgba8_affine, (T + 2B)² · 2 bytes of BC5 blocks for
/// bc5_affine (a finite map for both affine formats). Returns invalid_argument otherwise.
/// noexcept; safe for any input.
inline Status check_tile_upload(const TileUpload& t, const CacheConfig& cache) noexcept {
  const size_t n = size_t{cache.padded_tile_size()} * cache.padded_tile_size() * 4;
  if (t.slot >= cache.slot_count()) return Status::invalid_argument;
  if (cache_format_has_slot_map(cache.format)) {
    for (int c = 0; c < 4; ++c)
      if (!std::isfinite(t.map.offset[c]) || !std::isfinite(t.map.scale[c])) return Status::invalid_argument;
    if (cache.format == CacheFormat::bc5_affine)
      return cache.slot_side_fits_format() && t.bc5.size() == n / 2 ? Status::success : Status::invalid_argument;
    return t.unorm8.size() == n ? Status::success : Status::invalid_argument;
  }
  return t.texels.size() == n ? Status::success : Status::invalid_argument;
}

/// One texel of the GPU page table to overwrite. The GPU page table has one level per mip (so
/// the shader can blend two resident levels); runtime/vt/tile_cache.hpp's finest-level deltas are turned
/// into these writes by runtime/backend/page_table_writes.hpp. `tile` names the texel: layer
/// tile.texture (virtual texture), tile (x, y) at paper level tile.level; page_mip = material
/// finest level − tile.level is the mip it lives in (ShaderParams::vt_extent.z − level).
/// entry = pack_page_entry(slot, resident level) (runtime/vt/cache_config.hpp) of the tile the cache
/// uses for it: itself or its deepest resident ancestor.
// struct PageTableWrite is defined in runtime/vt/tile_cache.hpp (GPU-free, shared with the runtime).

/// Builds the write for tile `t` of a material whose finest level is `material_finest_level`.
/// Precondition: t.level ≤ material_finest_level.
constexpr PageTableWrite make_page_table_write(TileId t, uint32_t material_finest_level, uint32_t slot,
                                               uint32_t resident_level) noexcept {
  return PageTableWrite{t, material_finest_level - t.level, pack_page_entry(slot, resident_level)};
}

/// Checks a mesh before upload: a non-empty triangle list whose indices name existing vertices.
/// Returns invalid_argument saying which. Safe for untrusted data.
inline VoidResult validate_mesh(const MeshData& mesh) {
  if (mesh.vertices.empty() || mesh.indices.empty() || mesh.indices.size() % 3 != 0)
    return make_error(Status::invalid_argument, "mesh with %zu vertices, %zu indices (need a triangle list)",
                      mesh.vertices.size(), mesh.indices.size());
  for (uint32_t i : mesh.indices)
    if (i >= mesh.vertices.size())
      return make_error(Status::invalid_argument, "mesh index %u ≥ %zu vertices", i, mesh.vertices.size());
  return {};
}

/// Checks a material against the shader config before upload: 1 ≤ C_m ≤ the programs' C, spans
/// have the sizes the counts imply, table indices name existing directions and weights are
/// finite. Returns invalid_argument naming the field (expected vs found). Safe for untrusted data.
inline VoidResult validate_material(const FmfMaterialData& m, const ShaderConfig& config) {
  if (m.components == 0 || m.components > config.components)
    return make_error(Status::invalid_argument, "material: C = %u, shaders were generated for C ≤ %u", m.components,
                      config.components);
  if (!(m.transform == config.value_transform))
    return make_error(Status::invalid_argument, "material: value encoding %s, shaders were generated for %s",
                      value_encoding_name(m.transform.encoding), value_encoding_name(config.value_transform.encoding));
  if (m.light_count == 0 || m.view_count == 0 || m.light_count > 65536 || m.view_count > 65536)
    return make_error(Status::invalid_argument, "material: %u lights × %u views, expected 1..65536 each", m.light_count,
                      m.view_count);
  const size_t u = static_cast<size_t>(m.light_count) * m.view_count * 3 * m.components;
  if (m.eigen_abrdfs.size() != u)
    return make_error(Status::invalid_argument, "material: U' has %zu floats, expected %zu", m.eigen_abrdfs.size(), u);
  if (!m.eigen_textures.empty() && m.eigen_textures.channels() != static_cast<int>(m.components))
    return make_error(Status::invalid_argument, "material: eigen-textures have %d channels, expected %u",
                      m.eigen_textures.channels(), m.components);
  const AngularTablesData& a = m.angular;
  if (a.resolution != config.angular.resolution)
    return make_error(Status::invalid_argument, "material: angular tables %u², shaders expect %u²", a.resolution,
                      config.angular.resolution);
  const size_t n = static_cast<size_t>(a.resolution) * a.resolution * 3;
  if (a.light_index.size() != n || a.light_weight.size() != n || a.view_index.size() != n || a.view_weight.size() != n)
    return make_error(Status::invalid_argument, "material: angular table spans %zu/%zu/%zu/%zu, expected %zu each",
                      a.light_index.size(), a.light_weight.size(), a.view_index.size(), a.view_weight.size(), n);
  for (size_t i = 0; i < n; ++i) {
    if (a.light_index[i] >= m.light_count || a.view_index[i] >= m.view_count)
      return make_error(Status::invalid_argument, "material: angular index %zu names direction %u/%u, have %u/%u", i,
                        a.light_index[i], a.view_index[i], m.light_count, m.view_count);
    if (!std::isfinite(a.light_weight[i]) || !std::isfinite(a.view_weight[i]))
      return make_error(Status::invalid_argument, "material: angular weight %zu is not finite", i);
  }
  return {};
}

/// `params` for drawing an FMF material of C_m components, what a backend's draw() uploads:
/// vt_extent.w, the components the FMF and BSVTF programs sum (ShaderParams::vt_extent), is
/// the caller's count when it is 1 … C_m − 1 (the first components only, e.g. a progressive
/// quality step) and C_m otherwise (0, NaN or above C_m). noexcept.
inline ShaderParams params_for_material(ShaderParams params, uint32_t components) noexcept {
  const float asked = params.vt_extent.w;
  params.vt_extent.w =
      asked >= 1.0f && asked < static_cast<float>(components) ? std::floor(asked) : static_cast<float>(components);
  return params;
}

/// One U′ packet (paper 000 §6): components 4g … 4g+3 of an FMF material's U′, as the runtime
/// hands it out (runtime/streamer.hpp StreamerPacketUpload): `rows` = light_count · view_count ·
/// 3 rows in light-major order (row = (light · view_count + view) · 3 + colour, the order of
/// FmfMaterialData::eigen_abrdfs), 4 half-float bits per row (component 4g + i in column i;
/// columns past C are ignored).
struct UPacketUpload {
  uint32_t packet = 0;               ///< g: components 4g … 4g+3
  uint32_t rows = 0;                 ///< light_count · view_count · 3
  std::span<const uint16_t> halves;  ///< rows · 4 half bits
};

/// Checks a U′ packet against a material of `light_count` × `view_count` directions and C =
/// `components`: packet g < ⌈C/4⌉, rows = lights · views · 3, halves = rows · 4. Returns
/// invalid_argument or success. noexcept; safe for untrusted values (sizes only: the half
/// values are not inspected).
inline Status check_u_packet(const UPacketUpload& p, uint32_t light_count, uint32_t view_count,
                             uint32_t components) noexcept {
  const uint64_t rows = uint64_t{light_count} * view_count * 3;
  if (components == 0 || p.packet >= (components + 3) / 4 || p.rows != rows || p.halves.size() != rows * 4)
    return Status::invalid_argument;
  return Status::success;
}

/// The CPU reference of a U′ upload: writes packet p into `eigen_abrdfs`, a material's U′ in
/// FmfMaterialData's layout (u[((light · views + view) · 3 + colour) · C + c], light-major),
/// i.e. columns 4g … min(4g+3, C−1) of every row. Returns invalid_argument (writing nothing)
/// when check_u_packet() fails or eigen_abrdfs has not lights · views · 3 · C floats.
/// noexcept, no allocation.
inline Status write_u_packet(const UPacketUpload& p, uint32_t light_count, uint32_t view_count, uint32_t components,
                             std::span<float> eigen_abrdfs) noexcept {
  if (check_u_packet(p, light_count, view_count, components) != Status::success ||
      eigen_abrdfs.size() != size_t{p.rows} * components)
    return Status::invalid_argument;
  const uint32_t first = 4 * p.packet, n = std::min(4u, components - first);
  for (size_t r = 0; r < p.rows; ++r)
    for (uint32_t i = 0; i < n; ++i)
      eigen_abrdfs[r * components + first + i] = Half::from_bits(p.halves[r * 4 + i]).to_float();
  return Status::success;
}

/// A U′ packet as the layers 4g … 4g+n−1 (n = min(4, C − 4g)) of the eigen_abrdfs texture
/// (pack_eigen_abrdfs_rgba's layout: RGBA32F, texel (light, view), rgb = colour, a = 0): writes
/// n · views · lights · 4 floats into `layers` and returns n, or 0 when check_u_packet() fails
/// or `layers` is smaller. What the GPU backends upload. noexcept, no allocation.
inline uint32_t u_packet_to_rgba_layers(const UPacketUpload& p, uint32_t light_count, uint32_t view_count,
                                        uint32_t components, std::span<float> layers) noexcept {
  if (check_u_packet(p, light_count, view_count, components) != Status::success) return 0;
  const uint32_t first = 4 * p.packet, n = std::min(4u, components - first);
  const size_t plane = size_t{light_count} * view_count * 4;
  if (layers.size() < plane * n) return 0;
  for (uint32_t i = 0; i < n; ++i)
    for (uint32_t v = 0; v < view_count; ++v)
      for (uint32_t l = 0; l < light_count; ++l) {
        float* texel = &layers[i * plane + (size_t{v} * light_count + l) * 4];
        const size_t row = (size_t{l} * view_count + v) * 3;
        for (uint32_t k = 0; k < 3; ++k) texel[k] = Half::from_bits(p.halves[(row + k) * 4 + i]).to_float();
        texel[3] = 0.0f;
      }
  return n;
}

/// U' as the eigen_abrdfs texture wants it: RGBA32F 2D array, texel (light, view), layer c,
/// rgb = colour, a = 0. Returns light·view·C·4 floats. Precondition: validate_material passed.
inline std::vector<float> pack_eigen_abrdfs_rgba(const FmfMaterialData& m) {
  const size_t C = m.components;
  std::vector<float> out(static_cast<size_t>(m.light_count) * m.view_count * C * 4, 0.0f);
  for (uint32_t l = 0; l < m.light_count; ++l)
    for (uint32_t v = 0; v < m.view_count; ++v)
      for (size_t c = 0; c < C; ++c)
        for (size_t k = 0; k < 3; ++k)
          out[((c * m.view_count + v) * m.light_count + l) * 4 + k] =
              m.eigen_abrdfs[((static_cast<size_t>(l) * m.view_count + v) * 3 + k) * C + c];
  return out;
}

/// The angular tables as two 2-layer textures (layer 0 light, 1 view): indices RGBA32UI and
/// weights RGBA32F, res² texels per layer, .w = 0. Precondition: validate_material passed.
inline void pack_angular_tables_rgba(const AngularTablesData& a, std::vector<uint32_t>& index,
                                     std::vector<float>& weight) {
  const size_t n = static_cast<size_t>(a.resolution) * a.resolution;
  index.assign(n * 2 * 4, 0u);
  weight.assign(n * 2 * 4, 0.0f);
  for (size_t i = 0; i < n; ++i)
    for (size_t k = 0; k < 3; ++k) {
      index[i * 4 + k] = a.light_index[i * 3 + k];
      weight[i * 4 + k] = a.light_weight[i * 3 + k];
      index[(n + i) * 4 + k] = a.view_index[i * 3 + k];
      weight[(n + i) * 4 + k] = a.view_weight[i * 3 + k];
    }
}

/// Eigen-textures V' as the eigen_textures texture wants them: RGBA32F 2D array of ⌈C/4⌉
/// layers (components 4g … 4g+3, zero past C), M × N texels per layer, row 0 = first image row.
inline std::vector<float> pack_eigen_textures_rgba(ImageView<const float> v) {
  const int groups = (v.channels() + 3) / 4;
  const size_t plane = static_cast<size_t>(v.width()) * static_cast<size_t>(v.height()) * 4;
  std::vector<float> out(plane * static_cast<size_t>(groups), 0.0f);
  for (int g = 0; g < groups; ++g)
    for (int y = 0; y < v.height(); ++y)
      for (int x = 0; x < v.width(); ++x)
        for (int k = 0; k < 4 && 4 * g + k < v.channels(); ++k)
          out[plane * static_cast<size_t>(g) + (static_cast<size_t>(y) * v.width() + x) * 4 + k] =
              v.at(x, y, 4 * g + k);
  return out;
}

// --- the other representations (laplacian, lpca, pca_views programs) ----------------------
// Each material carries its data in the layout its generated program reads (docs/shaders.md,
// "Representation layouts"); offline/packing/representation_packing.hpp builds them from factor/'s
// LaplacianPca, LocalPca and PcaViews. A backend generates the material's program at creation
// from its init() config with the representation's own parameters (representation_config()),
// so C, λmax, K, R and k need not match the FMF/BSVTF config. All float data is RGBA32F,
// tightly packed, array layers outermost, then rows (row 0 = texture coordinate t = 0), then
// texels; mip chains are concatenated finest first.

/// Laplacian-pyramid PCA (paper 001 §3.3–3.4, eq. 7). Component j of pyramid level k is a weight
/// d_kj per texel and an eigen Laplacian BRDF with one value per (light, view) and YCbCr channel
/// (packing a channel's scalar component into its own rgb slot, the others 0, reproduces the
/// per-channel PCA exactly). C = components per level, zero-padded to the largest level.
struct LaplacianMaterialData {
  uint32_t components = 0;  ///< C (Y + Cb + Cr components of the richest level)
  uint32_t max_level = 0;   ///< λmax: levels 0 (finest band) … λmax (top)
  uint32_t light_count = 0;
  uint32_t view_count = 0;
  uint32_t width = 0;   ///< finest weight map (level 0) width; power of two
  uint32_t height = 0;  ///< power of two; level k is max(1, width >> k) × max(1, height >> k)
  bool ycbcr = true;    ///< values are YCbCr (paper 001 §3.1): the shader converts to RGB
  /// 2D array, texel (light, view), layer k·C + j: rgb = (Y, Cb, Cr) of E_kj. Sampled with
  /// texelFetch. (λmax + 1)·C·views·lights·4 floats.
  std::span<const float> eigen;
  /// Mipmapped 2D array of ⌈C/4⌉ layers, mip k = pyramid level k, component j in layer j/4,
  /// channel j%4; nearest filtering (paper 001 stores D_k per pyramid texel). Σ_k
  /// ⌈C/4⌉·w_k·h_k·4 floats, mip 0 first.
  std::span<const float> weights;
  /// 2D, texel (light, view): rgb = μ'_{λmax} (paper 001 eq. 5–6: Phong Y mean, constant Cb, Cr)
  /// tabulated at the measured directions. views·lights·4 floats.
  std::span<const float> mean;
  AngularTablesData angular;  ///< the shader uses the nearest (largest-weight) index (§3.4 step 1)
};

/// Local PCA with the 3D-texture layout of paper 002 §6.2: per texel a cluster k; per cluster
/// the mean (j = 0) and C eigen-BRDFs (j = 1 … C) resampled on a regular R⁴ grid over
/// (s_v, t_v, s_l, t_l) of the parameterised view and light directions, grid sample i at
/// s = i/(R−1). Volume texel (x, y, z) with x = j·R + a (s_v = a/(R−1)), y = k·R + b
/// (t_v = b/(R−1)), z = i·R + c (t_l = i/(R−1), s_l = c/(R−1)); linear filtering does s_v, t_v,
/// s_l and the shader lerps t_l by hand. The volume is 8-bit (paper 002 §6.3): every (k, j)
/// block is quantised separately to snorm8, q = round(127·v/s_{k,j}) with s_{k,j} = max |v| over
/// the block, and the scale is folded into the texel's weight of slot j: the shader computes
/// Σ_{j=0..C} α'_j · (q_j/127), α'_0 = s_{k,0}, α'_j = α_j·s_{k,j} (q/127 is what an snorm8
/// texture returns, before filtering).
struct LpcaMaterialData {
  uint32_t components = 0;       ///< C eigen-BRDFs per cluster
  uint32_t clusters = 0;         ///< K
  uint32_t grid_resolution = 0;  ///< R ≥ 2
  uint32_t width = 0;
  uint32_t height = 0;
  DirectionParameterisation parameterisation = DirectionParameterisation::elevated_concentric;
  std::span<const uint32_t> cluster;  ///< width·height cluster ids < K (R32UI 2D, texelFetch)
  /// 2D array ⌈(C+1)/4⌉ layers: α'_j (j = 0 the mean's scale, scales folded in) in layer j/4,
  /// channel j%4.
  std::span<const float> weights;
  /// 3D snorm8 RGBA, (C+1)·R × K·R × R·R texels, x fastest then y then z: rgb = colour / s_{k,j}
  /// (×127, rounded), a = 0. 4 bytes per texel.
  std::span<const int8_t> volume;
};

/// PCA over groups of k neighbouring views (paper 004 §4.3.2, §6.3): per group b, A_b = L·R with
/// L = [m | UΣ] (one scalar per texel and component c = 0 … C, c = 0 the mean) and
/// R = [1; Vᵀ] (one value per component, light, view and colour: red = Σ_c L_c R_{c,3i}).
struct PcaViewsMaterialData {
  uint32_t components = 0;  ///< C per group (zero-padded to the largest group)
  uint32_t views_per_group = 0;
  uint32_t light_count = 0;
  uint32_t view_count = 0;
  uint32_t width = 0;
  uint32_t height = 0;
  /// 2D array of groups·⌈(C+1)/4⌉ layers: L_{t,c} of group b in layer b·⌈(C+1)/4⌉ + c/4,
  /// channel c%4; nearest (paper 004 §6.3: i = ⌊u·N⌋).
  std::span<const float> l;
  /// 2D, C × lights·views texels: texel (c − 1, light + lights·view) rgb = R_{c, colour} of the
  /// view's group (row 0 of R, all ones, is implicit).
  std::span<const float> r;
  AngularTablesData angular;  ///< 3 closest directions, barycentric weights (paper 004 §4.4)
};

/// SPMM (paper 003 eq. 1–3) in the layout of the spmm program (ShaderConfig::spmm; built by
/// offline/packing/spmm_packing.hpp). Chosen for few scattered fetches: everything per texel is in one
/// RGBA32UI array texture (adjacent fragments read adjacent texels of one layer), only the
/// dictionary entries (2 texels per occupied slot) and the residual table are data-addressed.
struct SpmmMaterialData {
  uint32_t slots = 0;                ///< S: weight slots per texel
  uint32_t residual_components = 0;  ///< P: N_PCA stored per cluster
  uint32_t clusters = 0;             ///< K
  uint32_t bases = 0;                ///< dictionary entries of all clusters together
  uint32_t light_count = 0;
  uint32_t view_count = 0;
  uint32_t width = 0;
  uint32_t height = 0;
  /// RGBA32UI 2D array of S + spmm_residual_layers(P) layers, W × H texels each. Layer k < S:
  /// slot k = (global basis index or 0xffffffff when empty, α_r, α_g, α_b as float bits),
  /// occupied slots first. Layer S + g: element 4g + i of [cluster id, coef_0 … coef_{P−1}]
  /// (coefficients as float bits, zero-padded).
  std::span<const uint32_t> texels;
  /// RGBA32F 2D, 2·kSpmmBasesPerRow × ⌈bases / kSpmmBasesPerRow⌉ texels: basis g at texels
  /// (2·(g mod 128), g / 128) = (model id as float, κ0, κ1, κ2) and (n_j, 0) (paper 003 eq. 2).
  std::span<const float> dictionary;
  /// RGBA32F 2D array, texel (light, view), K·(P+1) layers: layer c·(P+1) is the residual mean
  /// ε̄(c) and layer c·(P+1) + 1 + i component b_i(c) (paper 003 eq. 3), rgb.
  std::span<const float> residual;
  AngularTablesData angular;  ///< the residual's 3 × 3 barycentric taps (paper 003 §4.2)
};

namespace detail {
inline bool is_pow2(uint32_t v) noexcept { return v != 0 && (v & (v - 1)) == 0; }
inline VoidResult check_angular(const AngularTablesData& a, uint32_t lights, uint32_t views, uint32_t resolution) {
  if (a.resolution != resolution)
    return make_error(Status::invalid_argument, "material: angular tables %u², shaders expect %u²", a.resolution,
                      resolution);
  const size_t n = static_cast<size_t>(a.resolution) * a.resolution * 3;
  if (a.light_index.size() != n || a.light_weight.size() != n || a.view_index.size() != n || a.view_weight.size() != n)
    return make_error(Status::invalid_argument, "material: angular table spans %zu/%zu/%zu/%zu, expected %zu each",
                      a.light_index.size(), a.light_weight.size(), a.view_index.size(), a.view_weight.size(), n);
  for (size_t i = 0; i < n; ++i) {
    if (a.light_index[i] >= lights || a.view_index[i] >= views)
      return make_error(Status::invalid_argument, "material: angular index %zu names direction %u/%u, have %u/%u", i,
                        a.light_index[i], a.view_index[i], lights, views);
    if (!std::isfinite(a.light_weight[i]) || !std::isfinite(a.view_weight[i]))
      return make_error(Status::invalid_argument, "material: angular weight %zu is not finite", i);
  }
  return {};
}
inline size_t laplacian_weight_floats(const LaplacianMaterialData& m) noexcept {
  size_t s = 0;
  for (uint32_t k = 0; k <= m.max_level; ++k)
    s += static_cast<size_t>(std::max(1u, m.width >> k)) * std::max(1u, m.height >> k) * 4 * ((m.components + 3) / 4);
  return s;
}
}  // namespace detail

/// Checks a Laplacian material (counts, power-of-two sizes, λmax ≤ 15, span sizes, angular
/// tables against `config.angular.resolution`). Returns invalid_argument naming the field.
/// Safe for untrusted data.
inline VoidResult validate_material(const LaplacianMaterialData& m, const ShaderConfig& config) {
  if (m.components == 0 || m.components > 64 || m.max_level > 15 || m.light_count == 0 || m.view_count == 0 ||
      m.light_count > 16384 || m.view_count > 16384 || !detail::is_pow2(m.width) || !detail::is_pow2(m.height) ||
      m.width > 16384 || m.height > 16384 || (1u << m.max_level) > std::max(m.width, m.height))
    return make_error(Status::invalid_argument,
                      "laplacian material: C = %u, λmax = %u, %u lights × %u views, %u×%u weights (expected C 1..64, "
                      "λmax ≤ 15 and ≤ log2 of the power-of-two size)",
                      m.components, m.max_level, m.light_count, m.view_count, m.width, m.height);
  const size_t dirs = static_cast<size_t>(m.light_count) * m.view_count;
  if (m.eigen.size() != dirs * (m.max_level + 1) * m.components * 4 || m.mean.size() != dirs * 4 ||
      m.weights.size() != detail::laplacian_weight_floats(m))
    return make_error(Status::invalid_argument,
                      "laplacian material: eigen/weights/mean have %zu/%zu/%zu floats, expected %zu/%zu/%zu",
                      m.eigen.size(), m.weights.size(), m.mean.size(), dirs * (m.max_level + 1) * m.components * 4,
                      detail::laplacian_weight_floats(m), dirs * 4);
  return detail::check_angular(m.angular, m.light_count, m.view_count, config.angular.resolution);
}

/// Checks an LPCA material (counts, span sizes, every cluster id < K). Returns
/// invalid_argument naming the field. Safe for untrusted data.
inline VoidResult validate_material(const LpcaMaterialData& m, const ShaderConfig&) {
  if (m.components == 0 || m.components > 64 || m.clusters == 0 || m.clusters > 4096 || m.grid_resolution < 2 ||
      m.grid_resolution > 64 || m.width == 0 || m.height == 0 || m.width > 16384 || m.height > 16384)
    return make_error(Status::invalid_argument,
                      "lpca material: C = %u, K = %u, R = %u, %u×%u (expected C 1..64, K 1..4096, R 2..64)",
                      m.components, m.clusters, m.grid_resolution, m.width, m.height);
  const size_t texels = static_cast<size_t>(m.width) * m.height, r = m.grid_resolution;
  const size_t volume = (m.components + 1) * r * m.clusters * r * r * r * 4;
  const size_t weights = texels * 4 * ((m.components + 4) / 4);
  if (m.cluster.size() != texels || m.weights.size() != weights || m.volume.size() != volume)
    return make_error(Status::invalid_argument,
                      "lpca material: cluster/weights/volume have %zu/%zu/%zu values, expected %zu/%zu/%zu",
                      m.cluster.size(), m.weights.size(), m.volume.size(), texels, weights, volume);
  for (size_t t = 0; t < texels; ++t)
    if (m.cluster[t] >= m.clusters)
      return make_error(Status::invalid_argument, "lpca material: texel %zu has cluster %u, K = %u", t, m.cluster[t],
                        m.clusters);
  return {};
}

/// Checks a PCA-k material (counts, span sizes, angular tables). Returns invalid_argument
/// naming the field. Safe for untrusted data.
inline VoidResult validate_material(const PcaViewsMaterialData& m, const ShaderConfig& config) {
  if (m.components == 0 || m.components > 64 || m.views_per_group == 0 || m.view_count == 0 || m.light_count == 0 ||
      m.views_per_group > m.view_count || m.light_count > 16384 || m.view_count > 16384 || m.width == 0 ||
      m.height == 0 || m.width > 16384 || m.height > 16384)
    return make_error(Status::invalid_argument, "pca_views material: C = %u, k = %u, %u lights × %u views, %u×%u",
                      m.components, m.views_per_group, m.light_count, m.view_count, m.width, m.height);
  const size_t groups = (m.view_count + m.views_per_group - 1) / m.views_per_group;
  const size_t l = groups * ((m.components + 4) / 4) * m.width * m.height * 4;
  const size_t r = static_cast<size_t>(m.components) * m.light_count * m.view_count * 4;
  if (m.l.size() != l || m.r.size() != r)
    return make_error(Status::invalid_argument, "pca_views material: L/R have %zu/%zu floats, expected %zu/%zu",
                      m.l.size(), m.r.size(), l, r);
  return detail::check_angular(m.angular, m.light_count, m.view_count, config.angular.resolution);
}

/// Checks an SPMM material: counts (S 1..64, P 0..64, K·(P+1) ≤ 2048 layers, sizes ≤ 16384),
/// span sizes, every slot index < bases or empty with occupied slots first, every cluster id
/// < K, every weight, coefficient, κ, normal and residual value finite, model ids 0..6, basis
/// normals with n.z > 0, angular tables. Returns invalid_argument naming the field. Safe for
/// untrusted data (the shader then never reads outside a texture).
inline VoidResult validate_material(const SpmmMaterialData& m, const ShaderConfig& config) {
  const uint64_t layers = static_cast<uint64_t>(m.clusters) * (m.residual_components + 1ull);
  const uint64_t rows = (m.bases + static_cast<uint64_t>(kSpmmBasesPerRow) - 1) / kSpmmBasesPerRow;
  if (m.slots == 0 || m.slots > 64 || m.residual_components > 64 || m.clusters == 0 || layers > 2048 || m.bases == 0 ||
      rows > 16384 || m.light_count == 0 || m.view_count == 0 || m.light_count > 16384 || m.view_count > 16384 ||
      m.width == 0 || m.height == 0 || m.width > 16384 || m.height > 16384)
    return make_error(Status::invalid_argument,
                      "spmm material: S = %u, P = %u, K = %u, %u bases, %u lights × %u views, %u×%u (expected S "
                      "1..64, P 0..64, K·(P+1) ≤ 2048, sizes 1..16384)",
                      m.slots, m.residual_components, m.clusters, m.bases, m.light_count, m.view_count, m.width,
                      m.height);
  const size_t n = static_cast<size_t>(m.width) * m.height;
  const size_t texels = (m.slots + spmm_residual_layers(m.residual_components)) * n * 4;
  const size_t dictionary = static_cast<size_t>(rows) * 2 * kSpmmBasesPerRow * 4;
  const size_t residual = static_cast<size_t>(layers) * m.light_count * m.view_count * 4;
  if (m.texels.size() != texels || m.dictionary.size() != dictionary || m.residual.size() != residual)
    return make_error(Status::invalid_argument,
                      "spmm material: texels/dictionary/residual have %zu/%zu/%zu values, expected %zu/%zu/%zu",
                      m.texels.size(), m.dictionary.size(), m.residual.size(), texels, dictionary, residual);
  auto bits_finite = [](uint32_t b) { return (b & 0x7f800000u) != 0x7f800000u; };
  for (size_t t = 0; t < n; ++t) {
    bool empty_seen = false;
    for (size_t k = 0; k < m.slots; ++k) {
      const uint32_t* s = &m.texels[(k * n + t) * 4];
      if (s[0] == 0xffffffffu) {
        empty_seen = true;
        continue;
      }
      if (s[0] >= m.bases || empty_seen || !bits_finite(s[1]) || !bits_finite(s[2]) || !bits_finite(s[3]))
        return make_error(Status::invalid_argument,
                          "spmm material: texel %zu slot %zu: basis %u of %u%s or a non-finite weight", t, k, s[0],
                          m.bases, empty_seen ? " after an empty slot" : "");
    }
    const size_t first = static_cast<size_t>(m.slots) * n * 4;
    for (size_t g = 0; g < spmm_residual_layers(m.residual_components); ++g)
      for (size_t i = 0; i < 4; ++i) {
        const uint32_t v = m.texels[first + (g * n + t) * 4 + i];
        if (g == 0 && i == 0 ? v >= m.clusters : !bits_finite(v))
          return make_error(Status::invalid_argument,
                            "spmm material: texel %zu: cluster %u of %u or a non-finite coefficient", t,
                            m.texels[first + t * 4], m.clusters);
      }
  }
  for (size_t g = 0; g < m.bases; ++g) {
    const size_t row = g / kSpmmBasesPerRow, col = 2 * (g % kSpmmBasesPerRow);
    const float* p = &m.dictionary[(row * 2 * kSpmmBasesPerRow + col) * 4];
    bool ok = p[0] >= 0.0f && p[0] <= 6.0f && p[0] == std::floor(p[0]) && p[6] > 0.0f;
    for (int i = 0; i < 8; ++i) ok = ok && std::isfinite(p[i]);
    if (!ok)
      return make_error(Status::invalid_argument, "spmm material: basis %zu has model %g, a non-finite κ or n.z ≤ 0", g,
                        static_cast<double>(p[0]));
  }
  for (float v : m.residual)
    if (!std::isfinite(v)) return make_error(Status::invalid_argument, "spmm material: a residual value is not finite");
  return detail::check_angular(m.angular, m.light_count, m.view_count, config.angular.resolution);
}

/// The config a backend generates a representation's program from: `base` (angular tables,
/// targets) with the material's own component count and representation parameters.
inline ShaderConfig representation_config(const ShaderConfig& base, const LaplacianMaterialData& m) {
  ShaderConfig c = base;
  c.components = m.components;
  c.laplacian.max_level = m.max_level;
  c.laplacian.ycbcr_output = m.ycbcr;
  return c;
}
/// See representation_config(const ShaderConfig&, const LaplacianMaterialData&).
inline ShaderConfig representation_config(const ShaderConfig& base, const LpcaMaterialData& m) {
  ShaderConfig c = base;
  c.components = m.components;
  c.lpca.clusters = m.clusters;
  c.lpca.grid_resolution = m.grid_resolution;
  c.angular.parameterisation = m.parameterisation;
  return c;
}
/// See representation_config(const ShaderConfig&, const LaplacianMaterialData&).
inline ShaderConfig representation_config(const ShaderConfig& base, const PcaViewsMaterialData& m) {
  ShaderConfig c = base;
  c.components = m.components;
  c.pca.views_per_group = m.views_per_group;
  c.pca.light_count = m.light_count;
  return c;
}
/// See representation_config(const ShaderConfig&, const LaplacianMaterialData&).
inline ShaderConfig representation_config(const ShaderConfig& base, const SpmmMaterialData& m) {
  ShaderConfig c = base;
  c.spmm.slots = m.slots;
  c.spmm.residual_components = m.residual_components;
  return c;
}

/// Checks page-table writes against the page-table shape (layers, finest level); shared by
/// the backends so they reject the same inputs. Returns invalid_argument or success. noexcept.
inline Status check_page_table_writes(std::span<const PageTableWrite> writes, uint32_t layers,
                                      uint32_t finest_level) noexcept {
  for (const PageTableWrite& d : writes) {
    if (d.tile.texture >= layers || d.page_mip > finest_level) return Status::invalid_argument;
    const uint32_t side = 1u << (finest_level - d.page_mip);
    if (d.tile.x >= side || d.tile.y >= side) return Status::invalid_argument;
  }
  return Status::success;
}

/// Opaque handles (index + 1; 0 = none).
struct MeshHandle {
  uint32_t id = 0;
};
struct MaterialHandle {
  uint32_t id = 0;
};

/// Size of the frame targets. The colour target is RGBA32F (linear radiance); the feedback
/// target is R32UI, usually 1/8–1/32 of the screen (ShaderParams::lod.y = log2 of the factor).
struct FrameDesc {
  uint32_t width = 256;
  uint32_t height = 256;
  uint32_t feedback_width = 32;
  uint32_t feedback_height = 32;
  float clear_color[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  /// Frames drawn with ShaderProgram::bsvtf_feedback: feedback texel (x, y) is the word of
  /// screen pixel (x·bw + feedback_sample_x, y·bh + feedback_sample_y), counted from the top
  /// left, with bw × bh = feedback_block_width() × feedback_block_height() (subsample_feedback()).
  /// Rotate it over the block from frame to frame (feedback_sample_offset()). Must be < bw, bh.
  uint32_t feedback_sample_x = 0;
  uint32_t feedback_sample_y = 0;

  /// ⌈width / feedback_width⌉: screen pixels per feedback texel across.
  constexpr uint32_t feedback_block_width() const noexcept {
    return feedback_width ? (width + feedback_width - 1) / feedback_width : 0;
  }
  /// ⌈height / feedback_height⌉: screen pixels per feedback texel down.
  constexpr uint32_t feedback_block_height() const noexcept {
    return feedback_height ? (height + feedback_height - 1) / feedback_height : 0;
  }
};

/// The feedback target of a bsvtf_feedback frame from the full-resolution words its colour pass
/// wrote: out[x + y·feedback_width] = the word of pixel (x·bw + sample_x, y·bh + sample_y) of
/// `full` (frame.width × frame.height words, row 0 = top row of the image, or the bottom row
/// when `bottom_up`, as GL reads back), `empty_word` where that pixel is outside the screen.
/// Returns invalid_argument (and writes nothing) when a size does not match the frame or the
/// sample is outside the block. Backends call it when a readback arrives; no allocation.
inline Status subsample_feedback(std::span<const uint32_t> full, bool bottom_up, const FrameDesc& frame,
                                 uint32_t empty_word, std::span<uint32_t> out) noexcept {
  const uint32_t bw = frame.feedback_block_width(), bh = frame.feedback_block_height();
  if (full.size() != static_cast<size_t>(frame.width) * frame.height ||
      out.size() != static_cast<size_t>(frame.feedback_width) * frame.feedback_height || bw == 0 || bh == 0 ||
      frame.feedback_sample_x >= bw || frame.feedback_sample_y >= bh)
    return Status::invalid_argument;
  for (uint32_t y = 0; y < frame.feedback_height; ++y) {
    const uint64_t py = static_cast<uint64_t>(y) * bh + frame.feedback_sample_y;  // from the top
    uint32_t* row = out.data() + static_cast<size_t>(y) * frame.feedback_width;
    if (py >= frame.height) {
      std::fill(row, row + frame.feedback_width, empty_word);
      continue;
    }
    const uint32_t* src = full.data() + static_cast<size_t>(bottom_up ? frame.height - 1 - py : py) * frame.width;
    for (uint32_t x = 0; x < frame.feedback_width; ++x) {
      const uint64_t px = static_cast<uint64_t>(x) * bw + frame.feedback_sample_x;
      row[x] = px < frame.width ? src[px] : empty_word;
    }
  }
  return Status::success;
}

/// A finished feedback readback. `words` stays valid until the next poll_feedback() or
/// end_frame(); width·height words, row 0 = top row of the image.
struct FeedbackFrame {
  uint64_t frame = 0;  ///< the end_frame() counter value of the frame it was rendered in
  uint32_t width = 0;
  uint32_t height = 0;
  std::span<const uint32_t> words;
};

/// The rendering backend. See the file comment for threading and allocation rules.
class Backend {
 public:
  virtual ~Backend() = default;

  /// Human-readable name including the driver, e.g. "OpenGL 4.5 (llvmpipe)". Never null.
  virtual const char* name() const noexcept = 0;

  // --- set-up (may allocate; returns a readable error) ------------------------------------
  /// Generates and compiles the fmf, bsvtf, feedback and bsvtf_feedback programs for `config` and creates the
  /// tile cache (RGBA16F, config.vt.slot_count() slots) and the page table (R32UI array of
  /// `virtual_texture_count` layers, config.vt.finest_level + 1 mips, every entry 0 = slot 0 at
  /// level 0). Call once, before anything else; then upload the root tiles and the initial page
  /// tables (with runtime/vt/tile_cache.hpp: append_full_page_table_writes() per virtual texture, since
  /// the cache pins root t in slot t).
  virtual VoidResult init(const ShaderConfig& config, uint32_t virtual_texture_count) = 0;
  /// Uploads a mesh. Returns its handle.
  virtual Result<MeshHandle> create_mesh(const MeshData& mesh) = 0;
  /// Uploads an FMF material (U', angular tables, optional V'). Returns its handle.
  virtual Result<MaterialHandle> create_material(const FmfMaterialData& material) = 0;
  /// Releases a material of any kind (textures, descriptor sets, its own pipeline) once no
  /// submitted frame uses it: e.g. after a Streamer's material_removed event. Waits for the GPU
  /// when a frame in flight may read it (set-up time, not per frame). The handle is invalid
  /// afterwards (draw and upload_u_packets return invalid_argument) and never handed out again.
  /// Returns invalid_argument for an empty, unknown or already destroyed handle; a backend that
  /// cannot release resources a recorded frame uses (Vulkan) also refuses it between
  /// begin_frame() and end_frame().
  virtual Status destroy_material(MaterialHandle material) = 0;
  /// Uploads a Laplacian-pyramid PCA material and builds its `laplacian` program (paper 001
  /// eq. 7) from the init() config and representation_config(). Returns its handle (draw it with
  /// ShaderProgram::laplacian; ShaderParams::lod.z scales the eye distance: λ = log2(d·lod.z)),
  /// invalid_argument when validate_material() fails, unsupported when the backend has no
  /// such path (the default).
  virtual Result<MaterialHandle> create_laplacian_material(const LaplacianMaterialData&) {
    return make_error(Status::unsupported, "%s: no laplacian program", name());
  }
  /// Uploads a local-PCA material (paper 002 §6.2; draw with ShaderProgram::lpca). As above.
  virtual Result<MaterialHandle> create_lpca_material(const LpcaMaterialData&) {
    return make_error(Status::unsupported, "%s: no lpca program", name());
  }
  /// Uploads a PCA-k material (paper 004 §6.3; draw with ShaderProgram::pca_views). As above.
  virtual Result<MaterialHandle> create_pca_views_material(const PcaViewsMaterialData&) {
    return make_error(Status::unsupported, "%s: no pca_views program", name());
  }
  /// Uploads an SPMM material (paper 003 eq. 1–3; draw with ShaderProgram::spmm, residual
  /// switch in ShaderParams::ids.w = spmm_residual_mode()). As above.
  virtual Result<MaterialHandle> create_spmm_material(const SpmmMaterialData&) {
    return make_error(Status::unsupported, "%s: no spmm program", name());
  }

  /// Adds a cache pool (docs/vt.md, "Cache pools"): a cache texture of `cache`'s shape and format
  /// (and its slot-map table for the affine formats) and bsvtf / bsvtf_feedback programs
  /// generated for init()'s config with `cache` in place of its cache shape (tile size and
  /// format are compile-time constants of the shaders). Pools are numbered in order, init()'s
  /// cache being pool 0, so adding a Streamer's pools 1, 2, … in order makes the numbers match
  /// (StreamerTileUpload::pool, TileUpload::pool, FmfMaterialData::cache_pool). The page table
  /// and U′ textures are shared. Returns the pool's index; invalid_argument before init(), past
  /// kMaxCachePools or for a cache shape validate_shader_config() refuses; unsupported when the
  /// backend has no pools (the default) or the GPU's limits are exceeded. Set-up only.
  virtual Result<uint32_t> add_cache_pool(const CacheConfig&) {
    return make_error(Status::unsupported, "%s: one cache pool only", name());
  }
  /// Cache pools: 1 after init() plus one per add_cache_pool() (0 before init()).
  virtual uint32_t cache_pool_count() const noexcept { return 1; }

  // --- streaming (per frame; no allocation, no GPU wait) ----------------------------------
  /// Copies tiles into cache slots of their pools' cache textures (TileUpload::pool). Returns
  /// invalid_argument (and uploads nothing) when a pool does not exist, a slot is out of its
  /// pool's range or a span has the wrong size for its pool.
  virtual Status upload_tiles(std::span<const TileUpload> tiles) noexcept = 0;
  /// Overwrites page-table texels. Returns invalid_argument (and applies nothing) when a write
  /// names a layer, mip or texel outside the page table.
  virtual Status apply_page_table_writes(std::span<const PageTableWrite> writes) noexcept = 0;
  /// Overwrites components 4g … 4g+3 of an FMF material's U′ (its eigen_abrdfs texture, read
  /// by the fmf and bsvtf programs) with U′ packets, e.g. the runtime's
  /// StreamerOutputs::packet_uploads (runtime/backend/streamer_outputs.hpp forwards them). Packets apply
  /// in order; a material created with any U′ (zeros while streaming, paper 000 §6) shades with
  /// what has arrived. Returns invalid_argument (and uploads nothing) when the handle names no
  /// FMF material or a packet fails check_u_packet() for it; insufficient_space when the frame's
  /// staging memory is exhausted (Vulkan). No allocation, no GPU wait.
  virtual Status upload_u_packets(MaterialHandle material, std::span<const UPacketUpload> packets) noexcept = 0;

  // --- frame (per frame) -------------------------------------------------------------------
  /// Starts a frame: clears the colour target and the feedback target (to the config's
  /// FeedbackWordLayout::empty_word). Targets are (re)created when the size changes. Returns
  /// invalid_argument for a zero or oversized target or a feedback sample outside its block.
  virtual Status begin_frame(const FrameDesc& frame) noexcept = 0;
  /// Draws a mesh with `program` and the given shader parameters: fmf, bsvtf or bsvtf_feedback
  /// for an FMF material (with params_for_material(params, its C_m)), laplacian / lpca /
  /// pca_views / spmm for a material of that representation. Returns invalid_argument when the
  /// program does not fit the material.
  virtual Status draw(ShaderProgram program, MeshHandle mesh, MaterialHandle material,
                      const ShaderParams& params) noexcept = 0;
  /// Draws a mesh into the feedback target (paper 000 eq. 1–2). The feedback program is
  /// generated for init()'s cache (pool 0's tile size): materials of a pool with another tile
  /// size write their words with ShaderProgram::bsvtf_feedback draws instead. A frame whose colour pass uses
  /// ShaderProgram::bsvtf_feedback needs none: draw() then writes the words of every pixel and
  /// end_frame() reads back FrameDesc's sample of them (subsample_feedback()), replacing what
  /// draw_feedback() wrote in that frame.
  virtual Status draw_feedback(MeshHandle mesh, const ShaderParams& params) noexcept = 0;
  /// Submits the frame and starts the asynchronous feedback readback into a ring of
  /// feedback_ring_size() buffers. When every ring buffer is still in flight the oldest
  /// readback is dropped (counted in dropped_feedback()); the call never waits.
  virtual Status end_frame() noexcept = 0;
  /// Non-blocking: returns true and fills `out` with the oldest finished readback, false when
  /// none has finished yet.
  virtual bool poll_feedback(FeedbackFrame& out) noexcept = 0;
  virtual uint32_t feedback_ring_size() const noexcept = 0;
  virtual uint64_t dropped_feedback() const noexcept = 0;

  // --- tests and image output (blocking) ---------------------------------------------------
  /// Waits for the last frame and copies the colour target into `out` (width × height × 4
  /// floats, row 0 = top). Returns invalid_argument when the view has the wrong shape.
  virtual Status read_color(ImageView<float> out) noexcept = 0;
  /// Waits until every submitted frame, including its feedback readback, has finished.
  virtual Status wait_idle() noexcept = 0;
};

}  // namespace btflod
