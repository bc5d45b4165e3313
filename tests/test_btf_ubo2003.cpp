// Tests for offline/btf/ubo2003_folder.hpp: the key-based name parser on every known spelling,
// writer → reader round trips (flat and per-view-folder layouts, PNG exact, JPEG close,
// UBO2003 recognised automatically, half-degree UBO2014 angles), and the failure classes of the
// folder reader (missing combinations, duplicates, differing sizes, unparseable names,
// truncated and wrong-signature images, oversized images and BTFs).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "btflod/core/bytes.hpp"
#include "btflod/offline/btf/ubo2003_folder.hpp"
#include "test_btf_helpers.hpp"

namespace {

using namespace btflod;
using namespace btflod_test;
namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const fs::path p = fresh_tmp_path("ubo_" + name);
  fs::create_directories(p);
  return p;
}

// ---- name parsing ---------------------------------------------------------------------------

void expect_keys(std::string_view text, float tl, float pl, float tv, float pv) {
  auto k = parse_ubo_angle_keys(text);
  ASSERT_TRUE(k) << k.message();
  ASSERT_TRUE(k->complete()) << text << " missing " << k->missing();
  EXPECT_FLOAT_EQ(k->degrees[UboAngleKeys::tl], tl) << text;
  EXPECT_FLOAT_EQ(k->degrees[UboAngleKeys::pl], pl) << text;
  EXPECT_FLOAT_EQ(k->degrees[UboAngleKeys::tv], tv) << text;
  EXPECT_FLOAT_EQ(k->degrees[UboAngleKeys::pv], pv) << text;
}

TEST(Ubo2003Names, EveryKnownSpellingParses) {
  expect_keys("00008 tl000 pl000 tv030 pv030", 0, 0, 30, 30);
  expect_keys("WoolPKNT256_00084_tl015_pl000_tv015_pv120", 15, 0, 15, 120);
  expect_keys("tl000_pl000_tv000_pv000", 0, 0, 0, 0);
  // Order, case, '=' and decimals do not matter; nothing is read at fixed offsets.
  expect_keys("pv330 TV075 x pl=7.5 tl:23.5", 23.5f, 7.5f, 75, 330);
  expect_keys("tl15-pl345-tv60-pv-20", 15, 345, 60, -20);
}

TEST(Ubo2003Names, WordsThatStartLikeKeysAreIgnored) {
  // "plastic", "tvx", "Pv3d" and "atl015" are not keys.
  auto k = parse_ubo_angle_keys("plastic_tvx_Pv3d_atl015_tl010");
  ASSERT_TRUE(k) << k.message();
  EXPECT_TRUE(k->present[UboAngleKeys::tl]);
  EXPECT_FLOAT_EQ(k->degrees[UboAngleKeys::tl], 10);
  EXPECT_FALSE(k->present[UboAngleKeys::pl]);
  EXPECT_FALSE(k->present[UboAngleKeys::tv]);
  EXPECT_FALSE(k->present[UboAngleKeys::pv]);
  EXPECT_EQ(k->missing(), "pl tv pv");
}

TEST(Ubo2003Names, ConflictingOrOutOfRangeKeysAreErrors) {
  auto dup = parse_ubo_angle_keys("tl015_tl030_pl000_tv000_pv000");
  ASSERT_FALSE(dup);
  EXPECT_NE(dup.message().find("appears twice"), std::string::npos) << dup.message();
  EXPECT_TRUE(parse_ubo_angle_keys("tl015_tl015"));  // the same value twice is fine
  auto range = parse_ubo_angle_keys("tl095_pl000");
  ASSERT_FALSE(range);
  EXPECT_NE(range.message().find("out of range"), std::string::npos) << range.message();
}

TEST(Ubo2003Names, FolderAndFileKeysMerge) {
  auto k = parse_ubo_image_path("Wool/tv030_pv060/00012 tl015 pl120.jpg");
  ASSERT_TRUE(k) << k.message();
  EXPECT_FLOAT_EQ(k->degrees[UboAngleKeys::tv], 30);
  EXPECT_FLOAT_EQ(k->degrees[UboAngleKeys::pv], 60);
  EXPECT_FLOAT_EQ(k->degrees[UboAngleKeys::tl], 15);
  EXPECT_FLOAT_EQ(k->degrees[UboAngleKeys::pl], 120);
  // Keys repeated in the file name must agree with the folder's.
  EXPECT_TRUE(parse_ubo_image_path("tv030_pv060/tl000_pl000_tv030_pv060.png"));
  auto bad = parse_ubo_image_path("tv030_pv060/tl000_pl000_tv045_pv060.png");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.message().find("disagree"), std::string::npos) << bad.message();
  auto missing = parse_ubo_image_path("tv030/tl000_pl000.png");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.message().find("missing key(s) pv"), std::string::npos) << missing.message();
}

