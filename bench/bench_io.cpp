// Benchmarks for BTF data in and out. Each figure has an in-run baseline next to it:
//   BonnParse (read_bonn_btf of a DFMF file in memory) next to MemcpyBaseline of the same bytes;
//   BonnReconstruct (U·SxVᵀ + colour model for a 32×32, 81×81-direction BTF, k = 8) next to
//   FillBaseline writing the same number of floats;
//   DecodePngLinear (stb PNG decode + sRGB table) next to InflateBaseline (zlib inflate of the
//   same pixel bytes compressed at level 6, the lower bound for any PNG decoder).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstring>
#include <vector>

#include <zlib.h>

#include "btflod/offline/btf/bonn_btf.hpp"
#include "btflod/offline/btf/image_io.hpp"

namespace {

using namespace btflod;

BtfFloat demo_btf(int size) {
  BtfFloat btf(size, size, DirectionSet::ubo2003(), DirectionSet::ubo2003());
  auto s = btf.samples();
  for (size_t i = 0; i < s.size(); ++i) s[i] = 0.05f + 0.9f * static_cast<float>((i * 2654435761u) % 1000) / 1000.0f;
  return btf;
}

const BonnBtfFile& demo_factors() {
  static const BonnBtfFile f = [] {
    DfmfFactorizeOptions opt;
    opt.components = 8;
    opt.color_model = BonnColorModel::yuv;
    return *factorize_bonn_dfmf(demo_btf(32), opt);
  }();
  return f;
}

const std::vector<uint8_t>& demo_file() {
  static const std::vector<uint8_t> bytes = *encode_bonn_btf(demo_factors());
  return bytes;
}

void BonnParse(benchmark::State& state) {
  const auto& bytes = demo_file();
  for (auto _ : state) {
    auto f = read_bonn_btf(bytes);
    benchmark::DoNotOptimize(f.ok());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(bytes.size()));
}
BENCHMARK(BonnParse)->Unit(benchmark::kMillisecond);

void MemcpyBaseline(benchmark::State& state) {
  const auto& bytes = demo_file();
  std::vector<uint8_t> copy(bytes.size());
  for (auto _ : state) {
    std::memcpy(copy.data(), bytes.data(), bytes.size());
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(bytes.size()));
}
BENCHMARK(MemcpyBaseline)->Unit(benchmark::kMillisecond);

void BonnReconstruct(benchmark::State& state) {
  const auto& f = demo_factors();
  ThreadPool pool(1);  // single-threaded, comparable with the baseline
  BonnReconstructOptions opt;
  opt.pool = &pool;
  size_t samples = 0;
  for (auto _ : state) {
    auto btf = reconstruct_bonn_btf(f, opt);
    samples = btf->samples().size();
    benchmark::DoNotOptimize(btf->samples().data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(samples));
}
BENCHMARK(BonnReconstruct)->Unit(benchmark::kMillisecond);

void FillBaseline(benchmark::State& state) {
  const auto& f = demo_factors();
  const size_t samples =
      static_cast<size_t>(f.width) * static_cast<size_t>(f.height) * f.views.size() * f.lights.size() * 3;
  for (auto _ : state) {
    std::vector<float> out(samples);
    std::fill(out.begin(), out.end(), 0.5f);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(samples));
}
BENCHMARK(FillBaseline)->Unit(benchmark::kMillisecond);

Image<uint8_t> photo_like(int w, int h) {
  Image<uint8_t> img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        img.at(x, y, c) = static_cast<uint8_t>((x * 3 + y * 2 + c * 50 + ((x * y) >> 5)) & 0xff);
  return img;
}

void DecodePngLinear(benchmark::State& state) {
  const auto img = photo_like(256, 256);
  const auto png = *encode_png(img.view());
  for (auto _ : state) {
    auto out = decode_image_linear(png);
    benchmark::DoNotOptimize(out->data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(img.size()));
  state.counters["png_bytes"] = static_cast<double>(png.size());
}
BENCHMARK(DecodePngLinear)->Unit(benchmark::kMicrosecond);

void InflateBaseline(benchmark::State& state) {
  const auto img = photo_like(256, 256);
  uLongf packed_size = compressBound(static_cast<uLong>(img.size()));
  std::vector<uint8_t> packed(packed_size);
  compress2(packed.data(), &packed_size, img.data(), static_cast<uLong>(img.size()), 6);
  std::vector<uint8_t> out(img.size());
  for (auto _ : state) {
    uLongf n = static_cast<uLongf>(out.size());
    uncompress(out.data(), &n, packed.data(), packed_size);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * static_cast<int64_t>(img.size()));
  state.counters["zlib_bytes"] = static_cast<double>(packed_size);
}
BENCHMARK(InflateBaseline)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
