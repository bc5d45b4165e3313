// btflod sample — headless Vulkan backend (lavapipe in CI): offscreen images, no swapchain.
//
// Implements btflod::Backend (include/btflod/runtime/backend/backend.hpp) with the generated Vulkan
// GLSL, compiled to SPIR-V by glslc (subprocess) when init() runs. Needs Vulkan 1.3 (dynamic
// rendering). No Vulkan header leaks out of this file (internals: vk_internal.hpp).
#pragma once

#include <memory>

#include "btflod/core/result.hpp"
#include "btflod/runtime/backend/backend.hpp"

namespace btflod::samples {

struct VkBackendOptions {
  uint32_t feedback_ring_size = 3;              ///< host-visible readback buffers polled by poll_feedback()
  uint32_t frames_in_flight = 2;                ///< command buffers recorded while the GPU works
  uint32_t max_draws_per_frame = 256;           ///< uniform-buffer slices per frame
  uint64_t staging_bytes_per_frame = 8u << 20;  ///< tile and page-table uploads per frame
  /// Every program from generate_hlsl_program(), compiled to SPIR-V by glslangValidator's HLSL
  /// front end (a texture and its sampler state share the combined image-sampler binding);
  /// false: the Vulkan GLSL of generate_program() through glslc.
  bool hlsl_programs = false;
};

/// Creates a Vulkan 1.3 instance and device on the first physical device with a graphics queue
/// (lavapipe on CI machines) and a backend on it. Returns `unsupported` with the reason when no
/// Vulkan driver, no 1.3 device or no glslc is available (callers skip or fall back).
Result<std::unique_ptr<Backend>> create_vk_backend(const VkBackendOptions& options = {});

}  // namespace btflod::samples
