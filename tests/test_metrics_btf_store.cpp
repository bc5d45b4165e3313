// offline/factor/fmf_store_metrics.hpp: evaluating a factorisation against a BTF store streamed from
// disk gives exactly the in-memory compare_btfs() report, within a memory budget; and the
// store's view reader (BtfStore::read_view_images, BtfStore::peak) it is built on.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "btflod/offline/btf/btf_store.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/fmf_store_metrics.hpp"
#include "btflod/offline/factor/low_rank_btf.hpp"
#include "test_btf_helpers.hpp"

using namespace btflod;

namespace {

std::string tmp_path(const std::string& name) { return std::string(BTFLOD_TEST_TMP_DIR) + "/store_eval_" + name; }

// 23 × 19 texels (437: six blocks of 80, the last one partial), 6 views × 5 lights, rank 5 plus
// noise, so a rank-3 FMF leaves a real error.
BtfFloat test_btf() {
  return make_low_rank_btf(23, 19, small_direction_set(2, 5), small_direction_set(2, 4), 5, 0.6f, 0.02f, 11);
}

Fmf test_fmf(const BtfFloat& btf) {
  FmfOptions o;
  o.components = 3;
  auto f = factorize_fmf(btf, o);
  EXPECT_TRUE(f) << f.message();
  return std::move(*f);
}

auto fmf_images(const Fmf& f) {
  return [&f](size_t v, size_t l, std::span<float> out) { return fmf_reconstruct_image(f, v, l, out); };
}

void expect_same_report(const BtfErrorReport& a, const BtfErrorReport& b) {
  EXPECT_EQ(a.rmse, b.rmse);
  EXPECT_EQ(a.psnr, b.psnr);
  EXPECT_EQ(a.mean_ssim, b.mean_ssim);
  EXPECT_EQ(a.mae_cielab, b.mae_cielab);
  EXPECT_EQ(a.delta_e_p99, b.delta_e_p99);
  EXPECT_EQ(a.relative_frobenius, b.relative_frobenius);
  for (size_t c = 0; c < 3; ++c) EXPECT_EQ(a.mse_ycbcr[c], b.mse_ycbcr[c]) << c;
}

}  // namespace

TEST(BtfStoreEval, FmfImageEqualsWholeReconstruction) {
  const BtfFloat btf = test_btf();
  const Fmf f = test_fmf(btf);
  const BtfFloat whole = f.reconstruct();
  std::vector<float> img(btf.texel_count() * 3);
  for (size_t v = 0; v < btf.view_count(); ++v)
    for (size_t l = 0; l < btf.light_count(); ++l) {
      ASSERT_TRUE(fmf_reconstruct_image(f, v, l, img));
      const auto ref = whole.image(v, l);
      for (size_t t = 0; t < btf.texel_count(); ++t)
        for (int c = 0; c < 3; ++c)
          ASSERT_EQ(img[t * 3 + static_cast<size_t>(c)], ref.at(static_cast<int>(t % 23), static_cast<int>(t / 23), c));
    }
  EXPECT_FALSE(fmf_reconstruct_image(f, btf.view_count(), 0, img));
  std::vector<float> small(3);
  EXPECT_FALSE(fmf_reconstruct_image(f, 0, 0, small));
}

TEST(BtfStoreEval, ReadViewImagesEqualsReadAll) {
  const BtfFloat btf = test_btf();
  const std::string path = tmp_path("views.btfstore");
  auto store = btflod_test::write_and_open_store(btf, path, BtfStoreValueType::float16, 80);
  ASSERT_TRUE(store) << store.message();
  auto all = store->read_all();
  ASSERT_TRUE(all);
  const size_t n = btf.texel_count();
  std::vector<uint8_t> scratch;
  std::vector<float> out(3 * n * 3);
  ASSERT_TRUE(store->read_view_images(4, 1, 4, out, scratch));
  for (size_t l = 1; l < 4; ++l) {
    const auto ref = all->image(4, l);
    for (size_t t = 0; t < n; ++t)
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ(out[((l - 1) * n + t) * 3 + static_cast<size_t>(c)],
                  ref.at(static_cast<int>(t % 23), static_cast<int>(t / 23), c));
  }
  EXPECT_EQ(store->read_view_images(btf.view_count(), 0, 1, std::span<float>(out.data(), n * 3), scratch).status(),
            Status::invalid_argument);
  EXPECT_EQ(store->read_view_images(0, 2, 2, std::span<float>(out.data(), 0), scratch).status(),
            Status::invalid_argument);
  EXPECT_EQ(store->read_view_images(0, 0, 2, std::span<float>(out.data(), n * 3), scratch).status(),
            Status::invalid_argument);
  auto peak = store->peak();
  ASSERT_TRUE(peak);
  EXPECT_EQ(*peak, btf_peak(*all));
  std::remove(path.c_str());
}

