// Vulkan backend (samples/vulkan, headless on lavapipe): FMF and BSVTF renders agree with the
// CPU evaluation of the same formulas, tiles reach the screen through the page table, the
// feedback pass writes the expected words and its readback ring never waits; the same cases again
// with the HLSL programs (VkBackendOptions::hlsl_programs).
// btflod-link: btflod_vk_backend
// btflod-label: gpu
#include <gtest/gtest.h>

#include "test_shader_backend_cases.hpp"
#include "vk_backend.hpp"

namespace {

std::unique_ptr<btflod::Backend> make_vk_with(std::string& why, bool hlsl) {
  btflod::samples::VkBackendOptions o;
  o.hlsl_programs = hlsl;
  auto r = btflod::samples::create_vk_backend(o);
  if (!r) {
    why = r.message();
    return nullptr;
  }
  return std::move(r.value());
}
std::unique_ptr<btflod::Backend> make_vk(std::string& why) { return make_vk_with(why, false); }
std::unique_ptr<btflod::Backend> make_vk_hlsl(std::string& why) { return make_vk_with(why, true); }

}  // namespace

BTFLOD_BACKEND_TEST_CASES(Vk, make_vk)
BTFLOD_BACKEND_TEST_CASES(VkHlsl, make_vk_hlsl)
