// Structure-aware, checksum-aware mutation for btflod's libFuzzer targets.
//
// Byte-level mutation of a `.bsvtf` container almost never gets past its CRC-32s, and byte
// mutation of a tile payload almost never gets past raw inflate. The helpers here parse an input
// into its parts, let libFuzzer mutate ONE part (LLVMFuzzerMutate on that sub-range), then
// serialise again with every size, offset and CRC recomputed, so the mutation reaches the code
// behind the verification:
//   - tile payloads: the entropy-coded stream (deflate, or zstd in tile format 3) is decoded,
//     the symbol bytes (or the header) mutated, the symbol count fixed up and the stream coded
//     again with the tile's coder (mutate_tile_payload);
//   - `.bsvtf` containers: the header fields, the metadata, a U packet, a tile-index entry or a
//     tile payload is mutated, tiles are added, dropped or swapped between inputs
//     (BsvtfMutator), then sections are laid out again with fresh CRCs.
// A small share of mutations stays plain byte-level (or leaves one field inconsistent on
// purpose) so the verification itself keeps being exercised.
//
// The targets that use these define LLVMFuzzerCustomMutator and LLVMFuzzerCustomCrossOver. With
// BTFLOD_FUZZ_BYTES=1 in the environment they fall back to plain byte-level mutation
// (LLVMFuzzerMutate on the whole input) and a plain splice cross-over, for comparison runs.
#pragma once

#include <zlib.h>
#if defined(BTFLOD_TILE_CODEC_ZSTD) && BTFLOD_TILE_CODEC_ZSTD
#include <zstd.h>
#endif

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"

extern "C" size_t LLVMFuzzerMutate(uint8_t* data, size_t size, size_t max_size);

