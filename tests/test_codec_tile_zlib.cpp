// The whole of tests/test_codec_tile.cpp once more, compiled WITHOUT BTFLOD_TILE_CODEC_LIBDEFLATE:
// the zlib-only decoder that a build with -DBTFLOD_WITH_LIBDEFLATE=OFF ships (the btflod target
// defines the macro when libdeflate is used; this executable is one translation unit, so the
// #undef before any include gives it the zlib-only definitions throughout, no ODR mix).
#undef BTFLOD_TILE_CODEC_LIBDEFLATE
#include "test_codec_tile.cpp"

static_assert(btflod::kDefaultInflateBackend == btflod::InflateBackend::zlib,
              "this twin must build the zlib-only decoder");

TEST(TileCodecZlibOnly, DecodersUseZlib) {
  btflod::TileDecoder decoder(btflod::TileLayout{16, 4, 4}, btflod::InflateBackend::libdeflate);
  EXPECT_EQ(decoder.backend(), btflod::InflateBackend::zlib)
      << "without the macro a libdeflate request falls back to zlib";
}
