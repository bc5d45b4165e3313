// btflod-label: unit threads
// Tests for runtime/codec/container.hpp: build → read round trip (metadata, U packets, weights, tiles
// decoded down the hierarchy within the tolerance), the contiguous coarse-to-fine prefix,
// determinism across thread counts, and failure classes (truncated, trailing bytes, wrong
// checksum, wrong signature/version, oversized counts, offsets outside the file, overlaps).
// With BTFLOD_WRITE_CONTAINER_SEEDS=<dir> it also writes the fuzz seeds of
// fuzz/corpus/fuzz_container_reader into <dir>.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

#include "btflod/core/thread_pool.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "test_fuzz_seeds.hpp"

namespace {

using namespace btflod;

struct Material {
  BsvtfMetadata metadata;
  std::vector<float> u;
  std::vector<std::vector<float>> samples;
  std::vector<BsvtfTileInput> tiles;
};

float value(uint32_t comp, double u, double v) {
  return static_cast<float>((1.0 + comp) *
                            (std::sin(7.0 * u + comp) * std::cos(5.0 * v) + 0.2 * std::sin(37.0 * u * v + comp)));
}

// A small synthetic material: T = 16, B = 4 (24² stored), 3 levels, 6 components (2 textures).
Material make_material(uint32_t levels = 3, uint32_t components = 6) {
  Material m;
  auto& md = m.metadata;
  md.material_name = "synthetic";
  md.tile_size = 16;
  md.border = 4;
  md.level_count = levels;
  md.width = md.height = 16u << (levels - 1);
  md.component_count = components;
  md.u_rows = 10;
  md.light_set = "L";
  md.view_set = "V";
  md.light_directions = {0, 0, 1, 0.6f, 0, 0.8f};
  md.view_directions = {0, 0, 1};
  for (uint32_t r = 0; r < md.u_rows; ++r)
    for (uint32_t c = 0; c < components; ++c) m.u.push_back(0.01f * static_cast<float>(r * components + c) - 0.3f);
  const TileLayout layout = md.layout();
  const uint32_t s = layout.stored_size();
  for (uint32_t g = 0; g < md.texture_count(); ++g)
    for (uint32_t l = 0; l < levels; ++l)
      for (uint32_t y = 0; y < (1u << l); ++y)
        for (uint32_t x = 0; x < (1u << l); ++x) {
          std::vector<float> t(layout.sample_count(), 0.0f);
          const double w = 16.0 * (1u << l);
          for (uint32_t j = 0; j < s; ++j)
            for (uint32_t i = 0; i < s; ++i) {
              const double px = std::clamp(x * 16.0 - 4 + i, 0.0, w - 1), py = std::clamp(y * 16.0 - 4 + j, 0.0, w - 1);
              for (uint32_t k = 0; k < 4; ++k)
                if (4 * g + k < components) t[(j * s + i) * 4 + k] = value(4 * g + k, (px + 0.5) / w, (py + 0.5) / w);
            }
          m.samples.push_back(std::move(t));
          m.tiles.push_back({TileId{g, l, x, y}, {}, 0.5f / (1.0f + l + x)});
        }
  for (size_t i = 0; i < m.tiles.size(); ++i) m.tiles[i].samples = m.samples[i];
  return m;
}

std::vector<uint8_t> build(const Material& m, float quality = 50, ThreadPool* pool = nullptr) {
  BsvtfBuildOptions o;
  o.quality = quality;
  o.pool = pool;
  auto r = build_bsvtf(m.metadata, m.u, m.tiles, o);
  EXPECT_TRUE(r.ok()) << r.message();
  return r.ok() ? r.value() : std::vector<uint8_t>{};
}

// The coded tiles of a container as write_bsvtf takes them (payload bytes, weight, energy).
std::vector<BsvtfEncodedTile> encoded_tiles_of(const std::vector<uint8_t>& file, const BsvtfDirectory& d) {
  std::vector<BsvtfEncodedTile> tiles;
  for (const auto& e : d.tiles)
    tiles.push_back(BsvtfEncodedTile{e.id,
                                     std::vector<uint8_t>(file.begin() + static_cast<ptrdiff_t>(e.offset),
                                                          file.begin() + static_cast<ptrdiff_t>(e.offset + e.size)),
                                     e.weight, e.energy});
  return tiles;
}

void fix_header_crc(std::vector<uint8_t>& f) {
  const uint32_t c = crc32_of(std::span<const uint8_t>(f).first(kBsvtfHeaderSize - 4));
  std::memcpy(f.data() + kBsvtfHeaderSize - 4, &c, 4);
}
template <class T>
void patch(std::vector<uint8_t>& f, size_t at, T v) {
  std::memcpy(f.data() + at, &v, sizeof v);
}
// Header field offsets (docs/bsvtf_format.md).
constexpr size_t kOffMetaSize = 40, kOffMetaCrc = 44, kOffPacketCount = 56, kOffTileCount = 72, kOffIndexCrc = 76,
                 kOffIndex = 64;

TEST(CodecContainer, RoundTripMetadataPacketsWeightsAndTiles) {
  const Material m = make_material();
  const auto file = build(m);
  auto dir = read_bsvtf(file);
  ASSERT_TRUE(dir.ok()) << dir.message();
  const auto& md = dir->metadata;
  EXPECT_EQ(md.material_name, "synthetic");
  EXPECT_EQ(md.width, 64u);
  EXPECT_EQ(md.level_count, 3u);
  EXPECT_EQ(md.component_count, 6u);
  EXPECT_EQ(md.light_directions, m.metadata.light_directions);
  EXPECT_EQ(md.light_set, "L");
  EXPECT_EQ(md.component_ranges.size(), 6u);
  EXPECT_EQ(md.component_scales, std::vector<float>(6, 1.0f));
  EXPECT_FLOAT_EQ(md.quality, 50.0f);
  // Components 4..5 live in packet 1, channels 0..1; channels 2..3 are zero padding.
  ASSERT_EQ(dir->packets.size(), 2u);
  std::vector<float> packet(md.u_rows * 4);
  const auto& p1 = dir->packets[1];
  const auto p1_bytes = std::span<const uint8_t>(file).subspan(p1.offset, p1.size);
  ASSERT_EQ(verify_bsvtf_payload(p1.size, p1.crc, p1_bytes), Status::success);
  unpack_bsvtf_packet(p1_bytes, packet);
  for (uint32_t r = 0; r < md.u_rows; ++r) {
    EXPECT_NEAR(packet[r * 4 + 0], m.u[r * 6 + 4], 1e-3);
    EXPECT_NEAR(packet[r * 4 + 1], m.u[r * 6 + 5], 1e-3);
    EXPECT_EQ(packet[r * 4 + 2], 0.0f);
  }
  // Every tile: checksum, weight, and decoded down the hierarchy within the tolerance.
  ASSERT_EQ(dir->tiles.size(), m.tiles.size());
  const TileLayout layout = md.layout();
  TileDecoder dec(layout);
  std::unordered_map<uint64_t, std::vector<float>> decoded;
  for (uint32_t level = 0; level < 3; ++level)
    for (size_t i = 0; i < m.tiles.size(); ++i) {
      const TileId id = m.tiles[i].id;
      if (id.level != level) continue;
      const auto* e = dir->find(id);
      ASSERT_NE(e, nullptr);
      EXPECT_FLOAT_EQ(e->weight, m.tiles[i].weight);
      const auto bytes = std::span<const uint8_t>(file).subspan(e->offset, e->size);
      ASSERT_EQ(verify_bsvtf_payload(e->size, e->crc, bytes), Status::success);
      std::vector<float> out(layout.sample_count());
      std::span<const float> parent;
      if (level > 0) parent = decoded.at(id.parent().key());
      ASSERT_EQ(dec.decode(bytes, parent, id.x & 1, id.y & 1, out), Status::success) << dec.message();
      for (uint32_t k = 0; k < 4; ++k) {
        const uint32_t comp = 4 * id.texture + k;
        // Default ToleranceReference::shared_max: one absolute tolerance from the largest range.
        const float max_range = *std::max_element(md.component_ranges.begin(), md.component_ranges.end());
        const float t = comp < 6 ? tolerance_for_quality(50, max_range) : 1.0f;
        double e2 = 0;
        for (size_t s = k; s < out.size(); s += 4) e2 += (out[s] - m.samples[i][s]) * (out[s] - m.samples[i][s]);
        EXPECT_LE(std::sqrt(e2 / layout.texel_count()), t * 1.001) << "tile level " << level << " comp " << comp;
      }
      decoded[id.key()] = out;
    }
  EXPECT_EQ(dir->find(TileId{0, 2, 3, 3})->id, (TileId{0, 2, 3, 3}));
  EXPECT_EQ(dir->find(TileId{2, 0, 0, 0}), nullptr);
}

TEST(CodecContainer, DecodeTileFollowsTheChainAndReportsEachFailure) {
  const Material m = make_material();
  auto file = build(m);
  auto dir = read_bsvtf(file);
  ASSERT_TRUE(dir.ok()) << dir.message();
  const TileLayout layout = dir->metadata.layout();
  TileDecoder dec(layout);
  std::vector<float> scratch(layout.sample_count()), out(layout.sample_count()), parent(layout.sample_count()),
      step(layout.sample_count());
  // Level 2 tile (1, 2) by hand: root, (0, 1), then the tile, each against its parent.
  const TileId t{1, 2, 1, 2};
  for (uint32_t l = 0; l <= 2; ++l) {
    const BsvtfTileEntry* e = dir->find(t.ancestor(l));
    ASSERT_NE(e, nullptr);
    ASSERT_EQ(dec.decode(std::span<const uint8_t>(file).subspan(e->offset, e->size),
                         l > 0 ? std::span<const float>(parent) : std::span<const float>(), t.ancestor(l).x & 1,
                         t.ancestor(l).y & 1, step),
              Status::success);
    std::swap(parent, step);
  }
  for (uint32_t level : {0u, 1u, 2u}) {  // both parities of the alternating buffers
    ASSERT_EQ(decode_bsvtf_tile(*dir, file, t.ancestor(level), dec, scratch, out), Status::success);
    if (level == 2) {
      EXPECT_EQ(out, parent);
    }
  }
  EXPECT_EQ(decode_bsvtf_tile(*dir, file, TileId{1, 3, 0, 0}, dec, scratch, out), Status::invalid_argument);
  EXPECT_EQ(decode_bsvtf_tile(*dir, file, t, dec, std::span<float>(scratch).first(8), out), Status::invalid_argument);
  const BsvtfTileEntry* mid = dir->find(t.ancestor(1));
  EXPECT_EQ(decode_bsvtf_tile(*dir, std::span<const uint8_t>(file).first(mid->offset + 3), t, dec, scratch, out),
            Status::short_output);
  file[mid->offset + mid->size / 2] ^= 0x40;  // the CRC of an ancestor no longer matches
  EXPECT_EQ(decode_bsvtf_tile(*dir, file, t, dec, scratch, out), Status::bad_data);
}

TEST(CodecContainer, CoarseToFinePrefixIsContiguousAndDirectoryParsesAlone) {
  const Material m = make_material(4, 4);
  const auto file = build(m);
  auto dir = read_bsvtf(file);
  ASSERT_TRUE(dir.ok()) << dir.message();
  // The directory alone (what a streaming client fetches first) parses.
  auto alone = parse_bsvtf_directory(std::span<const uint8_t>(file).first(dir->header.directory_size), file.size());
  ASSERT_TRUE(alone.ok()) << alone.message();
  auto too_short =
      parse_bsvtf_directory(std::span<const uint8_t>(file).first(dir->header.directory_size - 1), file.size());
  EXPECT_EQ(too_short.status(), Status::short_output);
  for (uint32_t level = 0; level < 4; ++level) {
    const uint64_t prefix = dir->prefix_size(level);
    for (const auto& t : dir->tiles) {
      if (t.id.level <= level) {
        EXPECT_LE(t.offset + t.size, prefix);
      } else {
        EXPECT_GE(t.offset, prefix) << "a finer tile lies inside the level-" << level << " prefix";
      }
    }
    for (const auto& p : dir->packets) EXPECT_LE(p.offset + p.size, dir->prefix_size(0));
  }
  EXPECT_EQ(dir->prefix_size(3), file.size());
}

TEST(CodecContainer, BuildIsDeterministicAcrossThreadCounts) {
  const Material m = make_material();
  ThreadPool one(1), two(2);
  EXPECT_EQ(build(m, 40, &one), build(m, 40, &two));
}

TEST(CodecContainer, PerComponentToleranceSpendsMoreBitsOnSmallComponents) {
  const Material m = make_material();  // component ranges grow with the index (amplitude 1 + c)
  BsvtfBuildOptions shared, per;
  per.tolerance_reference = ToleranceReference::per_component;
  const auto a = build_bsvtf(m.metadata, m.u, m.tiles, shared).value();
  const auto b = build_bsvtf(m.metadata, m.u, m.tiles, per).value();
  EXPECT_LT(a.size(), b.size());
  // The stored per-channel tolerance of the root tile differs accordingly.
  const auto da = read_bsvtf(a).value(), db = read_bsvtf(b).value();
  TileHeaderInfo ia, ib;
  const auto* ea = da.find({0, 0, 0, 0});
  const auto* eb = db.find({0, 0, 0, 0});
  ASSERT_EQ(tile_peek_header(std::span<const uint8_t>(a).subspan(ea->offset, ea->size), ia), Status::success);
  ASSERT_EQ(tile_peek_header(std::span<const uint8_t>(b).subspan(eb->offset, eb->size), ib), Status::success);
  EXPECT_FLOAT_EQ(ia.tolerance[0], ia.tolerance[3]);
  EXPECT_LT(ib.tolerance[0], ib.tolerance[3]);
}

TEST(CodecContainer, HigherQualityGivesLargerFile) {
  const Material m = make_material();
  EXPECT_LT(build(m, 20).size(), build(m, 90).size());
}

TEST(CodecContainer, WriterRejectsInconsistentInput) {
  Material m = make_material(2, 4);
  auto dup = m.tiles;
  dup.push_back(dup.back());  // refused before any encoding: two workers would write one slot
  auto d = build_bsvtf(m.metadata, m.u, dup);
  EXPECT_EQ(d.status(), Status::invalid_argument);
  EXPECT_NE(d.message().find("given twice"), std::string::npos) << d.message();
  auto orphan = m.tiles;
  orphan.erase(orphan.begin());  // drop the root
  auto r = build_bsvtf(m.metadata, m.u, orphan);
  EXPECT_EQ(r.status(), Status::invalid_argument);
  EXPECT_NE(r.message().find("no parent"), std::string::npos) << r.message();
  auto wrong_size = m.tiles;
  wrong_size[0].samples = wrong_size[0].samples.first(10);
  EXPECT_EQ(build_bsvtf(m.metadata, m.u, wrong_size).status(), Status::invalid_argument);
  auto short_u = m.u;
  short_u.pop_back();
  EXPECT_EQ(build_bsvtf(m.metadata, short_u, m.tiles).status(), Status::invalid_argument);
  auto bad_meta = m.metadata;
  bad_meta.width = 1000;
  EXPECT_EQ(build_bsvtf(bad_meta, m.u, m.tiles).status(), Status::invalid_argument);
  BsvtfBuildOptions cancel;
  cancel.progress = [](std::string_view, double f) { return f < 0.3; };
  EXPECT_EQ(build_bsvtf(m.metadata, m.u, m.tiles, cancel).status(), Status::cancelled);
}

class CodecContainerFailures : public ::testing::Test {
 protected:
  void SetUp() override {
    file_ = build(make_material());
    auto d = read_bsvtf(file_);
    ASSERT_TRUE(d.ok());
    dir_ = d.value();
  }
  Status read(const std::vector<uint8_t>& f) { return read_bsvtf(f).status(); }
  std::vector<uint8_t> file_;
  BsvtfDirectory dir_;
};

TEST_F(CodecContainerFailures, TruncatedFileIsShortOutput) {
  for (size_t n : {size_t{0}, size_t{7}, size_t{127}, size_t{128}, size_t{200}, file_.size() - 1}) {
    std::vector<uint8_t> f(file_.begin(), file_.begin() + n);
    EXPECT_EQ(read(f), Status::short_output) << n;
  }
  // Any prefix fails cleanly.
  for (size_t n = 0; n < dir_.header.directory_size; n += 3)
    ASSERT_FALSE(read_bsvtf(std::span<const uint8_t>(file_).first(n)).ok());
}

TEST_F(CodecContainerFailures, TrailingBytesAreBadData) {
  auto f = file_;
  f.push_back(0);
  auto r = read_bsvtf(f);
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("trailing"), std::string::npos) << r.message();
}

