// Regression test for offline/btf/openexr_image_set.hpp, failure class "an attribute size beyond the
// file": found by fuzz_exr_image_set (a 360-byte input whose first header attribute declared
// 1,677,918,208 bytes made OpenEXR allocate 1.6 GB before its read failed; under ASan each such
// input took over 10 s). probe_exr and decode_exr now walk the attribute list first and refuse
// it without allocating. The largest allocation is measured by replacing the global operator
// new for this test program (OpenEXR allocates attribute values with new[]).
#include <gtest/gtest.h>

#if defined(BTFLOD_WITH_OPENEXR) && BTFLOD_WITH_OPENEXR

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <vector>

#include "btflod/offline/btf/openexr_image_set.hpp"

namespace {
std::atomic<bool> g_watch{false};
std::atomic<size_t> g_largest{0};

void* counted_alloc(size_t n) {
  if (g_watch.load(std::memory_order_relaxed)) {
    size_t prev = g_largest.load(std::memory_order_relaxed);
    while (n > prev && !g_largest.compare_exchange_weak(prev, n)) {
    }
  }
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
}  // namespace

void* operator new(size_t n) { return counted_alloc(n); }
void* operator new[](size_t n) { return counted_alloc(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, size_t) noexcept { std::free(p); }
void operator delete[](void* p, size_t) noexcept { std::free(p); }

namespace {

using namespace btflod;

std::vector<uint8_t> small_exr() {
  Image<float> img(4, 3, 3);
  for (size_t i = 0; i < img.size(); ++i) img.data()[i] = 0.5f + 0.25f * static_cast<float>(i % 7);
  return encode_exr(img).value();
}

// Offset of the size field of the first header attribute (after the 8-byte magic and version).
// The attribute's name and type are changed to ones OpenEXR does not know, as in the fuzzer's
// input: OpenEXR then reads the value as an opaque attribute, allocating its declared size first.
size_t first_attribute_size_field(std::vector<uint8_t>& f) {
  size_t p = 8;
  f[p] = 'x';  // e.g. "channels" -> "xhannels"
  while (f[p] != 0) ++p;
  f[++p] = 'x';  // e.g. "chlist" -> "xhlist"
  while (f[p] != 0) ++p;
  return p + 1;
}

TEST(OpenExrAttributeSize, AttributeSizeBeyondTheFileIsRefusedBeforeAllocating) {
  std::vector<uint8_t> f = small_exr();
  ASSERT_TRUE(decode_exr(f).ok());
  const uint32_t hostile = 1677918208u;  // the fuzzer's value
  std::memcpy(f.data() + first_attribute_size_field(f), &hostile, 4);

  g_largest = 0;
  g_watch = true;
  auto info = probe_exr(f);
  auto img = decode_exr(f);
  g_watch = false;
  EXPECT_EQ(info.status(), Status::short_output) << info.message();
  EXPECT_EQ(img.status(), Status::short_output) << img.message();
  EXPECT_NE(info.message().find("declares more bytes"), std::string::npos) << info.message();
  EXPECT_LT(g_largest.load(), size_t{1} << 20) << "a hostile attribute size must not be allocated";
}

TEST(OpenExrAttributeSize, AttributeNameWithoutItsEndIsTruncatedAndOverlongNamesAreBadData) {
  std::vector<uint8_t> f = small_exr();
  std::vector<uint8_t> cut(f.begin(), f.begin() + 12);  // inside the first attribute's name
  EXPECT_EQ(probe_exr(cut).status(), Status::short_output);
  std::vector<uint8_t> long_name(f.begin(), f.begin() + 8);
  long_name.insert(long_name.end(), 300, 'a');
  long_name.insert(long_name.end(), f.begin() + 8, f.end());
  auto r = probe_exr(long_name);
  EXPECT_EQ(r.status(), Status::bad_data) << r.message();
}

}  // namespace

#else
TEST(OpenExrAttributeSize, SkippedWithoutOpenExr) { GTEST_SKIP() << "btflod configured without OpenEXR"; }
#endif
