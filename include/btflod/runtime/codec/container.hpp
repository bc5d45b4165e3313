// btflod — the streaming container file `.bsvtf` (layout documented in docs/bsvtf_format.md).
//
// One static file holds a whole material: a fixed header, the material metadata, the angular
// matrix U as packets of 4 components (paper 000 §7: "packing four components into the RGBA
// channels ... packets of 534 KB for interleaving with the tile transmission"), a per-tile index
// (offset, size, CRC-32, weight w of paper 000 eq. 8) and the tile payloads of codec/
// tile_codec.hpp. Payloads are ordered coarse to fine — U packet g next to the root tile of
// texture g, then level 1, level 2, … — so that a prefix of the file holds every level up to
// some l, and a client can fetch the header + directory in one or two range requests.
//
// Readers never trust a size: every count, offset and size is checked against the section that
// holds it and against the file size before use; each section and payload has a CRC-32.
//
// Reading is runtime code and stays cheap to include: the directory parser, the writers
// (write_bsvtf, build_bsvtf — the multi-threaded encoder) and bsvtf_component_ranges are defined in
// the implementation TU (BTFLOD_IMPLEMENTATION), so this header includes no <thread>, <future> or
// <mutex> and instantiates none of their containers and sorts; verify_bsvtf_payload and
// unpack_bsvtf_packet, called per payload, stay inline.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "btflod/core/angular_row_order.hpp"
#include "btflod/core/bytes.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/progress.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/value_transform.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/vt/tile_id.hpp"

namespace btflod {

class ThreadPool;  // core/thread_pool.hpp (offline): build_bsvtf's workers

inline constexpr uint8_t kBsvtfMagic[8] = {'B', 'S', 'V', 'T', 'F', '\r', '\n', 0x1a};
/// Version written. 4: the metadata stores the value encoding of the factorisation
/// (value_transform); 3: the row order of U (u_row_order) and each tile entry its energy
/// ‖T‖²_F/T² (paper 000 §6); 2: tile format 2 (run-length symbols).
inline constexpr uint32_t kBsvtfVersion = 4;
/// Oldest version read: version 2 files are read with u_row_order = unspecified and energies
/// 0 (a runtime then needs the order from its caller, see runtime/streamer.hpp).
inline constexpr uint32_t kBsvtfOldestReadableVersion = 2;
inline constexpr size_t kBsvtfHeaderSize = 128;
inline constexpr size_t kBsvtfPacketEntrySize = 24;
inline constexpr size_t kBsvtfTileEntrySize = 32;
inline constexpr uint32_t kBsvtfMaxComponents = 65536;
inline constexpr uint32_t kBsvtfMaxStringBytes = 4096;

/// How the colour channels of U are to be interpreted.
enum class ColorMode : uint32_t { linear_rgb = 0, ycbcr = 1, luminance = 2 };

/// Material metadata stored in the container.
struct BsvtfMetadata {
  std::string material_name;
  uint32_t width = 0;            ///< finest-level texture width in texels
  uint32_t height = 0;           ///< finest-level texture height in texels
  uint32_t tile_size = 64;       ///< T
  uint32_t border = 4;           ///< B
  uint32_t level_count = 1;      ///< levels 0 (coarsest) … level_count − 1 (finest), paper 000 numbering
  uint32_t component_count = 0;  ///< C eigen-textures; virtual texture g holds components 4g … 4g+3
  uint32_t color_channels = 3;
  ColorMode color_mode = ColorMode::linear_rgb;
  uint32_t u_rows = 0;  ///< rows of U: lights × views × colour channels, in u_row_order
  /// Order of U's rows (stored since version 3). Writers must say which order U is in.
  AngularRowOrder u_row_order = AngularRowOrder::light_major;
  std::string light_set;  ///< name of the light direction set (e.g. "UBO2014-151")
  std::string view_set;
  std::vector<float> light_directions;  ///< xyz triples, local frame
  std::vector<float> view_directions;   ///< xyz triples, local frame
  std::vector<float> component_ranges;  ///< C values: max − min of each eigen-texture (sets the codec tolerance)
  std::vector<float> component_scales;  ///< C values: per-component scale applied when shading (1 if unused)
  float quality = 50.0f;                ///< codec quality the tiles were built with
  /// The encoding U·Vᵀ approximates (stored since version 4; earlier files are linear):
  /// renderers decode the sum of paper 000 eq. 5 with it (core/value_transform.hpp).
  ValueTransform value_transform{};

  /// Number of virtual textures (RGBA eigen-texture packs) = packets of U.
  uint32_t texture_count() const noexcept { return (component_count + 3) / 4; }
  TileLayout layout() const noexcept { return TileLayout{tile_size, border, 4}; }
};

/// Where one tile's payload lives.
struct BsvtfTileEntry {
  TileId id;
  uint64_t offset = 0;
  uint32_t size = 0;
  uint32_t crc = 0;
  float weight = 0.0f;  ///< w(i, l, l−1), paper 000 eq. 8
  float energy = 0.0f;  ///< ‖T‖²_F / T², paper 000 §6 (0 in version-2 files)
};

/// Where one U packet (4 components, u_rows × 4 halves) lives.
struct BsvtfPacketEntry {
  uint32_t index = 0;
  uint64_t offset = 0;
  uint32_t size = 0;
  uint32_t crc = 0;
};

/// The fixed 128-byte header.
struct BsvtfHeader {
  uint32_t version = kBsvtfVersion;
  uint64_t file_size = 0;
  uint64_t directory_size = 0;  ///< bytes [0, directory_size): header, metadata, packet table, tile index
  uint64_t metadata_offset = 0;
  uint32_t metadata_size = 0, metadata_crc = 0;
  uint64_t packet_table_offset = 0;
  uint32_t packet_count = 0, packet_table_crc = 0;
  uint64_t tile_index_offset = 0;
  uint32_t tile_count = 0, tile_index_crc = 0;
  uint64_t payload_offset = 0, payload_size = 0;
};

/// Everything a client needs before fetching payloads.
struct BsvtfDirectory {
  BsvtfHeader header;
  BsvtfMetadata metadata;
  std::vector<BsvtfPacketEntry> packets;  ///< indexed by packet number
  std::vector<BsvtfTileEntry> tiles;      ///< sorted by TileId::key()

