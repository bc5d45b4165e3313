// libFuzzer target for the UBO image-name parser (offline/btf/ubo2003_folder.hpp) and the in-memory
// image decoder (offline/btf/image_io.hpp). The first byte picks the mode: even → the rest is a
// relative image path (parse_ubo_angle_keys + parse_ubo_image_path), odd → the rest is an
// encoded image decoded with small limits (so a declared bomb cannot allocate much).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string_view>

#include "btflod/offline/btf/image_io.hpp"
#include "btflod/offline/btf/ubo2003_folder.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace btflod;
  if (size == 0) return 0;
  const uint8_t mode = data[0];
  ++data;
  --size;
  if ((mode & 1) == 0) {
    if (size > 4096) return 0;
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    auto keys = parse_ubo_angle_keys(text);
    if (keys) {
      for (int k = 0; k < 4; ++k) {
        if (!keys->present[k]) continue;
        const float d = keys->degrees[k];
        const bool theta = k == UboAngleKeys::tl || k == UboAngleKeys::tv;
        if (!(theta ? (d >= 0.0f && d <= 90.0f) : (d >= -360.0f && d <= 360.0f))) __builtin_trap();
      }
    } else if (keys.message().empty()) {
      __builtin_trap();
    }
    auto path = parse_ubo_image_path(std::filesystem::path(std::string(text)));
    if (path && !path->complete()) __builtin_trap();
    return 0;
  }
  ImageLimits limits;
  limits.max_width = 512;
  limits.max_height = 512;
  limits.max_pixels = 1u << 16;
  auto img = decode_image_linear(std::span<const uint8_t>(data, size), limits);
  if (img && (img->width() > 512 || img->height() > 512 || img->channels() != 3)) __builtin_trap();
  return 0;
}
