// The two-plane BC5 cache layout's BC4 blocks (runtime/vt/cache_bc5.hpp) against libsquish's BC4
// encoder (Debian libsquish-dev 1.15, kBc4) on real eigen-texture tiles: the four demo materials
// synthesised at 64² texels, factorised (FMF, C = 8, log_ycbcr), cut into the demo's 40² tiles
// (T = 32, B = 4) and quantised to unorm8 under each slot's map as the cache does. Reports each
// encoder's mean squared error per value (unorm8 units) over every block and its time per tile
// (8 BC4 blocks × 100 blocks of a 40² slot); the counters are the comparison, in one run.
// btflod-link: btflod_squish
#include <benchmark/benchmark.h>
#include <squish.h>

#include <cstdint>
#include <vector>

#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/build/tile_pyramid.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/fmf_stream.hpp"
#include "btflod/runtime/vt/cache_bc5.hpp"

namespace {

using namespace btflod;

// Every 4 × 4 block of every component of every quantised tile: 16 unorm8 values each.
struct Blocks {
  std::vector<uint8_t> values;  // 16 per block
  size_t tiles = 0;
  size_t count() const { return values.size() / 16; }
};

const Blocks& eigen_texture_blocks() {
  static const Blocks blocks = [] {
    Blocks b;
    for (SynthMaterial kind :
         {SynthMaterial::cloth, SynthMaterial::stone, SynthMaterial::leather, SynthMaterial::tiles}) {
      SynthesisOptions so;
      auto btf = synthesize_material(kind, 64, 64, 1, so);
      if (!btf) continue;
      FmfOptions fo;
      fo.components = 8;
      fo.transform.encoding = ValueEncoding::log_ycbcr;
      auto fmf = factorize_fmf(*btf, fo);
      if (!fmf) continue;
      auto pyramid = TilePyramid::build(eigen_textures_from_fmf(*fmf), 32, 4, TileEdge::wrap);
      if (!pyramid) continue;
      const uint32_t side = 40;
      std::vector<float> texels(size_t{side} * side * 4);
      std::vector<uint8_t> q(texels.size());
      for (uint32_t k = 0; k < pyramid->texture_count(); ++k)
        for (uint32_t i = 0; i < pyramid->levels().tile_count(); ++i) {
          half_to_float(pyramid->tile_texels(k, i), texels);
          encode_cache_tile_unorm8(texels, q);
          ++b.tiles;
          for (uint32_t c = 0; c < 4; ++c)
            for (uint32_t by = 0; by < side / 4; ++by)
              for (uint32_t bx = 0; bx < side / 4; ++bx)
                for (uint32_t y = 0; y < 4; ++y)
                  for (uint32_t x = 0; x < 4; ++x) b.values.push_back(q[((by * 4 + y) * side + bx * 4 + x) * 4 + c]);
        }
    }
    return b;
  }();
  return blocks;
}

double block_sse(const uint8_t* v, const uint8_t* block) {
  float decoded[16];
  decode_bc4_block(block, decoded);
  double sse = 0;
  for (int t = 0; t < 16; ++t) sse += (v[t] - decoded[t] * 255.0) * (v[t] - decoded[t] * 255.0);
  return sse;
}

// The counters of both encoders: mean squared error per value of the encoded blocks, time per
// 40² tile (four components of 100 blocks), block count.
void report(benchmark::State& state, const Blocks& b, const std::vector<uint8_t>& out) {
  double sse = 0;
  for (size_t i = 0; i < b.count(); ++i) sse += block_sse(&b.values[i * 16], &out[i * 8]);
  state.counters["mse_unorm8"] = sse / static_cast<double>(b.values.size());
  state.counters["us_per_tile"] = benchmark::Counter(
      static_cast<double>(b.tiles) * 1e-6, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["blocks"] = static_cast<double>(b.count());
}

void BM_Bc4Blocks_Btflod(benchmark::State& state) {
  const Blocks& b = eigen_texture_blocks();
  std::vector<uint8_t> out(b.count() * 8);
  for (auto _ : state)
    for (size_t i = 0; i < b.count(); ++i) encode_bc4_block(&b.values[i * 16], &out[i * 8]);
  report(state, b, out);
}
BENCHMARK(BM_Bc4Blocks_Btflod)->Unit(benchmark::kMillisecond);

void BM_Bc4Blocks_Squish(benchmark::State& state) {
  const Blocks& b = eigen_texture_blocks();
  std::vector<uint8_t> out(b.count() * 8);
  for (auto _ : state)
    for (size_t i = 0; i < b.count(); ++i) {
      uint8_t rgba[64] = {};
      for (int t = 0; t < 16; ++t) rgba[t * 4] = b.values[i * 16 + t], rgba[t * 4 + 3] = 255;  // kBc4 codes red
      squish::Compress(rgba, &out[i * 8], squish::kBc4);
    }
  report(state, b, out);
}
BENCHMARK(BM_Bc4Blocks_Squish)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