TEST_F(CodecContainerFailures, WrongSignatureVersionAndChecksums) {
  auto f = file_;
  f[0] = 'X';
  EXPECT_EQ(read(f), Status::bad_data);
  f = file_;
  patch<uint32_t>(f, 8, 1);  // version 1 held tile format 1, which this decoder no longer reads
  fix_header_crc(f);
  EXPECT_EQ(read(f), Status::unsupported);
  f = file_;
  patch<uint32_t>(f, 8, kBsvtfVersion + 1);
  fix_header_crc(f);
  EXPECT_EQ(read(f), Status::unsupported);
  f = file_;
  f[20] ^= 1;  // inside the header, not fixed up
  EXPECT_EQ(read(f), Status::bad_data);
  f = file_;
  f[kBsvtfHeaderSize + 3] ^= 1;  // metadata byte
  auto r = read_bsvtf(f);
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("metadata: checksum"), std::string::npos) << r.message();
  f = file_;
  f[dir_.header.tile_index_offset + 9] ^= 1;  // tile index byte
  EXPECT_EQ(read(f), Status::bad_data);
  // A flipped payload byte is caught by the payload checksum (the directory is still fine).
  f = file_;
  const auto& e = dir_.tiles[5];
  f[e.offset + e.size / 2] ^= 0x10;
  ASSERT_EQ(read(f), Status::success);
  EXPECT_EQ(verify_bsvtf_payload(e.size, e.crc, std::span<const uint8_t>(f).subspan(e.offset, e.size)),
            Status::bad_data);
  EXPECT_EQ(verify_bsvtf_payload(e.size, e.crc, std::span<const uint8_t>(file_).subspan(e.offset, e.size - 1)),
            Status::short_output);
}

