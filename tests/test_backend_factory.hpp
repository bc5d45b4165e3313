// The backend factories the GPU tests pass to their shared cases: a sample backend's create
// result as a Backend, or null with the reason in `why` (the cases then skip with it).
#pragma once

#include <memory>
#include <string>
#include <utility>

#include "btflod/runtime/backend/backend.hpp"

namespace btflod::test {

/// The backend of a create_*_backend() result, or null with its message in `why`.
template <class CreateResult>
std::unique_ptr<Backend> backend_or_why(CreateResult result, std::string& why) {
  if (!result) {
    why = result.message();
    return nullptr;
  }
  return std::move(result.value());
}

}  // namespace btflod::test

#if defined(BTFLOD_TEST_VK_FACTORY)
#include "vk_backend.hpp"

namespace btflod::test {

/// The Vulkan backend with GLSL (or, `hlsl`, HLSL-compiled) programs.
inline std::unique_ptr<Backend> make_vk_backend(std::string& why, bool hlsl) {
  samples::VkBackendOptions o;
  o.hlsl_programs = hlsl;
  return backend_or_why(samples::create_vk_backend(o), why);
}

}  // namespace btflod::test
#endif
