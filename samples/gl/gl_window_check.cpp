// btflod sample — checks the windowed GL path on a real X server (ctest gl_window_xvfb runs it
// under Xvfb through run_with_xvfb.sh). Renders the shared FMF test scene into an X11 window
// for a bounded number of frames (the light moves each frame), presents each with
// eglSwapBuffers, then reads back what the X server shows (XGetImage) and compares it with
// the headless backend's render of the last frame, sRGB-encoded to 8 bits: PSNR ≥ 40 dB, and
// the shown image must not be an earlier frame. Finally a WM_DELETE_WINDOW close request sent
// from a second X connection must close the window through poll_events().
// Exit codes: 0 pass, 1 fail, 77 skipped (no X display).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>
#include <vector>

#include "../../tests/test_shader_scene.hpp"
#include "gl_backend.hpp"
#include "gl_window.hpp"

#include <X11/Xlib.h>  // after the btflod headers (Xlib.h defines Status)
#undef Status

using namespace btflod;
using namespace btflod::test_scene;

namespace {

constexpr uint32_t kSide = 128;
constexpr int kFrames = 6;

struct Rig {
  MeshHandle mesh;
  MaterialHandle material;
};

bool set_up(Backend& be, const ShaderConfig& c, const Material& m, Rig& rig) {
  if (!be.init(c, 1)) return false;
  const auto verts = quad_vertices();
  const auto idx = quad_indices();
  auto mesh = be.create_mesh(MeshData{verts, idx});
  auto mat = be.create_material(m.data(true));
  if (!mesh || !mat) return false;
  rig.mesh = *mesh;
  rig.material = *mat;
  return true;
}

ShaderParams frame_params(int f) {
  ShaderParams p = make_params();
  p.light = glm::vec4(-0.6f + 0.2f * static_cast<float>(f), 0.5f, 0.8f, 1.0f);
  return p;
}

bool render(Backend& be, const Rig& rig, int f) {
  FrameDesc d{kSide, kSide, kSide / 8, kSide / 8, {0.1f, 0.2f, 0.3f, 1.0f}};
  return be.begin_frame(d) == Status::success &&
         be.draw(ShaderProgram::fmf, rig.mesh, rig.material, frame_params(f)) == Status::success &&
         be.end_frame() == Status::success;
}

uint8_t to_srgb8(float v, bool srgb) {
  v = std::clamp(v, 0.0f, 1.0f);
  if (srgb) v = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
  return static_cast<uint8_t>(std::lround(v * 255.0f));
}

double psnr8(const std::vector<uint8_t>& shown, const std::vector<uint8_t>& want) {
  double se = 0;
  size_t n = 0;
  for (size_t i = 0; i < shown.size(); ++i) {
    if (i % 4 == 3) continue;
    const double d = static_cast<double>(shown[i]) - static_cast<double>(want[i]);
    se += d * d;
    ++n;
  }
  return se == 0 ? 99.0 : 10.0 * std::log10(255.0 * 255.0 / (se / static_cast<double>(n)));
}

std::vector<uint8_t> headless_frame(Backend& be, const Rig& rig, int f, bool srgb) {
  std::vector<uint8_t> out;
  if (!render(be, rig, f) || be.wait_idle() != Status::success) return out;
  Image<float> img(kSide, kSide, 4);
  if (be.read_color(img.view()) != Status::success) return out;
  out.resize(static_cast<size_t>(kSide) * kSide * 4, 255);
  for (uint32_t y = 0; y < kSide; ++y)
    for (uint32_t x = 0; x < kSide; ++x)
      for (int c = 0; c < 3; ++c)
        out[(y * kSide + x) * 4 + static_cast<size_t>(c)] =
            to_srgb8(img.at(static_cast<int>(x), static_cast<int>(y), c), srgb);
  return out;
}

}  // namespace