TEST_F(CodecContainerFailures, OversizedCountsAreBadDataWithoutHugeAllocations) {
  auto f = file_;
  patch<uint32_t>(f, kOffTileCount, 0xFFFFFFF0u);
  fix_header_crc(f);
  EXPECT_EQ(read(f), Status::bad_data);
  f = file_;
  patch<uint32_t>(f, kOffPacketCount, 0x7FFFFFFFu);
  fix_header_crc(f);
  EXPECT_EQ(read(f), Status::bad_data);
  f = file_;
  patch<uint32_t>(f, kOffMetaSize, 0xFFFFFFFFu);
  fix_header_crc(f);
  EXPECT_EQ(read(f), Status::bad_data);
  // A light count of 2^32 − 1 inside a checksummed metadata block.
  f = file_;
  patch<uint32_t>(f, kBsvtfHeaderSize + 36, 0xFFFFFFFFu);
  const uint32_t meta_size = dir_.header.metadata_size;
  patch<uint32_t>(f, kOffMetaCrc, crc32_of(std::span<const uint8_t>(f).subspan(kBsvtfHeaderSize, meta_size)));
  fix_header_crc(f);
  auto r = read_bsvtf(f);
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("light direction"), std::string::npos) << r.message();
}

TEST_F(CodecContainerFailures, IndexEntriesOutsideThePayloadOrOverlappingAreBadData) {
  const size_t index = dir_.header.tile_index_offset;
  auto refix = [&](std::vector<uint8_t>& f) {
    patch<uint32_t>(f, kOffIndexCrc,
                    crc32_of(std::span<const uint8_t>(f).subspan(index, dir_.tiles.size() * kBsvtfTileEntrySize)));
    fix_header_crc(f);
  };
  auto f = file_;
  patch<uint64_t>(f, index + 8, file_.size() - 10);  // entry 0 offset near the end: runs past it
  refix(f);
  EXPECT_EQ(read(f), Status::bad_data);
  f = file_;
  patch<uint64_t>(f, index + 8, 0xFFFFFFFFFFFFFFF0ull);  // overflow bait
  refix(f);
  EXPECT_EQ(read(f), Status::bad_data);
  f = file_;
  patch<uint64_t>(f, index + 8, 16);  // points into the header
  refix(f);
  EXPECT_EQ(read(f), Status::bad_data);
  f = file_;
  patch<uint64_t>(f, index + kBsvtfTileEntrySize + 8, dir_.tiles[0].offset + 1);  // overlaps entry 0
  refix(f);
  EXPECT_EQ(read(f), Status::bad_data);
  f = file_;
  patch<uint32_t>(f, index + 16, 0x7FFFFFFF);  // absurd tile size
  refix(f);
  EXPECT_EQ(read(f), Status::bad_data);
  f = file_;
  patch<uint64_t>(f, index, TileId{9, 0, 0, 0}.key());  // texture beyond the material
  refix(f);
  EXPECT_EQ(read(f), Status::bad_data);
  (void)kOffIndex;
}

