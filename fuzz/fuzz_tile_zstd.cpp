// libFuzzer target for the zstd entropy coder of runtime/codec/tile_codec.hpp (tile format 3, coder 1).
// Byte 0 selects the mode:
//   even: bytes 1–2 (little-endian) are the declared symbol byte count (folded into the range
//         tile_peek_header accepts for a 24×24×4 tile), the rest is the zstd frame behind an
//         otherwise valid format-3 header (bit 1 of byte 0: a residual tile, decoded against a
//         fixed parent); decode must succeed with finite samples or fail with a message;
//   odd:  round trip: the rest seeds a 16×16×4 tile (T = 8, B = 4); encoded with zstd and with
//         deflate, both decode to the encoder's reconstruction bit for bit (and to each other).
// Without zstd in the build (BTFLOD_WITH_ZSTD=OFF) every zstd tile must be rejected.
//
// Speed: decoders, encoders and buffers are made once; in the round trip the encoders are the
// oracle, compiled without coverage instrumentation (tile_encoder_oracle.ignorelist), and the
// tile is the smallest one with several blocks (4 per channel).
// btflod-coverage-ignorelist: tile_encoder_oracle.ignorelist
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "btflod/runtime/codec/tile_codec.hpp"
#include "tile_zstd_decode_payload.hpp"

namespace {
using namespace btflod;

const TileLayout kLayout{16, 4, 4};
const TileLayout kRoundTripLayout{8, 4, 4};

void decode_mode(const uint8_t* data, size_t size, uint8_t selector) {
  static TileDecoder decoder(kLayout);
  static const std::vector<float> parent = [] {
    std::vector<float> p(kLayout.sample_count());
    for (size_t i = 0; i < p.size(); ++i) p[i] = static_cast<float>(i % 17) * 0.125f;
    return p;
  }();
  static std::vector<uint8_t> payload;
  btflod_fuzz::tile_zstd_decode_payload(kLayout, data, size, payload);
  static std::vector<float> out(kLayout.sample_count());
  const Status st = decoder.decode(payload, parent, selector >> 2 & 1u, selector >> 3 & 1u, out);
  if (st == Status::success) {
    if (!tile_entropy_coder_available(TileEntropyCoder::zstd)) std::abort();
    for (float v : out)
      if (!std::isfinite(v)) std::abort();
  } else if (const char* m = decoder.message(); m == nullptr || *m == '\0') {
    std::abort();
  }
}

void round_trip_mode(const uint8_t* data, size_t size) {
  static TileEncoder packed(kRoundTripLayout, 1),
      plain(kRoundTripLayout, 1);  // fast levels: the fuzzer is after the decoder
  static const bool have_zstd = packed.set_entropy_coder(TileEntropyCoder::zstd, 3);
  static TileDecoder decoder(kRoundTripLayout);
  if (!have_zstd) return;
  const size_t n = kRoundTripLayout.sample_count();
  static std::vector<float> tile(n), ra(n), rb(n), out(n);
  static std::vector<uint8_t> a(packed.bound()), b(plain.bound());
  for (size_t i = 0; i < tile.size(); ++i) {
    const uint8_t b = size ? data[i % size] : 0;
    tile[i] = (static_cast<float>(b) - 128.0f) * (1.0f + static_cast<float>(i % 5));
  }
  const float t = 0.05f + (size ? data[0] : 0) * 0.25f;
  const float tol[4] = {t, t * 2, t * 0.5f, t};
  size_t na = 0, nb = 0;
  if (packed.encode(tile, {}, 0, 0, tol, a, na, ra) != Status::success) std::abort();
  if (plain.encode(tile, {}, 0, 0, tol, b, nb, rb) != Status::success) std::abort();
  if (std::memcmp(ra.data(), rb.data(), ra.size() * sizeof(float)) != 0) std::abort();
  if (decoder.decode(std::span<const uint8_t>(a).first(na), {}, 0, 0, out) != Status::success) std::abort();
  if (std::memcmp(out.data(), ra.data(), out.size() * sizeof(float)) != 0) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  if (data[0] & 1u) {
    round_trip_mode(data + 1, size - 1);
  } else {
    decode_mode(data, size, data[0]);
  }
  return 0;
}
