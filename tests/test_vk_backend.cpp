// Vulkan backend (samples/vulkan, headless on lavapipe): FMF and BSVTF renders agree with the
// CPU evaluation of the same formulas, tiles reach the screen through the page table, the
// feedback pass writes the expected words and its readback ring never waits.
// btflod-link: btflod_vk_backend
// btflod-label: gpu
#include <gtest/gtest.h>

#include "vk_backend.hpp"
#include "test_shader_backend_cases.hpp"

namespace {

std::unique_ptr<btflod::Backend> make_vk(std::string& why) {
  auto r = btflod::samples::create_vk_backend();
  if (!r) {
    why = r.message();
    return nullptr;
  }
  return std::move(r.value());
}

}  // namespace

BTFLOD_BACKEND_TEST_CASES(Vk, make_vk)