TEST_F(CodecContainerFailures, RandomDirectoryCorruptionNeverCrashes) {
  std::mt19937 rng(17);
  int accepted = 0;
  for (int trial = 0; trial < 400; ++trial) {
    auto f = file_;
    const size_t at = rng() % dir_.header.directory_size;
    f[at] ^= static_cast<uint8_t>(1 + rng() % 255);
    if (trial % 2) fix_header_crc(f);  // get past the header checksum half of the time
    if (read_bsvtf(f).ok()) ++accepted;
  }
  EXPECT_LT(accepted, 40);  // only bytes outside any checked field (reserved, crc-fixed padding) may pass
}

// Seeds of fuzz/fuzz_container_reader.cpp, written into BTFLOD_WRITE_CONTAINER_SEEDS when set
// (BTFLOD_WRITE_CONTAINER_SEEDS=fuzz/corpus/fuzz_container_reader test_codec_container
// --gtest_filter='*Seeds*' adds them to the corpus), else into the test's temporary folder. Read
// back, each does what the fuzzer needs of it: the whole files parse, verify and decode every
// tile (parents first) and U packet, the truncated one is refused with a message.
TEST(CodecContainer, WritesFuzzSeedsThatParseTheFuzzersWay) {
  const btflod_test::FuzzSeedFolder seeds("BTFLOD_WRITE_CONTAINER_SEEDS", "seeds_container_reader");
  const auto small = build(make_material(2, 4), 30);
  seeds.write("seed_small.bsvtf", small);
  seeds.write("seed_two_textures.bsvtf", build(make_material(2, 6), 10));
  seeds.write("seed_truncated.bsvtf",
              std::vector<uint8_t>(small.begin(), small.begin() + static_cast<std::ptrdiff_t>(small.size() / 2)));
  for (const char* name : {"seed_small.bsvtf", "seed_two_textures.bsvtf"}) {
    const std::vector<uint8_t> file = seeds.read(name);
    auto dir_or = read_bsvtf(file);
    ASSERT_TRUE(dir_or.ok()) << name << ": " << dir_or.message();
    const BsvtfDirectory& d = dir_or.value();
    EXPECT_EQ(d.packets.size(), d.metadata.texture_count()) << name;
    for (const BsvtfPacketEntry& p : d.packets)
      EXPECT_EQ(verify_bsvtf_payload(p.size, p.crc, std::span<const uint8_t>(file).subspan(p.offset, p.size)),
                Status::success)
          << name << " packet " << p.index;
    // Every tile decodes against its decoded parent, as a client (and the fuzzer) would.
    const TileLayout layout = d.metadata.layout();
    TileDecoder dec(layout);
    std::map<uint64_t, std::vector<float>> decoded;
    for (uint32_t level = 0; level < d.metadata.level_count; ++level)
      for (const BsvtfTileEntry& e : d.tiles) {
        if (e.id.level != level) continue;
        const auto payload = std::span<const uint8_t>(file).subspan(e.offset, e.size);
        ASSERT_EQ(verify_bsvtf_payload(e.size, e.crc, payload), Status::success) << name;
        std::vector<float> out(layout.sample_count());
        const std::vector<float>* parent = level > 0 ? &decoded.at(e.id.parent().key()) : nullptr;
        ASSERT_EQ(dec.decode(payload, parent ? std::span<const float>(*parent) : std::span<const float>(), e.id.x & 1u,
                             e.id.y & 1u, out),
                  Status::success)
            << name << ": " << dec.message();
        decoded[e.id.key()] = std::move(out);
      }
    EXPECT_EQ(decoded.size(), d.tiles.size()) << name;
  }
  auto truncated = read_bsvtf(seeds.read("seed_truncated.bsvtf"));
  EXPECT_FALSE(truncated.ok());
  EXPECT_FALSE(truncated.message().empty());
}

}  // namespace

