// Tests for offline/btf/image_io.hpp: PNG/JPEG encode/decode round trips, sRGB linearisation against the
// IEC 61966-2-1 formula, the decompression-bomb guard on a hand-made PNG header, and the failure
// classes of the decoder (empty, truncated, garbage, missing file).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "btflod/core/bytes.hpp"
#include "btflod/offline/btf/image_io.hpp"

namespace {

using namespace btflod;

std::string tmp_path(const std::string& name) {
  std::filesystem::create_directories(BTFLOD_TEST_TMP_DIR);
  return std::string(BTFLOD_TEST_TMP_DIR) + "/image_io_" + name;
}

Image<uint8_t> pattern(int w, int h, int c) {
  Image<uint8_t> img(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k) img.at(x, y, k) = static_cast<uint8_t>((x * 37 + y * 11 + k * 101) & 0xff);
  return img;
}

// A PNG made of the signature and an IHDR chunk only, declaring w×h RGB8: what a bomb looks
// like before its (absent or tiny) IDAT.
std::vector<uint8_t> png_header_only(uint32_t w, uint32_t h) {
  std::vector<uint8_t> out = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  auto be32 = [&](uint32_t v) {
    out.push_back(static_cast<uint8_t>(v >> 24));
    out.push_back(static_cast<uint8_t>(v >> 16));
    out.push_back(static_cast<uint8_t>(v >> 8));
    out.push_back(static_cast<uint8_t>(v));
  };
  be32(13);
  const size_t type_at = out.size();
  out.insert(out.end(), {'I', 'H', 'D', 'R'});
  be32(w);
  be32(h);
  out.insert(out.end(), {8, 2, 0, 0, 0});  // bit depth 8, colour type RGB, deflate, filter 0, no interlace
  be32(crc32_of(std::span<const uint8_t>(out.data() + type_at, out.size() - type_at)));
  return out;
}

TEST(ImageIo, PngRoundTripIsExactForEveryChannelCount) {
  for (int c = 1; c <= 4; ++c) {
    const auto img = pattern(13, 7, c);
    auto png = encode_png(img.view());
    ASSERT_TRUE(png) << png.message();
    auto info = probe_image(*png);
    ASSERT_TRUE(info) << info.message();
    EXPECT_EQ(info->width, 13);
    EXPECT_EQ(info->height, 7);
    EXPECT_EQ(info->channels, c);
    auto back = decode_image(*png);
    ASSERT_TRUE(back) << back.message();
    ASSERT_EQ(back->channels(), c);
    ASSERT_EQ(back->size(), img.size());
    for (size_t i = 0; i < img.size(); ++i) ASSERT_EQ(back->data()[i], img.data()[i]) << "c=" << c << " i=" << i;
  }
}

TEST(ImageIo, StridedViewIsWrittenAsItsRectangle) {
  const auto big = pattern(20, 10, 4);
  // The rectangle (3,2)-(10,7), channels 0..2 of an RGBA image: not dense.
  const auto view = big.view().subview(3, 2, 8, 6).channel_range(0, 3);
  ASSERT_FALSE(view.is_dense());
  const std::string path = tmp_path("strided.png");
  ASSERT_TRUE(write_png(path, view));
  auto back = load_image(path);
  ASSERT_TRUE(back) << back.message();
  ASSERT_EQ(back->width(), 8);
  ASSERT_EQ(back->height(), 6);
  ASSERT_EQ(back->channels(), 3);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x)
      for (int c = 0; c < 3; ++c) ASSERT_EQ(back->at(x, y, c), big.at(x + 3, y + 2, c));
}

TEST(ImageIo, DesiredChannelsConvertsGreyToRgb) {
  const auto grey = pattern(5, 4, 1);
  auto png = encode_png(grey.view());
  ASSERT_TRUE(png);
  auto rgb = decode_image(*png, 3);
  ASSERT_TRUE(rgb) << rgb.message();
  ASSERT_EQ(rgb->channels(), 3);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 5; ++x)
      for (int c = 0; c < 3; ++c) EXPECT_EQ(rgb->at(x, y, c), grey.at(x, y, 0));
}

