// Vulkan backend (samples/vulkan, headless on lavapipe): FMF and BSVTF renders agree with the
// CPU evaluation of the same formulas, tiles reach the screen through the page table, the
// feedback pass writes the expected words and its readback ring never waits; the same cases again
// with the HLSL programs (VkBackendOptions::hlsl_programs).
// btflod-link: btflod_vk_backend
// btflod-label: gpu
#include <gtest/gtest.h>

#define BTFLOD_TEST_VK_FACTORY 1
#include "test_backend_factory.hpp"
#include "test_shader_backend_cases.hpp"
#include "vk_backend.hpp"

namespace {

std::unique_ptr<btflod::Backend> make_vk(std::string& why) { return btflod::test::make_vk_backend(why, false); }
std::unique_ptr<btflod::Backend> make_vk_hlsl(std::string& why) { return btflod::test::make_vk_backend(why, true); }

}  // namespace

BTFLOD_BACKEND_TEST_CASES(Vk, make_vk)
BTFLOD_BACKEND_TEST_CASES(VkHlsl, make_vk_hlsl)