// Per-tile tolerance scale (BsvtfTileInput::tolerance_scale, set by the luminance-adaptive
// producer, samples/common/bsvtf_input.hpp): the header stores the scaled tolerance and the
// decoded error follows it; the default 1 leaves the bytes unchanged.
TEST(CodecContainer, PerTileToleranceScaleIsStoredAndBoundsTheError) {
  Material m = make_material(2);
  const auto plain = build(m);
  for (auto& t : m.tiles) t.tolerance_scale = 1.0f;
  EXPECT_EQ(build(m), plain);  // explicit 1 == default bytes
  const TileId dark{0, 1, 0, 0}, bright{0, 1, 1, 1};
  for (auto& t : m.tiles)
    if (t.id == dark) t.tolerance_scale = 0.25f;
  const auto scaled = build(m);
  EXPECT_GT(scaled.size(), plain.size());
  const auto dp = read_bsvtf(plain).value(), ds = read_bsvtf(scaled).value();
  const auto header = [](const std::vector<uint8_t>& f, const BsvtfDirectory& d, TileId id) {
    const auto* e = d.find(id);
    TileHeaderInfo info;
    EXPECT_EQ(tile_peek_header(std::span<const uint8_t>(f).subspan(e->offset, e->size), info), Status::success);
    return info;
  };
  const TileHeaderInfo hd = header(scaled, ds, dark), hb = header(scaled, ds, bright), hp = header(plain, dp, dark);
  for (int c = 0; c < 4; ++c) {
    EXPECT_FLOAT_EQ(hd.tolerance[c], 0.25f * hp.tolerance[c]);
    EXPECT_FLOAT_EQ(hb.tolerance[c], hp.tolerance[c]);
  }
  // Decoded RMS error of the dark tile: within the scaled tolerance and below the plain build's.
  const TileLayout layout = m.metadata.layout();
  const auto rms = [&](const std::vector<uint8_t>& f, const BsvtfDirectory& d) {
    TileDecoder dec(layout);
    std::vector<float> root(layout.sample_count()), out(layout.sample_count());
    const auto* r = d.find({0, 0, 0, 0});
    EXPECT_EQ(dec.decode(std::span<const uint8_t>(f).subspan(r->offset, r->size), {}, 0, 0, root), Status::success);
    const auto* e = d.find(dark);
    EXPECT_EQ(dec.decode(std::span<const uint8_t>(f).subspan(e->offset, e->size), root, 0, 0, out), Status::success);
    size_t index = 0;
    while (!(m.tiles[index].id == dark)) ++index;
    double e2 = 0;
    for (size_t s = 0; s < out.size(); s += 4) e2 += (out[s] - m.samples[index][s]) * (out[s] - m.samples[index][s]);
    return std::sqrt(e2 / layout.texel_count());
  };
  const double e_plain = rms(plain, dp), e_scaled = rms(scaled, ds);
  EXPECT_LE(e_scaled, hd.tolerance[0] * 1.001);
  EXPECT_LT(e_scaled, 0.6 * e_plain);
  // A scale that is not finite and positive is refused.
  for (auto& t : m.tiles) t.tolerance_scale = 0.0f;
  EXPECT_EQ(build_bsvtf(m.metadata, m.u, m.tiles).status(), Status::invalid_argument);
}