namespace btflod_fuzz {

using Bytes = std::vector<uint8_t>;

/// True when BTFLOD_FUZZ_BYTES=1: plain byte-level mutation only.
inline bool byte_mode() {
  static const bool on = [] {
    const char* v = std::getenv("BTFLOD_FUZZ_BYTES");
    return v != nullptr && v[0] == '1';
  }();
  return on;
}

/// Plain cross-over: a prefix of `a` followed by a suffix of `b` (what byte mode uses).
inline size_t splice(const uint8_t* a, size_t a_size, const uint8_t* b, size_t b_size, uint8_t* out, size_t max_size,
                     unsigned seed) {
  std::minstd_rand rng(seed);
  const size_t head = a_size ? std::min<size_t>(rng() % (a_size + 1), max_size) : 0;
  const size_t from = b_size ? rng() % b_size : 0;
  const size_t tail = std::min(b_size - from, max_size - head);
  std::memcpy(out, a, head);
  if (tail) std::memcpy(out + head, b + from, tail);
  return head + tail;
}

inline uint32_t crc32_bytes(const uint8_t* p, size_t n) {
  return static_cast<uint32_t>(crc32(0L, p, static_cast<uInt>(n)));
}
inline uint32_t get_u32(const uint8_t* p) {
  uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}
inline uint64_t get_u64(const uint8_t* p) {
  uint64_t v;
  std::memcpy(&v, p, 8);
  return v;
}
inline void put_u32(uint8_t* p, uint32_t v) { std::memcpy(p, &v, 4); }
inline void put_u64(uint8_t* p, uint64_t v) { std::memcpy(p, &v, 8); }

/// LLVMFuzzerMutate on a whole vector, allowing it to grow to `max_size` (at least its size).
inline void mutate_vector(Bytes& v, size_t max_size) {
  if (v.empty()) v.push_back(0);  // LLVMFuzzerMutate needs at least one byte
  max_size = std::max(max_size, v.size());
  const size_t old = v.size();
  v.resize(max_size);
  const size_t n = LLVMFuzzerMutate(v.data(), old, max_size);
  v.resize(n);
}

/// Raw inflate of a whole stream (at most `limit` bytes out); false when it is not a complete
/// raw deflate stream. One zlib state, made once and reset per call (mutators run on one thread).
inline bool raw_inflate(const uint8_t* in, size_t n, Bytes& out, size_t limit) {
  static z_stream z = [] {
    z_stream s{};
    inflateInit2(&s, -15);
    return s;
  }();
  inflateReset(&z);
  out.resize(limit);
  z.next_in = const_cast<uint8_t*>(in);
  z.avail_in = static_cast<uInt>(n);
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(limit);
  const int rc = inflate(&z, Z_FINISH);
  out.resize(z.total_out);
  return rc == Z_STREAM_END;
}

/// Raw deflate at a fast level (one zlib state, made once and reset per call).
inline Bytes raw_deflate(const uint8_t* in, size_t n) {
  static z_stream z = [] {
    z_stream s{};
    deflateInit2(&s, 1, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY);
    return s;
  }();
  deflateReset(&z);
  Bytes out(deflateBound(&z, static_cast<uLong>(n)));
  z.next_in = const_cast<uint8_t*>(in);
  z.avail_in = static_cast<uInt>(n);
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(out.size());
  deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  return out;
}

/// Decodes a tile's entropy-coded symbol stream (deflate, or zstd when built with it); false
/// when it does not decode.
inline bool tile_symbols(const btflod::TileHeaderInfo& info, const uint8_t* in, size_t n, Bytes& out, size_t limit) {
#if defined(BTFLOD_TILE_CODEC_ZSTD) && BTFLOD_TILE_CODEC_ZSTD
  if (info.coder == btflod::TileEntropyCoder::zstd) {
    out.resize(limit);
    const size_t r = ZSTD_decompress(out.data(), limit, in, n);
    if (ZSTD_isError(r)) return false;
    out.resize(r);
    return true;
  }
#endif
  return info.coder == btflod::TileEntropyCoder::deflate && raw_inflate(in, n, out, limit);
}

/// Entropy-codes a symbol stream with the tile's coder (fast levels).
inline Bytes tile_code(const btflod::TileHeaderInfo& info, const Bytes& symbols) {
#if defined(BTFLOD_TILE_CODEC_ZSTD) && BTFLOD_TILE_CODEC_ZSTD
  if (info.coder == btflod::TileEntropyCoder::zstd) {
    Bytes out(ZSTD_compressBound(symbols.size()));
    const size_t r = ZSTD_compress(out.data(), out.size(), symbols.data(), symbols.size(), 1);
    out.resize(ZSTD_isError(r) ? 0 : r);
    return out;
  }
#else
  (void)info;
#endif
  return raw_deflate(symbols.data(), symbols.size());
}

/// Mutates one tile payload in place. With a well-formed header the choice is: the symbol
/// stream (inflate, LLVMFuzzerMutate, symbol count fixed, deflate), the header fields (flags,
/// size, tolerances), the symbol count alone, or the raw bytes.
inline void mutate_tile_payload(Bytes& payload, std::minstd_rand& rng, size_t max_size) {
  const uint32_t pick = rng() % 16;
  btflod::TileHeaderInfo info;
  const bool header_ok = btflod::tile_peek_header(payload, info) == btflod::Status::success;
  if (!header_ok || pick == 0) {  // raw bytes
    mutate_vector(payload, max_size);
    return;
  }
  const size_t header = btflod::tile_header_size(info.channels);
  if (pick <= 11) {  // the symbol stream
    Bytes symbols;
    const size_t bound = btflod::tile_block_count(info.stored_size, info.channels) * btflod::kTileMaxBlockCode;
    if (!tile_symbols(info, payload.data() + header, payload.size() - header, symbols, bound)) {
      mutate_vector(payload, max_size);
      return;
    }
    mutate_vector(symbols, std::min(bound, symbols.size() + 64));
    // Keep the declared count exact most of the time; sometimes leave it stale.
    if (rng() % 8 != 0) put_u32(payload.data() + 8 + 4 * info.channels, static_cast<uint32_t>(symbols.size()));
    const Bytes stream = tile_code(info, symbols);
    payload.resize(header);
    payload.insert(payload.end(), stream.begin(), stream.end());
    return;
  }
  if (pick <= 14) {  // header fields: flags, size, tolerances
    Bytes h(payload.begin(), payload.begin() + static_cast<std::ptrdiff_t>(header));
    const size_t n = LLVMFuzzerMutate(h.data(), h.size(), h.size());
    (void)n;  // same size: the header layout is fixed
    std::copy(h.begin(), h.end(), payload.begin());
    return;
  }
  // The symbol count alone (the decompression-bomb and short-stream checks).
  put_u32(payload.data() + 8 + 4 * info.channels, static_cast<uint32_t>(rng()) % (info.symbol_bytes * 2 + 8));
}

/// A `.bsvtf` file split into its parts (lenient: enough for mutation, not a validation).
struct BsvtfParts {
  std::array<uint8_t, btflod::kBsvtfHeaderSize> header{};
  Bytes metadata;
  std::vector<std::array<uint8_t, btflod::kBsvtfPacketEntrySize>> packet_entries;
  std::vector<Bytes> packet_payloads;
  std::vector<std::array<uint8_t, btflod::kBsvtfTileEntrySize>> tile_entries;
  std::vector<Bytes> tile_payloads;

