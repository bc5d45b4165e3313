// btflod-link: PkgConfig::BTFLOD_LIBDEFLATE PkgConfig::BTFLOD_ZSTD PkgConfig::BTFLOD_JPEG
// Entropy stage of the tile codec: the same quantised DCT coefficients of every tile of real
// containers, coded by each candidate, in one table per material (bytes / ratio, decode µs,
// encode µs per tile, all in the same run):
//   deflate        the stored payloads (tile format 2: raw deflate of the byte-aligned run-length
//                  symbols at the level they were built with: build_bsvtf's default 6 for
//                  containers, TileEncoder's default 9 for --synth); decode = libdeflate inflate +
//                  symbol parse; encode = zlib level 9 of the symbols;
//   zstd-19        zstd level 19 of the same symbol stream, no dictionary;
//   zstd-19+dict   the same with a dictionary trained per material over its tiles' symbol streams
//                  (ZDICT_trainFromBuffer, 16 KiB); the dictionary's bytes are also shown amortised
//                  over the material's tiles (a per-material dictionary must ship with it);
//   zstd-split     bytes only, no decoder: the same symbols in five zstd-19 frames (DC varints, AC
//                  tokens starting at zig-zag positions 1–5, 6–20, 21–63, escape varints), each
//                  with its own literal table, + 3 bytes per stream for the sizes;
//   jpeg-huffman   JPEG's Huffman coding of the coefficients through libjpeg-turbo's coefficient
//                  API (jpeg_write_coefficients with optimised per-tile tables, jpeg_read_coefficients),
//                  one grayscale JPEG per channel plane, unit quantisation tables; bytes = DHT
//                  segments + scan data (the headers a tile format would not store are left out).
//                  Baseline JPEG limits |AC| < 2^10 and |ΔDC| < 2^11: tiles beyond are counted;
//   range          bench/entropy_range_prototype.hpp: a context-modelled adaptive binary range
//                  coder (CABAC-like binarisation, per-channel, per-frequency, per-neighbourhood
//                  contexts, each tile starting from p = ½), a prototype, not in the library;
//   order-0 bound  the ideal static per-frequency, per-channel order-0 code of the same coefficients
//                  (entropy of the zig-zag mapped value at each zig-zag position, per material, with
//                  the model free: an unreachable reference).
// Every decode produces the same output (the 64 quantised coefficients of every channel block,
// zig-zag order); the timings are the entropy stage only (no dequantisation or inverse DCT).
// Full-tile decode against libjpeg-turbo is bench_codec (BM_btflod_decode_tile_*).
//
// Usage: bench_codec_entropy [FILE.bsvtf ...] [--synth SIDE [--quality Q]] [--min-seconds S]
//   FILE.bsvtf   the tiles of a container (the demo materials: `btflod-demo --out DIR` writes
//                cloth-0, stone-1, leather-2 and tiles-3; their 64² syntheses repeat 4×4, so every
//                tile repeats itself and deflate's LZ stage finds duplicate blocks);
//   --synth SIDE the four synthesised materials at SIDE² texels without repetition, FMF C = 8,
//                coded at quality Q (default 50), shared tolerance, JPEG^(1/4) weighting.
#include <benchmark/benchmark.h>  // linked by every bench target; only DoNotOptimize is used
#include <libdeflate.h>
#include <zdict.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

// jpeglib.h needs FILE and size_t declared first.
#include <jpeglib.h>

#include "bench_mip_levels.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/build/perceptual_tolerance.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/vt/tile_id.hpp"
#include "entropy_range_prototype.hpp"

