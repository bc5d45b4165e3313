// Where a bc5_affine cache's blocks should be made (runtime/vt/cache_bc5.hpp): at stream time,
// as the Streamer's decode jobs do today (DCT tile decoded against its parent, then
// encode_cache_tile_bc5), or offline, with the container carrying zstd-compressed BC5 blocks the
// client only decompresses. Measured on the demo's own containers: the four demo materials
// (cloth, stone, leather, tiles) prepared with the demo's default settings (demo/materials.hpp:
// 32² texels repeated 8×, FMF C = 8, T = 32, B = 4, quality 60, zstd tiles), every tile of every
// level, decoded coarse to fine as the client decodes them.
//   wire: mean bytes per tile of today's DCT payloads (the container's tile entries) and of the
//         tile's BC5 blocks (3200 bytes for a 40² slot) compressed by zstd at levels 3 and 19,
//         one frame per tile (what a Range request would fetch);
//   client CPU per tile: DCT decode (parent given), encode_cache_tile_bc5, both together (the
//         stream-time path), and ZSTD_decompress of the tile's blocks (the offline path).
// The offline blocks are made from the same decoded values, so both paths put the same texels
// into the cache.
// btflod-link: btflod_demo_materials PkgConfig::BTFLOD_ZSTD
#include <benchmark/benchmark.h>
#include <zstd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/vt/cache_bc5.hpp"
#include "materials.hpp"

