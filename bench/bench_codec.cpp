// btflod-link: PkgConfig::BTFLOD_TURBOJPEG PkgConfig::BTFLOD_LIBDEFLATE
// Tile codec benchmark, all baselines in the same run on the same tile content:
//   - btflod tile codec (DCT + quantisation + deflate on closed-loop parent residuals),
//   - libjpeg-turbo (TurboJPEG API) coding each 72×72 component plane as 8-bit grayscale at the
//     JPEG quality whose RMSE matches ours,
//   - zlib deflate alone on the raw half floats,
//   - libdeflate inflating our tiles' entropy stage (is the optional backend worth it?).
//   - the decode-speed ratio against libjpeg-turbo measured pair by pair (BM_decode_pairs_*),
//   - the same tiles entropy-coded with zstd (tile format 3, BM_btflod_decode_tile_zstd*; the
//     entropy candidates themselves are compared in bench_codec_entropy.cpp).
// Content: real eigen-textures: a procedural stone BTF (offline/btf/synthesizer.hpp, 128² texels, 19×19
// directions) factorised by FMF (offline/factor/fmf.hpp, 8 components = 2 RGBA virtual textures), tiled
// periodically to 512² and cut into a 4-level pyramid of 64+2·4 tiles (2×2 box filter per level).
// Before the timings it prints compression ratio vs raw halves and PSNR at several qualities.
// The tile decoder is measured with both entropy backends (zlib default, libdeflate option).
//
// Real data: `bench_codec --bsvtf FILE [--bsvtf FILE ...] [--jpeg-quality Q]` decodes the tiles of
// each container instead, one benchmark per codec and level (BM_bsvtf_decode/<file>/<codec>/
// level:<l>, same codecs as `btflod-bench codec`: samples/tools/bench_cli/codec_bench.hpp). With
// --bsvtf the defaults become 5 repetitions, randomly interleaved, medians reported (any
// --benchmark_* flag given overrides them) and only the container benchmarks run unless a
// --benchmark_filter is given.
#ifndef BTFLOD_TILE_CODEC_LIBDEFLATE  // the btflod target defines it when built BTFLOD_WITH_LIBDEFLATE
#define BTFLOD_TILE_CODEC_LIBDEFLATE 1
#endif
#include <benchmark/benchmark.h>
#include <libdeflate.h>
#include <turbojpeg.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "btflod/core/half.hpp"
#include "btflod/offline/btf/measured_brdf.hpp"
#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/build/perceptual_tolerance.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/vt/tile_id.hpp"
#define BTFLOD_BENCH_HAS_TURBOJPEG 1
#define BTFLOD_BENCH_HAS_LIBDEFLATE 1
#include "../samples/tools/bench_cli/codec_bench.hpp"
#include "bench_main.hpp"
#include "bench_mip_levels.hpp"