// ---- round trips ----------------------------------------------------------------------------

DirectionSet small_set(const char* name, std::vector<std::pair<float, float>> deg) {
  std::vector<std::pair<float, float>> rad;
  for (auto [t, p] : deg) rad.emplace_back(degrees_to_radians(t), degrees_to_radians(p));
  return DirectionSet::from_radians(name, rad);
}

// Values taken from the sRGB table so that the 8-bit PNG round trip is exact.
BtfFloat table_btf(DirectionSet views, DirectionSet lights, int w, int h) {
  BtfFloat btf(w, h, std::move(views), std::move(lights));
  const float* table = srgb8_to_linear_table();
  for (size_t i = 0; i < btf.samples().size(); ++i) btf.samples()[i] = table[(i * 37 + i / 7) % 256];
  return btf;
}

TEST(Ubo2003Folder, FlatPngRoundTripIsExact) {
  // Sorted by θ then φ in [0, 360): what from_files reconstructs.
  const auto views = small_set("v", {{0, 0}, {30, 60}, {45, 300}});
  const auto lights = small_set("l", {{0, 0}, {15, 0}, {15, 120}, {60, 200}});
  const BtfFloat btf = table_btf(views, lights, 5, 3);
  const auto dir = fresh_dir("flat");
  Ubo2003WriteOptions wo;
  wo.prefix = "WoolPKNT256_";
  ASSERT_TRUE(write_ubo2003_folder(btf, dir, wo));
  EXPECT_TRUE(fs::exists(dir / "WoolPKNT256_00006_tl015_pl120_tv030_pv060.png"));  // v·nL + l = 6
  auto back = read_ubo2003_folder(dir);
  ASSERT_TRUE(back) << back.message();
  EXPECT_TRUE(back->warnings.empty());
  ASSERT_EQ(back->btf.view_count(), 3u);
  ASSERT_EQ(back->btf.light_count(), 4u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_NEAR(back->btf.views()[i].theta, views[i].theta, 1e-5);
    EXPECT_NEAR(back->btf.views()[i].phi, views[i].phi, 1e-5);
  }
  EXPECT_EQ(back->image_paths[1 * 4 + 2], "WoolPKNT256_00006_tl015_pl120_tv030_pv060.png");
  for (size_t i = 0; i < btf.samples().size(); ++i) ASSERT_EQ(back->btf.samples()[i], btf.samples()[i]) << i;
}

TEST(Ubo2003Folder, PerViewFoldersWithViewKeysOnlyInTheFolderName) {
  const auto views = small_set("v", {{0, 0}, {75, 345}});
  const auto lights = small_set("l", {{0, 0}, {30, 90}});
  const BtfFloat btf = table_btf(views, lights, 2, 2);
  const auto dir = fresh_dir("per_view");
  Ubo2003WriteOptions wo;
  wo.layout = UboLayout::per_view_folders;
  wo.separator = ' ';
  ASSERT_TRUE(write_ubo2003_folder(btf, dir, wo));
  EXPECT_TRUE(fs::exists(dir / "tv075 pv345" / "tl030 pl090.png"));
  std::ofstream(dir / "README.txt") << "not an image";
  Ubo2003ReadOptions ro;
  ro.directions = UboDirections::custom;
  ro.custom_views = views;
  ro.custom_lights = lights;
  auto back = read_ubo2003_folder(dir, ro);
  ASSERT_TRUE(back) << back.message();
  ASSERT_EQ(back->warnings.size(), 1u);
  EXPECT_NE(back->warnings[0].find("README.txt"), std::string::npos);
  for (size_t i = 0; i < btf.samples().size(); ++i) ASSERT_EQ(back->btf.samples()[i], btf.samples()[i]) << i;
}