  static bool split(const uint8_t* data, size_t size, BsvtfParts& p) {
    using namespace btflod;
    if (size < kBsvtfHeaderSize || std::memcmp(data, kBsvtfMagic, 8) != 0) return false;
    std::memcpy(p.header.data(), data, kBsvtfHeaderSize);
    const uint64_t meta_off = get_u64(data + 32);
    const uint32_t meta_size = get_u32(data + 40);
    const uint32_t packets = get_u32(data + 56);
    const uint32_t tiles = get_u32(data + 72);
    if (meta_off != kBsvtfHeaderSize || meta_size > size - meta_off) return false;
    const uint64_t pt = meta_off + meta_size;
    if (packets > 4096 || tiles > 65536) return false;
    const uint64_t ti = pt + uint64_t{packets} * kBsvtfPacketEntrySize;
    const uint64_t end = ti + uint64_t{tiles} * kBsvtfTileEntrySize;
    if (end > size) return false;
    p.metadata.assign(data + meta_off, data + pt);
    auto payload_at = [&](uint64_t off, uint32_t n) {
      if (off > size || n > size - off) return Bytes{};
      return Bytes(data + off, data + off + n);
    };
    for (uint32_t i = 0; i < packets; ++i) {
      auto& e = p.packet_entries.emplace_back();
      std::memcpy(e.data(), data + pt + i * kBsvtfPacketEntrySize, kBsvtfPacketEntrySize);
      p.packet_payloads.push_back(payload_at(get_u64(e.data() + 8), get_u32(e.data() + 16)));
    }
    for (uint32_t i = 0; i < tiles; ++i) {
      auto& e = p.tile_entries.emplace_back();
      std::memcpy(e.data(), data + ti + i * kBsvtfTileEntrySize, kBsvtfTileEntrySize);
      p.tile_payloads.push_back(payload_at(get_u64(e.data() + 8), get_u32(e.data() + 16)));
    }
    return true;
  }