TEST(CodecQuantize, LuminanceToleranceScaleFollowsLightness) {
  EXPECT_NEAR(luminance_tolerance_scale(8.0f, 1.0f, 0.0f), 4.0f, 1e-5f);     // (8)^(2/3)
  EXPECT_NEAR(luminance_tolerance_scale(0.125f, 1.0f, 0.0f), 0.25f, 1e-6f);  // darker: finer
  EXPECT_NEAR(luminance_tolerance_scale(0.0f, 1.0f, 0.125f), 0.25f, 1e-6f);  // black → the floor
  EXPECT_FLOAT_EQ(luminance_tolerance_scale(1.0f, 0.0f, 0.1f), 1.0f);        // no reference
  EXPECT_FLOAT_EQ(luminance_tolerance_scale(std::nanf(""), 1.0f, 0.1f), 1.0f);
  EXPECT_FLOAT_EQ(luminance_tolerance_scale(1e12f, 1.0f, 0.0f), 64.0f);  // clamped
}

// tolerance_min_scale: a floor (from the largest range) under per_component's small tolerances.
TEST(CodecContainer, ToleranceMinScaleFloorsSmallComponentTolerances) {
  Material m = make_material();
  BsvtfBuildOptions per;
  per.tolerance_reference = ToleranceReference::per_component;
  for (auto& t : m.tiles) t.tolerance_min_scale = 0.5f;
  const auto f = build_bsvtf(m.metadata, m.u, m.tiles, per).value();
  const auto d = read_bsvtf(f).value();
  const auto* e = d.find({0, 0, 0, 0});
  TileHeaderInfo info;
  ASSERT_EQ(tile_peek_header(std::span<const uint8_t>(f).subspan(e->offset, e->size), info), Status::success);
  const float built_max = *std::max_element(d.metadata.component_ranges.begin(), d.metadata.component_ranges.end());
  const float floor = tolerance_for_quality(50, built_max) * 0.5f;
  for (int c = 0; c < 4; ++c) {
    EXPECT_GE(info.tolerance[c], floor * 0.9999f);
    EXPECT_FLOAT_EQ(info.tolerance[c], std::max(floor, tolerance_for_quality(50, d.metadata.component_ranges[c])));
  }
  EXPECT_FLOAT_EQ(info.tolerance[0], floor);  // the smallest component is lifted to the floor
}