TEST(ImageIo, JpegRoundTripOfSmoothImageIsClose) {
  Image<uint8_t> img(32, 24, 3);
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 32; ++x) {
      img.at(x, y, 0) = static_cast<uint8_t>(x * 6);
      img.at(x, y, 1) = static_cast<uint8_t>(y * 8);
      img.at(x, y, 2) = 128;
    }
  auto jpg = encode_jpeg(img.view(), 95);
  ASSERT_TRUE(jpg) << jpg.message();
  ASSERT_GE(jpg->size(), 4u);
  EXPECT_EQ((*jpg)[0], 0xFF);
  EXPECT_EQ((*jpg)[1], 0xD8);  // SOI marker: it is a JPEG, not a PNG
  auto back = decode_image(*jpg);
  ASSERT_TRUE(back) << back.message();
  ASSERT_EQ(back->channels(), 3);
  double sum_abs = 0;
  for (size_t i = 0; i < img.size(); ++i) sum_abs += std::abs(int(back->data()[i]) - int(img.data()[i]));
  EXPECT_LT(sum_abs / static_cast<double>(img.size()), 3.0);
}

TEST(ImageIo, LoadImageLinearAppliesTheSrgbFormula) {
  Image<uint8_t> img(256, 1, 3);
  for (int x = 0; x < 256; ++x)
    for (int c = 0; c < 3; ++c) img.at(x, 0, c) = static_cast<uint8_t>(x);
  const std::string path = tmp_path("ramp.png");
  ASSERT_TRUE(write_png(path, img.view()));
  auto lin = load_image_linear(path);
  ASSERT_TRUE(lin) << lin.message();
  ASSERT_EQ(lin->channels(), 3);
  for (int x = 0; x < 256; ++x) {
    // IEC 61966-2-1, written out independently of core/color.hpp.
    const double e = x / 255.0;
    const double expected = e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
    ASSERT_NEAR(lin->at(x, 0, 0), expected, 1e-6) << x;
    ASSERT_NEAR(lin->at(x, 0, 2), expected, 1e-6) << x;
  }
}

TEST(ImageIo, WritePngSrgbClampsAndMapsNanToZero) {
  Image<float> img(6, 1, 3);
  const float values[6] = {0.0f, 0.5f, 1.0f, 7.0f, -3.0f, std::numeric_limits<float>::quiet_NaN()};
  for (int x = 0; x < 6; ++x)
    for (int c = 0; c < 3; ++c) img.at(x, 0, c) = values[x];
  img.at(5, 0, 1) = std::numeric_limits<float>::infinity();
  const std::string path = tmp_path("srgb.png");
  ASSERT_TRUE(write_png_srgb(path, img.view()));
  auto back = load_image(path);
  ASSERT_TRUE(back) << back.message();
  EXPECT_EQ(back->at(0, 0, 0), 0);
  EXPECT_EQ(back->at(1, 0, 0), 188);  // 1.055·0.5^(1/2.4) − 0.055 = 0.7354 → 187.5 → 188
  EXPECT_EQ(back->at(2, 0, 0), 255);
  EXPECT_EQ(back->at(3, 0, 0), 255);
  EXPECT_EQ(back->at(4, 0, 0), 0);
  EXPECT_EQ(back->at(5, 0, 0), 0);    // NaN
  EXPECT_EQ(back->at(5, 0, 1), 255);  // +Inf clamps
}

TEST(ImageIo, LinearRoundTripThroughPngIsWithinHalfAnSrgbStep) {
  Image<float> img(64, 1, 3);
  for (int x = 0; x < 64; ++x)
    for (int c = 0; c < 3; ++c) img.at(x, 0, c) = static_cast<float>(x * 3 + c) / 192.0f;
  const std::string path = tmp_path("linear_rt.png");
  ASSERT_TRUE(write_png_srgb(path, img.view()));
  auto back = load_image_linear(path);
  ASSERT_TRUE(back) << back.message();
  for (int x = 0; x < 64; ++x)
    for (int c = 0; c < 3; ++c) {
      const float enc = linear_to_srgb(img.at(x, 0, c));
      EXPECT_NEAR(linear_to_srgb(back->at(x, 0, c)), enc, 0.5f / 255.0f + 1e-5f);
    }
}