namespace {

using namespace btflod;

constexpr uint32_t kLevels = 4;      // 64·2³ = 512 texels at the finest level
constexpr uint32_t kComponents = 8;  // 2 virtual textures of 4
const TileLayout kLayout{64, 4, 4};

struct Tile {
  TileId id;
  std::vector<float> samples;
};

struct Content {
  std::vector<Tile> tiles;    // coarse to fine
  std::vector<float> ranges;  // per component
  size_t raw_half_bytes = 0;  // Σ tiles × 72² × 4 × 2
  float max_range = 0;        // shared tolerance reference (ToleranceReference::shared_max)
  double btf_peak = 0;        // largest BTF value (PSNR peak)
  size_t u_rows = 0;          // m: rows of U
};

// Eigen-textures of a synthesised, FMF-factorised material, as a tile pyramid. `brdf`, when not
// null, is the base reflectance (a measured car paint) instead of the analytic one.
Content make_content(SynthMaterial material, const MeasuredBrdf* brdf) {
  {
    Content out;
    const float thetas[] = {0.0f, 30.0f, 60.0f};
    const int counts[] = {1, 6, 12};
    SynthesisOptions so;
    so.views = DirectionSet::from_rings("bench19", thetas, counts, {}, false);
    so.lights = so.views;
    so.measured_brdf = brdf;
    const int w = 128;
    auto btf = synthesize_material(material, w, w, 7, so);
    if (!btf) {
      std::fprintf(stderr, "synthesis failed: %s\n", btf.message().c_str());
      std::exit(1);
    }
    for (float v : btf->samples()) out.btf_peak = std::max(out.btf_peak, static_cast<double>(v));
    FmfOptions fo;
    fo.components = static_cast<int>(kComponents);
    auto fmf = factorize_fmf(*btf, fo);
    if (!fmf) {
      std::fprintf(stderr, "FMF failed: %s\n", fmf.message().c_str());
      std::exit(1);
    }
    // Finest level: the 128² eigen-textures repeated 4×4 (the material is tileable).
    const uint32_t side = kLayout.tile_size << (kLevels - 1);
    std::vector<std::vector<float>> level(kLevels);  // [level] = side_l² × C, row-major, component fastest
    level[kLevels - 1].resize(size_t{side} * side * kComponents);
    for (uint32_t y = 0; y < side; ++y)
      for (uint32_t x = 0; x < side; ++x)
        for (uint32_t k = 0; k < kComponents; ++k)
          level[kLevels - 1][(size_t{y} * side + x) * kComponents + k] =
              fmf->v[(size_t{y % w} * w + x % w) * kComponents + k];
    btflod::bench::box_filter_coarser_levels(level, side, kComponents);
    out.ranges.assign(kComponents, 0.0f);
    for (uint32_t k = 0; k < kComponents; ++k) {
      float lo = INFINITY, hi = -INFINITY;
      for (size_t i = k; i < level[kLevels - 1].size(); i += kComponents) {
        lo = std::min(lo, level[kLevels - 1][i]);
        hi = std::max(hi, level[kLevels - 1][i]);
      }
      out.ranges[k] = hi - lo;
      out.max_range = std::max(out.max_range, out.ranges[k]);
    }
    out.u_rows = fmf->u.size() / kComponents;
    const uint32_t st = kLayout.stored_size();
    for (uint32_t g = 0; g < kComponents / 4; ++g)
      for (uint32_t l = 0; l < kLevels; ++l) {
        const int s = static_cast<int>(kLayout.tile_size << l);
        for (uint32_t ty = 0; ty < (1u << l); ++ty)
          for (uint32_t tx = 0; tx < (1u << l); ++tx) {
            Tile t{TileId{g, l, tx, ty}, std::vector<float>(kLayout.sample_count())};
            for (uint32_t j = 0; j < st; ++j)
              for (uint32_t i = 0; i < st; ++i) {
                const int x = ((static_cast<int>(tx * 64 + i) - 4) % s + s) % s;  // wrap: tileable
                const int y = ((static_cast<int>(ty * 64 + j) - 4) % s + s) % s;
                for (uint32_t k = 0; k < 4; ++k)
                  t.samples[(size_t{j} * st + i) * 4 + k] = level[l][(size_t(y) * s + x) * kComponents + 4 * g + k];
              }
            out.tiles.push_back(std::move(t));
          }
      }
    out.raw_half_bytes = out.tiles.size() * kLayout.sample_count() * 2;
    return out;
  }
}
const Content& content() {  // the timed content: procedural stone, analytic BRDF (noisy, hard to code)
  static const Content c = make_content(SynthMaterial::stone, nullptr);
  return c;
}
// A smoother material for the ratio table: leather mesostructure with a measured car-paint BRDF.
const Content* smooth_content() {
  static const MeasuredBrdf brdf = [] {
    auto b = read_mbsdf(std::string(BTFLOD_SHARED_DIR) + "/data/measured/carpaint_red.mbsdf");
    return b ? std::move(*b) : MeasuredBrdf{};
  }();
  if (brdf.empty()) return nullptr;
  static const Content c = make_content(SynthMaterial::leather, &brdf);
  return &c;
}

struct Coded {
  float quality = 0;
  std::vector<std::vector<uint8_t>> payloads;
  std::map<uint64_t, std::vector<float>> recon;
  size_t bytes = 0;
  double rmse = 0;  // RMSE over all samples, eigen-texture units
};

// PSNR of the BTF reconstructed from the coded eigen-textures: U has orthonormal columns, so the
// BTF's squared error per texel is Σ_c e_c² spread over m rows: RMSE_btf = RMSE_eig · √(C / m).
double btf_psnr(const Content& c, double eigen_rmse) {
  const double rmse_btf = eigen_rmse * std::sqrt(static_cast<double>(kComponents) / static_cast<double>(c.u_rows));
  return 20.0 * std::log10(c.btf_peak / rmse_btf);
}

Coded code_all(float quality, const Content& c = content(), uint32_t weight_quarters = kJpegWeightQuarters,
               TileEntropyCoder coder = TileEntropyCoder::deflate) {
  Coded out;
  out.quality = quality;
  TileEncoder enc(kLayout);
  enc.set_weight_quarters(weight_quarters);
  if (!enc.set_entropy_coder(coder)) std::exit(3);
  std::vector<uint8_t> buffer(enc.bound());
  double err = 0;
  size_t n = 0;
  for (const Tile& t : c.tiles) {
    float tol[4];
    for (uint32_t k = 0; k < 4; ++k) tol[k] = tolerance_for_quality(quality, c.max_range);
    std::vector<float> recon(kLayout.sample_count());
    std::span<const float> parent;
    if (t.id.level > 0) parent = out.recon.at(t.id.parent().key());
    size_t written = 0;
    if (enc.encode(t.samples, parent, t.id.x & 1, t.id.y & 1, tol, buffer, written, recon) != Status::success)
      std::exit(2);
    out.payloads.emplace_back(buffer.begin(), buffer.begin() + written);
    out.bytes += written;
    for (size_t i = 0; i < recon.size(); ++i) {
      const double d = recon[i] - t.samples[i];
      err += d * d;
      ++n;
    }
    out.recon[t.id.key()] = std::move(recon);
  }
  out.rmse = std::sqrt(err / n);
  return out;
}

// 8-bit grayscale planes of every tile component: (v − min) / range · 255.
struct Planes {
  std::vector<std::vector<uint8_t>> planes;
  std::vector<float> lo, scale;  // per plane
};
Planes make_planes(const Content& c) {
  {
    Planes out;
    const uint32_t n = kLayout.stored_size();
    for (const Tile& t : c.tiles)
      for (uint32_t k = 0; k < 4; ++k) {
        float lo = INFINITY, hi = -INFINITY;
        for (size_t i = k; i < t.samples.size(); i += 4) {
          lo = std::min(lo, t.samples[i]);
          hi = std::max(hi, t.samples[i]);
        }
        // Each plane scaled by its own min..max: the most favourable 8-bit mapping for JPEG.
        const float range = std::max(hi - lo, 1e-12f);
        std::vector<uint8_t> plane(size_t{n} * n);
        for (size_t i = 0; i < plane.size(); ++i)
          plane[i] =
              static_cast<uint8_t>(std::clamp(std::lround((t.samples[i * 4 + k] - lo) / range * 255.0f), 0L, 255L));
        out.planes.push_back(std::move(plane));
        out.lo.push_back(lo);
        out.scale.push_back(range / 255.0f);
      }
    return out;
  }
}
const Planes& planes() {
  static const Planes p = make_planes(content());
  return p;
}

struct JpegCoded {
  int quality = 0;
  std::vector<std::vector<uint8_t>> streams;
  size_t bytes = 0;
  double rmse = 0;
};

JpegCoded jpeg_all(int quality, const Content& content_ = content(), const Planes& p = planes()) {
  const int n = static_cast<int>(kLayout.stored_size());
  tjhandle c = tjInitCompress(), d = tjInitDecompress();
  JpegCoded out;
  out.quality = quality;
  std::vector<uint8_t> back(size_t(n) * n);
  double err = 0;
  size_t count = 0;
  for (size_t pi = 0; pi < p.planes.size(); ++pi) {
    unsigned char* buf = nullptr;
    unsigned long size = 0;
    tjCompress2(c, p.planes[pi].data(), n, n, n, TJPF_GRAY, &buf, &size, TJSAMP_GRAY, quality, 0);
    out.streams.emplace_back(buf, buf + size);
    out.bytes += size;
    tjFree(buf);
    tjDecompress2(d, out.streams.back().data(), size, back.data(), n, n, n, TJPF_GRAY, 0);
    const Tile& t = content_.tiles[pi / 4];
    const uint32_t k = static_cast<uint32_t>(pi % 4);
    for (size_t i = 0; i < back.size(); ++i) {
      const double v = p.lo[pi] + back[i] * p.scale[pi];
      const double e = v - t.samples[i * 4 + k];
      err += e * e;
      ++count;
    }
  }
  tjDestroy(c);
  tjDestroy(d);
  out.rmse = std::sqrt(err / count);
  return out;
}

// The lowest JPEG quality whose RMSE is <= `target` (binary search; RMSE falls with quality),
// or quality 100 when even that is above the target (8-bit rounding sets a floor).
JpegCoded jpeg_matched(double target, const Content& c = content(), const Planes& p = planes()) {
  int lo = 1, hi = 100;
  while (lo < hi) {
    const int mid = (lo + hi) / 2;
    if (jpeg_all(mid, c, p).rmse <= target) {
      hi = mid;
    } else {
      lo = mid + 1;
    }
  }
  return jpeg_all(lo, c, p);
}

constexpr float kBenchQuality = 50.0f;
const Coded& coded_q() {
  static const Coded c = code_all(kBenchQuality);
  return c;
}
// The same tiles with the frequency weighting btflod-convert build's perceptual default writes
// (JPEG^(1/4), kPerceptualWeightQuarters): a flatter table puts more non-zero coefficients at
// high frequencies, which the decoder's zero-run skipping and partial inverse DCT see.
const Coded& coded_q_perceptual_weighting() {
  static const Coded c = code_all(kBenchQuality, content(), kPerceptualWeightQuarters);
  return c;
}
// The same tiles with zstd-coded symbol streams (tile format 3): identical reconstruction.
const Coded& coded_q_zstd() {
  static const Coded c = code_all(kBenchQuality, content(), kJpegWeightQuarters, TileEntropyCoder::zstd);
  return c;
}
const Coded& coded_q_perceptual_weighting_zstd() {
  static const Coded c = code_all(kBenchQuality, content(), kPerceptualWeightQuarters, TileEntropyCoder::zstd);
  return c;
}
const JpegCoded& jpeg_q() {
  static const JpegCoded j = jpeg_matched(coded_q().rmse);
  return j;
}

void set_rates(benchmark::State& state, size_t samples_per_iteration) {
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * samples_per_iteration * 2));  // raw half bytes
  state.counters["s_per_sample"] =
      benchmark::Counter(static_cast<double>(samples_per_iteration) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// --- decode ---------------------------------------------------------------------------------
// Decodes tile i of content() from `coded` (its parent's reconstruction as the prediction).
bool decode_tile_at(TileDecoder& dec, const Coded& coded, size_t i, std::span<float> out) {
  const Tile& t = content().tiles[i];
  std::span<const float> parent;
  if (t.id.level > 0) parent = coded.recon.at(t.id.parent().key());
  const bool ok = dec.decode(coded.payloads[i], parent, t.id.x & 1, t.id.y & 1, out) == Status::success;
  benchmark::DoNotOptimize(out.data());
  return ok;
}
// Decodes the four JPEG planes of tile i (modulo the tiles `j` holds) into `plane`.
void turbojpeg_decode_tile_at(tjhandle d, const JpegCoded& j, size_t i, std::vector<uint8_t>& plane) {
  const int n = static_cast<int>(kLayout.stored_size());
  for (size_t k = 0; k < 4; ++k) {
    const auto& s = j.streams[(i * 4 + k) % j.streams.size()];
    tjDecompress2(d, s.data(), s.size(), plane.data(), n, n, n, TJPF_GRAY, 0);
    benchmark::DoNotOptimize(plane.data());
  }
}

// Decodes the content's tiles in turn with `dec`, one per iteration; rates per tile sample.
void decode_each_tile(benchmark::State& state, TileDecoder& dec, const Coded& coded) {
  const Content& c = content();
  std::vector<float> out(kLayout.sample_count());
  size_t i = 0;
  for (auto _ : state) {
    if (!decode_tile_at(dec, coded, i, out)) state.SkipWithError("decode");
    i = (i + 1) % c.tiles.size();
  }
  set_rates(state, kLayout.sample_count());
}

void decode_tiles(benchmark::State& state, InflateBackend backend, const Coded& coded = coded_q()) {
  TileDecoder dec(kLayout, backend);
  decode_each_tile(state, dec, coded);
  state.counters["bytes_per_tile"] = static_cast<double>(coded.bytes) / content().tiles.size();
}
void BM_btflod_decode_tile_zlib(benchmark::State& state) { decode_tiles(state, InflateBackend::zlib); }
BENCHMARK(BM_btflod_decode_tile_zlib);
void BM_btflod_decode_tile_libdeflate(benchmark::State& state) { decode_tiles(state, InflateBackend::libdeflate); }
BENCHMARK(BM_btflod_decode_tile_libdeflate);
void BM_btflod_decode_tile_libdeflate_weighting_1_4(benchmark::State& state) {
  decode_tiles(state, InflateBackend::libdeflate, coded_q_perceptual_weighting());
}
BENCHMARK(BM_btflod_decode_tile_libdeflate_weighting_1_4);
// zstd-coded tiles (BsvtfBuildOptions::entropy_coder = zstd): the same samples, baselines above
// and BM_turbojpeg_decode_tile_4_planes* below (same run).
void BM_btflod_decode_tile_zstd(benchmark::State& state) {
  if (!tile_entropy_coder_available(TileEntropyCoder::zstd)) return state.SkipWithError("built without zstd");
  decode_tiles(state, InflateBackend::libdeflate, coded_q_zstd());
}
BENCHMARK(BM_btflod_decode_tile_zstd);
void BM_btflod_decode_tile_zstd_weighting_1_4(benchmark::State& state) {
  if (!tile_entropy_coder_available(TileEntropyCoder::zstd)) return state.SkipWithError("built without zstd");
  decode_tiles(state, InflateBackend::libdeflate, coded_q_perceptual_weighting_zstd());
}
BENCHMARK(BM_btflod_decode_tile_zstd_weighting_1_4);

// Decode stages (profile): the same tiles, libdeflate backend. inflate = header checks + inflate
// only; upsample = the parent prediction only; scalar = the whole decode with the AVX2 inverse
// DCT disabled (its scalar twin). Symbol parsing + dequantisation + inverse DCT + add is the
// whole decode minus inflate and upsample.
void BM_btflod_decode_stage_inflate(benchmark::State& state) {
  const Content& c = content();
  const Coded& coded = coded_q();
  TileDecoder dec(kLayout, InflateBackend::libdeflate);
  std::vector<float> out(kLayout.sample_count());
  size_t i = 0, symbols = 0;
  for (auto _ : state) {
    const Tile& t = c.tiles[i];
    std::span<const float> parent;
    if (t.id.level > 0) parent = coded.recon.at(t.id.parent().key());
    if (dec.inflate_symbols(coded.payloads[i], parent, out) != Status::success) state.SkipWithError("inflate");
    symbols += dec.symbol_bytes();
    i = (i + 1) % c.tiles.size();
  }
  set_rates(state, kLayout.sample_count());
  state.counters["symbol_bytes_per_tile"] = static_cast<double>(symbols) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_btflod_decode_stage_inflate);
void BM_btflod_decode_stage_upsample(benchmark::State& state) {
  const Coded& coded = coded_q();
  const auto& parent = coded.recon.begin()->second;
  std::vector<float> out(kLayout.sample_count());
  uint32_t q = 0;
  for (auto _ : state) {
    upsample_parent(kLayout, parent.data(), q & 1, q >> 1 & 1, out.data());
    benchmark::DoNotOptimize(out.data());
    ++q;
  }
  set_rates(state, kLayout.sample_count());
}
BENCHMARK(BM_btflod_decode_stage_upsample);
void BM_btflod_decode_tile_libdeflate_scalar(benchmark::State& state) {
  TileDecoder dec(kLayout, InflateBackend::libdeflate);
  dec.set_simd(false);
  decode_each_tile(state, dec, coded_q());
}
BENCHMARK(BM_btflod_decode_tile_libdeflate_scalar);

void turbojpeg_decode_tiles(benchmark::State& state, const JpegCoded& j) {
  const int n = static_cast<int>(kLayout.stored_size());
  tjhandle d = tjInitDecompress();
  std::vector<uint8_t> out(size_t(n) * n);
  size_t i = 0;
  for (auto _ : state) {
    turbojpeg_decode_tile_at(d, j, i, out);
    i = (i + 1) % (j.streams.size() / 4);
  }
  tjDestroy(d);
  set_rates(state, kLayout.sample_count());
  state.counters["bytes_per_tile"] = static_cast<double>(j.bytes) / (j.streams.size() / 4);
  state.counters["jpeg_quality"] = j.quality;
}
void BM_turbojpeg_decode_tile_4_planes(benchmark::State& state) { turbojpeg_decode_tiles(state, jpeg_q()); }
BENCHMARK(BM_turbojpeg_decode_tile_4_planes);
// libjpeg-turbo matched to the error of the JPEG^(1/4)-weighted tiles (the baseline of
// BM_btflod_decode_tile_libdeflate_weighting_1_4).
void BM_turbojpeg_decode_tile_4_planes_matched_1_4(benchmark::State& state) {
  static const JpegCoded j = jpeg_matched(coded_q_perceptual_weighting().rmse);
  turbojpeg_decode_tiles(state, j);
}
BENCHMARK(BM_turbojpeg_decode_tile_4_planes_matched_1_4);

// The decode-speed ratio in one benchmark: each iteration decodes the same kPairTiles tiles with
// btflod and, right after, as four JPEG planes at the matched error (jpeg_q()), alternating which
// goes first, and records t_turbojpeg / t_btflod for that pair. Load that drifts during a run
// moves both sides of a pair alike, so these ratios are steadier than the ratio of two separately
// timed benchmarks. Counters (> 1: btflod decodes the samples faster): sample_rate_ratio =
// Σ t_turbojpeg / Σ t_btflod (the ratio of the sample rates), and the median and
// quartiles of the per-pair ratio (their spread is mostly tile content: the tiles of a pair
// change every iteration).
constexpr size_t kPairTiles = 8;
void decode_pairs(benchmark::State& state, const Coded& coded) {
  const Content& c = content();
  const JpegCoded& j = jpeg_q();
  TileDecoder dec(kLayout, InflateBackend::libdeflate);
  const int n = static_cast<int>(kLayout.stored_size());
  tjhandle d = tjInitDecompress();
  std::vector<float> out(kLayout.sample_count());
  std::vector<uint8_t> plane(size_t(n) * n);
  std::vector<double> ratios;
  double sum_btflod = 0, sum_jpeg = 0;
  size_t first = 0;
  bool btflod_first = true;
  const auto decode_btflod = [&] {
    for (size_t k = 0; k < kPairTiles; ++k)
      if (!decode_tile_at(dec, coded, (first + k) % c.tiles.size(), out)) return false;
    return true;
  };
  const auto decode_jpeg = [&] {
    for (size_t k = 0; k < kPairTiles; ++k) turbojpeg_decode_tile_at(d, j, (first + k) % c.tiles.size(), plane);
  };
  using clock = std::chrono::steady_clock;
  for (auto _ : state) {
    double t_btflod = 0, t_jpeg = 0;
    for (int side = 0; side < 2; ++side) {
      const auto t0 = clock::now();
      const bool btflod_now = (side == 0) == btflod_first;
      if (btflod_now) {
        if (!decode_btflod()) {
          state.SkipWithError("decode");
          break;
        }
      } else {
        decode_jpeg();
      }
      const double s = std::chrono::duration<double>(clock::now() - t0).count();
      (btflod_now ? t_btflod : t_jpeg) = s;
    }
    if (t_btflod > 0) ratios.push_back(t_jpeg / t_btflod);
    sum_btflod += t_btflod;
    sum_jpeg += t_jpeg;
    btflod_first = !btflod_first;
    first = (first + kPairTiles) % c.tiles.size();
  }
  tjDestroy(d);
  if (ratios.empty()) return;
  std::sort(ratios.begin(), ratios.end());
  const auto at = [&](double q) { return ratios[static_cast<size_t>(q * static_cast<double>(ratios.size() - 1))]; };
  state.counters["sample_rate_ratio"] = sum_jpeg / sum_btflod;
  state.counters["median"] = at(0.5);
  state.counters["q1"] = at(0.25);
  state.counters["q3"] = at(0.75);
  state.counters["pairs"] = static_cast<double>(ratios.size());
}
void BM_decode_pairs_zstd_vs_turbojpeg(benchmark::State& state) {
  if (!tile_entropy_coder_available(TileEntropyCoder::zstd)) return state.SkipWithError("built without zstd");
  decode_pairs(state, coded_q_zstd());
}
BENCHMARK(BM_decode_pairs_zstd_vs_turbojpeg)->MinTime(1.0);
void BM_decode_pairs_libdeflate_vs_turbojpeg(benchmark::State& state) { decode_pairs(state, coded_q()); }
BENCHMARK(BM_decode_pairs_libdeflate_vs_turbojpeg)->MinTime(1.0);

struct DeflatedHalves {
  std::vector<std::vector<uint8_t>> streams;
  size_t bytes = 0;
};
const DeflatedHalves& deflated_halves() {
  static const DeflatedHalves d = [] {
    DeflatedHalves out;
    std::vector<uint16_t> halves(kLayout.sample_count());
    for (const Tile& t : content().tiles) {
      out.streams.push_back(btflod::bench::deflate_raw_halves(t.samples, halves));
      out.bytes += out.streams.back().size();
    }
    return out;
  }();
  return d;
}

void BM_zlib_deflate_raw_halves_decode_tile(benchmark::State& state) {
  const DeflatedHalves& d = deflated_halves();
  std::vector<uint16_t> halves(kLayout.sample_count());
  std::vector<float> out(kLayout.sample_count());
  size_t i = 0;
  for (auto _ : state) {
    uLongf size = static_cast<uLongf>(halves.size() * 2);
    uncompress(reinterpret_cast<Bytef*>(halves.data()), &size, d.streams[i].data(), d.streams[i].size());
    half_to_float(halves, out);
    benchmark::DoNotOptimize(out.data());
    i = (i + 1) % d.streams.size();
  }
  set_rates(state, kLayout.sample_count());
  state.counters["bytes_per_tile"] = static_cast<double>(d.bytes) / d.streams.size();
}
BENCHMARK(BM_zlib_deflate_raw_halves_decode_tile);

// Entropy stage only: zlib's inflate (inside TileDecoder) vs libdeflate on the same streams.
void BM_entropy_only_zlib_inflate(benchmark::State& state) {
  const Coded& coded = coded_q();
  std::vector<uint8_t> out(tile_symbol_bound(kLayout));
  z_stream z{};
  inflateInit2(&z, -15);
  size_t i = 0;
  for (auto _ : state) {
    const auto& p = coded.payloads[i];
    const size_t h = tile_header_size(4);
    inflateReset(&z);
    z.next_in = const_cast<Bytef*>(p.data() + h);
    z.avail_in = static_cast<uInt>(p.size() - h);
    z.next_out = out.data();
    z.avail_out = static_cast<uInt>(out.size());
    inflate(&z, Z_FINISH);
    benchmark::DoNotOptimize(out.data());
    i = (i + 1) % coded.payloads.size();
  }
  inflateEnd(&z);
  set_rates(state, kLayout.sample_count());
}
BENCHMARK(BM_entropy_only_zlib_inflate);

void BM_entropy_only_libdeflate(benchmark::State& state) {
  const Coded& coded = coded_q();
  std::vector<uint8_t> out(tile_symbol_bound(kLayout));
  libdeflate_decompressor* d = libdeflate_alloc_decompressor();
  size_t i = 0;
  for (auto _ : state) {
    const auto& p = coded.payloads[i];
    const size_t h = tile_header_size(4);
    size_t got = 0;
    libdeflate_deflate_decompress(d, p.data() + h, p.size() - h, out.data(), out.size(), &got);
    benchmark::DoNotOptimize(out.data());
    i = (i + 1) % coded.payloads.size();
  }
  libdeflate_free_decompressor(d);
  set_rates(state, kLayout.sample_count());
}
BENCHMARK(BM_entropy_only_libdeflate);

// --- encode ---------------------------------------------------------------------------------
void BM_btflod_encode_tile(benchmark::State& state) {
  const Content& c = content();
  const Coded& coded = coded_q();
  TileEncoder enc(kLayout);
  std::vector<uint8_t> buffer(enc.bound());
  size_t i = 0;
  for (auto _ : state) {
    const Tile& t = c.tiles[i];
    float tol[4];
    for (uint32_t k = 0; k < 4; ++k) tol[k] = tolerance_for_quality(kBenchQuality, c.max_range);
    std::span<const float> parent;
    if (t.id.level > 0) parent = coded.recon.at(t.id.parent().key());
    size_t written = 0;
    if (enc.encode(t.samples, parent, t.id.x & 1, t.id.y & 1, tol, buffer, written) != Status::success)
      state.SkipWithError("encode");
    benchmark::DoNotOptimize(buffer.data());
    i = (i + 1) % c.tiles.size();
  }
  set_rates(state, kLayout.sample_count());
}
BENCHMARK(BM_btflod_encode_tile);

void BM_turbojpeg_encode_tile_4_planes(benchmark::State& state) {
  const Planes& p = planes();
  const int n = static_cast<int>(kLayout.stored_size());
  const int q = jpeg_q().quality;
  tjhandle c = tjInitCompress();
  std::vector<uint8_t> buf(tjBufSize(n, n, TJSAMP_GRAY));
  size_t i = 0;
  for (auto _ : state) {
    for (int k = 0; k < 4; ++k) {
      unsigned char* out = buf.data();
      unsigned long size = buf.size();
      tjCompress2(c, p.planes[(i * 4 + k) % p.planes.size()].data(), n, n, n, TJPF_GRAY, &out, &size, TJSAMP_GRAY, q,
                  TJFLAG_NOREALLOC);
      benchmark::DoNotOptimize(out);
    }
    i = (i + 1) % (p.planes.size() / 4);
  }
  tjDestroy(c);
  set_rates(state, kLayout.sample_count());
}
BENCHMARK(BM_turbojpeg_encode_tile_4_planes);

void BM_zlib_deflate_raw_halves_encode_tile(benchmark::State& state) {
  const Content& c = content();
  std::vector<uint16_t> halves(kLayout.sample_count());
  std::vector<uint8_t> out(compressBound(static_cast<uLong>(halves.size() * 2)));
  size_t i = 0;
  for (auto _ : state) {
    float_to_half(c.tiles[i].samples, halves);
    uLongf size = static_cast<uLongf>(out.size());
    compress2(out.data(), &size, reinterpret_cast<const Bytef*>(halves.data()), halves.size() * 2, 6);
    benchmark::DoNotOptimize(out.data());
    i = (i + 1) % c.tiles.size();
  }
  set_rates(state, kLayout.sample_count());
}
BENCHMARK(BM_zlib_deflate_raw_halves_encode_tile);

// --- compression ratio table -----------------------------------------------------------------
void print_ratio_table(const Content& c, const char* name) {
  const Planes p = make_planes(c);
  std::printf(
      "Tile content: %s: %zu tiles of %ux%u x 4 components (FMF eigen-textures V*S, %zu rows of U,\n"
      "  BTF peak %.3f), raw halves %zu bytes\n",
      name, c.tiles.size(), kLayout.stored_size(), kLayout.stored_size(), c.u_rows, c.btf_peak, c.raw_half_bytes);
  std::printf("%7s | %13s %9s %12s %9s | %8s %9s %9s\n", "quality", "btflod B/tile", "ratio", "eigen RMSE", "BTF PSNR",
              "jpeg q", "ratio", "BTF PSNR");
  for (float q : {5.0f, 10.0f, 25.0f, 50.0f, 75.0f, 90.0f}) {
    const Coded cd = code_all(q, c);
    const JpegCoded j = jpeg_matched(cd.rmse, c, p);
    std::printf("%7.0f | %13.0f %8.2f:1 %12.3g %8.2fdB | %8d %8.2f:1 %8.2fdB\n", q,
                static_cast<double>(cd.bytes) / c.tiles.size(), static_cast<double>(c.raw_half_bytes) / cd.bytes,
                cd.rmse, btf_psnr(c, cd.rmse), j.quality, static_cast<double>(c.raw_half_bytes) / j.bytes,
                btf_psnr(c, j.rmse));
  }
  std::printf("\n");
}

void print_ratio_tables() {
  std::printf("deflate(zlib 6) alone on the stone's raw halves: ratio %.2f:1 (lossless)\n",
              static_cast<double>(content().raw_half_bytes) / deflated_halves().bytes);
  print_ratio_table(content(), "procedural stone, analytic BRDF (noisy; the timed content)");
  {
    const Coded& a = coded_q();
    const Coded& b = coded_q_perceptual_weighting();
    std::printf(
        "quality %.0f with JPEG^(1/4) frequency weighting (kPerceptualWeightQuarters): %.0f B/tile, %.2f:1, eigen RMSE "
        "%.4g,"
        " BTF PSNR %.1f dB (JPEG's table: %.0f B/tile, %.2f:1, RMSE %.4g, %.1f dB)\n\n",
        static_cast<double>(kBenchQuality), static_cast<double>(b.bytes) / content().tiles.size(),
        static_cast<double>(content().raw_half_bytes) / b.bytes, b.rmse, btf_psnr(content(), b.rmse),
        static_cast<double>(a.bytes) / content().tiles.size(), static_cast<double>(content().raw_half_bytes) / a.bytes,
        a.rmse, btf_psnr(content(), a.rmse));
  }
  if (const Content* smooth = smooth_content()) {
    print_ratio_table(*smooth, "procedural leather, measured car paint carpaint_red.mbsdf (smoother)");
  } else {
    std::printf("(car-paint material skipped: %s/data/measured/carpaint_red.mbsdf not readable)\n\n",
                BTFLOD_SHARED_DIR);
  }
  std::printf(
      "(one shared absolute tolerance, ToleranceReference::shared_max; ratio = raw half floats / coded bytes;\n"
      " BTF PSNR = 20 log10(BTF peak / RMSE of the reconstructed BTF), exact from the eigen-texture error since U is\n"
      " orthonormal; JPEG codes each component plane as 8-bit gray over its own min..max at the lowest JPEG quality\n"
      " whose RMSE is <= btflod's (100 when none is); the speeds below use quality %.0f on the stone)\n\n",
      kBenchQuality);
  std::fflush(stdout);
}

}  // namespace