// Version 3 stores U's row order and each tile's energy; version-2 files are still read (row
// order unspecified, energies 0); a writer must say which order U is in.
TEST(CodecContainer, RowOrderAndEnergiesRoundTripAndVersionTwoIsRead) {
  Material m = make_material(2, 4);
  m.metadata.u_row_order = AngularRowOrder::view_major;
  for (size_t i = 0; i < m.tiles.size(); ++i) m.tiles[i].energy = 0.25f * static_cast<float>(i + 1);
  const auto file = build(m);
  const auto d = read_bsvtf(file);
  ASSERT_TRUE(d.ok()) << d.message();
  EXPECT_EQ(d->header.version, kBsvtfVersion);
  EXPECT_EQ(d->metadata.u_row_order, AngularRowOrder::view_major);
  for (const auto& t : m.tiles) EXPECT_EQ(d->find(t.id)->energy, t.energy);
  // The same tiles written as version 2.
  const std::vector<BsvtfEncodedTile> tiles = encoded_tiles_of(file, *d);
  BsvtfMetadata md = d->metadata;
  const auto v2 = write_bsvtf(md, m.u, tiles, 2);
  ASSERT_TRUE(v2.ok()) << v2.message();
  const auto d2 = read_bsvtf(*v2);
  ASSERT_TRUE(d2.ok()) << d2.message();
  EXPECT_EQ(d2->header.version, 2u);
  EXPECT_EQ(d2->metadata.u_row_order, AngularRowOrder::unspecified);
  EXPECT_EQ(d2->tiles.size(), d->tiles.size());
  for (const auto& e : d2->tiles) EXPECT_EQ(e.energy, 0.0f);
  md.u_row_order = AngularRowOrder::unspecified;
  const auto refused = write_bsvtf(md, m.u, tiles);
  EXPECT_EQ(refused.status(), Status::invalid_argument);
  EXPECT_NE(refused.message().find("u_row_order"), std::string::npos);
  EXPECT_EQ(write_bsvtf(d->metadata, m.u, tiles, kBsvtfVersion + 1).status(), Status::invalid_argument);
}

// Version 4 stores the value encoding of the factorisation (core/value_transform.hpp); earlier
// versions read as linear and cannot store another encoding; an unknown encoding or a log offset
// ≤ 0 in a file is bad_data.
TEST(CodecContainer, ValueTransformRoundTripsAndOlderVersionsCannotStoreIt) {
  Material m = make_material(2, 3);
  m.metadata.value_transform = ValueTransform{ValueEncoding::log, 0.125f};
  const auto file = build(m);
  const auto d = read_bsvtf(file);
  ASSERT_TRUE(d.ok()) << d.message();
  EXPECT_EQ(d->header.version, 4u);
  EXPECT_EQ(d->metadata.value_transform.encoding, ValueEncoding::log);
  EXPECT_EQ(d->metadata.value_transform.log_offset, 0.125f);
  const std::vector<BsvtfEncodedTile> tiles = encoded_tiles_of(file, *d);
  const auto v3 = write_bsvtf(d->metadata, m.u, tiles, 3);
  EXPECT_EQ(v3.status(), Status::invalid_argument);
  EXPECT_NE(v3.message().find("log"), std::string::npos) << v3.message();
  BsvtfMetadata linear = d->metadata;
  linear.value_transform = ValueTransform{};
  const auto old = write_bsvtf(linear, m.u, tiles, 3);
  ASSERT_TRUE(old.ok()) << old.message();
  EXPECT_TRUE(read_bsvtf(*old)->metadata.value_transform.is_linear());
  BsvtfMetadata bad = d->metadata;
  bad.value_transform.log_offset = 0.0f;
  EXPECT_EQ(write_bsvtf(bad, m.u, tiles).status(), Status::invalid_argument);
  // A hostile encoding in the metadata (its CRC fixed): refused with a reason.
  std::vector<uint8_t> f = file;
  uint64_t meta_offset = 0;
  std::memcpy(&meta_offset, f.data() + 32, 8);
  uint32_t meta_size = 0;
  std::memcpy(&meta_size, f.data() + kOffMetaSize, 4);
  const size_t at = static_cast<size_t>(meta_offset) + 12 * 4 + 4;  // 11 u32, quality f32, row order u32
  uint32_t encoding = 0;
  std::memcpy(&encoding, f.data() + at, 4);
  ASSERT_EQ(encoding, static_cast<uint32_t>(ValueEncoding::log));
  patch<uint32_t>(f, at, 7u);
  patch<uint32_t>(f, kOffMetaCrc,
                  crc32_of(std::span<const uint8_t>(f).subspan(static_cast<size_t>(meta_offset), meta_size)));
  fix_header_crc(f);
  const auto hostile = read_bsvtf(f);
  EXPECT_EQ(hostile.status(), Status::bad_data);
  EXPECT_NE(hostile.message().find("value encoding"), std::string::npos) << hostile.message();
}

