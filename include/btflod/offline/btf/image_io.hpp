// btflod — image files: PNG/JPEG (and the other formats stb_image reads) in and out.
//
// Decoding goes through stb_image (Debian's libstb, linked by the btflod target; this header
// includes <stb_image.h> / <stb_image_write.h> WITHOUT the *_IMPLEMENTATION macros). Every
// decode first asks stbi_info_from_memory for the declared size and rejects images larger than
// ImageLimits before a single pixel buffer is allocated, so a 40-byte PNG that declares
// 100000×100000 pixels (a decompression bomb) costs nothing.
//
// 8-bit files are sRGB-encoded; load_image_linear() returns linear float RGB (DESIGN.md: colour
// is linear RGB in float unless a function says otherwise) and write_png_srgb() goes back.
//
// Threading: all functions are reentrant. stb_image keeps its failure reason in thread-local
// storage (STBI_THREAD_LOCAL in stb_image 2.27) and this header never touches stb's global
// flags (vertical flip, unpremultiply), so concurrent decodes on different threads are safe.
#pragma once

#include <climits>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include <stb_image.h>
#include <stb_image_write.h>

#include "btflod/core/color.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/image.hpp"
#include "btflod/core/result.hpp"

namespace btflod {

/// Largest width or height accepted by default (a decompression-bomb guard).
inline constexpr int kMaxImageDimension = 16384;

/// Limits checked against the header of an image before decoding it.
struct ImageLimits {
  int max_width = kMaxImageDimension;
  int max_height = kMaxImageDimension;
  /// Largest width·height; the decoded buffer is at most this times the channel count bytes.
  uint64_t max_pixels = uint64_t{kMaxImageDimension} * uint64_t{kMaxImageDimension};
  /// Largest encoded file read by the path-based loaders.
  uint64_t max_file_bytes = uint64_t{1} << 31;
};

/// Size and channel count an image file declares in its header.
struct ImageInfo {
  int width = 0;
  int height = 0;
  int channels = 0;  ///< channels stored in the file (1 grey, 2 grey+alpha, 3 RGB, 4 RGBA)
};

namespace detail {

inline const char* stbi_reason() noexcept {
  const char* r = stbi_failure_reason();
  return r ? r : "unknown reason";
}

/// stb's write callback: appends to a std::vector<uint8_t>.
inline void append_to_vector(void* context, void* data, int size) {
  auto* out = static_cast<std::vector<uint8_t>*>(context);
  const auto* p = static_cast<const uint8_t*>(data);
  if (size > 0) out->insert(out->end(), p, p + size);
}

/// A dense copy of an 8-bit view when it is not dense already (stb needs packed pixels).
inline ImageView<const uint8_t> dense_or_copy(ImageView<const uint8_t> view, Image<uint8_t>& storage) {
  if (view.is_dense()) return view;
  storage = Image<uint8_t>::copy_of(view);
  return storage.view();
}

inline VoidResult check_encodable(ImageView<const uint8_t> view, const char* what) {
  if (view.empty() || view.data() == nullptr)
    return make_error(Status::invalid_argument, "%s: empty image (%dx%d)", what, view.width(), view.height());
  if (view.channels() < 1 || view.channels() > 4)
    return make_error(Status::invalid_argument, "%s: %d channels, expected 1 to 4", what, view.channels());
  if (view.width() > kMaxImageDimension * 4 || view.height() > kMaxImageDimension * 4)
    return make_error(Status::invalid_argument, "%s: %dx%d is too large to encode", what, view.width(), view.height());
  return {};
}

}  // namespace detail

/// Reads the size and channel count from the header of an encoded image without decoding it.
/// Returns bad_data (with stb's reason) when the format is not recognised, insufficient_space
/// when the declared size exceeds `limits`. Safe on untrusted input. Thread-safe.
inline Result<ImageInfo> probe_image(std::span<const uint8_t> bytes, const ImageLimits& limits = {}) {
  if (bytes.empty()) return make_error(Status::short_output, "image: 0 bytes, expected an encoded PNG/JPEG");
  if (bytes.size() > static_cast<size_t>(INT_MAX))
    return make_error(Status::insufficient_space, "image: %zu encoded bytes, limit is %d", bytes.size(), INT_MAX);
  ImageInfo info;
  if (!stbi_info_from_memory(bytes.data(), static_cast<int>(bytes.size()), &info.width, &info.height, &info.channels))
    return make_error(Status::bad_data, "image: not a decodable image (%zu bytes): %s", bytes.size(),
                      detail::stbi_reason());
  if (info.width <= 0 || info.height <= 0)
    return make_error(Status::bad_data, "image: declared size %dx%d is empty", info.width, info.height);
  const uint64_t pixels = static_cast<uint64_t>(info.width) * static_cast<uint64_t>(info.height);
  if (info.width > limits.max_width || info.height > limits.max_height || pixels > limits.max_pixels)
    return make_error(Status::insufficient_space,
                      "image: declared size %dx%d exceeds the limit %dx%d (%llu pixels); refusing to decode",
                      info.width, info.height, limits.max_width, limits.max_height,
                      static_cast<unsigned long long>(limits.max_pixels));
  return info;
}

/// Decodes an encoded image (PNG, JPEG, and whatever else stb_image reads) into 8-bit samples.
/// desired_channels: 0 keeps the file's channel count, 1..4 converts (grey↔RGB, adds opaque
/// alpha or drops it). 16-bit PNGs are reduced to 8 bits. Returns the errors of probe_image()
/// plus bad_data when the pixel data is corrupt. Safe on untrusted input: the declared size is
/// checked against `limits` before decoding. Thread-safe.
inline Result<Image<uint8_t>> decode_image(std::span<const uint8_t> bytes, int desired_channels = 0,
                                           const ImageLimits& limits = {}) {
  if (desired_channels < 0 || desired_channels > 4)
    return make_error(Status::invalid_argument, "image: desired_channels %d, expected 0 to 4", desired_channels);
  auto info = probe_image(bytes, limits);
  if (!info) return info.error();
  int w = 0, h = 0, n = 0;
  stbi_uc* pixels = stbi_load_from_memory(bytes.data(), static_cast<int>(bytes.size()), &w, &h, &n, desired_channels);
  if (!pixels)
    return make_error(Status::bad_data, "image: decoding %dx%d failed: %s", info->width, info->height,
                      detail::stbi_reason());
  const int channels = desired_channels ? desired_channels : n;
  if (w != info->width || h != info->height || channels < 1 || channels > 4) {
    stbi_image_free(pixels);
    return make_error(Status::bad_data, "image: decoder returned %dx%dx%d, header said %dx%d", w, h, channels,
                      info->width, info->height);
  }
  Image<uint8_t> out(w, h, channels);
  std::memcpy(out.data(), pixels, out.size());
  stbi_image_free(pixels);
  return out;
}

/// Reads and decodes an image file; see decode_image(). io_error names the path. Error
/// messages are prefixed with the path. Safe on untrusted files. Thread-safe.
inline Result<Image<uint8_t>> load_image(const std::string& path, int desired_channels = 0,
                                         const ImageLimits& limits = {}) {
  auto bytes = read_file_bytes(path, limits.max_file_bytes);
  if (!bytes) return bytes.error();
  auto image = decode_image(*bytes, desired_channels, limits);
  if (!image) return Error{image.status(), path + ": " + image.message()};
  return image;
}

namespace detail {
/// An image of the same size and channel count as `src` whose every sample is
/// f(source sample, is_alpha); is_alpha is true for the last channel of a 2- or 4-channel image.
template <class Out, class In, class F>
Image<Out> map_colour_samples(ImageView<const In> src, F&& f) {
  Image<Out> out(src.width(), src.height(), src.channels());
  const bool has_alpha = src.channels() == 2 || src.channels() == 4;
  for (int y = 0; y < src.height(); ++y)
    for (int x = 0; x < src.width(); ++x)
      for (int c = 0; c < src.channels(); ++c)
        out.at(x, y, c) = f(src.at(x, y, c), has_alpha && c == src.channels() - 1);
  return out;
}
}  // namespace detail

/// Converts 8-bit sRGB-encoded samples to linear float with the exact 256-entry table
/// (core/color.hpp). Channel 3 (alpha) of an RGBA image is not sRGB-encoded and is only scaled
/// to [0,1]. Never fails. Thread-safe.
inline Image<float> srgb8_to_linear_image(ImageView<const uint8_t> src) {
  const float* table = srgb8_to_linear_table();
  return detail::map_colour_samples<float>(
      src, [table](uint8_t v, bool alpha) { return alpha ? static_cast<float>(v) / 255.0f : table[v]; });
}

/// Converts linear float samples to 8-bit sRGB: clamps to [0,1], NaN → 0, rounds to nearest.
/// The last channel of a 2- or 4-channel image is treated as alpha (linear, clamped, not
/// gamma-encoded). Never fails. Thread-safe.
inline Image<uint8_t> linear_to_srgb8_image(ImageView<const float> src) {
  return detail::map_colour_samples<uint8_t>(src, [](float v, bool alpha) {
    if (!alpha) return linear_to_srgb8(v);
    const float a = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f;  // NaN fails v > 0 → 0
    return static_cast<uint8_t>(a * 255.0f + 0.5f);
  });
}

/// Decodes an 8-bit sRGB image from memory into linear float RGB (3 channels; grey is
/// replicated, alpha dropped). Errors as decode_image(). Safe on untrusted input. Thread-safe.
inline Result<Image<float>> decode_image_linear(std::span<const uint8_t> bytes, const ImageLimits& limits = {}) {
  auto image = decode_image(bytes, 3, limits);
  if (!image) return image.error();
  return srgb8_to_linear_image(image->view());
}

/// Loads an 8-bit sRGB image file as linear float RGB (3 channels). Errors are prefixed with the
/// path. Safe on untrusted files. Thread-safe.
inline Result<Image<float>> load_image_linear(const std::string& path, const ImageLimits& limits = {}) {
  auto image = load_image(path, 3, limits);
  if (!image) return image.error();
  return srgb8_to_linear_image(image->view());
}

/// Encodes an 8-bit image (1–4 channels, any strides) as PNG into memory. Returns
/// invalid_argument for an empty image or a bad channel count. Thread-safe (stb's PNG
/// compression level is a global that this function reads but never writes).
inline Result<std::vector<uint8_t>> encode_png(ImageView<const uint8_t> image) {
  if (auto ok = detail::check_encodable(image, "encode_png"); !ok) return ok.error();
  Image<uint8_t> storage;
  const auto dense = detail::dense_or_copy(image, storage);
  std::vector<uint8_t> out;
  if (!stbi_write_png_to_func(&detail::append_to_vector, &out, dense.width(), dense.height(), dense.channels(),
                              dense.data(), static_cast<int>(dense.row_stride())) ||
      out.empty())
    return make_error(Status::io_error, "encode_png: stb_image_write failed for %dx%dx%d", dense.width(),
                      dense.height(), dense.channels());
  return out;
}

/// Encodes an 8-bit image (1–4 channels; alpha is ignored by JPEG) as baseline JPEG, quality
/// 1..100. Returns invalid_argument for bad arguments. Thread-safe.
inline Result<std::vector<uint8_t>> encode_jpeg(ImageView<const uint8_t> image, int quality = 95) {
  if (auto ok = detail::check_encodable(image, "encode_jpeg"); !ok) return ok.error();
  if (quality < 1 || quality > 100)
    return make_error(Status::invalid_argument, "encode_jpeg: quality %d, expected 1 to 100", quality);
  Image<uint8_t> storage;
  const auto dense = detail::dense_or_copy(image, storage);
  std::vector<uint8_t> out;
  if (!stbi_write_jpg_to_func(&detail::append_to_vector, &out, dense.width(), dense.height(), dense.channels(),
                              dense.data(), quality) ||
      out.empty())
    return make_error(Status::io_error, "encode_jpeg: stb_image_write failed for %dx%dx%d", dense.width(),
                      dense.height(), dense.channels());
  return out;
}

/// Writes an 8-bit image as a PNG file (replaced atomically through `path.tmp`, see
/// write_file_bytes). Returns invalid_argument or io_error with the path. Thread-safe for
/// distinct paths.
inline VoidResult write_png(const std::string& path, ImageView<const uint8_t> image) {
  auto bytes = encode_png(image);
  if (!bytes) return Error{bytes.status(), path + ": " + bytes.message()};
  return write_file_bytes(path, *bytes);
}

/// Writes an 8-bit image as a JPEG file (quality 1..100). Errors as write_png().
inline VoidResult write_jpeg(const std::string& path, ImageView<const uint8_t> image, int quality = 95) {
  auto bytes = encode_jpeg(image, quality);
  if (!bytes) return Error{bytes.status(), path + ": " + bytes.message()};
  return write_file_bytes(path, *bytes);
}

/// Writes a linear float image (1–4 channels) as an 8-bit sRGB PNG: values are clamped to
/// [0,1], NaN becomes 0, alpha (last channel of 2/4) is stored linearly. Errors as write_png().
inline VoidResult write_png_srgb(const std::string& path, ImageView<const float> image) {
  if (image.empty())
    return make_error(Status::invalid_argument, "%s: empty image (%dx%d)", path.c_str(), image.width(), image.height());
  if (image.channels() < 1 || image.channels() > 4)
    return make_error(Status::invalid_argument, "%s: %d channels, expected 1 to 4", path.c_str(), image.channels());
  const Image<uint8_t> encoded = linear_to_srgb8_image(image);
  return write_png(path, encoded.view());
}

}  // namespace btflod
