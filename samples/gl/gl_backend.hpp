// btflod sample — headless OpenGL 4.5 core backend (EGL; llvmpipe in CI).
//
// Implements btflod::Backend (include/btflod/backend/backend.hpp) with the generated GLSL 4.50
// shaders. No GL header leaks out of this file: the GL objects live in gl_backend.cpp.
#pragma once

#include <memory>

#include "btflod/backend/backend.hpp"
#include "btflod/core/result.hpp"

namespace btflod::samples {

struct GlBackendOptions {
  uint32_t feedback_ring_size = 3;  ///< pixel-pack buffers + fences polled by poll_feedback()
};

/// Creates an OpenGL 4.5 core context without a window (EGL surfaceless platform, falling
/// back to the EGL device platform) and a backend on it. Returns `unsupported` with the reason
/// when no EGL display or no 4.5 core context is available (callers skip or fall back).
/// The backend must be used on the creating thread; the context is current there.
Result<std::unique_ptr<Backend>> create_gl_backend(const GlBackendOptions& options = {});

}  // namespace btflod::samples
