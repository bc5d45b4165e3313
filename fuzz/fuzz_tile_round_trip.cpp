// libFuzzer target for runtime/codec/tile_codec.hpp's encoder → decoder round trip. Byte 0: bits 1–3 the
// frequency weighting (quarters 0..7, values above 4 are treated as 4 by the encoder), bit 4 the
// entropy coder (deflate, or zstd when the build has it), bits 5–6 the channel count (1..4),
// bit 7 the tile size (8 or 16 texels, 4 of border: 16×16 or 24×24 stored); the rest seeds the
// tile and a tolerance. encode → decode must succeed and reproduce the encoder's reconstruction
// bit for bit.
//
// Speed: the encoder (deflate and zstd at the fast level 1: the target is after the codec's quantiser,
// token writer and closed loop, not zlib's match finder), the decoder and every buffer are
// made once per layout; an input costs one encode (forward DCT, quantisation, deflate, the
// encoder's own decode) and one decode of 4 to 36 blocks. The encoder is the oracle, not the code
// under test: it is compiled without coverage instrumentation (tile_encoder_oracle.ignorelist).
// btflod-coverage-ignorelist: tile_encoder_oracle.ignorelist
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "btflod/runtime/codec/tile_codec.hpp"

namespace {
using namespace btflod;

struct Codec {
  explicit Codec(TileLayout l)
      : layout(l),
        encoder(l, 1),
        decoder(l),
        tile(l.sample_count()),
        recon(l.sample_count()),
        out(l.sample_count()),
        payload(encoder.bound()) {}
  TileLayout layout;
  TileEncoder encoder;
  TileDecoder decoder;
  std::vector<float> tile, recon, out;
  std::vector<uint8_t> payload;
};

Codec& codec(uint32_t tile_size, uint32_t channels) {
  static std::unique_ptr<Codec> codecs[2][4];
  auto& c = codecs[tile_size == 16][channels - 1];
  if (!c) c = std::make_unique<Codec>(TileLayout{tile_size, 4, channels});
  return *c;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t selector = data[0];
  ++data;
  --size;
  Codec& k = codec(selector & 0x80u ? 16 : 8, 1 + (selector >> 5 & 3u));
  for (size_t i = 0; i < k.tile.size(); ++i) {
    const uint8_t b = size ? data[i % size] : 0;
    k.tile[i] = (static_cast<float>(b) - 128.0f) * (1.0f + static_cast<float>(i % 7));
  }
  const float t = 0.01f + (size ? data[0] : 0) * 0.5f;
  const float tol[4] = {t, t * 2, t * 0.5f, t};
  k.encoder.set_weight_quarters(selector >> 1 & 7u);
  const bool zstd = (selector >> 4 & 1u) && tile_entropy_coder_available(TileEntropyCoder::zstd);
  if (!k.encoder.set_entropy_coder(zstd ? TileEntropyCoder::zstd : TileEntropyCoder::deflate, 1)) std::abort();
  size_t written = 0;
  if (k.encoder.encode(k.tile, {}, 0, 0, std::span<const float>(tol, k.layout.channels), k.payload, written, k.recon) !=
      Status::success)
    std::abort();
  if (k.decoder.decode(std::span<const uint8_t>(k.payload).first(written), {}, 0, 0, k.out) != Status::success)
    std::abort();
  if (std::memcmp(k.out.data(), k.recon.data(), k.out.size() * sizeof(float)) != 0) std::abort();
  return 0;
}
