// btflod — images: an owning Image<T> and a non-owning strided ImageView<T>.
//
// Row-major, origin at the top-left texel (row 0 is the top row), channels interleaved.
// Strides are in elements of T, so a view can select a rectangle of a larger image or a
// subset of its channels.
#pragma once

#include <cassert>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>
#include <vector>

namespace btflod {

/// A non-owning view of a 2D image with any channel count. Cheap to copy.
/// at(x, y, c) = data[y * row_stride + x * pixel_stride + c].
template <class T>
class ImageView {
 public:
  ImageView() = default;
  /// Dense view: pixel_stride = channels, row_stride = width * channels.
  ImageView(T* data, int width, int height, int channels) noexcept
      : ImageView(data, width, height, channels, channels, static_cast<ptrdiff_t>(width) * channels) {}
  ImageView(T* data, int width, int height, int channels, ptrdiff_t pixel_stride, ptrdiff_t row_stride) noexcept
      : data_(data),
        width_(width),
        height_(height),
        channels_(channels),
        pixel_stride_(pixel_stride),
        row_stride_(row_stride) {}

  /// A view of const elements onto the same pixels.
  operator ImageView<const T>() const noexcept {  // NOLINT: implicit by design
    return ImageView<const T>(data_, width_, height_, channels_, pixel_stride_, row_stride_);
  }

  int width() const noexcept { return width_; }
  int height() const noexcept { return height_; }
  int channels() const noexcept { return channels_; }
  ptrdiff_t pixel_stride() const noexcept { return pixel_stride_; }
  ptrdiff_t row_stride() const noexcept { return row_stride_; }
  T* data() const noexcept { return data_; }
  bool empty() const noexcept { return data_ == nullptr || width_ <= 0 || height_ <= 0; }
  /// True when pixels and rows are packed without gaps.
  bool is_dense() const noexcept {
    return pixel_stride_ == channels_ && row_stride_ == static_cast<ptrdiff_t>(width_) * channels_;
  }

  /// Precondition: 0 <= x < width, 0 <= y < height, 0 <= c < channels (asserted in debug).
  T& at(int x, int y, int c = 0) const noexcept {
    assert(x >= 0 && x < width_ && y >= 0 && y < height_ && c >= 0 && c < channels_);
    return data_[y * row_stride_ + x * pixel_stride_ + c];
  }
  T* pixel(int x, int y) const noexcept { return data_ + y * row_stride_ + x * pixel_stride_; }

  /// A rectangle of this view. Precondition: the rectangle lies inside the view.
  ImageView subview(int x0, int y0, int w, int h) const noexcept {
    assert(x0 >= 0 && y0 >= 0 && x0 + w <= width_ && y0 + h <= height_);
    return ImageView(pixel(x0, y0), w, h, channels_, pixel_stride_, row_stride_);
  }
  /// Channels [first, first + count) of this view. Precondition: inside the channel range.
  ImageView channel_range(int first, int count) const noexcept {
    assert(first >= 0 && count > 0 && first + count <= channels_);
    return ImageView(data_ + first, width_, height_, count, pixel_stride_, row_stride_);
  }

 private:
  T* data_ = nullptr;
  int width_ = 0;
  int height_ = 0;
  int channels_ = 0;
  ptrdiff_t pixel_stride_ = 0;
  ptrdiff_t row_stride_ = 0;
};

/// An owning, dense image. Allocates on construction and resize only.
template <class T>
class Image {
 public:
  Image() = default;
  Image(int width, int height, int channels, T fill = T{})
      : width_(width),
        height_(height),
        channels_(channels),
        pixels_(static_cast<size_t>(width) * static_cast<size_t>(height) * static_cast<size_t>(channels), fill) {
    assert(width >= 0 && height >= 0 && channels >= 0);
  }

  int width() const noexcept { return width_; }
  int height() const noexcept { return height_; }
  int channels() const noexcept { return channels_; }
  size_t size() const noexcept { return pixels_.size(); }
  bool empty() const noexcept { return pixels_.empty(); }
  T* data() noexcept { return pixels_.data(); }
  const T* data() const noexcept { return pixels_.data(); }
  std::span<T> elements() noexcept { return pixels_; }
  std::span<const T> elements() const noexcept { return pixels_; }

  T& at(int x, int y, int c = 0) noexcept { return view().at(x, y, c); }
  const T& at(int x, int y, int c = 0) const noexcept { return view().at(x, y, c); }

  ImageView<T> view() noexcept { return ImageView<T>(pixels_.data(), width_, height_, channels_); }
  ImageView<const T> view() const noexcept { return ImageView<const T>(pixels_.data(), width_, height_, channels_); }
  operator ImageView<T>() noexcept { return view(); }              // NOLINT
  operator ImageView<const T>() const noexcept { return view(); }  // NOLINT

  void resize(int width, int height, int channels, T fill = T{}) {
    width_ = width;
    height_ = height;
    channels_ = channels;
    pixels_.assign(static_cast<size_t>(width) * static_cast<size_t>(height) * static_cast<size_t>(channels), fill);
  }

  /// Copies a view of any layout into a new dense image.
  static Image copy_of(ImageView<const T> src) {
    Image out(src.width(), src.height(), src.channels());
    for (int y = 0; y < src.height(); ++y)
      for (int x = 0; x < src.width(); ++x)
        for (int c = 0; c < src.channels(); ++c) out.at(x, y, c) = src.at(x, y, c);
    return out;
  }

 private:
  int width_ = 0;
  int height_ = 0;
  int channels_ = 0;
  std::vector<T> pixels_;
};

/// Copies src into dst element by element, converting with static_cast.
/// Precondition: equal width, height and channel count. Returns false (and copies nothing)
/// when the shapes differ.
template <class Dst, class Src>
bool copy_image(ImageView<const Src> src, ImageView<Dst> dst) noexcept {
  if (src.width() != dst.width() || src.height() != dst.height() || src.channels() != dst.channels()) return false;
  for (int y = 0; y < src.height(); ++y)
    for (int x = 0; x < src.width(); ++x)
      for (int c = 0; c < src.channels(); ++c) dst.at(x, y, c) = static_cast<Dst>(src.at(x, y, c));
  return true;
}

}  // namespace btflod
