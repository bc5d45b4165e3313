// btflod sample — X11 window + EGL window surface for the GL backend. See gl_window.hpp.
#include "gl_window.hpp"

#include <cstdlib>
#include <cstring>

// X11 after the btflod headers: Xlib.h defines macros (Status, Bool, None, True) that would
// rewrite btflod names; btflod::Status is spelled out below after the #undef.
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <X11/Xatom.h>
#include <X11/Xlib.h>
#include <X11/Xutil.h>
#include <X11/keysym.h>
#undef Status

namespace btflod::samples {

struct GlWindow::Impl {
  Display* x = nullptr;
  Window window = 0;
  Colormap colormap = 0;
  Atom wm_delete = 0;
  EGLDisplay egl = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  EGLSurface surface = EGL_NO_SURFACE;
  std::unique_ptr<Backend> backend;
  uint32_t width = 0, height = 0;
  uint64_t presented = 0;
  bool closed = false;
  std::string description;

  ~Impl() {
    backend.reset();  // GL objects go while the context is still current
    if (egl != EGL_NO_DISPLAY) {
      eglMakeCurrent(egl, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      if (surface != EGL_NO_SURFACE) eglDestroySurface(egl, surface);
      if (context != EGL_NO_CONTEXT) eglDestroyContext(egl, context);
      // Not eglTerminate: EGL displays are per-process singletons per native display, and the
      // X connection below is closed anyway (Mesa drops the display with it).
    }
    if (x) {
      if (window) XDestroyWindow(x, window);
      if (colormap) XFreeColormap(x, colormap);
      XCloseDisplay(x);
    }
  }
};

namespace {

// Xlib's default error handler exits the process; a sample that may fall back must not.
int ignore_x_error(Display*, XErrorEvent*) { return 0; }

}  // namespace

bool gl_window_display_available() noexcept {
  const char* name = std::getenv("DISPLAY");
  if (!name || !*name) return false;
  Display* d = XOpenDisplay(name);
  if (!d) return false;
  XCloseDisplay(d);
  return true;
}

GlWindow::GlWindow(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
GlWindow::~GlWindow() = default;

Result<std::unique_ptr<GlWindow>> GlWindow::create(const GlWindowOptions& options) {
  if (options.width == 0 || options.height == 0 || options.width > 16384 || options.height > 16384)
    return make_error(Status::invalid_argument, "GL window: size %u×%u", options.width, options.height);
  const char* name = std::getenv("DISPLAY");
  if (!name || !*name) return make_error(Status::unsupported, "GL window: DISPLAY is not set");
  auto w = std::make_unique<Impl>();
  w->x = XOpenDisplay(name);
  if (!w->x) return make_error(Status::unsupported, "GL window: cannot open X display %s", name);
  XSetErrorHandler(ignore_x_error);

  // EGL on the X11 platform: EGL 1.5 core entry point when the client library has it, else
  // the EXT variant (same enum value, EGL_PLATFORM_X11_KHR == EGL_PLATFORM_X11_EXT).
  auto get_display_ext =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  auto create_surface_ext = reinterpret_cast<PFNEGLCREATEPLATFORMWINDOWSURFACEEXTPROC>(
      eglGetProcAddress("eglCreatePlatformWindowSurfaceEXT"));
  if (!get_display_ext || !create_surface_ext)
    return make_error(Status::unsupported, "GL window: EGL_EXT_platform_base missing");
  const char* client_ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!client_ext ||
      (!std::strstr(client_ext, "EGL_KHR_platform_x11") && !std::strstr(client_ext, "EGL_EXT_platform_x11")))
    return make_error(Status::unsupported, "GL window: EGL has no X11 platform");
  w->egl = get_display_ext(EGL_PLATFORM_X11_KHR, w->x, nullptr);
  EGLint major = 0, minor = 0;
  if (w->egl == EGL_NO_DISPLAY || !eglInitialize(w->egl, &major, &minor))
    return make_error(Status::unsupported, "GL window: eglInitialize on X11 failed (0x%04x)", eglGetError());
  if (!eglBindAPI(EGL_OPENGL_API)) return make_error(Status::unsupported, "GL window: eglBindAPI(OpenGL) failed");
  const EGLint config_attribs[] = {EGL_SURFACE_TYPE,
                                   EGL_WINDOW_BIT,
                                   EGL_RENDERABLE_TYPE,
                                   EGL_OPENGL_BIT,
                                   EGL_RED_SIZE,
                                   8,
                                   EGL_GREEN_SIZE,
                                   8,
                                   EGL_BLUE_SIZE,
                                   8,
                                   EGL_NONE};
  EGLConfig config = nullptr;
  EGLint count = 0;
  if (!eglChooseConfig(w->egl, config_attribs, &config, 1, &count) || count == 0)
    return make_error(Status::unsupported, "GL window: no EGL window config with RGB8 + OpenGL");
  EGLint visual_id = 0;
  eglGetConfigAttrib(w->egl, config, EGL_NATIVE_VISUAL_ID, &visual_id);

  // The X window with the visual EGL asked for (a 24-bit TrueColor one on Xvfb).
  XVisualInfo tmpl{};
  tmpl.visualid = static_cast<VisualID>(visual_id);
  int n_visuals = 0;
  XVisualInfo* vi = XGetVisualInfo(w->x, VisualIDMask, &tmpl, &n_visuals);
  if (!vi) return make_error(Status::unsupported, "GL window: X visual 0x%x of the EGL config not found", visual_id);
  const Window root = RootWindow(w->x, vi->screen);
  w->colormap = XCreateColormap(w->x, root, vi->visual, AllocNone);
  XSetWindowAttributes attrs{};
  attrs.colormap = w->colormap;
  attrs.background_pixel = 0;
  attrs.border_pixel = 0;
  attrs.event_mask = StructureNotifyMask | KeyPressMask | ExposureMask;
  w->window = XCreateWindow(w->x, root, 0, 0, options.width, options.height, 0, vi->depth, InputOutput, vi->visual,
                            CWColormap | CWBackPixel | CWBorderPixel | CWEventMask, &attrs);
  XFree(vi);
  if (!w->window) return make_error(Status::unsupported, "GL window: XCreateWindow failed");
  XStoreName(w->x, w->window, options.title.c_str());
  w->wm_delete = XInternAtom(w->x, "WM_DELETE_WINDOW", False);
  XSetWMProtocols(w->x, w->window, &w->wm_delete, 1);
  XMapWindow(w->x, w->window);
  // Wait (bounded) for the MapNotify so the first present lands on a visible window.
  for (int i = 0; i < 2000; ++i) {
    XEvent e;
    if (XCheckTypedWindowEvent(w->x, w->window, MapNotify, &e)) break;
    XSync(w->x, False);
    if (i > 0 && i % 100 == 0) XFlush(w->x);
  }
  w->width = options.width;
  w->height = options.height;

  // EGL_KHR_gl_colorspace: an sRGB window surface, so the blit of the linear colour target
  // encodes sRGB like the demo's PNGs. Without the extension, the plain surface (linear).
  const char* dpy_ext = eglQueryString(w->egl, EGL_EXTENSIONS);
  const bool srgb = dpy_ext && std::strstr(dpy_ext, "EGL_KHR_gl_colorspace");
  const EGLint srgb_attribs[] = {EGL_GL_COLORSPACE_KHR, EGL_GL_COLORSPACE_SRGB_KHR, EGL_NONE};
  Window native = w->window;
  w->surface = create_surface_ext(w->egl, config, &native, srgb ? srgb_attribs : nullptr);
  if (w->surface == EGL_NO_SURFACE && srgb) w->surface = create_surface_ext(w->egl, config, &native, nullptr);
  if (w->surface == EGL_NO_SURFACE)
    return make_error(Status::unsupported, "GL window: eglCreatePlatformWindowSurface failed (0x%04x)", eglGetError());
  const EGLint context_attribs[] = {
      EGL_CONTEXT_MAJOR_VERSION,           4,       EGL_CONTEXT_MINOR_VERSION, 5, EGL_CONTEXT_OPENGL_PROFILE_MASK,
      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  w->context = eglCreateContext(w->egl, config, EGL_NO_CONTEXT, context_attribs);
  if (w->context == EGL_NO_CONTEXT)
    return make_error(Status::unsupported, "GL window: no OpenGL 4.5 core context (0x%04x)", eglGetError());
  auto be = create_gl_backend_on(GlExternalContext{w->egl, w->context, w->surface}, options.backend);
  if (!be) return be.error();
  w->backend = std::move(*be);
  eglSwapInterval(w->egl, 0);  // never wait for a vertical blank: frame times stay comparable
  const char* vendor = eglQueryString(w->egl, EGL_VENDOR);
  w->description = std::string("X11 ") + DisplayString(w->x) + ", EGL " + std::to_string(major) + "." +
                   std::to_string(minor) + " " + (vendor ? vendor : "?") + (srgb ? ", sRGB surface" : "");
  return std::unique_ptr<GlWindow>(new GlWindow(std::move(w)));
}

Backend& GlWindow::backend() noexcept { return *impl_->backend; }

Status GlWindow::present() noexcept {
  Impl& w = *impl_;
  if (w.closed) return Status::success;  // nothing to show on a closed window
  if (const Status s = gl_blit_color_to_default_framebuffer(*w.backend, w.width, w.height); s != Status::success)
    return s;
  if (!eglSwapBuffers(w.egl, w.surface)) return Status::io_error;
  ++w.presented;
  poll_events();
  return Status::success;
}

bool GlWindow::poll_events() noexcept {
  Impl& w = *impl_;
  while (!w.closed && XPending(w.x) > 0) {
    XEvent e;
    XNextEvent(w.x, &e);
    if (e.type == ClientMessage && static_cast<Atom>(e.xclient.data.l[0]) == w.wm_delete) {
      w.closed = true;
    } else if (e.type == DestroyNotify && e.xdestroywindow.window == w.window) {
      w.closed = true;
    } else if (e.type == KeyPress) {
      const KeySym k = XLookupKeysym(&e.xkey, 0);
      if (k == XK_Escape || k == XK_q) w.closed = true;
    } else if (e.type == ConfigureNotify) {
      // Frames are scaled to the client area (the backend's targets keep the demo's size).
      if (e.xconfigure.width > 0 && e.xconfigure.height > 0) {
        w.width = static_cast<uint32_t>(e.xconfigure.width);
        w.height = static_cast<uint32_t>(e.xconfigure.height);
      }
    }
  }
  return !w.closed;
}

bool GlWindow::close_requested() const noexcept { return impl_->closed; }
uint64_t GlWindow::presented_frames() const noexcept { return impl_->presented; }
uint32_t GlWindow::width() const noexcept { return impl_->width; }
uint32_t GlWindow::height() const noexcept { return impl_->height; }
std::string GlWindow::description() const { return impl_->description; }
uint64_t GlWindow::x11_window() const noexcept { return impl_->window; }

Status GlWindow::capture(std::vector<uint8_t>& rgba) noexcept {
  Impl& w = *impl_;
  eglWaitGL();  // the swap's image is with the X server once this and the XSync return
  XSync(w.x, False);
  XImage* img = XGetImage(w.x, w.window, 0, 0, w.width, w.height, AllPlanes, ZPixmap);
  if (!img) return Status::io_error;
  rgba.assign(static_cast<size_t>(w.width) * w.height * 4, 255);
  // TrueColor masks: find each channel's shift from its mask (8 bits per channel here).
  const auto shift_of = [](unsigned long mask) {
    int s = 0;
    while (mask && !(mask & 1ul)) mask >>= 1, ++s;
    return s;
  };
  const int rs = shift_of(img->red_mask), gs = shift_of(img->green_mask), bs = shift_of(img->blue_mask);
  for (uint32_t y = 0; y < w.height; ++y)
    for (uint32_t x = 0; x < w.width; ++x) {
      const unsigned long p = XGetPixel(img, static_cast<int>(x), static_cast<int>(y));
      uint8_t* o = &rgba[(static_cast<size_t>(y) * w.width + x) * 4];
      o[0] = static_cast<uint8_t>((p & img->red_mask) >> rs);
      o[1] = static_cast<uint8_t>((p & img->green_mask) >> gs);
      o[2] = static_cast<uint8_t>((p & img->blue_mask) >> bs);
    }
  XDestroyImage(img);
  return Status::success;
}

}  // namespace btflod::samples
