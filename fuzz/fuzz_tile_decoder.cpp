// libFuzzer target for runtime/codec/tile_codec.hpp's decoder. Byte 0 is a selector (bit 0 unused, so
// inputs of the former combined target stay valid seeds; bit 1 qx, bit 2 qy, bit 3 the zlib or
// the libdeflate backend); the rest is a tile payload, decoded with a 24×24 or 72×72 decoder
// (chosen from the header, channel count from the header) and a parent tile when the header
// asks for one. Each output span ends exactly at the end of its allocation so ASan catches any
// over-write. The encode → decode round trip is its own target (fuzz_tile_round_trip).
//
// Speed: decoders, parent tiles and output buffers are made once per (backend, size, channels)
// and reused, so an input costs one header parse, one inflate and at most one reconstruction —
// no allocation per input.
//
// Mutation: structure-aware (structure_mutators.hpp: mutate_tile_payload inflates the stream,
// mutates the symbols and deflates them again, so mutations reach the symbol decoder and the
// reconstruction rather than stopping at inflate); with BTFLOD_FUZZ_BYTES=1 in the environment
// libFuzzer's plain byte-level mutation is used. New entropy coders in the tile format are
// reached through the raw-bytes and header mutations (and the symbol mutation once the mutator
// knows their framing).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <vector>

#include "btflod/runtime/codec/tile_codec.hpp"
#include "structure_mutators.hpp"

namespace {
using namespace btflod;

struct DecodeState {
  std::unique_ptr<TileDecoder> decoder;
  std::vector<float> parent;
  std::vector<float> out;
};

DecodeState& state_for(uint32_t backend, bool large, uint32_t channels) {
  static DecodeState states[2][2][5];
  DecodeState& s = states[backend][large][channels];
  if (!s.decoder) {
    const TileLayout layout{large ? 64u : 16u, 4, channels};
    s.decoder = std::make_unique<TileDecoder>(layout, backend ? InflateBackend::libdeflate : InflateBackend::zlib);
    s.parent.resize(layout.sample_count());
    for (size_t i = 0; i < s.parent.size(); ++i) s.parent[i] = static_cast<float>(i % 17) * 0.125f;
    s.out.resize(layout.sample_count());
  }
  return s;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t selector = data[0];
  const std::span<const uint8_t> payload(data + 1, size - 1);
  TileHeaderInfo info;
  const bool peeked = tile_peek_header(payload, info) == Status::success;
  const bool large = peeked && info.stored_size == 72;
  const uint32_t channels = peeked && info.channels >= 1 && info.channels <= 4 ? info.channels : 4;
  DecodeState& s = state_for(selector >> 3 & 1u, large, channels);
  const Status st = s.decoder->decode(payload, s.parent, selector >> 1 & 1u, selector >> 2 & 1u, s.out);
  if (st == Status::success) {
    for (float v : s.out)
      if (!std::isfinite(v)) std::abort();  // bounded tolerances and symbols keep values finite
  } else if (const char* m = s.decoder->message(); m == nullptr || *m == '\0') {
    std::abort();  // every failure explains itself
  }
  return 0;
}

extern "C" size_t LLVMFuzzerCustomMutator(uint8_t* data, size_t size, size_t max_size, unsigned int seed) {
  std::minstd_rand rng(seed);
  if (btflod_fuzz::byte_mode() || size < 2 || rng() % 16 == 0) return LLVMFuzzerMutate(data, size, max_size);
  if (rng() % 16 == 0) {  // the selector byte: backend, quadrant
    data[0] = static_cast<uint8_t>(rng());
    return size;
  }
  btflod_fuzz::Bytes payload(data + 1, data + size);
  btflod_fuzz::mutate_tile_payload(payload, rng, max_size - 1);
  if (payload.empty() || payload.size() > max_size - 1) return LLVMFuzzerMutate(data, size, max_size);
  std::memcpy(data + 1, payload.data(), payload.size());
  return payload.size() + 1;
}
