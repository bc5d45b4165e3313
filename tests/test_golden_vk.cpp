// Golden images: the Vulkan backend (samples/vulkan, headless on lavapipe) vs the CPU reference
// of backend/cpu_reference.hpp on the same scene:
// PSNR >= 40 dB at 256x256 for FMF and for BSVTF through a partially filled vt/ TileCache.
// Skips with the reason when the GPU API is not available at run time.
// btflod-link: btflod_vk_backend
// btflod-label: gpu
#include <gtest/gtest.h>

#include "vk_backend.hpp"
#include "test_golden_scene.hpp"

namespace {

std::unique_ptr<btflod::Backend> make_backend(std::string& why) {
  auto r = btflod::samples::create_vk_backend();
  if (!r) {
    why = r.message();
    return nullptr;
  }
  return std::move(r.value());
}

}  // namespace

TEST(GoldenVk, FmfMatchesCpuReference) { btflod::golden::golden_fmf(make_backend); }
TEST(GoldenVk, BsvtfPartialCacheMatchesCpuReference) { btflod::golden::golden_bsvtf_partial(make_backend); }