namespace {
using namespace btflod;
using Clock = std::chrono::steady_clock;

// One tile's coefficients: blocks in raster order, channels interleaved, 64 zig-zag values each.
struct TileCoefs {
  uint32_t channels = 0, per_side = 0, texture = 0;
  std::vector<int32_t> zz;
  std::vector<uint8_t> symbols;   // the format-2 symbol stream
  std::vector<uint8_t> deflated;  // the stored deflate stream
  size_t header = 0;
};

// Parses a format-2 symbol stream into zig-zag coefficients (trusted input: the containers were read
// and decoded by the library first). Returns false on a parse error.
bool parse_symbols(const uint8_t* p, const uint8_t* end, uint32_t blocks, uint32_t channels, int32_t* zz) {
  int64_t dc[4] = {};
  for (uint32_t b = 0; b < blocks; ++b)
    for (uint32_t c = 0; c < channels; ++c) {
      int32_t* q = zz + (size_t{b} * channels + c) * 64;
      std::memset(q, 0, 64 * sizeof(int32_t));
      uint32_t u = 0;
      if (!detail::tile_read_varint(p, end, u)) return false;
      dc[c] += detail::tile_unzigzag(u);
      q[0] = static_cast<int32_t>(dc[c]);
      int k = 1;
      while (k < 64) {
        if (p == end) return false;
        const uint32_t t = *p++;
        if (t == 0) break;
        if (t == 0xF0) {
          k += 16;
          continue;
        }
        k += static_cast<int>(t >> 4);
        uint32_t m = t & 15u;
        if (m == 15) {
          uint32_t extra = 0;
          if (!detail::tile_read_varint(p, end, extra)) return false;
          m = 15 + extra;
        }
        if (k >= 64) return false;
        q[k++] = static_cast<int32_t>(detail::tile_unzigzag(m));
      }
    }
  return p == end;
}

// Range coder over a tile's blocks (the same calls TileEncoder / TileDecoder make).
size_t range_encode_tile(const TileCoefs& t, std::span<uint8_t> out) {
  RangeEncoder e(out);
  RangeChannelModel models[4];
  RangeNeighbours nb[4];
  int64_t prev_dc[4] = {};
  bool prev_zero[4] = {true, true, true, true};
  for (uint32_t by = 0; by < t.per_side; ++by)
    for (uint32_t bx = 0; bx < t.per_side; ++bx)
      for (uint32_t c = 0; c < t.channels; ++c) {
        const int32_t* q = t.zz.data() + ((size_t{by} * t.per_side + bx) * t.channels + c) * 64;
        const int64_t diff = q[0] - prev_dc[c];
        const uint64_t left = bx ? nb[c].mask[bx - 1] : 0, above = by ? nb[c].mask[bx] : 0;
        nb[c].mask[bx] = range_encode_block(e, models[c], q, diff, prev_zero[c], left, above);
        prev_zero[c] = diff == 0;
        prev_dc[c] = q[0];
      }
  return e.finish();
}
bool range_decode_tile(std::span<const uint8_t> in, uint32_t per_side, uint32_t channels, int32_t* zz) {
  RangeDecoder d(in);
  RangeChannelModel models[4];
  RangeNeighbours nb[4];
  int64_t dc[4] = {};
  bool prev_zero[4] = {true, true, true, true};
  RangeBlock rb;
  for (uint32_t by = 0; by < per_side; ++by)
    for (uint32_t bx = 0; bx < per_side; ++bx)
      for (uint32_t c = 0; c < channels; ++c) {
        int32_t* q = zz + ((size_t{by} * per_side + bx) * channels + c) * 64;
        const uint64_t left = bx ? nb[c].mask[bx - 1] : 0, above = by ? nb[c].mask[bx] : 0;
        if (!range_decode_block(d, models[c], prev_zero[c], left, above, rb)) return false;
        nb[c].mask[bx] = rb.mask;
        prev_zero[c] = rb.dc_diff == 0;
        dc[c] += rb.dc_diff;
        std::memset(q, 0, 64 * sizeof(int32_t));
        q[0] = static_cast<int32_t>(dc[c]);
        for (uint32_t i = 0; i < rb.count; ++i) q[rb.pos[i]] = rb.value[i];
      }
  return d.finish();
}

// --- libjpeg coefficient API ---------------------------------------------------------------
struct JpegError {
  jpeg_error_mgr mgr;
  std::jmp_buf jump;
};
void jpeg_error_exit(j_common_ptr cinfo) {
  JpegError* e = reinterpret_cast<JpegError*>(cinfo->err);
  std::longjmp(e->jump, 1);
}
void jpeg_silent(j_common_ptr, int) {}

// Counts the bytes a tile format would keep: DHT segments and the entropy-coded scan data.
size_t jpeg_kept_bytes(const uint8_t* p, size_t n) {
  size_t i = 2, kept = 0;  // after SOI
  while (i + 4 <= n) {
    const uint8_t marker = p[i + 1];
    const size_t len = size_t{p[i + 2]} << 8 | p[i + 3];
    if (marker == 0xC4) kept += len + 2;
    if (marker == 0xDA) {
      kept += n - (i + 2 + len) - 2;  // scan data up to EOI
      break;
    }
    i += 2 + len;
  }
  return kept;
}

// One grayscale JPEG per channel plane of the tile. Returns false when a coefficient is beyond
// baseline JPEG's range (libjpeg errors out).
bool jpeg_encode_tile(const TileCoefs& t, std::vector<std::vector<uint8_t>>& planes) {
  const auto& zigzag = zigzag_order<8>();
  planes.assign(t.channels, {});
  for (uint32_t c = 0; c < t.channels; ++c) {
    jpeg_compress_struct cinfo{};
    JpegError err{};
    cinfo.err = jpeg_std_error(&err.mgr);
    err.mgr.error_exit = jpeg_error_exit;
    err.mgr.emit_message = jpeg_silent;
    unsigned char* buf = nullptr;
    unsigned long size = 0;
    if (setjmp(err.jump)) {
      jpeg_destroy_compress(&cinfo);
      std::free(buf);
      return false;
    }
    jpeg_create_compress(&cinfo);
    jpeg_mem_dest(&cinfo, &buf, &size);
    cinfo.image_width = t.per_side * 8;
    cinfo.image_height = t.per_side * 8;
    cinfo.input_components = 1;
    cinfo.in_color_space = JCS_GRAYSCALE;
    jpeg_set_defaults(&cinfo);
    unsigned int ones[64];
    std::fill(ones, ones + 64, 1u);
    jpeg_add_quant_table(&cinfo, 0, ones, 100, TRUE);
    cinfo.optimize_coding = TRUE;
    jvirt_barray_ptr arrays[1];
    arrays[0] = (*cinfo.mem->request_virt_barray)(reinterpret_cast<j_common_ptr>(&cinfo), JPOOL_IMAGE, TRUE, t.per_side,
                                                  t.per_side, t.per_side);
    jpeg_write_coefficients(&cinfo, arrays);
    for (uint32_t by = 0; by < t.per_side; ++by) {
      JBLOCKARRAY row =
          (*cinfo.mem->access_virt_barray)(reinterpret_cast<j_common_ptr>(&cinfo), arrays[0], by, 1, TRUE);
      for (uint32_t bx = 0; bx < t.per_side; ++bx) {
        const int32_t* q = t.zz.data() + ((size_t{by} * t.per_side + bx) * t.channels + c) * 64;
        for (int k = 0; k < 64; ++k) {
          if (q[k] > 32767 || q[k] < -32767) longjmp(err.jump, 1);
          row[0][bx][zigzag[k]] = static_cast<JCOEF>(q[k]);
        }
      }
    }
    jpeg_finish_compress(&cinfo);
    jpeg_destroy_compress(&cinfo);
    planes[c].assign(buf, buf + size);
    std::free(buf);
  }
  return true;
}

struct JpegReader {
  jpeg_decompress_struct d{};
  JpegError err{};
  JpegReader() {
    d.err = jpeg_std_error(&err.mgr);
    err.mgr.error_exit = jpeg_error_exit;
    err.mgr.emit_message = jpeg_silent;
    jpeg_create_decompress(&d);
  }
  ~JpegReader() { jpeg_destroy_decompress(&d); }
  bool decode(const std::vector<std::vector<uint8_t>>& planes, uint32_t per_side, uint32_t channels, int32_t* zz) {
    const auto& zigzag = zigzag_order<8>();
    if (setjmp(err.jump)) {
      jpeg_abort_decompress(&d);
      return false;
    }
    for (uint32_t c = 0; c < channels; ++c) {
      jpeg_mem_src(&d, planes[c].data(), planes[c].size());
      jpeg_read_header(&d, TRUE);
      jvirt_barray_ptr* arrays = jpeg_read_coefficients(&d);
      for (uint32_t by = 0; by < per_side; ++by) {
        JBLOCKARRAY row = (*d.mem->access_virt_barray)(reinterpret_cast<j_common_ptr>(&d), arrays[0], by, 1, FALSE);
        for (uint32_t bx = 0; bx < per_side; ++bx) {
          int32_t* q = zz + ((size_t{by} * per_side + bx) * channels + c) * 64;
          for (int k = 0; k < 64; ++k) q[k] = row[0][bx][zigzag[k]];
        }
      }
      jpeg_finish_decompress(&d);
    }
    return true;
  }
};

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Runs `f` over all tiles repeatedly for at least `min_s` seconds; µs per tile (median of 3 rounds).
template <class F>
double time_per_tile(size_t tiles, double min_s, F&& f) {
  double best[3];
  for (double& r : best) {
    size_t n = 0;
    const auto t0 = Clock::now();
    do {
      for (size_t i = 0; i < tiles; ++i) f(i);
      n += tiles;
    } while (seconds_since(t0) < min_s / 3);
    r = seconds_since(t0) * 1e6 / static_cast<double>(n);
  }
  std::sort(best, best + 3);
  return best[1];
}

struct Row {
  explicit Row(const char* n) : name(n) {}
  std::string name;
  double bytes = 0;  // per tile
  double decode_us = 0, encode_us = 0;
  std::string note;
};

}  // namespace