  /// Serialises with every offset, size and CRC recomputed. `keep_entry` (an index into the
  /// tile entries, or −1) keeps that entry's offset, size and CRC as they are, so a mutated
  /// entry field reaches the entry checks.
  Bytes join(long keep_entry = -1) const {
    using namespace btflod;
    Bytes out(header.begin(), header.end());
    put_u32(out.data() + 8 + 4, static_cast<uint32_t>(kBsvtfHeaderSize));
    out.insert(out.end(), metadata.begin(), metadata.end());
    const uint64_t pt = kBsvtfHeaderSize + metadata.size();
    const uint64_t ti = pt + packet_entries.size() * kBsvtfPacketEntrySize;
    const uint64_t payload = ti + tile_entries.size() * kBsvtfTileEntrySize;
    uint64_t cursor = payload;
    auto packets = packet_entries;
    auto tiles = tile_entries;
    for (size_t i = 0; i < packets.size(); ++i) {
      put_u64(packets[i].data() + 8, cursor);
      put_u32(packets[i].data() + 16, static_cast<uint32_t>(packet_payloads[i].size()));
      put_u32(packets[i].data() + 20, crc32_bytes(packet_payloads[i].data(), packet_payloads[i].size()));
      cursor += packet_payloads[i].size();
    }
    for (size_t i = 0; i < tiles.size(); ++i) {
      if (static_cast<long>(i) != keep_entry) {
        put_u64(tiles[i].data() + 8, cursor);
        put_u32(tiles[i].data() + 16, static_cast<uint32_t>(tile_payloads[i].size()));
        put_u32(tiles[i].data() + 20, crc32_bytes(tile_payloads[i].data(), tile_payloads[i].size()));
      }
      cursor += tile_payloads[i].size();
    }
    for (const auto& e : packets) out.insert(out.end(), e.begin(), e.end());
    for (const auto& e : tiles) out.insert(out.end(), e.begin(), e.end());
    for (const auto& b : packet_payloads) out.insert(out.end(), b.begin(), b.end());
    for (const auto& b : tile_payloads) out.insert(out.end(), b.begin(), b.end());
    uint8_t* h = out.data();
    put_u64(h + 16, out.size());        // file size
    put_u64(h + 24, payload);           // directory size
    put_u64(h + 32, kBsvtfHeaderSize);  // metadata offset
    put_u32(h + 40, static_cast<uint32_t>(metadata.size()));
    put_u32(h + 44, crc32_bytes(metadata.data(), metadata.size()));
    put_u64(h + 48, pt);
    put_u32(h + 56, static_cast<uint32_t>(packets.size()));
    put_u32(h + 60, crc32_bytes(out.data() + pt, ti - pt));
    put_u64(h + 64, ti);
    put_u32(h + 72, static_cast<uint32_t>(tiles.size()));
    put_u32(h + 76, crc32_bytes(out.data() + ti, payload - ti));
    put_u64(h + 80, payload);
    put_u64(h + 88, out.size() - payload);
    put_u32(h + kBsvtfHeaderSize - 4, crc32_bytes(h, kBsvtfHeaderSize - 4));
    return out;
  }
};

/// Copies `bytes` into libFuzzer's buffer when it fits; returns the new size, or 0 when not.
inline size_t emit(const Bytes& bytes, uint8_t* data, size_t max_size) {
  if (bytes.size() > max_size || bytes.empty()) return 0;
  std::memcpy(data, bytes.data(), bytes.size());
  return bytes.size();
}

/// One structure-aware mutation of a `.bsvtf` file (see the file comment). Falls back to
/// LLVMFuzzerMutate when the input does not split.
inline size_t mutate_bsvtf(uint8_t* data, size_t size, size_t max_size, unsigned seed) {
  using namespace btflod;
  std::minstd_rand rng(seed);
  BsvtfParts p;
  const uint32_t pick = rng() % 32;
  if (pick == 0 || !BsvtfParts::split(data, size, p)) return LLVMFuzzerMutate(data, size, max_size);
  long keep = -1;
  const size_t room = max_size > size ? max_size - size : 0;
  if (pick <= 14 && !p.tile_payloads.empty()) {  // a tile payload (its symbols, mostly)
    auto& t = p.tile_payloads[rng() % p.tile_payloads.size()];
    mutate_tile_payload(t, rng, t.size() + std::min<size_t>(room, 256));
  } else if (pick <= 17) {  // the metadata
    mutate_vector(p.metadata, p.metadata.size() + std::min<size_t>(room, 64));
  } else if (pick <= 19 && !p.packet_payloads.empty()) {  // a U packet (halves)
    auto& u = p.packet_payloads[rng() % p.packet_payloads.size()];
    const size_t n = u.size();
    mutate_vector(u, n);
    if (rng() % 4 != 0) u.resize(n);  // keep its size (the reader requires u_rows · 8) most of the time
  } else if (pick <= 23 && !p.tile_entries.empty()) {  // a tile-index entry: key, weight, energy
    const size_t i = rng() % p.tile_entries.size();
    auto& e = p.tile_entries[i];
    Bytes copy(e.begin(), e.end());
    LLVMFuzzerMutate(copy.data(), copy.size(), copy.size());
    std::copy(copy.begin(), copy.end(), e.begin());
    if (rng() % 4 == 0) keep = static_cast<long>(i);     // offset/size/CRC as mutated
  } else if (pick <= 25 && !p.packet_entries.empty()) {  // a packet entry's index field
    auto& e = p.packet_entries[rng() % p.packet_entries.size()];
    put_u32(e.data(), static_cast<uint32_t>(rng() % 8));
  } else if (pick <= 27 && !p.tile_entries.empty()) {  // drop a tile, or duplicate one as another id
    const size_t i = rng() % p.tile_entries.size();
    if (rng() % 2) {
      p.tile_entries.erase(p.tile_entries.begin() + static_cast<std::ptrdiff_t>(i));
      p.tile_payloads.erase(p.tile_payloads.begin() + static_cast<std::ptrdiff_t>(i));
    } else if (p.tile_entries.size() < 256) {
      auto e = p.tile_entries[i];
      const TileId id = TileId::from_key(get_u64(e.data()));
      TileId child = id;
      child.level = id.level + 1;
      child.x = id.x * 2 + (rng() & 1);
      child.y = id.y * 2 + (rng() >> 1 & 1);
      put_u64(e.data(), child.key());
      // Keep the index sorted by key so the tile reaches the decoder, not the order check.
      size_t at = 0;
      while (at < p.tile_entries.size() && get_u64(p.tile_entries[at].data()) < child.key()) ++at;
      p.tile_entries.insert(p.tile_entries.begin() + static_cast<std::ptrdiff_t>(at), e);
      p.tile_payloads.insert(p.tile_payloads.begin() + static_cast<std::ptrdiff_t>(at), p.tile_payloads[i]);
    }
  } else {  // header fields (version, reserved bytes, counts): only the header CRC recomputed
    Bytes out = p.join();
    LLVMFuzzerMutate(out.data() + 8, kBsvtfHeaderSize - 12, kBsvtfHeaderSize - 12);
    put_u32(out.data() + kBsvtfHeaderSize - 4, crc32_bytes(out.data(), kBsvtfHeaderSize - 4));
    const size_t n = emit(out, data, max_size);
    return n ? n : LLVMFuzzerMutate(data, size, max_size);
  }
  const size_t n = emit(p.join(keep), data, max_size);
  return n ? n : LLVMFuzzerMutate(data, size, max_size);
}

/// Cross-over of two `.bsvtf` files: a tile payload (or the U packets) of the second replaces
/// one of the first, sections and CRCs recomputed. 0 when either does not split.
inline size_t cross_over_bsvtf(const uint8_t* a, size_t a_size, const uint8_t* b, size_t b_size, uint8_t* out,
                               size_t max_size, unsigned seed) {
  std::minstd_rand rng(seed);
  BsvtfParts pa, pb;
  if (!BsvtfParts::split(a, a_size, pa) || !BsvtfParts::split(b, b_size, pb)) return 0;
  if (!pa.tile_payloads.empty() && !pb.tile_payloads.empty() && rng() % 4 != 0) {
    pa.tile_payloads[rng() % pa.tile_payloads.size()] = pb.tile_payloads[rng() % pb.tile_payloads.size()];
  } else if (pa.packet_payloads.size() == pb.packet_payloads.size()) {
    pa.packet_payloads = pb.packet_payloads;
  } else {
    pa.metadata = pb.metadata;
  }
  return emit(pa.join(), out, max_size);
}

/// A factor file ("BTFLODFR", offline/factor/factor_file.hpp) split into its sections.
struct FactorParts {
  uint32_t version = 0, kind = 0;
  std::vector<uint32_t> tags;
  std::vector<Bytes> payloads;