namespace {
// --- real containers (--bsvtf) ---------------------------------------------------------------
struct LoadedContainer {
  btflod::bench::ContainerTiles tiles;
  btflod::bench::detail::Baselines base;
  std::vector<btflod::bench::TileCodec> codecs;
};

// Registers BM_bsvtf_decode/<file>/<codec>/level:<l> (and /all) for every container. Returns false
// after printing the reason when a file cannot be used.
bool register_container_benchmarks(const std::vector<std::string>& files, int jpeg_quality) {
  static std::vector<std::unique_ptr<LoadedContainer>> loaded;  // alive while benchmarks run
  for (const std::string& path : files) {
    auto c = btflod::bench::load_container_tiles(path);
    if (!c) {
      std::fprintf(stderr, "bench_codec: --bsvtf %s: %s\n", path.c_str(), c.message().c_str());
      return false;
    }
    auto lc = std::make_unique<LoadedContainer>();
    lc->tiles = std::move(*c);
    lc->base = btflod::bench::detail::make_baselines(lc->tiles, jpeg_quality);
    lc->codecs = btflod::bench::make_tile_decoders(lc->tiles, lc->base, jpeg_quality);
    const std::string stem = path.substr(path.find_last_of('/') == std::string::npos ? 0 : path.find_last_of('/') + 1);
    std::printf("%s: %zu tiles, %u levels\n", path.c_str(), lc->tiles.ids.size(), lc->tiles.metadata.level_count);
    const LoadedContainer* p = lc.get();
    for (size_t k = 0; k < p->codecs.size(); ++k)
      for (uint32_t l = 0; l <= p->tiles.metadata.level_count; ++l) {
        const bool all = l == p->tiles.metadata.level_count;
        std::vector<size_t> list;
        if (all) {
          for (size_t i = 0; i < p->tiles.ids.size(); ++i) list.push_back(i);
        } else {
          list = p->tiles.by_level[l];
        }
        if (list.empty()) continue;
        const std::string name =
            "BM_bsvtf_decode/" + stem + "/" + p->codecs[k].name + (all ? "/all" : "/level:" + std::to_string(l));
        benchmark::RegisterBenchmark(name.c_str(), [p, k, list](benchmark::State& state) {
          size_t i = 0;
          for (auto _ : state) {
            p->codecs[k].decode(list[i]);
            i = i + 1 == list.size() ? 0 : i + 1;
          }
          state.SetItemsProcessed(state.iterations());  // tiles
          state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(p->tiles.layout.sample_count() * 2));
          state.counters["coded_bytes_per_tile"] =
              static_cast<double>(p->codecs[k].bytes) / static_cast<double>(p->tiles.ids.size());
        })->Unit(benchmark::kMicrosecond);
      }
    loaded.push_back(std::move(lc));
  }
  return true;
}
}  // namespace

int main(int argc, char** argv) {
  // --bsvtf / --jpeg-quality are ours: taken out before Google Benchmark parses the rest.
  std::vector<std::string> containers;
  int jpeg_quality = 90;
  std::vector<char*> args{argv[0]};
  bool user_filter = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--bsvtf" || a == "--jpeg-quality") && i + 1 < argc) {
      if (a == "--bsvtf")
        containers.push_back(argv[++i]);
      else
        jpeg_quality = std::clamp(std::atoi(argv[++i]), 1, 100);
      continue;
    }
    user_filter = user_filter || a.rfind("--benchmark_filter", 0) == 0;
    args.push_back(argv[i]);
  }
  static char filter[] = "--benchmark_filter=^BM_bsvtf_decode/";
  if (!containers.empty()) {
    if (!register_container_benchmarks(containers, jpeg_quality)) return 2;
    if (!user_filter) args.push_back(filter);
    btflod::bench::add_steady_repetitions(args);
  }
  return btflod::bench::run_benchmarks(args, [&] {
    if (containers.empty()) print_ratio_tables();
  });
}