// One material: the stored format-2 payloads (with their texture index) of one layout.
struct Material {
  std::string name;
  TileLayout layout;
  uint32_t textures = 1;
  std::vector<uint32_t> texture;  // per tile
  std::vector<std::span<const uint8_t>> payloads;
};

// Synthesised material without the demo's repetition: `side`² texels of one synthesis (the demo
// repeats a 64² synthesis 4×4, so each of its tiles repeats itself and deflate's LZ stage finds
// whole duplicate blocks), FMF with 8 components (2 textures of 4), a pyramid of 64+2·4 tiles
// (wrapped borders, 2×2 box filter per level), coded closed loop at `quality` with the shared
// tolerance of the largest component range and JPEG^(1/4) frequency weighting.
struct SynthCoded {
  Material material;
  std::vector<std::vector<uint8_t>> storage;
};
bool synth_material(SynthMaterial which, int side, float quality, SynthCoded& out) {
  const TileLayout layout{64, 4, 4};
  const uint32_t kComponents = 8;
  const float thetas[] = {0.0f, 30.0f, 60.0f};
  const int counts[] = {1, 6, 12};
  SynthesisOptions so;
  so.views = DirectionSet::from_rings("entropy", thetas, counts, {}, false);
  so.lights = so.views;
  auto btf = synthesize_material(which, side, side, 7, so);
  if (!btf) return false;
  FmfOptions fo;
  fo.components = static_cast<int>(kComponents);
  auto fmf = factorize_fmf(*btf, fo);
  if (!fmf) return false;
  uint32_t levels = 0;
  while ((layout.tile_size << levels) < static_cast<uint32_t>(side)) ++levels;
  ++levels;
  std::vector<std::vector<float>> level(levels);
  const uint32_t finest = static_cast<uint32_t>(side);
  level[levels - 1].assign(fmf->v.begin(),
                           fmf->v.begin() + static_cast<ptrdiff_t>(size_t{finest} * finest * kComponents));
  btflod::bench::box_filter_coarser_levels(level, finest, kComponents);
  float lo = INFINITY, hi = -INFINITY;
  for (float v : level[levels - 1]) lo = std::min(lo, v), hi = std::max(hi, v);
  const float tol = tolerance_for_quality(quality, hi - lo);
  const float tols[4] = {tol, tol, tol, tol};
  TileEncoder enc(layout);
  enc.set_weight_quarters(kPerceptualWeightQuarters);
  std::vector<uint8_t> buffer(enc.bound());
  const uint32_t st = layout.stored_size();
  out.material.name = std::string(material_name(which)) + "-" + std::to_string(side) + " (synthesised, q" +
                      std::to_string(static_cast<int>(quality)) + ")";
  out.material.layout = layout;
  out.material.textures = kComponents / 4;
  for (uint32_t g = 0; g < kComponents / 4; ++g) {
    std::map<uint64_t, std::vector<float>> recon;
    for (uint32_t l = 0; l < levels; ++l) {
      const int s = static_cast<int>(layout.tile_size << l);
      for (uint32_t ty = 0; ty < (1u << l); ++ty)
        for (uint32_t tx = 0; tx < (1u << l); ++tx) {
          const TileId id{g, l, tx, ty};
          std::vector<float> tile(layout.sample_count());
          for (uint32_t j = 0; j < st; ++j)
            for (uint32_t i = 0; i < st; ++i) {
              const int x = ((static_cast<int>(tx * 64 + i) - 4) % s + s) % s;
              const int y = ((static_cast<int>(ty * 64 + j) - 4) % s + s) % s;
              for (uint32_t k = 0; k < 4; ++k)
                tile[(size_t{j} * st + i) * 4 + k] = level[l][(size_t(y) * s + x) * kComponents + 4 * g + k];
            }
          std::vector<float> rec(layout.sample_count());
          std::span<const float> parent;
          if (l > 0) parent = recon.at(id.parent().key());
          size_t written = 0;
          if (enc.encode(tile, parent, tx & 1, ty & 1, tols, buffer, written, rec) != Status::success) return false;
          out.storage.emplace_back(buffer.begin(), buffer.begin() + static_cast<ptrdiff_t>(written));
          out.material.texture.push_back(g);
          recon[id.key()] = std::move(rec);
        }
    }
  }
  for (const auto& p : out.storage) out.material.payloads.emplace_back(p);
  return true;
}

