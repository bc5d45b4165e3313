// Tests for offline/btf/openexr_image_set.hpp: EXR encode/decode in memory (HALF and FLOAT channels,
// values kept linear and exact in FLOAT, rounded to half in HALF), a BTF written as an image set
// with btflib's and the UBO2003 naming and read back, per-view folders, and the failure classes:
// truncated files (every prefix of a small file), wrong magic, missing channels, NaN samples,
// oversized data windows, images of differing sizes, missing pairs, non-EXR files skipped.
// Skipped when btflod is configured without OpenEXR (BTFLOD_WITH_OPENEXR=OFF).
#include <gtest/gtest.h>

#if defined(BTFLOD_WITH_OPENEXR) && BTFLOD_WITH_OPENEXR

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "btflod/core/half.hpp"
#include "btflod/offline/btf/openexr_image_set.hpp"
#include "test_btf_helpers.hpp"

namespace {

using namespace btflod;
namespace fs = std::filesystem;

std::string tmp(const std::string& name) { return btflod_test::fresh_tmp_path("exr_" + name).string(); }

Image<float> gradient(int w, int h, float scale = 1.0f) {
  Image<float> img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = scale * (0.1f * x + 0.37f * y + 1.5f * c + 0.001f);  // HDR: > 1
  return img;
}

// A small BTF with distinct, HDR values per (texel, view, light, channel).
BtfFloat small_btf(const DirectionSet& set) {
  BtfFloat btf(3, 2, set, set);
  float* s = btf.samples().data();
  for (size_t i = 0; i < btf.samples().size(); ++i) s[i] = 0.25f * static_cast<float>(i % 97) + 0.5f;
  return btf;
}

DirectionSet three_directions() {
  const std::vector<std::pair<float, float>> tp = {
      {0.0f, 0.0f}, {degrees_to_radians(15.0f), 0.0f}, {degrees_to_radians(15.0f), degrees_to_radians(60.0f)}};
  return DirectionSet::from_radians("three", tp);
}

TEST(OpenExr, FloatChannelsRoundTripExactlyHalfChannelsToHalfPrecision) {
  const Image<float> img = gradient(5, 4, 3.0f);
  for (ExrPixelType type : {ExrPixelType::float32, ExrPixelType::half}) {
    auto bytes = encode_exr(img.view(), type);
    ASSERT_TRUE(bytes.ok()) << bytes.message();
    auto info = probe_exr(*bytes);
    ASSERT_TRUE(info.ok()) << info.message();
    EXPECT_EQ(info->width, 5);
    EXPECT_EQ(info->height, 4);
    EXPECT_EQ(info->rgb_half, type == ExrPixelType::half);
    auto back = decode_exr(*bytes);
    ASSERT_TRUE(back.ok()) << back.message();
    ASSERT_EQ(back->width(), 5);
    ASSERT_EQ(back->height(), 4);
    for (size_t i = 0; i < img.size(); ++i) {
      const float expect =
          type == ExrPixelType::float32 ? img.data()[i] : half_bits_to_float(float_to_half_bits(img.data()[i]));
      ASSERT_EQ(back->data()[i], expect) << i;
    }
  }
}

TEST(OpenExr, ImageSetRoundTripsWithBothNamings) {
  const BtfFloat btf = small_btf(three_directions());
  for (ExrNaming naming : {ExrNaming::btflib, ExrNaming::ubo2003}) {
    const std::string dir = tmp(naming == ExrNaming::btflib ? "btflib" : "ubo2003");
    ExrImageSetWriteOptions wo;
    wo.naming = naming;
    wo.pixel_type = ExrPixelType::float32;
    wo.prefix = "Mat_";
    ASSERT_TRUE(write_exr_image_set(btf, dir, wo).ok());
    if (naming == ExrNaming::btflib) {
      EXPECT_TRUE(fs::exists(fs::path(dir) / "tv015_pv060_tl000_pl000.exr"));
    } else {
      EXPECT_TRUE(fs::exists(fs::path(dir) / "Mat_00002_tl015_pl060_tv000_pv000.exr"));
    }
    Ubo2003ReadOptions ro;
    ro.directions = UboDirections::custom;
    ro.custom_views = ro.custom_lights = three_directions();
    auto back = read_exr_image_set(dir, ro);
    ASSERT_TRUE(back.ok()) << back.message();
    ASSERT_EQ(back->btf.width(), 3);
    ASSERT_EQ(back->btf.height(), 2);
    for (size_t i = 0; i < btf.samples().size(); ++i) ASSERT_EQ(back->btf.samples()[i], btf.samples()[i]) << i;
  }
}

TEST(OpenExr, Ubo2003SetInHalfIsRecognisedAutomatically) {
  const BtfFloat btf = small_btf(DirectionSet::ubo2003());
  const std::string dir = tmp("auto");
  ASSERT_TRUE(write_exr_image_set(btf, dir).ok());  // btflib naming, HALF
  // A file that is not EXR is skipped with a warning.
  ASSERT_TRUE(write_file_bytes(dir + "/notes.txt", std::vector<uint8_t>{'h', 'i'}).ok());
  auto back = read_exr_image_set(dir);
  ASSERT_TRUE(back.ok()) << back.message();
  EXPECT_EQ(back->btf.views().name(), "UBO2003");
  ASSERT_EQ(back->warnings.size(), 1u);
  EXPECT_NE(back->warnings[0].find("not a OpenEXR image"), std::string::npos) << back->warnings[0];
  double worst = 0;
  for (size_t i = 0; i < btf.samples().size(); ++i)
    worst = std::max(worst, double(std::abs(back->btf.samples()[i] - btf.samples()[i]) / btf.samples()[i]));
  EXPECT_LT(worst, 1.0 / 1024);  // half precision
}

// ---- failure classes ---------------------------------------------------------------------------

TEST(OpenExr, EveryPrefixOfASmallFileIsRejectedAsTruncated) {
  auto bytes = encode_exr(gradient(4, 3).view(), ExrPixelType::half);
  ASSERT_TRUE(bytes.ok());
  for (size_t n = 0; n < bytes->size(); ++n) {
    auto img = decode_exr(std::span<const uint8_t>(bytes->data(), n));
    ASSERT_FALSE(img.ok()) << "accepted " << n << " of " << bytes->size() << " bytes";
    EXPECT_TRUE(img.status() == Status::short_output || img.status() == Status::bad_data) << img.message();
    EXPECT_FALSE(img.message().empty());
  }
  // Cuts inside the header are always truncation.
  for (size_t n : {size_t{0}, size_t{7}, size_t{8}, size_t{30}}) {
    EXPECT_EQ(decode_exr(std::span<const uint8_t>(bytes->data(), n)).status(), Status::short_output) << n;
  }
}

TEST(OpenExr, WrongMagicMissingChannelsAndNaNAreBadData) {
  auto bytes = encode_exr(gradient(2, 2).view(), ExrPixelType::float32);
  ASSERT_TRUE(bytes.ok());
  auto wrong = *bytes;
  wrong[0] ^= 0xff;
  auto r = decode_exr(wrong);
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("magic"), std::string::npos) << r.message();
  // Missing B: write an R, G only file through OpenEXR directly.
  {
    Imf::Header header(2, 2);
    header.channels().insert("R", Imf::Channel(Imf::FLOAT));
    header.channels().insert("G", Imf::Channel(Imf::FLOAT));
    detail::ExrMemoryOStream os;
    {
      Imf::OutputFile f(os, header);
      std::vector<float> px(8, 1.0f);
      Imf::FrameBuffer fb;
      fb.insert("R", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(px.data()), 8, 16));
      fb.insert("G", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(px.data() + 1), 8, 16));
      f.setFrameBuffer(fb);
      f.writePixels(2);
    }
    auto missing = decode_exr(os.take());
    EXPECT_EQ(missing.status(), Status::bad_data);
    EXPECT_NE(missing.message().find("no B channel (channels: G, R)"), std::string::npos) << missing.message();
  }
  Image<float> nan_img = gradient(3, 2);
  nan_img.at(2, 1, 1) = std::numeric_limits<float>::quiet_NaN();
  auto nan_bytes = encode_exr(nan_img.view(), ExrPixelType::float32);
  ASSERT_TRUE(nan_bytes.ok());
  auto n = decode_exr(*nan_bytes);
  EXPECT_EQ(n.status(), Status::bad_data);
  EXPECT_NE(n.message().find("pixel (2, 1) channel G is NaN"), std::string::npos) << n.message();
}

