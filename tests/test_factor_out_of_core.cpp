// btflod-label: unit threads
// offline/factor/out_of_core_svd.hpp and offline/factor/fmf_out_of_core.hpp: the out-of-core randomised SVD
// gives the in-memory truncated_svd()'s result bit for bit, stays under its memory budget
// (measured as growth of the resident set), resumes a stopped run from its checkpoint to the
// identical result, and refuses checkpoints of another problem.
#include <gtest/gtest.h>

#include <malloc.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "btflod/offline/btf/btf_store.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/fmf_out_of_core.hpp"
#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/factor/out_of_core_svd.hpp"

using namespace btflod;

#if defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define BTFLOD_TEST_TSAN 1  // ThreadSanitizer (clang's name for it; GCC defines __SANITIZE_THREAD__)
#endif
#endif
#if defined(__SANITIZE_THREAD__)
#define BTFLOD_TEST_TSAN 1
#endif

namespace {

// Per process: ctest runs each test of this file as its own process, several at once.
std::string tmp_path(const std::string& name) {
  return std::string(BTFLOD_TEST_TMP_DIR) + "/ooc_" + std::to_string(::getpid()) + "_" + name;
}

// 32 × 24 texels, 9 views × 9 lights: A is 243 × 768, numerical rank ~12 plus noise.
const BtfFloat& test_btf() {
  static const BtfFloat btf =
      make_low_rank_btf(32, 24, small_direction_set(3, 4), small_direction_set(3, 4), 12, 0.75f, 0.002f, 11);
  return btf;
}

const std::string& test_store() {
  static const std::string path = [] {
    const std::string p = tmp_path("store.btfstore");
    EXPECT_TRUE(write_btf_store(test_btf(), p, BtfStoreValueType::float32, 32));
    static const struct Remove {
      std::string path;
      ~Remove() { std::remove(path.c_str()); }
    } remove_at_exit{p};
    return p;
  }();
  return path;
}

SvdOptions algorithm() {
  SvdOptions o;
  o.method = SvdMethod::randomized;
  o.oversampling = 10;
  o.block_columns = 64;
  o.stripes = 4;
  o.power_iterations = 4;  // at least 5 passes: several checkpoints to resume from
  o.max_power_iterations = 6;
  return o;
}

bool same_bits(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), static_cast<size_t>(a.size()) * sizeof(float)) == 0;
}

Result<OutOfCoreSvd> run_store(const BtfStore& store, int rank, OutOfCoreSvdOptions o) {
  o.column_alignment = store.info().block_texels;
  o.source_id = store.content_id();
  return out_of_core_svd(
      store.rows(), store.columns(), rank,
      [&store](size_t col0, size_t count, Eigen::MatrixXf& out, std::vector<uint8_t>& scratch) {
        return store.read_columns(col0, count, out.data(), static_cast<size_t>(out.rows()), scratch);
      },
      o);
}

}  // namespace

TEST(OutOfCoreSvd, StoreResultIsBitIdenticalToTheInMemorySvd) {
  auto store = BtfStore::open(test_store());
  ASSERT_TRUE(store) << store.message();
  for (int zeta : {8, 0}) {  // sparse sign sketch and Gaussian sketch
    SvdOptions so = algorithm();
    so.sketch_nonzeros = zeta;
    const size_t m = store->rows(), n = store->columns();
    auto mem = truncated_svd(
        m, n, 10, [](size_t t0, size_t count, Eigen::MatrixXf& out) { gather_fmf_columns(test_btf(), t0, count, out); },
        so);
    ASSERT_TRUE(mem) << mem.message();
    OutOfCoreSvdOptions o;
    o.svd = so;
    auto ooc = run_store(*store, 10, o);
    ASSERT_TRUE(ooc) << ooc.message();
    EXPECT_GE(ooc->svd.report.power_iterations, 4);
    EXPECT_EQ(ooc->svd.report.power_iterations, mem->report.power_iterations);
    EXPECT_TRUE(same_bits(ooc->svd.u, mem->u)) << "zeta " << zeta;
    EXPECT_TRUE(same_bits(ooc->svd.v, mem->v)) << "zeta " << zeta;
    EXPECT_TRUE(same_bits(ooc->svd.s, mem->s)) << "zeta " << zeta;
    EXPECT_EQ(ooc->svd.report.error_estimate, mem->report.error_estimate);
    EXPECT_EQ(ooc->report.passes, ooc->svd.report.power_iterations + 1);
    EXPECT_EQ(ooc->report.columns_read, static_cast<uint64_t>(ooc->report.passes) * n);
    EXPECT_EQ(ooc->report.column_begin, 0u);
    EXPECT_EQ(ooc->report.column_end, n);
  }
}

