// The whole of tests/test_codec_tile.cpp once more with every decoder on zlib's inflate: the
// decoder that a build with -DBTFLOD_WITH_LIBDEFLATE=OFF ships, and the fallback of a
// libdeflate request when libdeflate is not compiled in. The backend is a run-time choice
// behind RawInflater (runtime/codec/tile_codec.hpp), so no build option changes TileDecoder's layout.
#define BTFLOD_TEST_INFLATE_BACKEND btflod::InflateBackend::zlib
#include "test_codec_tile.cpp"

TEST(TileCodecZlibOnly, DecodersUseZlib) {
  btflod::TileDecoder decoder(btflod::TileLayout{16, 4, 4}, btflod::InflateBackend::zlib);
  EXPECT_EQ(decoder.backend(), btflod::InflateBackend::zlib);
  EXPECT_TRUE(btflod::inflate_backend_available(btflod::InflateBackend::zlib));
}

TEST(TileCodecZlibOnly, LibdeflateRequestFallsBackToZlibWhenNotCompiledIn) {
  btflod::TileDecoder decoder(btflod::TileLayout{16, 4, 4}, btflod::InflateBackend::libdeflate);
  const bool available = btflod::inflate_backend_available(btflod::InflateBackend::libdeflate);
  EXPECT_EQ(decoder.backend(), available ? btflod::InflateBackend::libdeflate : btflod::InflateBackend::zlib);
  EXPECT_EQ(btflod::default_inflate_backend(), decoder.backend());
}