TEST(OpenExr, DataWindowBeyondTheLimitsIsRefusedBeforeDecoding) {
  auto bytes = encode_exr(gradient(40, 30).view());
  ASSERT_TRUE(bytes.ok());
  ImageLimits small;
  small.max_width = 32;
  auto r = decode_exr(*bytes, small);
  EXPECT_EQ(r.status(), Status::insufficient_space);
  EXPECT_NE(r.message().find("40 x 30 exceeds"), std::string::npos) << r.message();
  ImageLimits few;
  few.max_pixels = 1000;
  EXPECT_EQ(probe_exr(*bytes, few).status(), Status::insufficient_space);
}

TEST(OpenExr, SetErrorsNameTheFiles) {
  const BtfFloat btf = small_btf(three_directions());
  Ubo2003ReadOptions ro;
  ro.directions = UboDirections::custom;
  ro.custom_views = ro.custom_lights = three_directions();
  // A missing (view, light) pair.
  std::string dir = tmp("missing");
  ASSERT_TRUE(write_exr_image_set(btf, dir).ok());
  fs::remove(fs::path(dir) / "tv015_pv060_tl015_pl000.exr");
  auto r = read_exr_image_set(dir, ro);
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("missing 1 of 9"), std::string::npos) << r.message();
  // An image of another size.
  dir = tmp("sizes");
  ASSERT_TRUE(write_exr_image_set(btf, dir).ok());
  ASSERT_TRUE(write_file_bytes(dir + "/tv015_pv000_tl015_pl060.exr", *encode_exr(gradient(4, 4).view())).ok());
  r = read_exr_image_set(dir, ro);
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("tv015_pv000_tl015_pl060.exr: image is 4x4, expected 3x2"), std::string::npos)
      << r.message();
  // A truncated file in the set.
  dir = tmp("truncated");
  ASSERT_TRUE(write_exr_image_set(btf, dir).ok());
  auto good = encode_exr(btf.image(1, 1));
  ASSERT_TRUE(good.ok());
  good->resize(good->size() / 2);
  ASSERT_TRUE(write_file_bytes(dir + "/tv015_pv000_tl015_pl000.exr", *good).ok());
  r = read_exr_image_set(dir, ro);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.message().find("tv015_pv000_tl015_pl000.exr"), std::string::npos) << r.message();
  // Too big for the limits.
  dir = tmp("limits");
  ASSERT_TRUE(write_exr_image_set(btf, dir).ok());
  ro.max_samples = 10;
  EXPECT_EQ(read_exr_image_set(dir, ro).status(), Status::insufficient_space);
}

}  // namespace

#else
TEST(OpenExr, SkippedWithoutOpenExr) { GTEST_SKIP() << "btflod configured without OpenEXR (BTFLOD_WITH_OPENEXR=OFF)"; }
#endif