TEST(OutOfCoreSvd, FmfFromTheStoreEqualsTheInMemoryFmf) {
  auto store = BtfStore::open(test_store());
  ASSERT_TRUE(store);
  FmfOptions fo;
  fo.components = 8;
  fo.svd = algorithm();
  auto mem = factorize_fmf(test_btf(), fo);
  ASSERT_TRUE(mem);
  FmfOutOfCoreOptions oo;
  oo.components = 8;
  oo.svd.svd = algorithm();
  FmfOutOfCoreReport report;
  auto ooc = factorize_fmf_out_of_core(*store, oo, {}, &report);
  ASSERT_TRUE(ooc) << ooc.message();
  EXPECT_EQ(ooc->u, mem->u);
  EXPECT_EQ(ooc->v, mem->v);
  EXPECT_EQ(ooc->u_ambient, mem->u_ambient);
  EXPECT_EQ(ooc->singular_values, mem->singular_values);
  EXPECT_EQ(ooc->serialize(), mem->serialize());
  EXPECT_EQ(report.bytes_read, static_cast<uint64_t>(report.svd.passes) * store->info().data_bytes());
}

TEST(OutOfCoreSvd, RunStoppedAfterEachPassResumesToTheIdenticalResult) {
  auto store = BtfStore::open(test_store());
  ASSERT_TRUE(store);
  OutOfCoreSvdOptions o;
  o.svd = algorithm();
  auto whole = run_store(*store, 10, o);
  ASSERT_TRUE(whole);
  const int passes = whole->report.passes;
  ASSERT_GE(passes, 5);
  for (int k = 1; k < passes; ++k) {
    const std::string ckpt = tmp_path("resume_" + std::to_string(k) + ".ckpt");
    std::remove(ckpt.c_str());
    o.checkpoint_path = ckpt;
    o.stop_after_passes = k;  // an injected stop, as a killed run after pass k
    auto stopped = run_store(*store, 10, o);
    ASSERT_FALSE(stopped);
    EXPECT_EQ(stopped.status(), Status::cancelled);
    EXPECT_NE(stopped.message().find("stopped after pass " + std::to_string(k)), std::string::npos)
        << stopped.message();
    o.stop_after_passes = 0;
    auto resumed = run_store(*store, 10, o);
    ASSERT_TRUE(resumed) << resumed.message();
    EXPECT_EQ(resumed->report.resumed_passes, k);
    EXPECT_EQ(resumed->report.passes, passes - k) << "only the remaining passes are run";
    EXPECT_TRUE(same_bits(resumed->svd.u, whole->svd.u)) << "stopped after pass " << k;
    EXPECT_TRUE(same_bits(resumed->svd.v, whole->svd.v)) << "stopped after pass " << k;
    EXPECT_TRUE(same_bits(resumed->svd.s, whole->svd.s)) << "stopped after pass " << k;
    std::remove(ckpt.c_str());
  }
}

TEST(OutOfCoreSvd, CheckpointOfAnotherProblemOrCorruptIsRefused) {
  auto store = BtfStore::open(test_store());
  ASSERT_TRUE(store);
  const std::string ckpt = tmp_path("other.ckpt");
  std::remove(ckpt.c_str());
  OutOfCoreSvdOptions o;
  o.svd = algorithm();
  o.checkpoint_path = ckpt;
  o.stop_after_passes = 1;
  ASSERT_EQ(run_store(*store, 10, o).status(), Status::cancelled);
  o.stop_after_passes = 0;
  auto other_rank = run_store(*store, 9, o);
  ASSERT_FALSE(other_rank);
  EXPECT_EQ(other_rank.status(), Status::bad_data);
  EXPECT_NE(other_rank.message().find("made with rank 10, this run has 9"), std::string::npos) << other_rank.message();
  o.svd.seed += 1;
  EXPECT_NE(run_store(*store, 10, o).message().find("seed"), std::string::npos);
  o.svd.seed -= 1;
  {  // flip one byte of the saved basis
    std::fstream f(ckpt, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(200);
    f.put('\x55');
  }
  auto corrupt = run_store(*store, 10, o);
  ASSERT_FALSE(corrupt);
  EXPECT_NE(corrupt.message().find("CRC-32 mismatch"), std::string::npos) << corrupt.message();
  std::remove(ckpt.c_str());
}

TEST(OutOfCoreSvd, BudgetBelowTheMinimumIsRefusedBeforeReading) {
  auto store = BtfStore::open(test_store());
  ASSERT_TRUE(store);
  OutOfCoreSvdOptions o;
  o.svd = algorithm();
  o.memory_budget = 1 << 20;
  size_t reads = 0;
  auto r = out_of_core_svd(
      store->rows(), store->columns(), 10,
      [&](size_t, size_t, Eigen::MatrixXf&, std::vector<uint8_t>&) -> VoidResult {
        ++reads;
        return {};
      },
      o);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status(), Status::insufficient_space);
  EXPECT_NE(r.message().find("the budget is 1.0 MiB"), std::string::npos) << r.message();
  EXPECT_EQ(reads, 0u);
}