TEST(Ubo2003Folder, FullUbo2003IsRecognisedAutomatically) {
  const BtfFloat btf = table_btf(DirectionSet::ubo2003(), DirectionSet::ubo2003(), 1, 1);
  const auto dir = fresh_dir("full");
  Ubo2003WriteOptions wo;
  wo.separator = ' ';
  ASSERT_TRUE(write_ubo2003_folder(btf, dir, wo));
  EXPECT_TRUE(fs::exists(dir / "00243 tl000 pl000 tv015 pv120.png"));  // view 3 · 81 + light 0
  auto back = read_ubo2003_folder(dir);
  ASSERT_TRUE(back) << back.message();
  EXPECT_EQ(back->btf.views().name(), "UBO2003");
  EXPECT_EQ(back->btf.lights().name(), "UBO2003");
  for (size_t i = 0; i < btf.samples().size(); ++i) ASSERT_EQ(back->btf.samples()[i], btf.samples()[i]) << i;
  fs::remove_all(dir);  // 6561 files: do not leave them lying around
}

TEST(Ubo2003Folder, HalfDegreeUbo2014AnglesRoundTrip) {
  const DirectionSet u14 = DirectionSet::ubo2014();
  // A few UBO2014 directions with 23.5° / 52.5° polar angles and 7.5° azimuth offsets.
  std::vector<Direction> picked;
  for (const auto& d : u14)
    if (picked.size() < 3 && std::abs(radians_to_degrees(d.theta) - 52.5f) < 0.01f) picked.push_back(d);
  picked.push_back(u14[7]);  // θ = 23.5
  const DirectionSet views("u14 subset", picked);
  const BtfFloat btf = table_btf(views, small_set("l", {{0, 0}}), 2, 1);
  const auto dir = fresh_dir("u14");
  ASSERT_TRUE(write_ubo2003_folder(btf, dir));
  Ubo2003ReadOptions ro;
  ro.directions = UboDirections::custom;
  ro.custom_views = views;
  ro.custom_lights = btf.lights();
  auto back = read_ubo2003_folder(dir, ro);
  ASSERT_TRUE(back) << back.message();
  for (size_t i = 0; i < btf.samples().size(); ++i) ASSERT_EQ(back->btf.samples()[i], btf.samples()[i]);
  // and the names carry the half degrees
  bool saw_half = false;
  for (const auto& e : fs::directory_iterator(dir))
    saw_half |= e.path().filename().string().find("tv052.5") != std::string::npos;
  EXPECT_TRUE(saw_half);
}

TEST(Ubo2003Folder, JpegRoundTripIsClose) {
  const auto views = small_set("v", {{0, 0}});
  const auto lights = small_set("l", {{0, 0}, {45, 90}});
  BtfFloat btf(16, 16, views, lights);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x)
      for (size_t l = 0; l < 2; ++l)
        for (int c = 0; c < 3; ++c) btf.at(x, y, 0, l, c) = 0.1f + 0.02f * static_cast<float>(x + y) + 0.1f * c;
  const auto dir = fresh_dir("jpeg");
  Ubo2003WriteOptions wo;
  wo.format = UboImageFormat::jpeg;
  ASSERT_TRUE(write_ubo2003_folder(btf, dir, wo));
  auto back = read_ubo2003_folder(dir);
  ASSERT_TRUE(back) << back.message();
  double err = 0;
  for (size_t i = 0; i < btf.samples().size(); ++i) err += std::abs(back->btf.samples()[i] - btf.samples()[i]);
  EXPECT_LT(err / static_cast<double>(btf.samples().size()), 0.01);
}

// ---- failure classes --------------------------------------------------------------------------

fs::path small_folder(const std::string& name) {
  const auto dir = fresh_dir(name);
  const BtfFloat btf =
      table_btf(small_set("v", {{0, 0}, {30, 60}}), small_set("l", {{0, 0}, {15, 0}, {15, 120}}), 4, 3);
  EXPECT_TRUE(write_ubo2003_folder(btf, dir));
  return dir;
}

TEST(Ubo2003Folder, MissingCombinationIsNamed) {
  const auto dir = small_folder("missing");
  fs::remove(dir / "00005_tl015_pl120_tv030_pv060.png");
  auto r = read_ubo2003_folder(dir);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("missing 1 of 6"), std::string::npos) << r.message();
  EXPECT_NE(r.message().find("view 1 (θ=30 φ=60) × light 2 (θ=15 φ=120)"), std::string::npos) << r.message();
}

TEST(Ubo2003Folder, DuplicateImagesAreNamed) {
  const auto dir = small_folder("dup");
  fs::copy_file(dir / "00001_tl015_pl000_tv000_pv000.png", dir / "99999 tl15 pl0 tv0 pv0.png");
  auto r = read_ubo2003_folder(dir);
  ASSERT_FALSE(r);
  EXPECT_NE(r.message().find("duplicate images"), std::string::npos) << r.message();
  EXPECT_NE(r.message().find("99999 tl15 pl0 tv0 pv0.png"), std::string::npos) << r.message();
}