  static bool split(const uint8_t* data, size_t size, FactorParts& p) {
    if (size < 20 || std::memcmp(data, "BTFLODFR", 8) != 0) return false;
    p.version = get_u32(data + 8);
    p.kind = get_u32(data + 12);
    const uint32_t count = get_u32(data + 16);
    if (count > 64) return false;
    size_t at = 20;
    for (uint32_t i = 0; i < count; ++i) {
      if (size - at < 16) return false;
      const uint32_t tag = get_u32(data + at);
      const uint64_t n = get_u64(data + at + 4);
      at += 16;
      if (n > size - at) return false;
      p.tags.push_back(tag);
      p.payloads.emplace_back(data + at, data + at + n);
      at += n;
    }
    return true;
  }
  /// Serialises with every length and CRC recomputed (except section `stale`, whose CRC is kept
  /// from `stale_crc`: a deliberately wrong one).
  Bytes join(long stale = -1, uint32_t stale_crc = 0) const {
    Bytes out(20);
    std::memcpy(out.data(), "BTFLODFR", 8);
    put_u32(out.data() + 8, version);
    put_u32(out.data() + 12, kind);
    put_u32(out.data() + 16, static_cast<uint32_t>(tags.size()));
    for (size_t i = 0; i < tags.size(); ++i) {
      uint8_t h[16];
      put_u32(h, tags[i]);
      put_u64(h + 4, payloads[i].size());
      put_u32(h + 12, static_cast<long>(i) == stale ? stale_crc : crc32_bytes(payloads[i].data(), payloads[i].size()));
      out.insert(out.end(), h, h + 16);
      out.insert(out.end(), payloads[i].begin(), payloads[i].end());
    }
    return out;
  }
};

/// One structure-aware mutation of a factor file: a section payload (mostly), a section's tag,
/// the kind, a dropped or duplicated section, or plain bytes; lengths and CRCs recomputed.
inline size_t mutate_factor_file(uint8_t* data, size_t size, size_t max_size, unsigned seed) {
  std::minstd_rand rng(seed);
  FactorParts p;
  const uint32_t pick = rng() % 32;
  if (pick == 0 || !FactorParts::split(data, size, p) || p.tags.empty()) return LLVMFuzzerMutate(data, size, max_size);
  const size_t i = rng() % p.tags.size();
  const size_t room = max_size > size ? max_size - size : 0;
  long stale = -1;
  if (pick <= 22) {  // a section payload; its length mostly kept (readers check it against the shape)
    const size_t n = p.payloads[i].size();
    mutate_vector(p.payloads[i], n + std::min<size_t>(room, 64));
    if (rng() % 4 != 0 && p.payloads[i].size() != n) p.payloads[i].resize(n);
  } else if (pick <= 24) {  // another representation's reader on these sections
    p.kind = 1 + rng() % 6;
  } else if (pick <= 26) {  // a section's tag: another known tag, or a mutated one
    static const char* kTags[] = {"SHAP", "META", "MEAN", "CLID", "DICT", "EALL", "EIGF",
                                  "EIGQ", "FMFA", "FMFS", "FMFU", "FMFV", "LALL", "RALL",
                                  "RBAS", "RCOF", "RMEA", "SIDX", "SWGT", "WALL", "WGHT"};
    const char* t = kTags[rng() % (sizeof kTags / sizeof kTags[0])];
    p.tags[i] = get_u32(reinterpret_cast<const uint8_t*>(t));
    if (rng() % 2) p.tags[i] ^= 1u << (rng() % 32);
  } else if (pick <= 28) {  // drop or duplicate a section
    if (rng() % 2 || p.tags.size() >= 64) {
      p.tags.erase(p.tags.begin() + static_cast<std::ptrdiff_t>(i));
      p.payloads.erase(p.payloads.begin() + static_cast<std::ptrdiff_t>(i));
    } else {
      p.tags.push_back(p.tags[i]);
      p.payloads.push_back(p.payloads[i]);
    }
  } else if (pick <= 29) {  // a stale CRC
    stale = static_cast<long>(i);
  } else {  // a payload with its length and CRC as they were (truncation, trailing bytes)
    return LLVMFuzzerMutate(data, size, max_size);
  }
  const size_t n = emit(p.join(stale, static_cast<uint32_t>(rng())), data, max_size);
  return n ? n : LLVMFuzzerMutate(data, size, max_size);
}

/// Cross-over of two factor files: a section of the second replaces (or is added to) the first.
inline size_t cross_over_factor_file(const uint8_t* a, size_t a_size, const uint8_t* b, size_t b_size, uint8_t* out,
                                     size_t max_size, unsigned seed) {
  std::minstd_rand rng(seed);
  FactorParts pa, pb;
  if (!FactorParts::split(a, a_size, pa) || !FactorParts::split(b, b_size, pb) || pb.tags.empty()) return 0;
  const size_t j = rng() % pb.tags.size();
  size_t i = 0;
  while (i < pa.tags.size() && pa.tags[i] != pb.tags[j]) ++i;
  if (i < pa.tags.size())
    pa.payloads[i] = pb.payloads[j];
  else if (pa.tags.size() < 64)
    pa.tags.push_back(pb.tags[j]), pa.payloads.push_back(pb.payloads[j]);
  return emit(pa.join(), out, max_size);
}

}  // namespace btflod_fuzz

