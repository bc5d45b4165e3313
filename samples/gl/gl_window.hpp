// btflod sample — an X11 window for the OpenGL backend (EGL on the X11 platform).
//
// The headless backend (gl_backend.hpp) stays the default for tests and CI; this is the path a
// person watching the demo gets when a display exists: an X11 window, an EGL window surface
// (EGL_PLATFORM_X11_KHR through eglGetPlatformDisplay with the Xlib Display), the GL backend
// on that surface's context, each frame blitted from the backend's colour target into the
// window and presented with eglSwapBuffers, and the window manager's close button / Escape
// handled. No X11 or EGL header leaks out of this file: they live in gl_window.cpp.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "btflod/core/result.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "gl_backend.hpp"

namespace btflod::samples {

struct GlWindowOptions {
  uint32_t width = 480, height = 270;  ///< client area in pixels (frames are scaled to it)
  std::string title = "btflod";
  GlBackendOptions backend;
};

/// True when DISPLAY is set and an X server accepts a connection (opened and closed again).
/// Thread-safe; cheap enough to call once at start-up.
bool gl_window_display_available() noexcept;

/// An X11 window with an OpenGL 4.5 core context on an EGL window surface, and a btflod GL
/// backend on that context. Use on the creating thread only (the context is current there).
class GlWindow {
 public:
  /// Opens the display named by DISPLAY, creates and maps the window and the backend. Returns
  /// `unsupported` with the reason when there is no display, no EGL X11 platform, no window
  /// config or no 4.5 core context (callers then fall back to the headless backend).
  static Result<std::unique_ptr<GlWindow>> create(const GlWindowOptions& options = {});
  ~GlWindow();
  GlWindow(const GlWindow&) = delete;
  GlWindow& operator=(const GlWindow&) = delete;

  /// The GL backend drawing on this window's context. Valid while the window lives.
  Backend& backend() noexcept;

  /// Blits the backend's last colour frame into the window's back buffer, presents it with
  /// eglSwapBuffers and processes pending X events. Returns `io_error` when the swap fails,
  /// `invalid_argument` before the first frame. No allocation.
  Status present() noexcept;

  /// Handles pending X events without blocking: the window manager's close (WM_DELETE_WINDOW),
  /// the window being destroyed, and Escape or q. Returns true while the window stays open.
  bool poll_events() noexcept;
  /// True once the user asked to close the window.
  bool close_requested() const noexcept;
  /// Frames presented by present() so far.
  uint64_t presented_frames() const noexcept;
  /// Client-area size.
  uint32_t width() const noexcept;
  uint32_t height() const noexcept;

  /// Reads what the X server shows in the window (XGetImage of the client area, after an
  /// XSync), as RGBA8 rows top-down (alpha 255). This is what a person sees, so it checks that
  /// frames really were presented. Returns `io_error` when the server refuses; allocates.
  Status capture(std::vector<uint8_t>& rgba) noexcept;

  /// The X11 window id (an XID), e.g. for a test that sends it a close request.
  uint64_t x11_window() const noexcept;

  /// "X11 <display name>, EGL <vendor> <version>".
  std::string description() const;

 private:
  struct Impl;
  explicit GlWindow(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace btflod::samples
