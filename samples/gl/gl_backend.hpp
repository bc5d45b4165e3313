// btflod sample — headless OpenGL 4.5 core backend (EGL; llvmpipe in CI).
//
// Implements btflod::Backend (include/btflod/runtime/backend/backend.hpp) with the generated GLSL 4.50
// shaders. No GL header leaks out of this file: the GL objects live in gl_backend.cpp.
#pragma once

#include <memory>

#include "btflod/core/result.hpp"
#include "btflod/runtime/backend/backend.hpp"

namespace btflod::samples {

struct GlBackendOptions {
  uint32_t feedback_ring_size = 3;  ///< pixel-pack buffers + fences polled by poll_feedback()
};

/// Creates an OpenGL 4.5 core context without a window (EGL surfaceless platform, falling
/// back to the EGL device platform) and a backend on it. Returns `unsupported` with the reason
/// when no EGL display or no 4.5 core context is available (callers skip or fall back).
/// The backend must be used on the creating thread; the context is current there.
Result<std::unique_ptr<Backend>> create_gl_backend(const GlBackendOptions& options = {});

/// EGL objects made elsewhere (gl_window.cpp), as opaque pointers so this header stays free of
/// EGL: an EGLDisplay, an OpenGL 4.5 core EGLContext and the EGLSurface to draw on.
struct GlExternalContext {
  void* display = nullptr;
  void* context = nullptr;
  void* surface = nullptr;  ///< nullptr: surfaceless
};

/// Creates a backend on an existing display, context and surface (made current here). The
/// backend does not own them: the caller destroys the context and surface after the backend.
/// Returns `invalid_argument` for null handles, `unsupported` when the context cannot be made
/// current or has no GL 4.5. Same threading as create_gl_backend.
Result<std::unique_ptr<Backend>> create_gl_backend_on(const GlExternalContext& context,
                                                      const GlBackendOptions& options = {});

/// Blits the colour target of `backend`'s last frame (a backend of this file) into the default
/// framebuffer of its surface, scaled to width × height, linear → sRGB when that framebuffer
/// is sRGB-capable. Returns `invalid_argument` for another backend type or before a frame.
/// On the backend's thread; no allocation.
Status gl_blit_color_to_default_framebuffer(Backend& backend, uint32_t width, uint32_t height) noexcept;

}  // namespace btflod::samples
