// btflod-bench — decoding (and optionally encoding) every tile of a real .bsvtf container, per
// level, next to baselines on the same tiles in the same run:
//   btflod/zlib, btflod/libdeflate  the tile decoder with each inflate backend
//   turbojpeg                       libjpeg-turbo decoding each tile's 4 component planes coded as
//                                   8-bit gray over their own min..max (quality --jpeg-quality)
//   zlib-raw, libdeflate-raw        inflating the tile's decoded samples stored as deflated raw
//                                   half floats (lossless) + half→float
// Repetitions are interleaved (each repetition runs every codec once, in a rotating order) and
// each figure is the median over repetitions. MB/s counts decoded raw half-float bytes
// ((T + 2B)² × 4 × 2 per tile), the same unit for every codec. Also used by bench/bench_codec.cpp.
#pragma once

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#if defined(BTFLOD_BENCH_HAS_LIBDEFLATE)
#include <libdeflate.h>
#endif
#if defined(BTFLOD_BENCH_HAS_TURBOJPEG)
#include <turbojpeg.h>
#endif

#include "btflod/core/file_io.hpp"
#include "btflod/core/half.hpp"
#include "btflod/offline/build/perceptual_tolerance.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "report.hpp"

namespace btflod::bench {

/// A container's tiles, verified and decoded once (the parents every residual tile needs).
struct ContainerTiles {
  std::string path;
  BsvtfMetadata metadata;
  TileLayout layout;
  std::vector<TileId> ids;                         ///< coarse to fine
  std::vector<std::span<const uint8_t>> payloads;  ///< into bytes
  std::vector<std::vector<float>> decoded;         ///< per tile
  std::vector<int64_t> parent;                     ///< index of the parent tile, −1 for level 0
  std::vector<std::vector<size_t>> by_level;
  std::vector<uint8_t> bytes;
};

/// Reads a container, checks every payload CRC and decodes every tile coarse to fine.
inline Result<ContainerTiles> load_container_tiles(const std::string& path) {
  ContainerTiles c;
  c.path = path;
  auto bytes = read_file_bytes(path);
  if (!bytes) return bytes.error();
  c.bytes = std::move(*bytes);
  auto dir = read_bsvtf(c.bytes);
  if (!dir) return make_error(dir.status(), "%s: %s", path.c_str(), dir.message().c_str());
  c.metadata = dir->metadata;
  c.layout = c.metadata.layout();
  c.by_level.resize(c.metadata.level_count);
  std::map<uint64_t, size_t> index;
  for (uint32_t level = 0; level < c.metadata.level_count; ++level)
    for (const BsvtfTileEntry& e : dir->tiles) {
      if (e.id.level != level) continue;
      const auto payload = std::span<const uint8_t>(c.bytes).subspan(e.offset, e.size);
      if (verify_bsvtf_payload(e.size, e.crc, payload) != Status::success)
        return make_error(Status::bad_data, "%s: tile (%u, level %u, %u, %u): payload CRC mismatch", path.c_str(),
                          e.id.texture, e.id.level, e.id.x, e.id.y);
      int64_t parent = -1;
      if (level > 0) {
        auto it = index.find(e.id.parent().key());
        if (it == index.end()) return make_error(Status::bad_data, "%s: tile without parent", path.c_str());
        parent = static_cast<int64_t>(it->second);
      }
      index[e.id.key()] = c.ids.size();
      c.by_level[level].push_back(c.ids.size());
      c.ids.push_back(e.id);
      c.payloads.push_back(payload);
      c.parent.push_back(parent);
    }
  TileDecoder dec(c.layout);
  c.decoded.resize(c.ids.size());
  for (size_t i = 0; i < c.ids.size(); ++i) {
    c.decoded[i].resize(c.layout.sample_count());
    std::span<const float> parent;
    if (c.parent[i] >= 0) parent = c.decoded[static_cast<size_t>(c.parent[i])];
    if (const Status s = dec.decode(c.payloads[i], parent, c.ids[i].x & 1, c.ids[i].y & 1, c.decoded[i]);
        s != Status::success)
      return make_error(s, "%s: tile (%u, level %u, %u, %u): %s", path.c_str(), c.ids[i].texture, c.ids[i].level,
                        c.ids[i].x, c.ids[i].y, dec.message());
  }
  return c;
}

struct CodecOptions {
  int repetitions = 5;
  int jpeg_quality = 90;
  bool encode = false;
  std::vector<float> qualities{25.0f, 50.0f, 90.0f};
};

/// The zlib stream (level 6) of a tile's samples as raw halves: the "no codec" baseline.
/// `halves` is scratch space of the tile's sample count.
inline std::vector<uint8_t> deflate_raw_halves(std::span<const float> samples, std::span<uint16_t> halves) {
  float_to_half(samples, halves);
  uLongf size = compressBound(static_cast<uLong>(halves.size() * 2));
  std::vector<uint8_t> s(size);
  compress2(s.data(), &size, reinterpret_cast<const Bytef*>(halves.data()), halves.size() * 2, 6);
  s.resize(size);
  return s;
}

namespace detail {
struct Baselines {
  std::vector<std::vector<uint8_t>> zlib_raw;  // deflated raw halves per tile
  size_t zlib_raw_bytes = 0;
  std::vector<std::vector<uint8_t>> jpeg;  // 4 planes per tile
  std::vector<float> jpeg_lo, jpeg_scale;
  size_t jpeg_bytes = 0;
  double jpeg_rmse = 0;  // vs the btflod-decoded samples
};

inline Baselines make_baselines(const ContainerTiles& c, int jpeg_quality) {
  Baselines b;
  std::vector<uint16_t> halves(c.layout.sample_count());
  for (const auto& d : c.decoded) {
    b.zlib_raw.push_back(deflate_raw_halves(d, halves));
    b.zlib_raw_bytes += b.zlib_raw.back().size();
  }
#if defined(BTFLOD_BENCH_HAS_TURBOJPEG)
  const int n = static_cast<int>(c.layout.stored_size());
  const uint32_t ch = c.layout.channels;
  tjhandle enc = tjInitCompress(), dec = tjInitDecompress();
  std::vector<uint8_t> plane(size_t(n) * n), back(size_t(n) * n);
  double err = 0;
  size_t count = 0;
  for (const auto& d : c.decoded)
    for (uint32_t k = 0; k < ch; ++k) {
      float lo = INFINITY, hi = -INFINITY;
      for (size_t i = k; i < d.size(); i += ch) lo = std::min(lo, d[i]), hi = std::max(hi, d[i]);
      const float range = std::max(hi - lo, 1e-12f);
      for (size_t i = 0; i < plane.size(); ++i)
        plane[i] = static_cast<uint8_t>(std::clamp(std::lround((d[i * ch + k] - lo) / range * 255.0f), 0L, 255L));
      unsigned char* buf = nullptr;
      unsigned long size = 0;
      tjCompress2(enc, plane.data(), n, n, n, TJPF_GRAY, &buf, &size, TJSAMP_GRAY, jpeg_quality, 0);
      b.jpeg.emplace_back(buf, buf + size);
      b.jpeg_bytes += size;
      tjFree(buf);
      b.jpeg_lo.push_back(lo);
      b.jpeg_scale.push_back(range / 255.0f);
      tjDecompress2(dec, b.jpeg.back().data(), size, back.data(), n, n, n, TJPF_GRAY, 0);
      for (size_t i = 0; i < back.size(); ++i) {
        const double e = lo + back[i] * (range / 255.0f) - d[i * ch + k];
        err += e * e;
        ++count;
      }
    }
  tjDestroy(enc);
  tjDestroy(dec);
  b.jpeg_rmse = count ? std::sqrt(err / static_cast<double>(count)) : 0.0;
#else
  (void)jpeg_quality;
#endif
  return b;
}
}  // namespace detail

/// One codec decoding tile i of a container (the tile's samples land in a scratch buffer).
struct TileCodec {
  std::string name;
  std::function<void(size_t)> decode;
  size_t bytes = 0;  ///< coded bytes of all tiles
};

/// Every decoder measured on a container: btflod (zlib, and libdeflate when built with it),
/// deflated raw halves (zlib, libdeflate) and libjpeg-turbo when available. The functions keep
/// `c` and `base` by reference (both must outlive them) and own their scratch buffers.
inline std::vector<TileCodec> make_tile_decoders(const ContainerTiles& c, const detail::Baselines& base,
                                                 int jpeg_quality) {
  size_t btflod_bytes = 0;
  for (const auto& p : c.payloads) btflod_bytes += p.size();
  struct Scratch {
    std::vector<float> out;
    std::vector<uint16_t> halves;
    std::vector<uint8_t> plane;
  };
  auto scratch = std::make_shared<Scratch>();
  scratch->out.resize(c.layout.sample_count());
  scratch->halves.resize(c.layout.sample_count());
  scratch->plane.resize(c.layout.texel_count());
  std::vector<TileCodec> codecs;
  auto btflod_decoder = [&](InflateBackend backend) {
    auto dec = std::make_shared<TileDecoder>(c.layout, backend);
    return [&c, dec, scratch](size_t i) {
      std::span<const float> parent;
      if (c.parent[i] >= 0) parent = c.decoded[static_cast<size_t>(c.parent[i])];
      if (dec->decode(c.payloads[i], parent, c.ids[i].x & 1, c.ids[i].y & 1, scratch->out) != Status::success)
        std::abort();
    };
  };
  codecs.push_back({"btflod_zlib", btflod_decoder(InflateBackend::zlib), btflod_bytes});
  if (TileDecoder(c.layout, InflateBackend::libdeflate).backend() == InflateBackend::libdeflate)
    codecs.push_back({"btflod_libdeflate", btflod_decoder(InflateBackend::libdeflate), btflod_bytes});
  codecs.push_back({"zlib_raw_halves",
                    [&base, scratch](size_t i) {
                      uLongf size = static_cast<uLongf>(scratch->halves.size() * 2);
                      uncompress(reinterpret_cast<Bytef*>(scratch->halves.data()), &size, base.zlib_raw[i].data(),
                                 base.zlib_raw[i].size());
                      half_to_float(scratch->halves, scratch->out);
                    },
                    base.zlib_raw_bytes});
#if defined(BTFLOD_BENCH_HAS_LIBDEFLATE)
  std::shared_ptr<libdeflate_decompressor> ld(libdeflate_alloc_decompressor(), libdeflate_free_decompressor);
  codecs.push_back({"libdeflate_raw_halves",
                    [&base, ld, scratch](size_t i) {
                      size_t got = 0;
                      libdeflate_zlib_decompress(ld.get(), base.zlib_raw[i].data(), base.zlib_raw[i].size(),
                                                 scratch->halves.data(), scratch->halves.size() * 2, &got);
                      half_to_float(scratch->halves, scratch->out);
                    },
                    base.zlib_raw_bytes});
#endif
#if defined(BTFLOD_BENCH_HAS_TURBOJPEG)
  std::shared_ptr<void> tj(tjInitDecompress(), [](void* h) { tjDestroy(h); });
  codecs.push_back({"turbojpeg_q" + std::to_string(jpeg_quality),
                    [&c, &base, tj, scratch](size_t i) {
                      const int n = static_cast<int>(c.layout.stored_size());
                      const uint32_t ch = c.layout.channels;
                      for (uint32_t k = 0; k < ch; ++k) {
                        const auto& s = base.jpeg[i * ch + k];
                        tjDecompress2(tj.get(), s.data(), s.size(), scratch->plane.data(), n, n, n, TJPF_GRAY, 0);
                        const float lo = base.jpeg_lo[i * ch + k], sc = base.jpeg_scale[i * ch + k];
                        for (size_t t = 0; t < scratch->plane.size(); ++t)
                          scratch->out[t * ch + k] = lo + scratch->plane[t] * sc;
                      }
                    },
                    base.jpeg_bytes});
#else
  (void)jpeg_quality;
#endif
  return codecs;
}

/// Measures decoding (and with options.encode, encoding) of every tile of `c`, appending
/// metrics to `report` under the prefix `prefix` (e.g. "stone."). Prints a table.
inline void run_codec_bench(const ContainerTiles& c, const CodecOptions& options, Report& report,
                            const std::string& prefix) {
  const detail::Baselines base = detail::make_baselines(c, options.jpeg_quality);
  const size_t raw_tile_bytes = c.layout.sample_count() * 2;

  std::vector<TileCodec> codecs = make_tile_decoders(c, base, options.jpeg_quality);
  std::vector<uint16_t> halves(c.layout.sample_count());

  const uint32_t levels = c.metadata.level_count;
  // Interleaved repetitions: every codec once per repetition, starting with a different one.
  for (int r = 0; r < options.repetitions; ++r)
    for (size_t j = 0; j < codecs.size(); ++j) {
      TileCodec& k = codecs[(j + static_cast<size_t>(r)) % codecs.size()];
      double all_ns = 0;
      for (uint32_t l = 0; l < levels; ++l) {
        const auto& list = c.by_level[l];
        if (list.empty()) continue;
        const double t0 = thread_cpu_ns();
        for (const size_t i : list) k.decode(i);
        const double ns = thread_cpu_ns() - t0;
        all_ns += ns;
        const double us_per_tile = ns / 1000.0 / static_cast<double>(list.size());
        report.add(prefix + "decode." + k.name + ".level" + std::to_string(l) + ".us_per_tile", us_per_tile, "us",
                   Better::lower);
        report.add(prefix + "decode." + k.name + ".level" + std::to_string(l) + ".mb_per_s",
                   static_cast<double>(raw_tile_bytes) / (us_per_tile * 1e-6) / 1e6, "MB/s", Better::higher);
      }
      const double us_all = all_ns / 1000.0 / static_cast<double>(c.ids.size());
      report.add(prefix + "decode." + k.name + ".all.us_per_tile", us_all, "us", Better::lower);
      report.add(prefix + "decode." + k.name + ".all.mb_per_s",
                 static_cast<double>(raw_tile_bytes) / (us_all * 1e-6) / 1e6, "MB/s", Better::higher);
    }
  for (const TileCodec& k : codecs)
    for (int r = 0; r < options.repetitions; ++r)
      report.add(prefix + "decode." + k.name + ".bytes_per_tile",
                 static_cast<double>(k.bytes) / static_cast<double>(c.ids.size()), "B", Better::none);
#if defined(BTFLOD_BENCH_HAS_TURBOJPEG)
  for (int r = 0; r < options.repetitions; ++r)
    report.add(prefix + "decode.turbojpeg.rmse_vs_btflod", base.jpeg_rmse, "", Better::none);
#endif

  // --- encode ---
  if (options.encode) {
    const uint32_t ch = c.layout.channels;
    float max_range = 0;
    for (float x : c.metadata.component_ranges) max_range = std::max(max_range, std::isfinite(x) ? x : 0.0f);
    if (!(max_range > 0)) max_range = 1.0f;
    TileEncoder enc(c.layout);
    enc.set_weight_quarters(kPerceptualWeightQuarters);
    std::vector<uint8_t> buffer(enc.bound());
    std::vector<uint8_t> zbuf(compressBound(static_cast<uLong>(c.layout.sample_count() * 2)));
    for (int r = 0; r < options.repetitions; ++r) {
      for (const float q : options.qualities) {
        // The decoded tiles are the content; each tile is coded against its parent's
        // reconstruction at the same quality (the closed loop of build_bsvtf).
        std::vector<std::vector<float>> recon(c.ids.size(), std::vector<float>(c.layout.sample_count()));
        float tol[4];
        for (uint32_t k = 0; k < ch; ++k) tol[k] = tolerance_for_quality(q, max_range);
        size_t bytes = 0;
        const double t0 = thread_cpu_ns();
        for (size_t i = 0; i < c.ids.size(); ++i) {
          std::span<const float> parent;
          if (c.parent[i] >= 0) parent = recon[static_cast<size_t>(c.parent[i])];
          size_t written = 0;
          if (enc.encode(c.decoded[i], parent, c.ids[i].x & 1, c.ids[i].y & 1, std::span(tol, ch), buffer, written,
                         recon[i]) != Status::success)
            std::abort();
          bytes += written;
        }
        const double us = (thread_cpu_ns() - t0) / 1000.0 / static_cast<double>(c.ids.size());
        char qn[32];
        std::snprintf(qn, sizeof qn, "q%g", static_cast<double>(q));
        report.add(prefix + "encode.btflod." + qn + ".us_per_tile", us, "us", Better::lower);
        report.add(prefix + "encode.btflod." + qn + ".bytes_per_tile",
                   static_cast<double>(bytes) / static_cast<double>(c.ids.size()), "B", Better::none);
      }
      const double t0 = thread_cpu_ns();
      for (size_t i = 0; i < c.ids.size(); ++i) {
        float_to_half(c.decoded[i], halves);
        uLongf size = static_cast<uLongf>(zbuf.size());
        compress2(zbuf.data(), &size, reinterpret_cast<const Bytef*>(halves.data()), halves.size() * 2, 6);
      }
      report.add(prefix + "encode.zlib_raw_halves.us_per_tile",
                 (thread_cpu_ns() - t0) / 1000.0 / static_cast<double>(c.ids.size()), "us", Better::lower);
    }
  }
}

}  // namespace btflod::bench
