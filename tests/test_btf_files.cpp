// Tests for offline/btf/btf_files.hpp: the format of a path is told by its content (not its name),
// missing and foreign files are refused with the path in the message, and what save_btf()
// writes load_btf() reads back: an image folder exactly up to 8-bit sRGB, a Bonn DFMF file
// within its factorisation error.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "btflod/offline/btf/btf_files.hpp"

namespace {

using namespace btflod;
namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("btflod_test_btf_files_" + name);
  fs::remove_all(p);
  return p;
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream o(p, std::ios::binary);
  o << text;
}

DirectionSet degrees(const char* name, std::vector<std::pair<float, float>> deg) {
  std::vector<std::pair<float, float>> rad;
  for (auto [t, p] : deg) rad.emplace_back(degrees_to_radians(t), degrees_to_radians(p));
  return DirectionSet::from_radians(name, rad);
}

// Smooth, positive, within [0, 1] (what an 8-bit folder can hold), on UBO2003-named directions.
BtfFloat small_btf() {
  const DirectionSet views = degrees("v", {{0, 0}, {30, 60}, {45, 300}});
  const DirectionSet lights = degrees("l", {{0, 0}, {15, 0}, {15, 120}, {60, 200}});
  BtfFloat btf(6, 4, views, lights);
  for (size_t i = 0; i < btf.samples().size(); ++i)
    btf.samples()[i] = 0.2f + 0.6f * static_cast<float>(0.5 + 0.5 * std::sin(0.37 * static_cast<double>(i)));
  return btf;
}

}  // namespace

TEST(BtfFiles, KindIsToldByContentNotByName) {
  const fs::path dir = scratch("kinds");
  fs::create_directories(dir);
  write_text(dir / "looks_like.btf", "hello, not a BTF");
  write_text(dir / "named.txt", "!DFMF08FCR and then the rest");
  write_text(dir / "brdf.bin", "NVIDIA ARC MBSDF 1.0\n");
  EXPECT_EQ(detect_btf_file((dir / "looks_like.btf").string()), BtfFileKind::unknown);
  EXPECT_EQ(detect_btf_file((dir / "named.txt").string()), BtfFileKind::bonn);
  EXPECT_EQ(detect_btf_file((dir / "brdf.bin").string()), BtfFileKind::mbsdf);
  EXPECT_EQ(detect_btf_file(dir.string()), BtfFileKind::image_folder);
  EXPECT_EQ(detect_btf_file((dir / "absent").string()), BtfFileKind::missing);
  EXPECT_STREQ(btf_file_kind_name(BtfFileKind::bonn), "Bonn binary BTF");
  fs::remove_all(dir);
}

TEST(BtfFiles, MissingForeignAndBrokenFilesAreRefusedNamingThePath) {
  const fs::path dir = scratch("refused");
  fs::create_directories(dir);
  const std::string absent = (dir / "absent.btf").string();
  auto r = load_btf(absent);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status(), Status::io_error);
  EXPECT_NE(r.message().find(absent), std::string::npos) << r.message();

  const std::string foreign = (dir / "notes.btf").string();
  write_text(foreign, "plain text");
  r = load_btf(foreign);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status(), Status::unsupported);
  EXPECT_NE(r.message().find(foreign), std::string::npos) << r.message();

  const std::string truncated = (dir / "truncated.btf").string();
  write_text(truncated, "!DFMF08FCR");  // the magic and nothing after it
  r = load_btf(truncated);
  ASSERT_FALSE(r);
  EXPECT_NE(r.status(), Status::success);
  fs::remove_all(dir);
}

TEST(BtfFiles, WhatSaveWritesLoadReadsBack) {
  const BtfFloat btf = small_btf();
  const fs::path folder = scratch("folder");
  ASSERT_TRUE(save_btf(btf, folder.string()));  // not .btf: a folder of 8-bit sRGB PNGs
  auto back = load_btf(folder.string());
  ASSERT_TRUE(back) << back.message();
  ASSERT_EQ(back->width(), btf.width());
  ASSERT_EQ(back->height(), btf.height());
  ASSERT_EQ(back->view_count(), btf.view_count());
  ASSERT_EQ(back->light_count(), btf.light_count());
  ASSERT_EQ(back->samples().size(), btf.samples().size());
  // The folder holds the same samples (in its own direction order): compare sorted values,
  // within half an 8-bit sRGB step at the brightest value (~0.0043 in linear at 0.8).
  std::vector<float> a(btf.samples().begin(), btf.samples().end()), b(back->samples().begin(), back->samples().end());
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  for (size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a[i], b[i], 0.005f) << i;
  fs::remove_all(folder);

  const fs::path bonn = scratch("material.btf");
  BtfSaveOptions options;
  options.components = 8;
  ASSERT_TRUE(save_btf(btf, bonn.string(), options));  // .btf: factorised into Bonn DFMF
  EXPECT_EQ(detect_btf_file(bonn.string()), BtfFileKind::bonn);
  back = load_btf(bonn.string());
  ASSERT_TRUE(back) << back.message();
  ASSERT_EQ(back->samples().size(), btf.samples().size());
  double err = 0, norm = 0;
  for (size_t i = 0; i < btf.samples().size(); ++i) {
    err += std::pow(back->samples()[i] - btf.samples()[i], 2.0);
    norm += std::pow(btf.samples()[i], 2.0);
  }
  EXPECT_LT(std::sqrt(err / norm), 0.05) << "relative error of the DFMF round trip";
  fs::remove(bonn);
}