  /// The index entry of a tile, or nullptr. O(log n), no allocation; thread-safe.
  const BsvtfTileEntry* find(const TileId& id) const noexcept {
    const uint64_t key = id.key();
    auto it = std::lower_bound(tiles.begin(), tiles.end(), key,
                               [](const BsvtfTileEntry& e, uint64_t k) { return e.id.key() < k; });
    return (it != tiles.end() && it->id.key() == key) ? &*it : nullptr;
  }
  /// Bytes of the file prefix that hold the directory, every U packet and every tile of level
  /// ≤ `level` (the coarse-to-fine prefix is contiguous).
  uint64_t prefix_size(uint32_t level) const noexcept {
    uint64_t end = header.payload_offset;
    for (const auto& p : packets) end = std::max(end, p.offset + p.size);
    for (const auto& t : tiles)
      if (t.id.level <= level) end = std::max(end, t.offset + t.size);
    return end;
  }
};

/// An encoded tile for write_bsvtf.
struct BsvtfEncodedTile {
  TileId id;
  std::vector<uint8_t> payload;
  float weight = 0.0f;
  float energy = 0.0f;  ///< ‖T‖²_F / T² (paper 000 §6)
};

/// Writes a container from already encoded tiles. `u` is U row-major, metadata.u_rows ×
/// metadata.component_count floats (stored as halves, 4 components per packet, the last packet
/// zero-padded). Every tile id must be valid, unique, of a texture < texture_count() and a level
/// < level_count, and every tile of level > 0 must have its parent in the list.
/// Returns the file bytes or invalid_argument with a message. Thread-safe (no shared state).
/// `version` is kBsvtfVersion; kBsvtfOldestReadableVersion writes the older layout (no row
/// order, no energies) for compatibility tests of readers. Defined in the implementation TU.
Result<std::vector<uint8_t>> write_bsvtf(const BsvtfMetadata& metadata, std::span<const float> u,
                                         std::span<const BsvtfEncodedTile> tiles, uint32_t version = kBsvtfVersion);

/// Parses and validates the fixed header (the first kBsvtfHeaderSize bytes of a file whose
/// total size is `file_size`). Returns short_output when fewer bytes are given, bad_data for a
/// wrong signature, checksum or inconsistent section table, unsupported for another major
/// version. Safe on untrusted input; thread-safe. Defined in the implementation TU.
Result<BsvtfHeader> parse_bsvtf_header(std::span<const uint8_t> bytes, uint64_t file_size);

/// Parses and validates the directory. `prefix` holds at least the first directory_size bytes
/// of a file of `file_size` bytes (more is fine: e.g. the whole file). Validates the header,
/// the checksums of the metadata, packet table and tile index, every metadata field, and every
/// packet and tile entry against the payload region (in range, no overlap, sizes plausible for
/// the layout, ids valid, keys strictly ascending, parents present). Payload checksums are
/// verified when payloads are fetched (verify_bsvtf_payload). Returns short_output with the
/// number of bytes needed when `prefix` is too short. Safe on untrusted input; thread-safe.
/// Defined in the implementation TU (allocates the directory's arrays).
Result<BsvtfDirectory> parse_bsvtf_directory(std::span<const uint8_t> prefix, uint64_t file_size);

/// Parses a whole container held in memory (parse_bsvtf_directory with the file size taken from
/// the span). Safe on untrusted input; thread-safe.
inline Result<BsvtfDirectory> read_bsvtf(std::span<const uint8_t> file) {
  return parse_bsvtf_directory(file, file.size());
}

/// Checks fetched payload bytes against their index entry: success, short_output (fewer bytes)
/// or bad_data (more bytes, or CRC-32 mismatch). No allocation; thread-safe.
inline Status verify_bsvtf_payload(uint32_t expected_size, uint32_t expected_crc,
                                   std::span<const uint8_t> bytes) noexcept {
  if (bytes.size() < expected_size) return Status::short_output;
  if (bytes.size() > expected_size) return Status::bad_data;
  return crc32_of(bytes) == expected_crc ? Status::success : Status::bad_data;
}

/// Decodes tile `t` (container-local id) of a whole container held in memory: the chain root →
/// t, each payload verified (verify_bsvtf_payload) and decoded against its decoded parent, as
/// the Streamer does. `scratch` and `out` hold at least layout().sample_count() floats each
/// (`decoder` has the container's layout); `out` receives the tile. Returns success;
/// invalid_argument (t or an ancestor not in the index, spans too small); bad_data or
/// short_output (a payload outside `file`, a CRC mismatch, or the decoder's failure). Safe on
/// untrusted directories and bytes. For tools and tests (the runtime streams payloads itself);
/// no allocation; thread-safe with one decoder per thread.
inline Status decode_bsvtf_tile(const BsvtfDirectory& d, std::span<const uint8_t> file, TileId t, TileDecoder& decoder,
                                std::span<float> scratch, std::span<float> out) noexcept {
  const size_t n = d.metadata.layout().sample_count();
  if (scratch.size() < n || out.size() < n) return Status::invalid_argument;
  // Alternate so that level t.level lands in `out`.
  float* buffers[2] = {(t.level % 2 == 0) ? out.data() : scratch.data(),
                       (t.level % 2 == 0) ? scratch.data() : out.data()};
  for (uint32_t l = 0; l <= t.level; ++l) {
    const TileId a = t.ancestor(l);
    const BsvtfTileEntry* e = d.find(a);
    if (e == nullptr) return Status::invalid_argument;
    if (e->offset > file.size() || e->size > file.size() - e->offset) return Status::short_output;
    const std::span<const uint8_t> payload(file.data() + e->offset, e->size);
    if (const Status v = verify_bsvtf_payload(e->size, e->crc, payload); v != Status::success) return v;
    const std::span<const float> parent =
        l > 0 ? std::span<const float>(buffers[(l - 1) % 2], n) : std::span<const float>();
    if (const Status s = decoder.decode(payload, parent, a.x & 1u, a.y & 1u, std::span<float>(buffers[l % 2], n));
        s != Status::success)
      return s;
  }
  return Status::success;
}

/// Unpacks U packet bytes (u_rows × 4 halves) into floats: out[r * 4 + k] = component 4g + k of
/// row r. Preconditions: bytes verified, out.size() >= bytes.size() / 2. No allocation.
inline void unpack_bsvtf_packet(std::span<const uint8_t> bytes, std::span<float> out) noexcept {
  const size_t n = std::min(bytes.size() / 2, out.size());
  for (size_t i = 0; i < n; ++i) {
    uint16_t h = 0;
    std::memcpy(&h, bytes.data() + 2 * i, 2);
    out[i] = half_bits_to_float(h);
  }
}

/// One tile for build_bsvtf: samples of layout().sample_count() floats (texel-interleaved RGBA
/// components 4·texture … 4·texture+3) and its weight w(i, l, l−1) (paper 000 eq. 8).
struct BsvtfTileInput {
  TileId id;
  std::span<const float> samples;
  float weight = 0.0f;
  /// ‖T‖²_F / T² (paper 000 §6), stored in the tile index for the U'-packet priority.
  float energy = 0.0f;
  /// Multiplies this tile's tolerances (every channel). 1 (the default) keeps the bytes of the
  /// plain reference; a producer may lower it where errors are more visible, e.g. dark tiles
  /// (luminance_tolerance_scale, runtime/codec/quantize.hpp). The tile header stores the product, so
  /// readers need nothing. Must be finite and > 0.
  float tolerance_scale = 1.0f;
  /// If > 0, every channel's tolerance is at least tolerance_for_quality(quality, largest
  /// component range) · tolerance_min_scale (a floor shared by all channels, e.g. the
  /// display-referred tolerance under ToleranceReference::per_component). 0: no floor.
  float tolerance_min_scale = 0.0f;
  /// Multiplies channel k's tolerance (component 4·texture + k) on top of tolerance_scale, e.g.
  /// the perceptual weights of perceptual_tolerance_scales() (offline/build/perceptual_tolerance.hpp).
  /// 1 (the default) keeps the bytes. Each must be finite and in (0, 1e6).
  std::array<float, 4> channel_scale{1.0f, 1.0f, 1.0f, 1.0f};
};

/// Which value range scales a component's codec tolerance (tolerance_for_quality).
enum class ToleranceReference : uint8_t {
  /// The largest component range, for every component. With FMF the eigen-textures are V·Σ and
  /// U has orthonormal columns (paper 000 eq. 4–5), so an error e_c in any component adds
  /// ‖e_c‖² to the rendered BTF's squared error: one absolute tolerance for all components
  /// spends bits where they reduce the rendered error. The default.
  shared_max,
  /// Each component's own range (every eigen-texture coded to the same relative precision).
  per_component,
};

/// Options for build_bsvtf.
struct BsvtfBuildOptions {
  float quality = 50.0f;  ///< 1..100, see tolerance_for_quality
  ToleranceReference tolerance_reference = ToleranceReference::shared_max;
  int deflate_level = 6;  ///< zlib level 0..9
  /// Frequency weighting: JPEG's table to the power weight_quarters / 4 (0..4; 4 = JPEG's table,
  /// the bytes of earlier versions; runtime/codec/quantize.hpp quant_step_factors). Stored per tile.
  uint32_t weight_quarters = kJpegWeightQuarters;
  /// Entropy coder of every tile: zstd (tile format 3, readers built with BTFLOD_WITH_ZSTD;
  /// runtime/codec/tile_codec.hpp) at zstd_level (1..22), or deflate (tile format 2, every reader, the
  /// bytes of earlier versions). Default: default_tile_entropy_coder() — zstd when this build can
  /// encode it (smaller tiles that decode faster), else deflate.
  TileEntropyCoder entropy_coder = default_tile_entropy_coder();
  int zstd_level = 19;
  /// Dead-zone threshold of the AC coefficients (TileEncoder::set_ac_rounding_threshold): 0.5 is
  /// round-to-nearest; larger values zero more small coefficients. In [0.5, 1).
  float ac_rounding_threshold = 0.5f;
  ThreadPool* pool = nullptr;  ///< nullptr: default_thread_pool()
  ProgressCallback progress;   ///< stage "encode tiles", fraction of tiles done; false cancels
};

/// max − min of each of the `component_count` eigen-texture components over `tiles` (4
/// channels per tile: component 4·texture + channel; components no tile holds get 0): what
/// build_bsvtf() fills metadata.component_ranges with when it is empty. Allocates the result.
std::vector<float> bsvtf_component_ranges(std::span<const BsvtfTileInput> tiles, uint32_t component_count);

/// Encodes tiles coarse to fine with the closed-loop residual codec and writes the container.
/// Tolerances come from options.quality and options.tolerance_reference, times each tile's
/// tolerance_scale and channel_scale (invalid_argument unless finite and in (0, 1e6)).
/// metadata.component_ranges is filled from the tiles when empty, component_scales with 1 when
/// empty, and metadata.quality from the options. Tiles of one level are encoded in parallel on
/// the pool; each tile is coded against its parent's reconstruction. Returns the file bytes,
/// invalid_argument (bad ids, sizes, missing parents, non-finite samples) or cancelled.
/// Deterministic: the same input gives the same bytes for any thread count. Not for per-frame
/// use (allocates, runs threads). Defined in the implementation TU (BTFLOD_IMPLEMENTATION).
Result<std::vector<uint8_t>> build_bsvtf(BsvtfMetadata metadata, std::span<const float> u,
                                         std::span<const BsvtfTileInput> tiles, const BsvtfBuildOptions& options = {});

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
// build_bsvtf encodes the tiles of a level on a ThreadPool: <thread>, <future> and <mutex> are
// included here only, so that reading containers stays cheap to include.
#include <mutex>
#include <unordered_map>

#include "btflod/core/thread_pool.hpp"

namespace btflod {

// The container writer and reader (declared above): compiled once, here.
namespace detail {
void bsvtf_write_string(ByteWriter& w, const std::string& s) {
  w.u32(static_cast<uint32_t>(s.size()));
  w.text(s);
}

VoidResult bsvtf_check_metadata(const BsvtfMetadata& m) {
  if (!m.layout().valid())
    return make_error(Status::invalid_argument,
                      "bsvtf metadata: tile size %u with border %u is not a valid tile layout", m.tile_size, m.border);
  if (m.level_count < 1 || m.level_count > kMaxTileLevel + 1)
    return make_error(Status::invalid_argument, "bsvtf metadata: level count %u not in 1..%u", m.level_count,
                      kMaxTileLevel + 1);
  const uint64_t side = uint64_t{m.tile_size} << (m.level_count - 1);
  if (m.width < 1 || m.height < 1 || m.width > side || m.height > side)
    return make_error(Status::invalid_argument,
                      "bsvtf metadata: texture %ux%u does not fit %u levels of %u-texel tiles (max %llu)", m.width,
                      m.height, m.level_count, m.tile_size, static_cast<unsigned long long>(side));
  if (m.component_count < 1 || m.component_count > kBsvtfMaxComponents)
    return make_error(Status::invalid_argument, "bsvtf metadata: component count %u not in 1..%u", m.component_count,
                      kBsvtfMaxComponents);
  if (m.color_channels < 1 || m.color_channels > 4)
    return make_error(Status::invalid_argument, "bsvtf metadata: colour channel count %u not in 1..4",
                      m.color_channels);
  if (static_cast<uint32_t>(m.color_mode) > 2)
    return make_error(Status::invalid_argument, "bsvtf metadata: colour mode %u unknown",
                      static_cast<uint32_t>(m.color_mode));
  if (m.u_rows > (1u << 28))
    return make_error(Status::invalid_argument, "bsvtf metadata: %u rows of U exceed 2^28", m.u_rows);
  if (static_cast<uint32_t>(m.u_row_order) > 2)
    return make_error(Status::invalid_argument, "bsvtf metadata: row order %u unknown",
                      static_cast<uint32_t>(m.u_row_order));
  if (m.light_directions.size() % 3 || m.view_directions.size() % 3)
    return make_error(Status::invalid_argument, "bsvtf metadata: direction arrays must hold xyz triples");
  if (m.component_ranges.size() != m.component_count || m.component_scales.size() != m.component_count)
    return make_error(Status::invalid_argument, "bsvtf metadata: %zu ranges and %zu scales for %u components",
                      m.component_ranges.size(), m.component_scales.size(), m.component_count);
  if (m.material_name.size() > kBsvtfMaxStringBytes || m.light_set.size() > kBsvtfMaxStringBytes ||
      m.view_set.size() > kBsvtfMaxStringBytes)
    return make_error(Status::invalid_argument, "bsvtf metadata: a name is longer than %u bytes", kBsvtfMaxStringBytes);
  return {};
}

std::vector<uint8_t> bsvtf_serialise_metadata(const BsvtfMetadata& m, uint32_t version) {
  ByteWriter w;
  for (uint32_t v :
       {m.width, m.height, m.tile_size, m.border, m.level_count, m.component_count, m.color_channels,
        static_cast<uint32_t>(m.color_mode), m.u_rows, static_cast<uint32_t>(m.light_directions.size() / 3),
        static_cast<uint32_t>(m.view_directions.size() / 3)})
    w.u32(v);
  w.f32(m.quality);
  if (version >= 3) w.u32(static_cast<uint32_t>(m.u_row_order));
  if (version >= 4) {
    w.u32(static_cast<uint32_t>(m.value_transform.encoding));
    w.f32(m.value_transform.log_offset);
  }
  bsvtf_write_string(w, m.material_name);
  bsvtf_write_string(w, m.light_set);
  bsvtf_write_string(w, m.view_set);
  for (float f : m.light_directions) w.f32(f);
  for (float f : m.view_directions) w.f32(f);
  for (float f : m.component_ranges) w.f32(f);
  for (float f : m.component_scales) w.f32(f);
  return w.take();
}

bool bsvtf_read_string(ByteReader& r, std::string& out) {
  const uint32_t n = r.u32();
  if (!r.ok() || n > kBsvtfMaxStringBytes || n > r.remaining()) return false;
  out = r.fixed_string(n);
  return r.ok();
}

/// Calls f(field) for the header fields after the version and header size, in file order
/// (u64 or u32 each): the one field list the writer and the reader share. `H` is BsvtfHeader or
/// const BsvtfHeader.
template <class H, class F>
void bsvtf_for_each_header_field(H& h, F&& f) {
  f(h.file_size);
  f(h.directory_size);
  f(h.metadata_offset);
  f(h.metadata_size);
  f(h.metadata_crc);
  f(h.packet_table_offset);
  f(h.packet_count);
  f(h.packet_table_crc);
  f(h.tile_index_offset);
  f(h.tile_count);
  f(h.tile_index_crc);
  f(h.payload_offset);
  f(h.payload_size);
}

}  // namespace detail

Result<std::vector<uint8_t>> write_bsvtf(const BsvtfMetadata& metadata, std::span<const float> u,
                                         std::span<const BsvtfEncodedTile> tiles, uint32_t version) {
  if (auto ok = detail::bsvtf_check_metadata(metadata); !ok) return ok.error();
  if (version < kBsvtfOldestReadableVersion || version > kBsvtfVersion)
    return make_error(Status::invalid_argument, "write_bsvtf: cannot write version %u", version);
  if (!metadata.value_transform.valid())
    return make_error(Status::invalid_argument, "write_bsvtf: invalid value transform");
  if (!metadata.value_transform.is_linear() && version < 4)
    return make_error(Status::invalid_argument,
                      "write_bsvtf: version %u cannot store the %s value encoding (version 4 can)", version,
                      value_encoding_name(metadata.value_transform.encoding));
  const uint32_t textures = metadata.texture_count();
  if (u.size() != size_t{metadata.u_rows} * metadata.component_count)
    return make_error(Status::invalid_argument, "write_bsvtf: U has %zu floats, expected %u rows x %u components",
                      u.size(), metadata.u_rows, metadata.component_count);
  // Sort tile references by key; check ids, duplicates and parents.
  std::vector<const BsvtfEncodedTile*> by_key;
  by_key.reserve(tiles.size());
  for (const auto& t : tiles) {
    if (!t.id.valid() || t.id.texture >= textures || t.id.level >= metadata.level_count)
      return make_error(Status::invalid_argument, "write_bsvtf: tile (%u, level %u, %u, %u) outside the material",
                        t.id.texture, t.id.level, t.id.x, t.id.y);
    if (t.payload.empty() || t.payload.size() > UINT32_MAX)
      return make_error(Status::invalid_argument, "write_bsvtf: tile (%u, level %u, %u, %u) has a payload of %zu bytes",
                        t.id.texture, t.id.level, t.id.x, t.id.y, t.payload.size());
    if (!std::isfinite(t.weight) || t.weight < 0 || !std::isfinite(t.energy) || t.energy < 0)
      return make_error(Status::invalid_argument, "write_bsvtf: tile weight and energy must be finite and >= 0");
    if (metadata.u_row_order == AngularRowOrder::unspecified && version >= 3)
      return make_error(Status::invalid_argument,
                        "write_bsvtf: metadata.u_row_order must say how U's rows are ordered");
    by_key.push_back(&t);
  }
  std::sort(by_key.begin(), by_key.end(), [](auto* a, auto* b) { return a->id.key() < b->id.key(); });
  for (size_t i = 1; i < by_key.size(); ++i)
    if (by_key[i]->id.key() == by_key[i - 1]->id.key())
      return make_error(Status::invalid_argument, "write_bsvtf: tile (%u, level %u, %u, %u) appears twice",
                        by_key[i]->id.texture, by_key[i]->id.level, by_key[i]->id.x, by_key[i]->id.y);
  std::vector<uint64_t> keys;
  keys.reserve(by_key.size());
  for (const auto* t : by_key) keys.push_back(t->id.key());
  auto has = [&](const TileId& id) { return std::binary_search(keys.begin(), keys.end(), id.key()); };
  for (const auto* t : by_key)
    if (t->id.level > 0 && !has(t->id.parent()))
      return make_error(Status::invalid_argument, "write_bsvtf: tile (%u, level %u, %u, %u) has no parent",
                        t->id.texture, t->id.level, t->id.x, t->id.y);

  const std::vector<uint8_t> meta = detail::bsvtf_serialise_metadata(metadata, version);
  BsvtfHeader h;
  h.version = version;
  h.metadata_offset = kBsvtfHeaderSize;
  h.metadata_size = static_cast<uint32_t>(meta.size());
  h.metadata_crc = crc32_of(meta);
  h.packet_table_offset = h.metadata_offset + h.metadata_size;
  h.packet_count = textures;
  h.tile_index_offset = h.packet_table_offset + uint64_t{textures} * kBsvtfPacketEntrySize;
  h.tile_count = static_cast<uint32_t>(by_key.size());
  h.directory_size = h.tile_index_offset + uint64_t{h.tile_count} * kBsvtfTileEntrySize;
  h.payload_offset = h.directory_size;

  // U packets as halves: packet g row r = components 4g..4g+3 of row r.
  std::vector<std::vector<uint8_t>> packets(textures);
  for (uint32_t g = 0; g < textures; ++g) {
    std::vector<uint16_t> halves(size_t{metadata.u_rows} * 4, 0);
    for (uint32_t r = 0; r < metadata.u_rows; ++r)
      for (uint32_t k = 0; k < 4; ++k) {
        const uint32_t c = 4 * g + k;
        if (c < metadata.component_count)
          halves[size_t{r} * 4 + k] = float_to_half_bits(u[size_t{r} * metadata.component_count + c]);
      }
    packets[g].resize(halves.size() * 2);
    if (!halves.empty()) std::memcpy(packets[g].data(), halves.data(), packets[g].size());
  }

  // Payload order: for each texture its U packet then its root tile; then levels 1, 2, … in key order.
  std::vector<BsvtfPacketEntry> packet_entries(textures);
  std::vector<BsvtfTileEntry> tile_entries(by_key.size());
  std::vector<const uint8_t*> order_data;
  std::vector<size_t> order_size;
  uint64_t cursor = h.payload_offset;
  auto place_tile = [&](size_t i) {
    const auto* t = by_key[i];
    tile_entries[i] = BsvtfTileEntry{
        t->id, cursor, static_cast<uint32_t>(t->payload.size()), crc32_of(t->payload), t->weight, t->energy};
    order_data.push_back(t->payload.data());
    order_size.push_back(t->payload.size());
    cursor += t->payload.size();
  };
  for (uint32_t g = 0; g < textures; ++g) {
    packet_entries[g] = BsvtfPacketEntry{g, cursor, static_cast<uint32_t>(packets[g].size()), crc32_of(packets[g])};
    order_data.push_back(packets[g].data());
    order_size.push_back(packets[g].size());
    cursor += packets[g].size();
    for (size_t i = 0; i < by_key.size(); ++i)
      if (by_key[i]->id.texture == g && by_key[i]->id.level == 0) place_tile(i);
  }
  for (uint32_t level = 1; level < metadata.level_count; ++level)
    for (size_t i = 0; i < by_key.size(); ++i)
      if (by_key[i]->id.level == level) place_tile(i);
  h.payload_size = cursor - h.payload_offset;
  h.file_size = cursor;

  ByteWriter table;
  for (const auto& p : packet_entries) {
    table.u32(p.index);
    table.u32(0);
    table.u64(p.offset);
    table.u32(p.size);
    table.u32(p.crc);
  }
  const std::vector<uint8_t> packet_table = table.take();
  ByteWriter index;
  for (const auto& t : tile_entries) {
    index.u64(t.id.key());
    index.u64(t.offset);
    index.u32(t.size);
    index.u32(t.crc);
    index.f32(t.weight);
    if (version >= 3)
      index.f32(t.energy);
    else
      index.u32(0);  // reserved in version 2
  }
  const std::vector<uint8_t> tile_index = index.take();
  h.packet_table_crc = crc32_of(packet_table);
  h.tile_index_crc = crc32_of(tile_index);

  ByteWriter w;
  w.raw(kBsvtfMagic, 8);
  w.u32(h.version);
  w.u32(static_cast<uint32_t>(kBsvtfHeaderSize));
  detail::bsvtf_for_each_header_field(h, [&w](auto v) {
    if constexpr (sizeof v == 8)
      w.u64(v);
    else
      w.u32(v);
  });
  while (w.size() < kBsvtfHeaderSize - 4) w.u8(0);
  w.u32(crc32_of(std::span<const uint8_t>(w.bytes().data(), kBsvtfHeaderSize - 4)));
  w.bytes().reserve(h.file_size);
  w.raw(meta);
  w.raw(packet_table);
  w.raw(tile_index);
  for (size_t i = 0; i < order_data.size(); ++i) w.raw(order_data[i], order_size[i]);
  return w.take();
}

Result<BsvtfHeader> parse_bsvtf_header(std::span<const uint8_t> bytes, uint64_t file_size) {
  if (bytes.size() < kBsvtfHeaderSize)
    return make_error(Status::short_output, "bsvtf header: %zu bytes, expected at least %zu", bytes.size(),
                      kBsvtfHeaderSize);
  ByteReader r(bytes.first(kBsvtfHeaderSize));
  if (!r.match(std::string_view(reinterpret_cast<const char*>(kBsvtfMagic), 8)))
    return make_error(Status::bad_data, "bsvtf header: signature is not BSVTF\\r\\n\\x1a");
  const uint32_t stored_crc = [&] {
    uint32_t c = 0;
    std::memcpy(&c, bytes.data() + kBsvtfHeaderSize - 4, 4);
    return c;
  }();
  const uint32_t crc = crc32_of(bytes.first(kBsvtfHeaderSize - 4));
  BsvtfHeader h;
  h.version = r.u32();
  if (h.version < kBsvtfOldestReadableVersion || h.version > kBsvtfVersion)
    return make_error(
        Status::unsupported, "bsvtf header: version %u, this reader handles versions %u to %u%s", h.version,
        kBsvtfOldestReadableVersion, kBsvtfVersion,
        h.version > kBsvtfVersion ? " (a newer writer made this file: update btflod)" : " (rebuild the file)");
  if (crc != stored_crc)
    return make_error(Status::bad_data, "bsvtf header: checksum %08x, stored %08x", crc, stored_crc);
  const uint32_t header_size = r.u32();
  if (header_size != kBsvtfHeaderSize)
    return make_error(Status::bad_data, "bsvtf header: header size %u, expected %zu", header_size, kBsvtfHeaderSize);
  detail::bsvtf_for_each_header_field(h, [&r](auto& v) {
    if constexpr (sizeof v == 8)
      v = r.u64();
    else
      v = r.u32();
  });
  const auto reserved = r.take(kBsvtfHeaderSize - 4 - 96);
  if (std::any_of(reserved.begin(), reserved.end(), [](uint8_t b) { return b != 0; }))
    return make_error(Status::bad_data, "bsvtf header: reserved bytes 96..123 are not zero");
  if (h.file_size != file_size) {
    return make_error(file_size < h.file_size ? Status::short_output : Status::bad_data,
                      "bsvtf header: file has %llu bytes, header declares %llu%s",
                      static_cast<unsigned long long>(file_size), static_cast<unsigned long long>(h.file_size),
                      file_size > h.file_size ? " (trailing bytes)" : " (truncated)");
  }
  // The sections follow each other exactly: header, metadata, packet table, tile index, payloads.
  const uint64_t packet_table_size = uint64_t{h.packet_count} * kBsvtfPacketEntrySize;
  const uint64_t tile_index_size = uint64_t{h.tile_count} * kBsvtfTileEntrySize;
  if (h.metadata_offset != kBsvtfHeaderSize || h.packet_table_offset != h.metadata_offset + h.metadata_size ||
      h.tile_index_offset != h.packet_table_offset + packet_table_size ||
      h.directory_size != h.tile_index_offset + tile_index_size || h.payload_offset != h.directory_size)
    return make_error(
        Status::bad_data,
        "bsvtf header: section table is not contiguous (metadata %llu+%u, packets %llu, index %llu, directory %llu)",
        static_cast<unsigned long long>(h.metadata_offset), h.metadata_size,
        static_cast<unsigned long long>(h.packet_table_offset), static_cast<unsigned long long>(h.tile_index_offset),
        static_cast<unsigned long long>(h.directory_size));
  if (h.directory_size > file_size || h.payload_size != file_size - h.payload_offset)
    return make_error(
        Status::bad_data,
        "bsvtf header: directory of %llu bytes and payload of %llu bytes do not add up to the file size %llu",
        static_cast<unsigned long long>(h.directory_size), static_cast<unsigned long long>(h.payload_size),
        static_cast<unsigned long long>(file_size));
  return h;
}

Result<BsvtfDirectory> parse_bsvtf_directory(std::span<const uint8_t> prefix, uint64_t file_size) {
  auto header = parse_bsvtf_header(prefix, file_size);
  if (!header) return header.error();
  BsvtfDirectory d;
  d.header = header.value();
  const BsvtfHeader& h = d.header;
  if (prefix.size() < h.directory_size)
    return make_error(Status::short_output, "bsvtf directory: %zu bytes given, the directory needs %llu", prefix.size(),
                      static_cast<unsigned long long>(h.directory_size));

  // Metadata.
  const auto meta_bytes = prefix.subspan(h.metadata_offset, h.metadata_size);
  if (const uint32_t c = crc32_of(meta_bytes); c != h.metadata_crc)
    return make_error(Status::bad_data, "bsvtf metadata: checksum %08x, stored %08x", c, h.metadata_crc);
  ByteReader r(meta_bytes);
  BsvtfMetadata& m = d.metadata;
  for (uint32_t* v :
       {&m.width, &m.height, &m.tile_size, &m.border, &m.level_count, &m.component_count, &m.color_channels})
    *v = r.u32();
  m.color_mode = static_cast<ColorMode>(r.u32());
  m.u_rows = r.u32();
  const uint32_t light_count = r.u32();
  const uint32_t view_count = r.u32();
  m.quality = r.f32();
  m.u_row_order = AngularRowOrder::unspecified;
  if (h.version >= 3) {
    const uint32_t order = r.u32();
    if (r.ok() && order > 1)
      return make_error(Status::bad_data, "bsvtf metadata: row order %u is neither light-major (0) nor view-major (1)",
                        order);
    m.u_row_order = static_cast<AngularRowOrder>(order);
  }
  m.value_transform = ValueTransform{};
  if (h.version >= 4) {
    m.value_transform.encoding = static_cast<ValueEncoding>(r.u32());
    m.value_transform.log_offset = r.f32();
    if (r.ok() && !m.value_transform.valid())
      return make_error(Status::bad_data, "bsvtf metadata: value encoding %u (log offset %g) is not valid",
                        static_cast<unsigned>(m.value_transform.encoding),
                        static_cast<double>(m.value_transform.log_offset));
  }
  if (!r.ok())
    return make_error(Status::bad_data, "bsvtf metadata: %u bytes, too short for the fixed fields", h.metadata_size);
  if (!detail::bsvtf_read_string(r, m.material_name) || !detail::bsvtf_read_string(r, m.light_set) ||
      !detail::bsvtf_read_string(r, m.view_set))
    return make_error(Status::bad_data, "bsvtf metadata: a name is truncated or longer than %u bytes",
                      kBsvtfMaxStringBytes);
  auto read_floats = [&](std::vector<float>& out, uint64_t count, const char* what) -> VoidResult {
    if (!r.can_hold(count, 4))
      return make_error(Status::bad_data, "bsvtf metadata: %llu %s need %llu bytes, %zu remain",
                        static_cast<unsigned long long>(count), what, static_cast<unsigned long long>(count * 4),
                        r.remaining());
    out.resize(static_cast<size_t>(count));
    r.copy_to(out.data(), out.size() * 4);
    for (float f : out)
      if (!std::isfinite(f)) return make_error(Status::bad_data, "bsvtf metadata: %s contain a non-finite value", what);
    return {};
  };
  if (auto ok = read_floats(m.light_directions, uint64_t{light_count} * 3, "light direction floats"); !ok)
    return ok.error();
  if (auto ok = read_floats(m.view_directions, uint64_t{view_count} * 3, "view direction floats"); !ok)
    return ok.error();
  if (auto ok = read_floats(m.component_ranges, m.component_count, "component ranges"); !ok) return ok.error();
  if (auto ok = read_floats(m.component_scales, m.component_count, "component scales"); !ok) return ok.error();
  if (r.remaining() != 0) return make_error(Status::bad_data, "bsvtf metadata: %zu trailing bytes", r.remaining());
  if (auto ok = detail::bsvtf_check_metadata(m); !ok) return make_error(Status::bad_data, "%s", ok.message().c_str());
  if (!std::isfinite(m.quality)) return make_error(Status::bad_data, "bsvtf metadata: quality is not finite");

  const uint64_t payload_begin = h.payload_offset;
  const uint64_t payload_end = h.payload_offset + h.payload_size;  // == file_size, checked by the header parser
  auto in_payload = [&](uint64_t offset, uint32_t size) {
    return offset >= payload_begin && offset <= payload_end && size <= payload_end - offset;
  };

  // U packets.
  if (h.packet_count != m.texture_count())
    return make_error(Status::bad_data, "bsvtf packet table: %u packets, expected %u for %u components", h.packet_count,
                      m.texture_count(), m.component_count);
  const auto packet_bytes = prefix.subspan(h.packet_table_offset, size_t{h.packet_count} * kBsvtfPacketEntrySize);
  if (const uint32_t c = crc32_of(packet_bytes); c != h.packet_table_crc)
    return make_error(Status::bad_data, "bsvtf packet table: checksum %08x, stored %08x", c, h.packet_table_crc);
  ByteReader pr(packet_bytes);
  const uint64_t packet_size = uint64_t{m.u_rows} * 4 * 2;
  d.packets.resize(h.packet_count);
  for (uint32_t i = 0; i < h.packet_count; ++i) {
    BsvtfPacketEntry& p = d.packets[i];
    p.index = pr.u32();
    pr.u32();
    p.offset = pr.u64();
    p.size = pr.u32();
    p.crc = pr.u32();
    if (p.index != i || p.size != packet_size || !in_payload(p.offset, p.size))
      return make_error(
          Status::bad_data, "bsvtf packet %u: index %u, %u bytes at %llu; expected %llu bytes inside [%llu, %llu)", i,
          p.index, p.size, static_cast<unsigned long long>(p.offset), static_cast<unsigned long long>(packet_size),
          static_cast<unsigned long long>(payload_begin), static_cast<unsigned long long>(payload_end));
  }

  // Tile index.
  const auto index_bytes = prefix.subspan(h.tile_index_offset, size_t{h.tile_count} * kBsvtfTileEntrySize);
  if (const uint32_t c = crc32_of(index_bytes); c != h.tile_index_crc)
    return make_error(Status::bad_data, "bsvtf tile index: checksum %08x, stored %08x", c, h.tile_index_crc);
  const TileLayout layout = m.layout();
  const uint64_t max_tile = tile_encode_bound(layout);
  const uint64_t min_tile = tile_header_size(layout.channels) + 1;
  ByteReader ir(index_bytes);
  d.tiles.resize(h.tile_count);
  for (uint32_t i = 0; i < h.tile_count; ++i) {
    BsvtfTileEntry& t = d.tiles[i];
    const uint64_t key = ir.u64();
    t.id = TileId::from_key(key);
    t.offset = ir.u64();
    t.size = ir.u32();
    t.crc = ir.u32();
    t.weight = ir.f32();
    t.energy = h.version >= 3 ? ir.f32() : (ir.u32(), 0.0f);
    if (t.id.key() != key || !t.id.valid() || t.id.texture >= m.texture_count() || t.id.level >= m.level_count)
      return make_error(Status::bad_data, "bsvtf tile entry %u: key %016llx is not a tile of this material", i,
                        static_cast<unsigned long long>(key));
    if (i > 0 && key <= d.tiles[i - 1].id.key())
      return make_error(Status::bad_data, "bsvtf tile entry %u: keys not strictly ascending", i);
    if (t.size < min_tile || t.size > max_tile || !in_payload(t.offset, t.size))
      return make_error(Status::bad_data,
                        "bsvtf tile entry %u: %u bytes at %llu; expected %llu..%llu bytes inside [%llu, %llu)", i,
                        t.size, static_cast<unsigned long long>(t.offset), static_cast<unsigned long long>(min_tile),
                        static_cast<unsigned long long>(max_tile), static_cast<unsigned long long>(payload_begin),
                        static_cast<unsigned long long>(payload_end));
    if (!std::isfinite(t.weight) || t.weight < 0 || !std::isfinite(t.energy) || t.energy < 0)
      return make_error(Status::bad_data, "bsvtf tile entry %u: weight or energy not finite and >= 0", i);
  }
  for (uint32_t i = 0; i < h.tile_count; ++i)
    if (d.tiles[i].id.level > 0 && d.find(d.tiles[i].id.parent()) == nullptr)
      return make_error(Status::bad_data, "bsvtf tile entry %u: parent tile missing", i);

  // No two payloads overlap.
  std::vector<std::pair<uint64_t, uint64_t>> spans;
  spans.reserve(d.tiles.size() + d.packets.size());
  for (const auto& p : d.packets) spans.emplace_back(p.offset, p.size);
  for (const auto& t : d.tiles) spans.emplace_back(t.offset, t.size);
  std::sort(spans.begin(), spans.end());
  for (size_t i = 1; i < spans.size(); ++i)
    if (spans[i - 1].first + spans[i - 1].second > spans[i].first)
      return make_error(Status::bad_data, "bsvtf: payloads at %llu and %llu overlap",
                        static_cast<unsigned long long>(spans[i - 1].first),
                        static_cast<unsigned long long>(spans[i].first));
  return d;
}

std::vector<float> bsvtf_component_ranges(std::span<const BsvtfTileInput> tiles, uint32_t component_count) {
  std::vector<float> lo(component_count, INFINITY), hi(component_count, -INFINITY);
  for (const auto& t : tiles)
    for (uint32_t k = 0; k < 4; ++k) {
      const uint64_t c = uint64_t{t.id.texture} * 4 + k;
      if (c >= component_count) continue;
      for (size_t i = k; i < t.samples.size(); i += 4) {
        lo[c] = std::min(lo[c], t.samples[i]);
        hi[c] = std::max(hi[c], t.samples[i]);
      }
    }
  std::vector<float> ranges(component_count);
  for (uint32_t c = 0; c < component_count; ++c) ranges[c] = hi[c] >= lo[c] ? hi[c] - lo[c] : 0.0f;
  return ranges;
}

Result<std::vector<uint8_t>> build_bsvtf(BsvtfMetadata metadata, std::span<const float> u,
                                         std::span<const BsvtfTileInput> tiles, const BsvtfBuildOptions& options) {
  metadata.quality = options.quality;
  if (options.weight_quarters > kJpegWeightQuarters)
    return make_error(Status::invalid_argument, "build_bsvtf: weight_quarters %u not in 0..4", options.weight_quarters);
  if (!(options.ac_rounding_threshold >= 0.5f && options.ac_rounding_threshold < 1.0f))
    return make_error(Status::invalid_argument, "build_bsvtf: ac_rounding_threshold %g not in [0.5, 1)",
                      static_cast<double>(options.ac_rounding_threshold));
  const TileLayout layout = metadata.layout();
  if (!layout.valid()) return make_error(Status::invalid_argument, "build_bsvtf: invalid tile layout");
  for (const auto& t : tiles)
    if (!(t.tolerance_scale > 0.0f) || !(t.tolerance_scale < 1e6f) || !(t.tolerance_min_scale >= 0.0f) ||
        !(t.tolerance_min_scale < 1e6f) ||
        std::any_of(t.channel_scale.begin(), t.channel_scale.end(), [](float x) { return !(x > 0.0f) || !(x < 1e6f); }))
      return make_error(Status::invalid_argument,
                        "build_bsvtf: tile (%u, level %u, %u, %u) tolerance scale %g not in (0, 1e6)", t.id.texture,
                        t.id.level, t.id.x, t.id.y, static_cast<double>(t.tolerance_scale));
  for (const auto& t : tiles)
    if (t.samples.size() != layout.sample_count())
      return make_error(Status::invalid_argument,
                        "build_bsvtf: tile (%u, level %u, %u, %u) has %zu samples, expected %zu", t.id.texture,
                        t.id.level, t.id.x, t.id.y, t.samples.size(), layout.sample_count());
  if (metadata.component_ranges.empty())
    metadata.component_ranges = bsvtf_component_ranges(tiles, metadata.component_count);
  if (metadata.component_scales.empty()) metadata.component_scales.assign(metadata.component_count, 1.0f);
  float max_range = 0.0f;
  for (float r : metadata.component_ranges) max_range = std::max(max_range, std::isfinite(r) ? r : 0.0f);
  if (auto ok = detail::bsvtf_check_metadata(metadata); !ok) return ok.error();

  // Coarse to fine: indices of tiles per level.
  std::vector<std::vector<size_t>> by_level(metadata.level_count);
  for (size_t i = 0; i < tiles.size(); ++i) {
    const auto& id = tiles[i].id;
    if (!id.valid() || id.level >= metadata.level_count || id.texture >= metadata.texture_count())
      return make_error(Status::invalid_argument, "build_bsvtf: tile (%u, level %u, %u, %u) outside the material",
                        id.texture, id.level, id.x, id.y);
    by_level[id.level].push_back(i);
  }
  if (!tile_entropy_coder_available(options.entropy_coder))
    return make_error(Status::invalid_argument, "build_bsvtf: zstd tiles need a build with zstd (BTFLOD_WITH_ZSTD)");
  ThreadPool& pool = options.pool ? *options.pool : default_thread_pool();
  std::vector<BsvtfEncodedTile> encoded(tiles.size());
  std::unordered_map<uint64_t, std::vector<float>> parents, current;
  std::mutex mutex;
  std::string failure;
  Status failure_status = Status::success;
  size_t done = 0;
  bool cancelled = false;
  for (uint32_t level = 0; level < metadata.level_count; ++level) {
    const auto& list = by_level[level];
    current.clear();
    // Pre-create one slot per tile, so workers only write values, each its own slot. A tile
    // given twice would have two workers writing one slot at once: refused here.
    for (size_t i : list)
      if (!current.try_emplace(tiles[i].id.key()).second)
        return make_error(Status::invalid_argument, "build_bsvtf: tile (%u, level %u, %u, %u) given twice",
                          tiles[i].id.texture, tiles[i].id.level, tiles[i].id.x, tiles[i].id.y);
    pool.parallel_for(0, list.size(), 4, [&](size_t begin, size_t end) {
      TileEncoder encoder(layout, options.deflate_level);
      encoder.set_weight_quarters(options.weight_quarters);
      encoder.set_ac_rounding_threshold(options.ac_rounding_threshold);
      if (!encoder.set_entropy_coder(options.entropy_coder, options.zstd_level)) {
        std::lock_guard lock(mutex);
        failure_status = Status::insufficient_space;
        failure = "build_bsvtf: the zstd compression context could not be allocated";
        return;
      }
      std::vector<uint8_t> buffer(encoder.bound());
      for (size_t j = begin; j < end; ++j) {
        const BsvtfTileInput& t = tiles[list[j]];
        std::span<const float> parent;
        if (level > 0) {
          auto it = parents.find(t.id.parent().key());
          if (it == parents.end()) {
            std::lock_guard lock(mutex);
            failure_status = Status::invalid_argument;
            failure = format_message("build_bsvtf: tile (%u, level %u, %u, %u) has no parent", t.id.texture, t.id.level,
                                     t.id.x, t.id.y);
            return;
          }
          parent = it->second;
        }
        float tolerance[4];
        for (uint32_t k = 0; k < 4; ++k) {
          const uint64_t c = uint64_t{t.id.texture} * 4 + k;
          const float range = c >= metadata.component_count ? 0.0f
                              : options.tolerance_reference == ToleranceReference::shared_max
                                  ? max_range
                                  : metadata.component_ranges[c];
          tolerance[k] = tolerance_for_quality(options.quality, range);
          tolerance[k] *= t.tolerance_scale * t.channel_scale[k];  // × 1 is exact: default inputs keep their bytes
          if (t.tolerance_min_scale > 0.0f)
            tolerance[k] =
                std::max(tolerance[k], tolerance_for_quality(options.quality, max_range) * t.tolerance_min_scale);
        }
        std::vector<float>& recon = current.find(t.id.key())->second;
        recon.resize(layout.sample_count());
        size_t written = 0;
        const Status s = encoder.encode(t.samples, parent, t.id.x & 1u, t.id.y & 1u, tolerance, buffer, written, recon);
        std::lock_guard lock(mutex);
        if (s != Status::success) {
          failure_status = s;
          failure = format_message("build_bsvtf: tile (%u, level %u, %u, %u): %s", t.id.texture, t.id.level, t.id.x,
                                   t.id.y, encoder.message());
          return;
        }
        encoded[list[j]] =
            BsvtfEncodedTile{t.id, std::vector<uint8_t>(buffer.begin(), buffer.begin() + written), t.weight, t.energy};
        ++done;
        if (!cancelled && !report_progress(options.progress, "encode tiles", static_cast<double>(done) / tiles.size()))
          cancelled = true;
      }
    });
    if (failure_status != Status::success) return Error{failure_status, failure};
    if (cancelled)
      return make_error(Status::cancelled, "build_bsvtf: cancelled after %zu of %zu tiles", done, tiles.size());
    parents.swap(current);
  }
  return write_bsvtf(metadata, u, encoded);
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