// The evaluation of a float32 store equals compare_btfs() on the in-memory BTF bit for bit,
// with a budget of one light per group and with one holding every light of a view.
TEST(BtfStoreEval, StreamedEqualsInMemoryAtEveryBudget) {
  const BtfFloat btf = test_btf();
  const Fmf f = test_fmf(btf);
  const BtfErrorReport mem = compare_btfs(btf, f.reconstruct(), btf_peak(btf));
  ASSERT_GT(mem.rmse, 0.0);
  ASSERT_LT(mem.mean_ssim, 1.0);
  const std::string path = tmp_path("f32.btfstore");
  auto store = btflod_test::write_and_open_store(btf, path, BtfStoreValueType::float32, 80);
  ASSERT_TRUE(store) << store.message();
  const uint64_t min_budget = btf_store_eval_min_budget(store->info());
  for (const uint64_t budget : {min_budget, min_budget + 2 * btf.texel_count() * 12 * 2, uint64_t{1} << 30}) {
    BtfStoreEvalOptions o;
    o.memory_budget = budget;
    BtfStoreEvalStats st;
    auto r = compare_btf_store(*store, fmf_images(f), o, &st);
    ASSERT_TRUE(r) << r.message();
    expect_same_report(*r, mem);
    EXPECT_LE(st.buffer_bytes, budget);
    const size_t per_group = budget == min_budget ? 1 : budget < (uint64_t{1} << 30) ? 3 : btf.light_count();
    EXPECT_EQ(st.lights_per_group, per_group) << budget;
    EXPECT_EQ(st.groups, btf.view_count() * ((btf.light_count() + per_group - 1) / per_group));
  }
  // An explicit data range is used as given.
  BtfStoreEvalOptions o;
  o.data_range = 2.0;
  auto r = compare_btf_store(*store, fmf_images(f), o);
  ASSERT_TRUE(r);
  expect_same_report(*r, compare_btfs(btf, f.reconstruct(), 2.0));
  std::remove(path.c_str());
}

// A half store: the reference is what the store holds (its read_all()), evaluated streamed.
TEST(BtfStoreEval, HalfStoreEqualsInMemoryOfItsValues) {
  const BtfFloat btf = test_btf();
  const Fmf f = test_fmf(btf);
  const std::string path = tmp_path("f16.btfstore");
  auto store = btflod_test::write_and_open_store(btf, path, BtfStoreValueType::float16, 64);
  ASSERT_TRUE(store) << store.message();
  auto all = store->read_all();
  ASSERT_TRUE(all);
  BtfStoreEvalOptions o;
  o.memory_budget = btf_store_eval_min_budget(store->info()) + 1;
  auto r = compare_btf_store(*store, fmf_images(f), o);
  ASSERT_TRUE(r) << r.message();
  expect_same_report(*r, compare_btfs(*all, f.reconstruct(), btf_peak(*all)));
  std::remove(path.c_str());
}

TEST(BtfStoreEval, RefusesSmallBudgetCorruptChunkAndFailingApproximation) {
  const BtfFloat btf = test_btf();
  const Fmf f = test_fmf(btf);
  const std::string path = tmp_path("bad.btfstore");
  ASSERT_TRUE(write_btf_store(btf, path, BtfStoreValueType::float32, 80));
  {
    auto store = BtfStore::open(path);
    ASSERT_TRUE(store);
    BtfStoreEvalOptions o;
    o.memory_budget = btf_store_eval_min_budget(store->info()) - 1;
    auto r = compare_btf_store(*store, fmf_images(f), o);
    EXPECT_EQ(r.status(), Status::insufficient_space);
    EXPECT_NE(r.message().find("at least"), std::string::npos) << r.message();
    // The approximation's error is passed on.
    auto bad = compare_btf_store(*store, [](size_t, size_t, std::span<float>) -> VoidResult {
      return make_error(Status::bad_data, "no such image");
    });
    EXPECT_EQ(bad.status(), Status::bad_data);
    // Cancelled from the progress callback.
    BtfStoreEvalOptions c;
    c.progress = [](std::string_view, double) { return false; };
    EXPECT_EQ(compare_btf_store(*store, fmf_images(f), c).status(), Status::cancelled);
  }
  // Flip one value inside block 2, view 3: the chunk's CRC no longer matches.
  auto info = BtfStore::open(path)->info();
  const uint64_t chunk = info.lights.size() * 80 * 3 * 4;
  {
    std::fstream fs(path, std::ios::in | std::ios::out | std::ios::binary);
    fs.seekp(static_cast<std::streamoff>(info.block_offset(2) + 3 * chunk + 17));
    const char x = 0x5a;
    fs.write(&x, 1);
  }
  auto store = BtfStore::open(path);
  ASSERT_TRUE(store);
  BtfStoreEvalOptions o;
  o.data_range = 1.0;  // skip the peak pass: the evaluation's own read finds the corruption
  auto r = compare_btf_store(*store, fmf_images(f), o);
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("block 2"), std::string::npos) << r.message();
  EXPECT_NE(r.message().find("view 3"), std::string::npos) << r.message();
  std::remove(path.c_str());
}