int main() {
  if (!samples::gl_window_display_available()) {
    std::printf("SKIP: no X display (DISPLAY unset or unreachable)\n");
    return 77;
  }
  samples::GlWindowOptions wo;
  wo.width = wo.height = kSide;
  wo.title = "btflod gl_window_check";
  auto win = samples::GlWindow::create(wo);
  if (!win) {
    std::printf("FAIL: window: %s\n", win.message().c_str());
    return 1;
  }
  const std::string desc = (*win)->description();
  const bool srgb = desc.find("sRGB") != std::string::npos;
  std::printf("window: %s; backend %s\n", desc.c_str(), (*win)->backend().name());
  ShaderConfig c;
  c.components = 5;
  c.angular.resolution = 32;
  static const Material m = make_material(c, 64, 64);
  Rig wrig;
  if (!set_up((*win)->backend(), c, m, wrig)) {
    std::printf("FAIL: window backend set-up\n");
    return 1;
  }
  for (int f = 0; f < kFrames; ++f) {
    if (!render((*win)->backend(), wrig, f)) {
      std::printf("FAIL: window frame %d\n", f);
      return 1;
    }
    if (const Status s = (*win)->present(); s != Status::success) {
      std::printf("FAIL: present frame %d: status %d\n", f, static_cast<int>(s));
      return 1;
    }
  }
  std::vector<uint8_t> shown;
  if ((*win)->capture(shown) != Status::success) {
    std::printf("FAIL: XGetImage of the window\n");
    return 1;
  }
  // The headless backend (surfaceless EGL) renders the same frames for comparison.
  auto headless = samples::create_gl_backend();
  if (!headless) {
    std::printf("FAIL: headless backend: %s\n", headless.message().c_str());
    return 1;
  }
  Rig hrig;
  if (!set_up(**headless, c, m, hrig)) {
    std::printf("FAIL: headless set-up\n");
    return 1;
  }
  const std::vector<uint8_t> last = headless_frame(**headless, hrig, kFrames - 1, srgb);
  const std::vector<uint8_t> earlier = headless_frame(**headless, hrig, 0, srgb);
  if (last.empty() || earlier.empty()) {
    std::printf("FAIL: headless render\n");
    return 1;
  }
  const double p_last = psnr8(shown, last), p_first = psnr8(shown, earlier), p_frames = psnr8(last, earlier);
  const uint64_t presented = (*win)->presented_frames();
  std::printf(
      "presented %llu frames; window vs headless last frame: PSNR %.1f dB; vs frame 0: %.1f dB "
      "(headless frame 0 vs last: %.1f dB)\n",
      static_cast<unsigned long long>(presented), p_last, p_first, p_frames);
  bool ok = presented == static_cast<uint64_t>(kFrames) && p_last >= 40.0 && p_first < p_last - 3.0 && p_frames < 35.0;

  // Close request from another client, as a window manager sends it.
  Display* other = XOpenDisplay(nullptr);
  if (!other) {
    std::printf("FAIL: second X connection\n");
    return 1;
  }
  XEvent e{};
  e.xclient.type = ClientMessage;
  e.xclient.window = static_cast<Window>((*win)->x11_window());
  e.xclient.message_type = XInternAtom(other, "WM_PROTOCOLS", False);
  e.xclient.format = 32;
  e.xclient.data.l[0] = static_cast<long>(XInternAtom(other, "WM_DELETE_WINDOW", False));
  e.xclient.data.l[1] = CurrentTime;
  XSendEvent(other, e.xclient.window, False, NoEventMask, &e);
  XSync(other, False);
  bool open_before = !(*win)->close_requested();
  for (int i = 0; i < 500 && (*win)->poll_events(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  XCloseDisplay(other);
  const bool closed = (*win)->close_requested();
  std::printf("close request: window %s\n", closed ? "closed" : "STILL OPEN");
  ok = ok && open_before && closed;
  std::printf("%s\n", ok ? "gl_window_check passed" : "gl_window_check FAILED");
  return ok ? 0 : 1;
}