int measure(const Material& m, double min_s) {
  const std::string& stem = m.name;
  const std::string& path = m.name;
  const TileLayout layout = m.layout;
  const uint32_t textures = m.textures;
  const uint32_t per_side = layout.stored_size() / 8, ch = layout.channels;
  const size_t blocks = size_t{per_side} * per_side;
  std::vector<TileCoefs> tiles;
  libdeflate_decompressor* ld = libdeflate_alloc_decompressor();
  for (size_t ti = 0; ti < m.payloads.size(); ++ti) {
    const auto payload = m.payloads[ti];
    TileHeaderInfo info;
    if (tile_peek_header(payload, info) != Status::success) return 1;
    TileCoefs t;
    t.channels = ch;
    t.per_side = per_side;
    t.texture = m.texture[ti];
    t.header = tile_header_size(ch);
    t.deflated.assign(payload.begin() + static_cast<ptrdiff_t>(t.header), payload.end());
    t.symbols.resize(info.symbol_bytes);
    size_t got = 0;
    if (libdeflate_deflate_decompress(ld, t.deflated.data(), t.deflated.size(), t.symbols.data(), t.symbols.size(),
                                      &got) != LIBDEFLATE_SUCCESS)
      return 1;
    t.zz.resize(blocks * ch * 64);
    if (!parse_symbols(t.symbols.data(), t.symbols.data() + t.symbols.size(), static_cast<uint32_t>(blocks), ch,
                       t.zz.data())) {
      std::fprintf(stderr, "%s: symbol parse failed\n", path.c_str());
      return 1;
    }
    tiles.push_back(std::move(t));
  }
  const size_t n = tiles.size();
  const double raw = static_cast<double>(layout.sample_count() * 2);  // raw halves per tile
  std::vector<int32_t> scratch(blocks * ch * 64);
  std::vector<uint8_t> sym_scratch(tile_symbol_bound(layout));
  std::vector<Row> rows;

  // deflate (stored) ---------------------------------------------------------------------------
  {
    Row r{"deflate (as stored; libdeflate decode)"};
    for (const auto& t : tiles) r.bytes += static_cast<double>(t.deflated.size() + t.header);
    r.decode_us = time_per_tile(n, min_s, [&](size_t i) {
      size_t got = 0;
      libdeflate_deflate_decompress(ld, tiles[i].deflated.data(), tiles[i].deflated.size(), sym_scratch.data(),
                                    tiles[i].symbols.size(), &got);
      parse_symbols(sym_scratch.data(), sym_scratch.data() + got, static_cast<uint32_t>(blocks), ch, scratch.data());
      benchmark::DoNotOptimize(scratch.data());
    });
    std::vector<uint8_t> out(compressBound(static_cast<uLong>(sym_scratch.size())));
    z_stream zs{};
    deflateInit2(&zs, 9, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY);
    r.encode_us = time_per_tile(n, min_s / 2, [&](size_t i) {
      deflateReset(&zs);
      zs.next_in = const_cast<Bytef*>(tiles[i].symbols.data());
      zs.avail_in = static_cast<uInt>(tiles[i].symbols.size());
      zs.next_out = out.data();
      zs.avail_out = static_cast<uInt>(out.size());
      deflate(&zs, Z_FINISH);
    });
    deflateEnd(&zs);
    r.note = "stored tiles (format 2)";
    rows.push_back(r);
  }
  // zstd without and with a per-material dictionary ----------------------------------------------
  // Dictionaries (16 KiB each): [0] trained on all the material's tiles (in-sample: the demo
  // textures repeat, so it memorises whole tiles); [1] on the tiles of textures < K/2 and [2] on
  // the others, each used for the other half (held out: what a dictionary trained once per
  // material brings to tiles it has not seen).
  auto train = [&](auto&& use) {
    std::vector<uint8_t> samples, dict(16384);
    std::vector<size_t> sizes;
    for (const auto& t : tiles)
      if (use(t)) {
        samples.insert(samples.end(), t.symbols.begin(), t.symbols.end());
        sizes.push_back(t.symbols.size());
      }
    const size_t d = sizes.empty() ? 0
                                   : ZDICT_trainFromBuffer(dict.data(), dict.size(), samples.data(), sizes.data(),
                                                           static_cast<unsigned>(sizes.size()));
    if (sizes.empty() || ZDICT_isError(d)) return std::vector<uint8_t>{};
    dict.resize(d);
    return dict;
  };
  const std::vector<uint8_t> dicts[3] = {train([](const TileCoefs&) { return true; }),
                                         train([&](const TileCoefs& t) { return t.texture < textures / 2; }),
                                         train([&](const TileCoefs& t) { return t.texture >= textures / 2; })};
  for (int mode = 0; mode < 3; ++mode) {
    if (mode == 1 && dicts[0].empty()) continue;
    if (mode == 2 && (textures < 2 || dicts[1].empty() || dicts[2].empty())) continue;
    Row r{mode == 0 ? "zstd 19" : mode == 1 ? "zstd 19 + dictionary (in-sample)" : "zstd 19 + dictionary (held out)"};
    ZSTD_CCtx* cc = ZSTD_createCCtx();
    ZSTD_DCtx* dc = ZSTD_createDCtx();
    ZSTD_CDict* cd[3] = {};
    ZSTD_DDict* dd[3] = {};
    for (int k = 0; k < 3; ++k)
      if (!dicts[k].empty()) {
        cd[k] = ZSTD_createCDict(dicts[k].data(), dicts[k].size(), 19);
        dd[k] = ZSTD_createDDict(dicts[k].data(), dicts[k].size());
      }
    // The dictionary of tile i: none, the in-sample one, or the other half's.
    auto dict_of = [&](size_t i) { return mode == 0 ? -1 : mode == 1 ? 0 : tiles[i].texture < textures / 2 ? 2 : 1; };
    std::vector<std::vector<uint8_t>> streams(n);
    std::vector<uint8_t> out(ZSTD_compressBound(sym_scratch.size()));
    auto encode = [&](size_t i) {
      const auto& s = tiles[i].symbols;
      const int k = dict_of(i);
      return k >= 0 ? ZSTD_compress_usingCDict(cc, out.data(), out.size(), s.data(), s.size(), cd[k])
                    : ZSTD_compressCCtx(cc, out.data(), out.size(), s.data(), s.size(), 19);
    };
    for (size_t i = 0; i < n; ++i) {
      const size_t z = encode(i);
      streams[i].assign(out.begin(), out.begin() + static_cast<ptrdiff_t>(z));
      r.bytes += static_cast<double>(z + tiles[i].header);
    }
    r.decode_us = time_per_tile(n, min_s, [&](size_t i) {
      const int k = dict_of(i);
      const size_t got = k >= 0 ? ZSTD_decompress_usingDDict(dc, sym_scratch.data(), sym_scratch.size(),
                                                             streams[i].data(), streams[i].size(), dd[k])
                                : ZSTD_decompressDCtx(dc, sym_scratch.data(), sym_scratch.size(), streams[i].data(),
                                                      streams[i].size());
      parse_symbols(sym_scratch.data(), sym_scratch.data() + got, static_cast<uint32_t>(blocks), ch, scratch.data());
      benchmark::DoNotOptimize(scratch.data());
    });
    r.encode_us = time_per_tile(n, min_s / 2, [&](size_t i) { benchmark::DoNotOptimize(encode(i)); });
    if (mode > 0) {
      const size_t dict_bytes = mode == 1 ? dicts[0].size() : dicts[1].size() + dicts[2].size();
      char buf[160];
      std::snprintf(buf, sizeof buf, "dictionaries %zu B (%.0f B/tile if shipped with the material, not counted)",
                    dict_bytes, static_cast<double>(dict_bytes) / static_cast<double>(n));
      r.note = buf;
    }
    for (int k = 0; k < 3; ++k) {
      ZSTD_freeCDict(cd[k]);
      ZSTD_freeDDict(dd[k]);
    }
    ZSTD_freeCCtx(cc);
    ZSTD_freeDCtx(dc);
    rows.push_back(r);
  }
  // zstd over split streams (bytes only) -------------------------------------------------------------
  // The same symbols in five streams, each its own zstd 19 frame (so each gets its own literal
  // Huffman table): DC varints; AC tokens that start at zig-zag position 1–5, 6–20 and 21–63; the
  // escapes' varints. Estimates what frequency-banded statistics give zstd's order-0 stage before
  // any format change; 3 bytes per stream are counted for the sizes a tile header would hold.
  {
    Row r{"zstd 19, five split streams (bytes only)"};
    ZSTD_CCtx* cc = ZSTD_createCCtx();
    std::vector<uint8_t> parts[5];
    std::vector<uint8_t> out(ZSTD_compressBound(sym_scratch.size()));
    uint8_t varint[5];
    const auto put_varint = [&](std::vector<uint8_t>& to, uint32_t v) {
      to.insert(to.end(), varint, detail::tile_write_varint(varint, v));
    };
    for (const auto& t : tiles) {
      for (auto& part : parts) part.clear();
      int64_t prev_dc[4] = {};
      for (size_t b = 0; b < blocks; ++b)
        for (uint32_t c = 0; c < ch; ++c) {
          const int32_t* q = t.zz.data() + (b * ch + c) * 64;
          put_varint(parts[0], detail::tile_zigzag(static_cast<int32_t>(q[0] - prev_dc[c])));
          prev_dc[c] = q[0];
          int last = 0;
          for (int k = 1; k < 64; ++k)
            if (q[k] != 0) last = k;
          int k = 1;
          while (k <= last) {
            std::vector<uint8_t>& tokens = parts[k < 6 ? 1 : k < 21 ? 2 : 3];
            int run = 0;
            while (q[k + run] == 0 && run < 15) ++run;
            if (q[k + run] == 0) {  // 16 zeros
              tokens.push_back(0xF0);
              k += 16;
              continue;
            }
            const uint32_t m = detail::tile_zigzag(q[k + run]);
            tokens.push_back(static_cast<uint8_t>(run << 4 | std::min(m, 15u)));
            if (m >= 15) put_varint(parts[4], m - 15);
            k += run + 1;
          }
          if (last < 63) parts[k < 6 ? 1 : k < 21 ? 2 : 3].push_back(0x00);
        }
      size_t split_bytes = 0;  // the same symbols, so the same count as the one stream
      for (const auto& part : parts) split_bytes += part.size();
      if (split_bytes != t.symbols.size()) {
        std::fprintf(stderr, "%s: split streams hold %zu bytes, the symbol stream %zu\n", path.c_str(), split_bytes,
                     t.symbols.size());
        ZSTD_freeCCtx(cc);
        return 1;
      }
      for (const auto& part : parts) {
        if (part.empty()) continue;
        r.bytes += static_cast<double>(ZSTD_compressCCtx(cc, out.data(), out.size(), part.data(), part.size(), 19) + 3);
      }
      r.bytes += static_cast<double>(t.header);
    }
    ZSTD_freeCCtx(cc);
    r.note = "no decoder: an estimate for a banded format";
    rows.push_back(r);
  }
  // JPEG Huffman ----------------------------------------------------------------------------------
  {
    Row r{"JPEG Huffman (libjpeg-turbo coefficient API)"};
    std::vector<std::vector<std::vector<uint8_t>>> jp(n);
    size_t fallback = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!jpeg_encode_tile(tiles[i], jp[i])) {
        ++fallback;
        jp[i].clear();
        r.bytes += static_cast<double>(tiles[i].deflated.size() + tiles[i].header);
        continue;
      }
      r.bytes += static_cast<double>(tiles[i].header);
      for (const auto& p : jp[i]) r.bytes += static_cast<double>(jpeg_kept_bytes(p.data(), p.size()));
    }
    JpegReader reader;
    r.decode_us = time_per_tile(n, min_s, [&](size_t i) {
      if (jp[i].empty()) return;
      reader.decode(jp[i], per_side, ch, scratch.data());
      benchmark::DoNotOptimize(scratch.data());
    });
    // Check: the JPEG path reproduces the coefficients.
    for (size_t i = 0; i < n; ++i)
      if (!jp[i].empty() && (!reader.decode(jp[i], per_side, ch, scratch.data()) || scratch != tiles[i].zz)) {
        std::fprintf(stderr, "%s: JPEG round trip differs on tile %zu\n", path.c_str(), i);
        return 1;
      }
    std::vector<std::vector<uint8_t>> tmp;
    r.encode_us = time_per_tile(n, min_s / 2, [&](size_t i) { jpeg_encode_tile(tiles[i], tmp); });
    char buf[160];
    std::snprintf(buf, sizeof buf, "%zu of %zu tiles beyond baseline range (counted at their deflate size)", fallback,
                  n);
    r.note = buf;
    rows.push_back(r);
  }
  // Range coder ------------------------------------------------------------------------------------
  {
    Row r{"range coder prototype (context-modelled, adaptive)"};
    std::vector<std::vector<uint8_t>> streams(n);
    std::vector<uint8_t> out(tile_encode_bound(layout));
    for (size_t i = 0; i < n; ++i) {
      const size_t z = range_encode_tile(tiles[i], out);
      if (z == 0) return 1;
      streams[i].assign(out.begin(), out.begin() + static_cast<ptrdiff_t>(z));
      r.bytes += static_cast<double>(z + tiles[i].header);
      if (!range_decode_tile(streams[i], per_side, ch, scratch.data()) || scratch != tiles[i].zz) {
        std::fprintf(stderr, "%s: range round trip differs on tile %zu\n", path.c_str(), i);
        return 1;
      }
    }
    r.decode_us = time_per_tile(n, min_s, [&](size_t i) {
      range_decode_tile(streams[i], per_side, ch, scratch.data());
      benchmark::DoNotOptimize(scratch.data());
    });
    r.encode_us =
        time_per_tile(n, min_s / 2, [&](size_t i) { benchmark::DoNotOptimize(range_encode_tile(tiles[i], out)); });
    rows.push_back(r);
  }
  // Order-0 bound ----------------------------------------------------------------------------------
  {
    std::vector<std::map<uint32_t, size_t>> hist(ch * 64);
    for (const auto& t : tiles)
      for (size_t b = 0; b < blocks; ++b)
        for (uint32_t c = 0; c < ch; ++c) {
          const int32_t* q = t.zz.data() + (b * ch + c) * 64;
          int32_t prev = 0;
          for (int k = 0; k < 64; ++k) {
            const int32_t v = k == 0 ? q[0] - prev : q[k];
            ++hist[c * 64 + k][detail::tile_zigzag(v)];
          }
        }
    double bits = 0;
    const double total = static_cast<double>(n * blocks);
    for (const auto& h : hist)
      for (const auto& [v, count] : h)
        bits -= static_cast<double>(count) * std::log2(static_cast<double>(count) / total);
    Row r{"order-0 per-frequency bound"};
    r.bytes = bits / 8 + static_cast<double>(tiles[0].header) * static_cast<double>(n);
    r.note = "static ideal code, model free (DC not differenced)";
    rows.push_back(r);
  }
  libdeflate_free_decompressor(ld);
  const double deflate_bytes = rows[0].bytes;
  for (const Row& r : rows) {
    std::printf("| %s | %s | %.0f | %.2f:1 | %.3f | %s | %s | %s |\n", stem.c_str(), r.name.c_str(),
                r.bytes / static_cast<double>(n), raw * static_cast<double>(n) / r.bytes, r.bytes / deflate_bytes,
                r.decode_us > 0 ? std::to_string(r.decode_us).substr(0, 6).c_str() : "—",
                r.encode_us > 0 ? std::to_string(r.encode_us).substr(0, 6).c_str() : "—", r.note.c_str());
  }
  std::fflush(stdout);
  return 0;
}