/// Defines LLVMFuzzerCustomMutator and LLVMFuzzerCustomCrossOver for a target whose inputs are
/// one structured format: `mutate(data, size, max_size, seed)` and `cross_over(a, a_size, b,
/// b_size, out, max_size, seed)` (returning 0 when the inputs do not split), with the byte-level
/// fallback of BTFLOD_FUZZ_BYTES=1 and a plain splice when the cross-over declines. Use at global
/// scope, once per target.
#define BTFLOD_FUZZ_STRUCTURE_AWARE(mutate, cross_over)                                                         \
  extern "C" size_t LLVMFuzzerCustomMutator(uint8_t* data, size_t size, size_t max_size, unsigned int seed) {   \
    if (btflod_fuzz::byte_mode()) return LLVMFuzzerMutate(data, size, max_size);                                \
    return mutate(data, size, max_size, seed);                                                                  \
  }                                                                                                             \
  extern "C" size_t LLVMFuzzerCustomCrossOver(const uint8_t* a, size_t a_size, const uint8_t* b, size_t b_size, \
                                              uint8_t* out, size_t max_size, unsigned int seed) {               \
    if (!btflod_fuzz::byte_mode())                                                                              \
      if (const size_t n = cross_over(a, a_size, b, b_size, out, max_size, seed)) return n;                     \
    return btflod_fuzz::splice(a, a_size, b, b_size, out, max_size, seed);                                      \
  }