TEST(Ubo2003Folder, SizeDoesNotMatchOtherImages) {
  const auto dir = small_folder("sizes");
  ASSERT_TRUE(write_png((dir / "00004_tl015_pl000_tv030_pv060.png").string(), Image<uint8_t>(5, 3, 3).view()));
  auto r = read_ubo2003_folder(dir);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("00004_tl015_pl000_tv030_pv060.png: image is 5x3, expected 4x3"), std::string::npos)
      << r.message();
  EXPECT_NE(r.message().find("the first image, '00000_tl000_pl000_tv000_pv000.png', sets it"), std::string::npos)
      << r.message();
}

TEST(Ubo2003Folder, UnparseableImageNameFailsUnlessIgnored) {
  const auto dir = small_folder("unparseable");
  fs::copy_file(dir / "00000_tl000_pl000_tv000_pv000.png", dir / "thumbnail.png");
  expect_refused(read_ubo2003_folder(dir), "'thumbnail.png': cannot parse the angles");
  Ubo2003ReadOptions ro;
  ro.ignore_unparseable_images = true;
  expect_one_warning(read_ubo2003_folder(dir, ro), "thumbnail.png");
}

TEST(Ubo2003Folder, TruncatedInputImageIsNamed) {
  const auto dir = small_folder("truncated");
  const auto victim = dir / "00003_tl000_pl000_tv030_pv060.png";
  fs::resize_file(victim, fs::file_size(victim) / 2);
  expect_refused(read_ubo2003_folder(dir), Status::bad_data, "00003_tl000_pl000_tv030_pv060.png");
}

TEST(Ubo2003Folder, WrongSignatureImageIsNamed) {
  const auto dir = small_folder("signature");
  std::ofstream(dir / "00002_tl015_pl120_tv000_pv000.png", std::ios::binary | std::ios::trunc)
      << "this is not an image at all";
  expect_refused(read_ubo2003_folder(dir), Status::bad_data, "00002_tl015_pl120_tv000_pv000.png");
}

TEST(Ubo2003Folder, OversizedCountIsRejected) {
  const auto dir = small_folder("oversized");
  Ubo2003ReadOptions ro;
  ro.max_samples = 4 * 3 * 2 * 3 * 3 - 1;
  auto r = read_ubo2003_folder(dir, ro);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status(), Status::insufficient_space) << r.message();
  Ubo2003ReadOptions tiny;
  tiny.image_limits.max_pixels = 11;  // images are 4×3
  auto r2 = read_ubo2003_folder(dir, tiny);
  ASSERT_FALSE(r2);
  EXPECT_EQ(r2.status(), Status::insufficient_space) << r2.message();
}

TEST(Ubo2003Folder, AngleOutsideTheChosenSetIsNamed) {
  const auto dir = small_folder("outside");
  Ubo2003ReadOptions ro;
  ro.directions = UboDirections::ubo2003;  // 30/60 is a UBO2003 view, 15/120 is a light ... but
  fs::rename(dir / "00005_tl015_pl120_tv030_pv060.png", dir / "00005_tl015_pl120_tv030_pv061.png");
  expect_refused(read_ubo2003_folder(dir, ro), "view direction (θ=30, φ=61) is not in the view set 'UBO2003'");
}

TEST(Ubo2003Folder, EmptyOrMissingFolder) {
  EXPECT_EQ(read_ubo2003_folder(fresh_dir("empty")).status(), Status::bad_data);
  EXPECT_EQ(read_ubo2003_folder("/nonexistent/btf").status(), Status::io_error);
}

TEST(Ubo2003Folder, WriterMapsNanToZeroAndClamps) {
  BtfFloat btf(2, 1, small_set("v", {{0, 0}}), small_set("l", {{0, 0}}));
  btf.at(0, 0, 0, 0, 0) = std::numeric_limits<float>::quiet_NaN();
  btf.at(1, 0, 0, 0, 0) = 5.0f;
  const auto dir = fresh_dir("nan");
  ASSERT_TRUE(write_ubo2003_folder(btf, dir));
  auto back = read_ubo2003_folder(dir);
  ASSERT_TRUE(back) << back.message();
  EXPECT_EQ(back->btf.at(0, 0, 0, 0, 0), 0.0f);
  EXPECT_EQ(back->btf.at(1, 0, 0, 0, 0), 1.0f);
}

}  // namespace