// The default coder (BsvtfBuildOptions{}, default_tile_entropy_coder()) is zstd where the build
// can encode it: a default-built container's tiles are format 3 / zstd, and each tile carries the
// same header fields and the same symbol stream (the same quantised coefficients) as the
// deflate-built container's tile at the same quality, so the containers decode down the hierarchy
// to the same bits. Without zstd the default is deflate and a zstd build says why it cannot.
TEST(CodecContainer, DefaultCoderIsZstdAndDecodesToTheDeflateContainersBits) {
  const Material m = make_material();
  BsvtfBuildOptions o;
  o.quality = 50;
  if (!tile_entropy_coder_available(TileEntropyCoder::zstd)) {
    EXPECT_EQ(o.entropy_coder, TileEntropyCoder::deflate);
    o.entropy_coder = TileEntropyCoder::zstd;
    EXPECT_EQ(build_bsvtf(m.metadata, m.u, m.tiles, o).status(), Status::invalid_argument);
    GTEST_SKIP() << "built without zstd";
  }
  EXPECT_EQ(default_tile_entropy_coder(), TileEntropyCoder::zstd);
  EXPECT_EQ(o.entropy_coder, TileEntropyCoder::zstd);
  const std::vector<uint8_t> z = build(m, 50);  // default options
  o.entropy_coder = TileEntropyCoder::deflate;
  auto built = build_bsvtf(m.metadata, m.u, m.tiles, o);
  ASSERT_TRUE(built.ok()) << built.message();
  const std::vector<uint8_t>& d = *built;
  const auto dz = read_bsvtf(z).value(), dd = read_bsvtf(d).value();
  EXPECT_EQ(dz.tiles.size(), m.tiles.size());
  const TileLayout layout = dz.metadata.layout();
  TileDecoder dec(layout);
  RawInflater inflater;
  ZstdDecompressor unzstd;
  ASSERT_TRUE(inflater.create(InflateBackend::zlib));
  ASSERT_TRUE(unzstd.create());
  std::unordered_map<uint64_t, std::vector<float>> from_z, from_d;
  uint64_t bytes_z = 0, bytes_d = 0;
  for (uint32_t level = 0; level < dz.metadata.level_count; ++level)
    for (const auto& tile : m.tiles) {
      const TileId id = tile.id;
      if (id.level != level) continue;
      const auto* ez = dz.find(id);
      const auto* ed = dd.find(id);
      ASSERT_TRUE(ez && ed);
      bytes_z += ez->size;
      bytes_d += ed->size;
      const auto bz = std::span<const uint8_t>(z).subspan(ez->offset, ez->size);
      const auto bd = std::span<const uint8_t>(d).subspan(ed->offset, ed->size);
      ASSERT_EQ(verify_bsvtf_payload(ez->size, ez->crc, bz), Status::success);
      TileHeaderInfo hz, hd;
      ASSERT_EQ(tile_peek_header(bz, hz), Status::success);
      ASSERT_EQ(tile_peek_header(bd, hd), Status::success);
      EXPECT_EQ(hz.version, 3u);
      EXPECT_EQ(hz.coder, TileEntropyCoder::zstd);
      EXPECT_EQ(hd.version, 2u);
      EXPECT_EQ(hd.coder, TileEntropyCoder::deflate);
      EXPECT_EQ(hz.residual, hd.residual);
      EXPECT_EQ(hz.weight_quarters, hd.weight_quarters);
      ASSERT_EQ(hz.symbol_bytes, hd.symbol_bytes);
      // Bytes 2.. of the header (channels, sizes, tolerances, symbol count) are equal; byte 0 is
      // the version, byte 3 the flags with the coder in bits 4-5.
      const size_t header = tile_header_size(hz.channels);
      EXPECT_EQ(bz[1], bd[1]);
      EXPECT_EQ(bz[3] & 0x0F, bd[3]);
      EXPECT_EQ(bz[3] >> 4, 1);
      EXPECT_EQ(std::memcmp(bz.data() + 4, bd.data() + 4, header - 4), 0);
      // The same quantised symbols under either coder.
      std::vector<uint8_t> sz(hz.symbol_bytes), sd(hd.symbol_bytes);
      ASSERT_EQ(unzstd.decompress(bz.subspan(header), sz, nullptr), Status::success);
      ASSERT_EQ(inflater.inflate(bd.subspan(header), sd, nullptr), Status::success);
      ASSERT_EQ(sz, sd);
      std::vector<float> oz(layout.sample_count()), od(layout.sample_count());
      std::span<const float> pz, pd;
      if (level > 0) pz = from_z.at(id.parent().key()), pd = from_d.at(id.parent().key());
      ASSERT_EQ(dec.decode(bz, pz, id.x & 1, id.y & 1, oz), Status::success) << dec.message();
      ASSERT_EQ(dec.decode(bd, pd, id.x & 1, id.y & 1, od), Status::success) << dec.message();
      ASSERT_EQ(std::memcmp(oz.data(), od.data(), oz.size() * sizeof(float)), 0);
      from_z[id.key()] = std::move(oz);
      from_d[id.key()] = std::move(od);
    }
  // No size assertion: these 24² tiles (about 100 bytes each) are too small for zstd's frame
  // header (about 9 bytes) to pay off; the demo's 72² tiles are 10 % smaller with zstd
  // (docs/bsvtf_format.md, "Entropy stage").
  std::printf("tile bytes: zstd %llu, deflate %llu (%.3fx)\n", static_cast<unsigned long long>(bytes_z),
              static_cast<unsigned long long>(bytes_d), static_cast<double>(bytes_d) / static_cast<double>(bytes_z));
}