namespace {

using namespace btflod;

struct Tile {
  const uint8_t* payload = nullptr;  // the DCT payload in its container
  size_t payload_size = 0;
  const float* parent = nullptr;  // the parent's decoded values (null for a root)
  uint32_t qx = 0, qy = 0;        // quadrant within the parent
  size_t decoded = 0;             // index of its decoded values in Corpus::decoded
  std::vector<uint8_t> zstd3, zstd19;
};

struct Corpus {
  std::vector<std::vector<uint8_t>> containers;
  std::vector<Tile> tiles;
  std::vector<std::vector<float>> decoded;  // per tile, sample_count floats
  TileLayout layout{};
  uint32_t side = 0;  // T + 2B
  double dct_bytes = 0, zstd3_bytes = 0, zstd19_bytes = 0;
  std::string error;
};

const Corpus& corpus() {
  static const Corpus c = [] {
    Corpus k;
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "btflod_bench_cache_bc5_wire";
    std::filesystem::create_directories(dir);
    demo::MaterialSettings settings;  // the demo's defaults
    for (uint32_t i = 0; i < 4; ++i) {
      auto m = demo::prepare_material(i, settings, dir.string());
      if (!m) {
        k.error = m.message();
        return k;
      }
      k.containers.push_back(m->bsvtf);
    }
    std::filesystem::remove_all(dir);
    std::vector<uint8_t> scratch, blocks;
    ZSTD_CCtx* cctx = ZSTD_createCCtx();
    for (const std::vector<uint8_t>& file : k.containers) {
      auto d = read_bsvtf(file);
      if (!d) {
        k.error = d.message();
        break;
      }
      k.layout = d->metadata.layout();
      k.side = k.layout.stored_size();
      TileDecoder decoder(k.layout);
      const size_t first = k.decoded.size();
      scratch.resize(k.layout.sample_count());
      blocks.resize(cache_bc5_tile_bytes(k.side));
      // Directory order is coarse to fine: a parent is decoded before its children (as the client).
      for (const BsvtfTileEntry& e : d->tiles) {
        Tile t;
        t.payload = file.data() + e.offset;
        t.payload_size = e.size;
        t.qx = e.id.x & 1u;
        t.qy = e.id.y & 1u;
        if (e.id.level > 0) {
          const BsvtfTileEntry* p = d->find(e.id.parent());
          t.parent = k.decoded[first + static_cast<size_t>(p - d->tiles.data())].data();
        }
        t.decoded = k.decoded.size();
        std::vector<float>& out = k.decoded.emplace_back(k.layout.sample_count());
        if (decoder.decode(std::span<const uint8_t>(t.payload, t.payload_size),
                           t.parent ? std::span<const float>(t.parent, out.size()) : std::span<const float>(), t.qx,
                           t.qy, out) != Status::success) {
          k.error = std::string("decode: ") + decoder.message();
          break;
        }
        encode_cache_tile_bc5(out, k.side, scratch, blocks);
        for (int level : {3, 19}) {
          std::vector<uint8_t>& z = level == 3 ? t.zstd3 : t.zstd19;
          z.resize(ZSTD_compressBound(blocks.size()));
          z.resize(ZSTD_compressCCtx(cctx, z.data(), z.size(), blocks.data(), blocks.size(), level));
        }
        k.dct_bytes += static_cast<double>(t.payload_size);
        k.zstd3_bytes += static_cast<double>(t.zstd3.size());
        k.zstd19_bytes += static_cast<double>(t.zstd19.size());
        k.tiles.push_back(std::move(t));
      }
    }
    ZSTD_freeCCtx(cctx);
    // The parents' pointers stay valid: `decoded` holds vectors whose buffers never move.
    return k;
  }();
  return c;
}

const Corpus* corpus_or_skip(benchmark::State& state) {
  const Corpus& c = corpus();
  if (!c.error.empty() || c.tiles.empty()) {
    state.SkipWithError(("demo materials: " + c.error).c_str());
    return nullptr;
  }
  return &c;
}

// Counters every benchmark carries: the wire bytes per tile of both paths, and the time per tile.
void report(benchmark::State& state, const Corpus& c) {
  const double n = static_cast<double>(c.tiles.size());
  state.counters["tiles"] = n;
  state.counters["us_per_tile"] =
      benchmark::Counter(n * 1e-6, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["wire_B_dct"] = c.dct_bytes / n;
  state.counters["wire_B_bc5_raw"] = static_cast<double>(cache_bc5_tile_bytes(c.side));
  state.counters["wire_B_bc5_zstd3"] = c.zstd3_bytes / n;
  state.counters["wire_B_bc5_zstd19"] = c.zstd19_bytes / n;
}

// One DCT tile of the corpus decoded into `out`, against its parent's decoded values if it has one.
Status decode_tile(TileDecoder& decoder, const Tile& t, std::span<float> out) {
  return decoder.decode(std::span<const uint8_t>(t.payload, t.payload_size),
                        t.parent ? std::span<const float>(t.parent, out.size()) : std::span<const float>(), t.qx, t.qy,
                        out);
}

// Today's client work per tile, first half: the DCT tile decoded against its parent.
void BM_Bc5Wire_DctDecode(benchmark::State& state) {
  const Corpus* c = corpus_or_skip(state);
  if (!c) return;
  TileDecoder decoder(c->layout);
  std::vector<float> out(c->layout.sample_count());
  for (auto _ : state)
    for (const Tile& t : c->tiles) {
      const Status s = decode_tile(decoder, t, out);
      benchmark::DoNotOptimize(s);
      benchmark::DoNotOptimize(out.data());
    }
  report(state, *c);
}
BENCHMARK(BM_Bc5Wire_DctDecode)->Unit(benchmark::kMillisecond);

// Second half: encode_cache_tile_bc5 of the decoded values (what a decode job adds for bc5).
void BM_Bc5Wire_Bc5Encode(benchmark::State& state) {
  const Corpus* c = corpus_or_skip(state);
  if (!c) return;
  std::vector<uint8_t> scratch(c->layout.sample_count()), blocks(cache_bc5_tile_bytes(c->side));
  for (auto _ : state)
    for (const Tile& t : c->tiles) {
      const CacheSlotMap map = encode_cache_tile_bc5(c->decoded[t.decoded], c->side, scratch, blocks);
      benchmark::DoNotOptimize(map);
      benchmark::DoNotOptimize(blocks.data());
    }
  report(state, *c);
}
BENCHMARK(BM_Bc5Wire_Bc5Encode)->Unit(benchmark::kMillisecond);

// The stream-time path whole: DCT decode, then BC5 encode, per tile.
void BM_Bc5Wire_StreamTime(benchmark::State& state) {
  const Corpus* c = corpus_or_skip(state);
  if (!c) return;
  TileDecoder decoder(c->layout);
  std::vector<float> out(c->layout.sample_count());
  std::vector<uint8_t> scratch(c->layout.sample_count()), blocks(cache_bc5_tile_bytes(c->side));
  for (auto _ : state)
    for (const Tile& t : c->tiles) {
      const Status s = decode_tile(decoder, t, out);
      benchmark::DoNotOptimize(s);
      const CacheSlotMap map = encode_cache_tile_bc5(out, c->side, scratch, blocks);
      benchmark::DoNotOptimize(map);
      benchmark::DoNotOptimize(blocks.data());
    }
  report(state, *c);
}
BENCHMARK(BM_Bc5Wire_StreamTime)->Unit(benchmark::kMillisecond);

// The offline path: the client only zstd-decompresses the tile's blocks (range(0): zstd level
// the container would have been written with).
void BM_Bc5Wire_ZstdBlocks(benchmark::State& state) {
  const Corpus* c = corpus_or_skip(state);
  if (!c) return;
  const bool high = state.range(0) == 19;
  ZSTD_DCtx* dctx = ZSTD_createDCtx();
  std::vector<uint8_t> blocks(cache_bc5_tile_bytes(c->side));
  for (auto _ : state)
    for (const Tile& t : c->tiles) {
      const std::vector<uint8_t>& z = high ? t.zstd19 : t.zstd3;
      const size_t n = ZSTD_decompressDCtx(dctx, blocks.data(), blocks.size(), z.data(), z.size());
      benchmark::DoNotOptimize(n);
      benchmark::DoNotOptimize(blocks.data());
    }
  ZSTD_freeDCtx(dctx);
  report(state, *c);
}
BENCHMARK(BM_Bc5Wire_ZstdBlocks)->Arg(3)->Arg(19)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