int main(int argc, char** argv) {
  std::vector<std::string> files;
  double min_s = 0.6;
  int synth_side = 0;
  float synth_quality = 50.0f;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--min-seconds" && i + 1 < argc) {
      min_s = std::atof(argv[++i]);
    } else if (a == "--synth" && i + 1 < argc) {
      synth_side = std::atoi(argv[++i]);
    } else if (a == "--quality" && i + 1 < argc) {
      synth_quality = static_cast<float>(std::atof(argv[++i]));
    } else {
      files.push_back(a);
    }
  }
  if (files.empty() && synth_side <= 0) {
    std::fprintf(stderr,
                 "usage: bench_codec_entropy [FILE.bsvtf ...] [--synth SIDE [--quality Q]] [--min-seconds S]\n");
    return 2;
  }
  std::printf(
      "| material | coder | B/tile | ratio | vs deflate | decode µs/tile | encode µs/tile | note |\n"
      "|---|---|---|---|---|---|---|---|\n");
  for (const std::string& path : files) {
    auto bytes = read_file_bytes(path);
    if (!bytes) {
      std::fprintf(stderr, "%s: %s\n", path.c_str(), bytes.message().c_str());
      return 1;
    }
    auto dir = read_bsvtf(*bytes);
    if (!dir) {
      std::fprintf(stderr, "%s: %s\n", path.c_str(), dir.message().c_str());
      return 1;
    }
    Material m;
    m.name = path.substr(path.find_last_of('/') == std::string::npos ? 0 : path.find_last_of('/') + 1);
    m.layout = dir->metadata.layout();
    m.textures = dir->metadata.texture_count();
    for (const BsvtfTileEntry& e : dir->tiles) {
      m.payloads.push_back(std::span<const uint8_t>(*bytes).subspan(e.offset, e.size));
      m.texture.push_back(e.id.texture);
    }
    if (const int r = measure(m, min_s); r != 0) return r;
  }
  if (synth_side > 0)
    for (SynthMaterial which :
         {SynthMaterial::cloth, SynthMaterial::stone, SynthMaterial::leather, SynthMaterial::tiles}) {
      SynthCoded sc;
      if (!synth_material(which, synth_side, synth_quality, sc)) {
        std::fprintf(stderr, "synthesis of %s failed\n", material_name(which));
        return 1;
      }
      if (const int r = measure(sc.material, min_s); r != 0) return r;
    }
  return 0;
}
