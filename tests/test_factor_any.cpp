// Tests of the kind-dispatching factor reader (offline/factor/any_factorization.hpp) and of the BTF
// error report (offline/metrics/btf_metrics.hpp). Also writes tiny factor files of every kind to
// BTFLOD_TEST_TMP_DIR/factor_seeds (the seeds in fuzz/corpus/fuzz_factor_reader came from it).
#include <gtest/gtest.h>

#include <filesystem>

#include "btflod/offline/factor/any_factorization.hpp"
#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/metrics/btf_metrics.hpp"
#include "test_factor_helpers.hpp"

namespace btflod {
namespace {

using namespace btflod_test;

BtfFloat tiny_btf() {
  return make_low_rank_btf(4, 4, small_direction_set(2, 2, "v"), small_direction_set(2, 3, "l"), 3, 0.5f, 0.01f, 2);
}

std::vector<AnyFactorization> all_kinds(const BtfFloat& btf) {
  std::vector<AnyFactorization> out;
  out.emplace_back(factorize_fmf(btf, fmf_options(2)).value());
  out.emplace_back(factorize_pca_views(btf, pca_views_options(2, 2)).value());
  out.emplace_back(factorize_laplacian_pca(btf, laplacian_options(1, {2, 1, 1})).value());
  out.emplace_back(factorize_local_pca(btf, local_pca_options(2, 1)).value());
  return out;
}

// FactorFile keeps views into the parsed bytes, so parsing a temporary buffer must not compile
// (it left the section views dangling: a heap-use-after-free found under ASan).
template <class Bytes>
concept ParsesAsFactorFile = requires {
  FactorFile::parse(Bytes{});
};
static_assert(!ParsesAsFactorFile<std::vector<uint8_t>>, "parsing a temporary vector must be refused");
static_assert(ParsesAsFactorFile<std::span<const uint8_t>>, "parsing caller-owned bytes must work");

TEST(FactorAny, ParsesEveryKindAndWritesSeeds) {
  const auto btf = tiny_btf();
  const std::string dir = std::string(BTFLOD_TEST_TMP_DIR) + "/factor_seeds";
  std::filesystem::create_directories(dir);
  const char* names[] = {"fmf", "pca-k", "laplacian", "lpca"};
  int i = 0;
  for (const auto& f : all_kinds(btf)) {
    EXPECT_STREQ(factorization_name(f), names[i]);
    const std::string path = dir + "/" + names[i] + ".bfr";
    ASSERT_TRUE(save_factorization(f, path).ok());
    auto back = load_factorization(path);
    ASSERT_TRUE(back.ok()) << back.message();
    EXPECT_EQ(back->index(), f.index());
    EXPECT_EQ(serialize_factorization(*back), serialize_factorization(f));
    EXPECT_EQ(factorization_shape(*back).width, 4);
    EXPECT_GT(factorization_compression_ratio(*back), 0.0);
    EXPECT_EQ(reconstruct_factorization(*back).samples().size(), btf.samples().size());
    ++i;
  }
  EXPECT_FALSE(load_factorization(dir + "/does_not_exist.bfr").ok());
  const uint8_t junk[] = {'B', 'T', 'F', 'L', 'O', 'D', 'F', 'R', 1, 0, 0, 0, 9, 0, 0, 0, 0, 0, 0, 0};
  auto r = parse_factorization(junk);
  EXPECT_NE(r.message().find("unknown kind 9"), std::string::npos) << r.message();
}

TEST(FactorAny, HostileSectionSizesAreRejectedNotAllocated) {
  // A section header that declares 2^60 bytes must fail on the length check.
  ByteWriter w;
  w.raw(kFactorMagic, 8);
  w.u32(kFactorFormatVersion);
  w.u32(1);
  w.u32(1);
  w.u32(factor_tag("SHAP"));
  w.u64(uint64_t{1} << 60);
  w.u32(0);
  auto r = parse_factorization(w.bytes());
  EXPECT_EQ(r.status(), Status::short_output);
  EXPECT_NE(r.message().find("declares"), std::string::npos);
  // Too many sections.
  ByteWriter m;
  m.raw(kFactorMagic, 8);
  m.u32(kFactorFormatVersion);
  m.u32(2);
  m.u32(100000);
  EXPECT_NE(parse_factorization(m.bytes()).message().find("sections"), std::string::npos);
}

TEST(MetricsBtf, ReportOfIdenticalAndPerturbedBtfs) {
  const auto btf = tiny_btf();
  const auto same = compare_btfs(btf, btf, btf_peak(btf));
  EXPECT_EQ(same.rmse, 0.0);
  EXPECT_TRUE(std::isinf(same.psnr));
  EXPECT_NEAR(same.mean_ssim, 1.0, 1e-12);
  EXPECT_EQ(same.mae_cielab, 0.0);
  BtfFloat off = btf;
  for (auto& v : off.samples()) v += 0.1f;
  const auto r = compare_btfs(btf, off, 1.0);
  EXPECT_NEAR(r.rmse, 0.1, 1e-6);
  EXPECT_NEAR(r.psnr, 20.0, 1e-4);
  EXPECT_NEAR(r.mse_ycbcr[0], 0.01, 1e-6);  // a grey offset moves Y only
  EXPECT_NEAR(r.mse_ycbcr[1], 0.0, 1e-9);
  EXPECT_GT(r.mae_cielab, 0.0);
  EXPECT_LT(r.mean_ssim, 1.0);
  BtfFloat other(3, 4, btf.views(), btf.lights());
  EXPECT_TRUE(std::isnan(compare_btfs(btf, other, 1.0).rmse));
}

}  // namespace
}  // namespace btflod
