// btflod-label: unit threads
// Tests for core/result.hpp, core/bytes.hpp, core/image.hpp, core/color.hpp, core/thread_pool.hpp.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "btflod/core/bytes.hpp"
#include "btflod/core/color.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/image.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/thread_pool.hpp"

namespace {

using namespace btflod;

TEST(Result, CarriesValueOrFormattedError) {
  Result<int> good = 42;
  ASSERT_TRUE(good.ok());
  EXPECT_EQ(*good, 42);
  EXPECT_EQ(good.status(), Status::success);
  Result<int> bad = make_error(Status::short_output, "file %s: expected %d bytes, found %d", "x.btf", 100, 7);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status(), Status::short_output);
  EXPECT_EQ(bad.message(), "file x.btf: expected 100 bytes, found 7");
  VoidResult v;
  EXPECT_TRUE(v.ok());
  VoidResult e = make_error(Status::io_error, "nope");
  EXPECT_FALSE(e.ok());
  EXPECT_STREQ(status_name(e.status()), "io_error");
}

TEST(ByteReader, ReadsLittleEndianAndStopsAtTheEnd) {
  const std::vector<uint8_t> bytes = {0x78, 0x56, 0x34, 0x12, 0x01, 0x02, 'A', 'B', 0, 'Z'};
  ByteReader r(bytes);
  EXPECT_EQ(r.u32(), 0x12345678u);
  EXPECT_EQ(r.u16(), 0x0201u);
  EXPECT_EQ(r.fixed_string(4), "AB");  // trimmed at the NUL
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.remaining(), 0u);
  EXPECT_EQ(r.u8(), 0u);  // over-read fails ...
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.u32(), 0u);  // ... and the failure is sticky
}

TEST(ByteReader, OverReadOfALargeBlockFailsWithoutTouchingMemory) {
  const std::vector<uint8_t> bytes(16, 0xab);
  ByteReader r(bytes);
  EXPECT_TRUE(r.can_hold(4, 4));
  EXPECT_FALSE(r.can_hold(5, 4));
  EXPECT_FALSE(r.can_hold(UINT64_MAX / 2, 4));  // overflow guard
  EXPECT_TRUE(r.take(17).empty());
  EXPECT_FALSE(r.ok());
}

TEST(ByteWriter, RoundTripsThroughReaderAndPatches) {
  ByteWriter w;
  w.text("SIG!");
  const size_t at = w.size();
  w.u32(0);
  w.f32(1.5f);
  w.fixed_string("name", 8);
  w.patch<uint32_t>(at, 0xdeadbeef);
  const auto bytes = w.take();
  ByteReader r(bytes);
  EXPECT_TRUE(r.match("SIG!"));
  EXPECT_EQ(r.u32(), 0xdeadbeefu);
  EXPECT_EQ(r.f32(), 1.5f);
  EXPECT_EQ(r.fixed_string(8), "name");
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.remaining(), 0u);
}

TEST(Crc32, MatchesTheStandardCheckValue) {
  const std::string s = "123456789";
  EXPECT_EQ(crc32_of({reinterpret_cast<const uint8_t*>(s.data()), s.size()}), 0xCBF43926u);
}

TEST(Image, ViewsAddressPixelsRowMajorFromTheTopLeft) {
  Image<float> img(4, 3, 2);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x)
      for (int c = 0; c < 2; ++c) img.at(x, y, c) = static_cast<float>(100 * y + 10 * x + c);
  EXPECT_EQ(img.data()[0], 0.0f);
  EXPECT_EQ(img.data()[(1 * 4 + 2) * 2 + 1], 121.0f);
  ImageView<float> sub = img.view().subview(1, 1, 2, 2);
  EXPECT_EQ(sub.at(0, 0, 0), 110.0f);
  EXPECT_EQ(sub.at(1, 1, 1), 221.0f);
  EXPECT_FALSE(sub.is_dense());
  ImageView<float> green = img.view().channel_range(1, 1);
  EXPECT_EQ(green.channels(), 1);
  EXPECT_EQ(green.at(3, 2), 231.0f);
  Image<float> copy = Image<float>::copy_of(sub);
  EXPECT_TRUE(copy.view().is_dense());
  EXPECT_EQ(copy.at(1, 0, 0), 120.0f);
  Image<uint8_t> bytes(2, 2, 2);
  EXPECT_FALSE((copy_image<uint8_t, float>(img.view(), bytes.view())));  // shape mismatch refused
  EXPECT_TRUE((copy_image<uint8_t, float>(sub, bytes.view())));
  EXPECT_EQ(bytes.at(1, 1, 1), 221);
}

TEST(Color, SrgbTransferIsInvertibleAndHitsKnownValues) {
  EXPECT_FLOAT_EQ(srgb_to_linear(0.0f), 0.0f);
  EXPECT_FLOAT_EQ(srgb_to_linear(1.0f), 1.0f);
  EXPECT_NEAR(srgb_to_linear(0.5f), 0.214041f, 1e-5f);
  for (int i = 0; i < 256; ++i) EXPECT_EQ(linear_to_srgb8(srgb8_to_linear_table()[i]), i);
  EXPECT_EQ(linear_to_srgb8(std::nanf("")), 0);
  EXPECT_EQ(linear_to_srgb8(7.0f), 255);
}

TEST(ThreadPool, ParallelForCoversEveryIndexExactlyOnce) {
  ThreadPool pool(3);
  std::vector<std::atomic<int>> hits(1001);
  pool.parallel_for(0, hits.size(), 7, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) hits[i].fetch_add(1);
  });
  for (auto& h : hits) ASSERT_EQ(h.load(), 1);
}

TEST(ThreadPool, ExceptionsReachTheCallerAfterAllChunksFinish) {
  ThreadPool pool(2);
  std::atomic<int> done{0};
  EXPECT_THROW(pool.parallel_for(0, 100, 1,
                                 [&](size_t b, size_t) {
                                   if (b == 13) throw std::runtime_error("chunk 13");
                                   done.fetch_add(1);
                                 }),
               std::runtime_error);
  EXPECT_EQ(done.load(), 99);
  auto f = pool.submit([] { return 6 * 7; });
  EXPECT_EQ(f.get(), 42);
}

TEST(FileIo, WriteThenReadAndMissingFileIsAnIoError) {
  const std::string path = std::string(BTFLOD_TEST_TMP_DIR) + "/core_basics.bin";
  const std::vector<uint8_t> bytes = {1, 2, 3, 4, 5};
  ASSERT_TRUE(write_file_bytes(path, bytes).ok());
  auto back = read_file_bytes(path);
  ASSERT_TRUE(back.ok()) << back.message();
  EXPECT_EQ(*back, bytes);
  auto limited = read_file_bytes(path, 4);
  EXPECT_EQ(limited.status(), Status::insufficient_space);
  auto missing = read_file_bytes(path + ".does-not-exist");
  EXPECT_EQ(missing.status(), Status::io_error);
  EXPECT_NE(missing.message().find("does-not-exist"), std::string::npos);
}

}  // namespace
