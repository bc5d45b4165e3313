// offline/btf/btf_store.hpp: the on-disk BTF store — round trips, view-by-view writing from the
// synthesiser, and refusal of truncated, padded, corrupt and incomplete files.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "btflod/offline/btf/btf_store.hpp"
#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/factor/low_rank_btf.hpp"
#include "test_btf_helpers.hpp"

using namespace btflod;

namespace {

std::string tmp_path(const std::string& name) { return std::string(BTFLOD_TEST_TMP_DIR) + "/store_" + name; }

BtfFloat small_btf() {
  return make_low_rank_btf(13, 7, small_direction_set(2, 3), small_direction_set(2, 2), 4, 0.6f, 0.01f, 7);
}

std::vector<uint8_t> file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<uint8_t>((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

void put_file(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace

TEST(BtfStore, Float32RoundTripIsExactForEveryBlockSize) {
  const BtfFloat btf = small_btf();  // 91 texels: blocks of 1, 16, 91 and 200 (one partial block)
  for (uint32_t block : {1u, 16u, 91u, 200u}) {
    const std::string path = tmp_path("f32_" + std::to_string(block));
    auto store = btflod_test::write_and_open_store(btf, path, BtfStoreValueType::float32, block);
    ASSERT_TRUE(store) << store.message();
    EXPECT_EQ(store->rows(), btf.view_count() * btf.light_count() * 3);
    EXPECT_EQ(store->columns(), btf.texel_count());
    EXPECT_EQ(store->info().views.size(), btf.view_count());
    EXPECT_FLOAT_EQ(store->info().views[3].theta, btf.views()[3].theta);
    auto back = store->read_all();
    ASSERT_TRUE(back) << back.message();
    ASSERT_EQ(back->samples().size(), btf.samples().size());
    for (size_t i = 0; i < btf.samples().size(); ++i) ASSERT_EQ(back->samples()[i], btf.samples()[i]) << i;
  }
}

TEST(BtfStore, ReadColumnsMatchesTheFmfMatrixForUnalignedRanges) {
  const BtfFloat btf = small_btf();
  const std::string path = tmp_path("cols");
  auto store = btflod_test::write_and_open_store(btf, path, BtfStoreValueType::float32, 16);
  ASSERT_TRUE(store) << store.message();
  const size_t m = store->rows(), n = btf.texel_count();
  std::vector<uint8_t> scratch;
  for (auto [t0, cnt] : {std::pair<size_t, size_t>{0, 91}, {5, 30}, {15, 2}, {90, 1}, {33, 0}}) {
    std::vector<float> out(m * cnt + 1, -1.0f);
    ASSERT_TRUE(store->read_columns(t0, cnt, out.data(), m, scratch));
    for (size_t j = 0; j < cnt; ++j)
      for (size_t r = 0; r < m; ++r)
        ASSERT_EQ(out[j * m + r], btf.samples()[((r / 3) * n + t0 + j) * 3 + r % 3]) << t0 << " " << j << " " << r;
    EXPECT_EQ(out.back(), -1.0f) << "wrote past the requested columns";
  }
  std::vector<float> out(m * 2);
  EXPECT_EQ(store->read_columns(90, 2, out.data(), m, scratch).status(), Status::invalid_argument);
}

TEST(BtfStore, HalfStoreRoundsToNearestHalf) {
  const BtfFloat btf = small_btf();
  const std::string path = tmp_path("f16");
  auto store = btflod_test::write_and_open_store(btf, path, BtfStoreValueType::float16, 32);
  ASSERT_TRUE(store) << store.message();
  auto back = store->read_all();
  ASSERT_TRUE(back);
  for (size_t i = 0; i < btf.samples().size(); ++i)
    ASSERT_EQ(back->samples()[i], Half(btf.samples()[i]).to_float()) << i;
  // Half the data bytes of float32.
  EXPECT_EQ(store->info().data_bytes(), btf.samples().size() * 2);
}

TEST(BtfStore, SynthesiserWritesViewByView) {
  auto meso = make_mesostructure(SynthMaterial::cloth, 8, 8, 3, 1.0f);
  ASSERT_TRUE(meso);
  SynthesisOptions so;
  so.views = small_direction_set(2, 3);
  so.lights = small_direction_set(2, 4);
  auto whole = synthesize_btf<float>(*meso, so);
  ASSERT_TRUE(whole);
  const std::string path = tmp_path("synth");
  auto w = BtfStoreWriter::create(path, 8, 8, so.views, so.lights, BtfStoreValueType::float32, 24);
  ASSERT_TRUE(w);
  ASSERT_TRUE(synthesize_btf_views(
      *meso, so, [&](size_t v, std::span<const float> block) { return static_cast<bool>(w->write_view(v, block)); }));
  ASSERT_TRUE(w->finish());
  auto store = BtfStore::open(path);
  ASSERT_TRUE(store) << store.message();
  auto back = store->read_all();
  ASSERT_TRUE(back);
  for (size_t i = 0; i < whole->samples().size(); ++i) ASSERT_EQ(back->samples()[i], whole->samples()[i]);
}

TEST(BtfStore, WriterRejectsWrongSizesRepeatsAndMissingViews) {
  const BtfFloat btf = small_btf();
  const std::string path = tmp_path("writer_errors");
  auto w = BtfStoreWriter::create(path, btf.width(), btf.height(), btf.views(), btf.lights());
  ASSERT_TRUE(w);
  const size_t per_view = btf.light_count() * btf.texel_count() * 3;
  EXPECT_EQ(w->write_view(0, btf.samples().first(per_view - 1)).status(), Status::invalid_argument);
  EXPECT_EQ(w->write_view(btf.view_count(), btf.samples().first(per_view)).status(), Status::invalid_argument);
  ASSERT_TRUE(w->write_view(0, btf.samples().first(per_view)));
  EXPECT_EQ(w->write_view(0, btf.samples().first(per_view)).status(), Status::invalid_argument);
  const auto missing = w->finish();
  EXPECT_EQ(missing.status(), Status::invalid_argument);
  EXPECT_NE(missing.message().find("view 1 was never written"), std::string::npos) << missing.message();
  // What a killed writer leaves behind is refused.
  const auto incomplete = BtfStore::open(path);
  ASSERT_FALSE(incomplete);
  EXPECT_NE(incomplete.message().find("incomplete"), std::string::npos) << incomplete.message();
  EXPECT_EQ(BtfStoreWriter::create(path, 0, 4, btf.views(), btf.lights()).status(), Status::invalid_argument);
}

TEST(BtfStore, TruncatedStoreIsRefused) {
  const std::string path = tmp_path("truncated");
  ASSERT_TRUE(write_btf_store(small_btf(), path, BtfStoreValueType::float16, 16));
  const auto bytes = file_bytes(path);
  for (size_t keep : {size_t{0}, size_t{7}, size_t{40}, size_t{4096}, bytes.size() / 2, bytes.size() - 1}) {
    put_file(path, std::vector<uint8_t>(bytes.begin(), bytes.begin() + static_cast<ptrdiff_t>(keep)));
    const auto s = BtfStore::open(path);
    ASSERT_FALSE(s) << keep;
    EXPECT_NE(s.status(), Status::success);
    if (keep >= 4096) {
      EXPECT_NE(s.message().find("truncated"), std::string::npos) << s.message();
    }
  }
}

TEST(BtfStore, TrailingBytesAreRefused) {
  const std::string path = tmp_path("trailing");
  ASSERT_TRUE(write_btf_store(small_btf(), path));
  auto bytes = file_bytes(path);
  bytes.push_back(0);
  put_file(path, bytes);
  const auto s = BtfStore::open(path);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("trailing bytes"), std::string::npos) << s.message();
}

TEST(BtfStore, CorruptHeaderIsRefusedByItsCrc) {
  const std::string path = tmp_path("bad_header");
  ASSERT_TRUE(write_btf_store(small_btf(), path));
  auto bytes = file_bytes(path);
  bytes[20] ^= 1;  // width
  put_file(path, bytes);
  const auto s = BtfStore::open(path);
  ASSERT_FALSE(s);
  EXPECT_EQ(s.status(), Status::bad_data);
  EXPECT_NE(s.message().find("header CRC-32"), std::string::npos) << s.message();
  bytes[20] ^= 1;
  bytes[0] = 'X';
  put_file(path, bytes);
  EXPECT_NE(BtfStore::open(path).message().find("bad magic"), std::string::npos);
}

TEST(BtfStore, CorruptDataIsReportedWithItsBlockAndView) {
  const BtfFloat btf = small_btf();
  const std::string path = tmp_path("bad_data");
  auto store = btflod_test::write_and_open_store(btf, path, BtfStoreValueType::float32, 16);
  ASSERT_TRUE(store) << store.message();
  const BtfStoreInfo info = store->info();
  auto bytes = file_bytes(path);
  // A value of block 2, view 1.
  const size_t off = info.block_offset(2) + btf.light_count() * 16 * 3 * 4 + 8;
  bytes[off] ^= 0x40;
  put_file(path, bytes);
  auto reopened = BtfStore::open(path);
  ASSERT_TRUE(reopened) << "the header and table are intact: opening succeeds";
  std::vector<float> out(reopened->rows() * 16);
  std::vector<uint8_t> scratch;
  ASSERT_TRUE(reopened->read_columns(0, 16, out.data(), reopened->rows(), scratch));
  const auto bad = reopened->read_columns(32, 16, out.data(), reopened->rows(), scratch);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.status(), Status::bad_data);
  EXPECT_NE(bad.message().find("block 2 (texels 32..47), view 1: CRC-32 mismatch"), std::string::npos) << bad.message();
  // A corrupt checksum table is refused when opening.
  bytes[off] ^= 0x40;
  bytes[bytes.size() - 6] ^= 1;
  put_file(path, bytes);
  EXPECT_NE(BtfStore::open(path).message().find("checksum table"), std::string::npos);
}

TEST(BtfStore, HostileHeaderSizesAreRefusedWithoutAllocating) {
  const std::string path = tmp_path("hostile");
  ASSERT_TRUE(write_btf_store(small_btf(), path));
  auto bytes = file_bytes(path);
  // Claim 2^20 × 2^20 texels with a correct header CRC: the file size check refuses it.
  uint32_t header_bytes = 0;
  std::memcpy(&header_bytes, bytes.data() + 12, 4);
  const uint32_t side = 1u << 20;
  std::memcpy(bytes.data() + 20, &side, 4);
  std::memcpy(bytes.data() + 24, &side, 4);
  const uint32_t crc = crc32_of(std::span<const uint8_t>(bytes.data(), header_bytes - 4));
  std::memcpy(bytes.data() + header_bytes - 4, &crc, 4);
  auto info = parse_btf_store_header(std::span<const uint8_t>(bytes.data(), header_bytes), bytes.size());
  ASSERT_FALSE(info);
  EXPECT_EQ(info.status(), Status::short_output);
  EXPECT_NE(info.message().find("the header implies"), std::string::npos) << info.message();
}

// The fuzz seeds are written by an independent implementation of the format (a few lines of
// Python following the header comment of btf_store.hpp): the reader agrees with the document.
TEST(BtfStore, StoresWrittenFromTheFormatDescriptionAreRead) {
  const std::filesystem::path seeds =
      std::filesystem::path(__FILE__).parent_path().parent_path() / "fuzz" / "corpus" / "fuzz_btf_store";
  auto f16 = BtfStore::open((seeds / "seed_f16.btfstore").string());
  ASSERT_TRUE(f16) << f16.message();
  EXPECT_EQ(f16->info().width, 5);
  EXPECT_EQ(f16->info().value_type, BtfStoreValueType::float16);
  auto all = f16->read_all();
  ASSERT_TRUE(all) << all.message();
  // Value at texel t, view v, light l, channel c: 0.5 + 0.25 sin(0.3 t + v + 0.5 l + c).
  for (size_t v = 0; v < 3; ++v)
    for (size_t l = 0; l < 2; ++l)
      for (int t = 0; t < 15; ++t)
        for (int c = 0; c < 3; ++c)
          ASSERT_NEAR(all->at(t % 5, t / 5, v, l, c),
                      0.5 + 0.25 * std::sin(0.3 * t + static_cast<double>(v) + 0.5 * static_cast<double>(l) + c), 1e-3);
  EXPECT_TRUE(BtfStore::open((seeds / "seed_f32.btfstore").string()));
  EXPECT_NE(BtfStore::open((seeds / "seed_incomplete.btfstore").string()).message().find("incomplete"),
            std::string::npos);
  EXPECT_EQ(BtfStore::open((seeds / "seed_truncated.btfstore").string()).status(), Status::short_output);
  auto bad = BtfStore::open((seeds / "seed_bad_chunk.btfstore").string());
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->read_all().status(), Status::bad_data);
}