TEST(ImageIo, DecompressionBombIsRejectedBeforeDecoding) {
  // 12000×12000 RGB declared in 33 bytes: stb itself would accept the header (432 MB < 1 GiB),
  // so only our limit stands between it and a huge allocation.
  ImageLimits limits;
  limits.max_pixels = uint64_t{4096} * 4096;
  const auto bomb = png_header_only(12000, 12000);
  auto info = probe_image(bomb, limits);
  ASSERT_FALSE(info);
  EXPECT_EQ(info.status(), Status::insufficient_space);
  EXPECT_NE(info.message().find("12000x12000"), std::string::npos) << info.message();
  auto img = decode_image(bomb, 0, limits);
  ASSERT_FALSE(img);
  EXPECT_EQ(img.status(), Status::insufficient_space);
  // Just over the default per-side limit, small area: still rejected.
  auto wide = decode_image(png_header_only(kMaxImageDimension + 1, 1));
  EXPECT_EQ(wide.status(), Status::insufficient_space) << wide.message();
  // Far beyond everything: stb refuses the header itself; we still fail without decoding.
  auto huge = decode_image(png_header_only(100000, 100000));
  EXPECT_FALSE(huge);
  EXPECT_FALSE(huge.message().empty());
}

TEST(ImageIo, CustomLimitsRejectARealImage) {
  auto png = encode_png(pattern(40, 30, 3).view());
  ASSERT_TRUE(png);
  ImageLimits limits;
  limits.max_pixels = 40 * 30 - 1;
  auto img = decode_image(*png, 0, limits);
  ASSERT_FALSE(img);
  EXPECT_EQ(img.status(), Status::insufficient_space);
  limits.max_pixels = 40 * 30;
  EXPECT_TRUE(decode_image(*png, 0, limits));
}

TEST(ImageIo, TruncatedInputIsBadData) {
  auto png = encode_png(pattern(64, 64, 3).view());
  ASSERT_TRUE(png);
  for (size_t keep : {size_t{1}, size_t{8}, size_t{30}, png->size() / 2, png->size() - 13}) {
    std::vector<uint8_t> cut(png->begin(), png->begin() + static_cast<ptrdiff_t>(keep));
    auto img = decode_image(cut);
    EXPECT_FALSE(img) << "kept " << keep << " of " << png->size();
    if (!img) {
      EXPECT_FALSE(img.message().empty());
    }
  }
}

TEST(ImageIo, WrongSignatureIsBadDataWithReason) {
  std::vector<uint8_t> junk(200, 0x5a);
  auto img = decode_image(junk);
  ASSERT_FALSE(img);
  EXPECT_EQ(img.status(), Status::bad_data);
  EXPECT_NE(img.message().find("not a decodable image"), std::string::npos) << img.message();
  EXPECT_EQ(decode_image({}).status(), Status::short_output);
}

TEST(ImageIo, MissingFileIsIoErrorNamingThePath) {
  auto img = load_image_linear("/nonexistent/dir/x.png");
  ASSERT_FALSE(img);
  EXPECT_EQ(img.status(), Status::io_error);
  EXPECT_NE(img.message().find("/nonexistent/dir/x.png"), std::string::npos);
}

TEST(ImageIo, InvalidArgumentsAreRejected) {
  Image<uint8_t> five(2, 2, 5);
  EXPECT_EQ(encode_png(five.view()).status(), Status::invalid_argument);
  EXPECT_EQ(encode_png(ImageView<const uint8_t>()).status(), Status::invalid_argument);
  EXPECT_EQ(encode_jpeg(pattern(2, 2, 3).view(), 0).status(), Status::invalid_argument);
  EXPECT_EQ(decode_image(std::vector<uint8_t>(10), 7).status(), Status::invalid_argument);
  EXPECT_EQ(write_png_srgb(tmp_path("never.png"), ImageView<const float>()).status(), Status::invalid_argument);
}

}  // namespace