TEST(OutOfCoreSvd, ReaderErrorsStopTheRunWithTheirMessage) {
  OutOfCoreSvdOptions o;
  o.svd = algorithm();
  auto r = out_of_core_svd(
      100, 1000, 5,
      [](size_t col0, size_t, Eigen::MatrixXf& out, std::vector<uint8_t>&) -> VoidResult {
        if (col0 >= 640) return make_error(Status::bad_data, "block at %zu is bad", col0);
        out.setOnes();
        return {};
      },
      o);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("is bad"), std::string::npos);
}

TEST(OutOfCoreSvd, NanInTheMatrixIsRefusedNotFactorised) {
  OutOfCoreSvdOptions o;
  o.svd = algorithm();
  auto r = out_of_core_svd(
      50, 300, 5,
      [](size_t col0, size_t count, Eigen::MatrixXf& out, std::vector<uint8_t>&) -> VoidResult {
        out.setConstant(0.5f);
        if (col0 <= 137 && 137 < col0 + count) out(7, static_cast<Eigen::Index>(137 - col0)) = std::nanf("");
        return {};
      },
      o);
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("NaN or infinite"), std::string::npos) << r.message();
}

namespace {

[[maybe_unused]] uint64_t status_kib(const char* key) {  // unused when the sanitizers skip the test
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind(key, 0) == 0) return std::stoull(line.substr(std::strlen(key)));
  return 0;
}

}  // namespace

// The resident set grows by less than the budget while a store 3× larger than the budget is
// factorised (Linux: peak RSS reset through /proc/self/clear_refs). pread keeps the store in the
// page cache, which is not part of the resident set.
TEST(OutOfCoreSvd, ResidentSetStaysUnderTheBudget) {
#if defined(__SANITIZE_ADDRESS__) || defined(BTFLOD_TEST_TSAN)
  GTEST_SKIP() << "the sanitizer's shadow memory makes the resident set meaningless";
#else
  {
    std::ofstream reset("/proc/self/clear_refs");
    if (!reset) GTEST_SKIP() << "/proc/self/clear_refs is not writable here";
  }
  // 19 × 19 directions, 128 × 128 texels: A is 1083 × 16384, 71 MB as float32. Written view by
  // view from a generator, so the test never holds the BTF either.
  const DirectionSet dirs = small_direction_set(4, 6);
  const int side = 128;
  const std::string path = tmp_path("budget.btfstore");
  {
    auto w = BtfStoreWriter::create(path, side, side, dirs, dirs, BtfStoreValueType::float32, 64);
    ASSERT_TRUE(w);
    const size_t n = static_cast<size_t>(side) * side, nl = dirs.size();
    std::vector<float> view(nl * n * 3);
    for (size_t v = 0; v < dirs.size(); ++v) {
      for (size_t l = 0; l < nl; ++l)
        for (size_t t = 0; t < n; ++t)
          for (size_t c = 0; c < 3; ++c)
            view[(l * n + t) * 3 + c] =
                0.5f + 0.3f * std::sin(0.01f * static_cast<float>(t * (c + 1)) + 0.7f * static_cast<float>(v)) *
                           std::cos(0.3f * static_cast<float>(l + t % 7));
      ASSERT_TRUE(w->write_view(v, view));
    }
    ASSERT_TRUE(w->finish());
  }
  auto store = BtfStore::open(path);
  ASSERT_TRUE(store);
  const uint64_t budget = 24u << 20;
  ASSERT_GT(store->info().data_bytes(), 2 * budget);
  OutOfCoreSvdOptions o;
  o.svd.oversampling = 10;
  o.svd.block_columns = 512;
  o.memory_budget = budget;
  ::malloc_trim(0);
  const uint64_t before = status_kib("VmRSS:");
  {
    std::ofstream reset("/proc/self/clear_refs");
    reset << "5";
  }
  auto r = run_store(*store, 16, o);
  const uint64_t peak = status_kib("VmHWM:");
  ASSERT_TRUE(r) << r.message();
  EXPECT_LE(r->report.estimated_peak_bytes, budget);
  const uint64_t growth = (peak > before ? peak - before : 0) * 1024;
  std::printf("store %.1f MiB, budget %.1f MiB, estimate %.1f MiB, resident growth %.1f MiB, %zu-column blocks\n",
              static_cast<double>(store->info().data_bytes()) / 1048576.0, static_cast<double>(budget) / 1048576.0,
              static_cast<double>(r->report.estimated_peak_bytes) / 1048576.0, static_cast<double>(growth) / 1048576.0,
              r->report.block_columns);
  EXPECT_LE(growth, budget);
  EXPECT_GT(growth, 256u << 10) << "the measurement should see the factorisation's own matrices";
  std::remove(path.c_str());
#endif
}
