// btflod — the tabulated BTF container.
//
// A BTF ρ(x, ωl, ωv) sampled at W×H texels, n_view view directions and n_light light
// directions, 3 linear-RGB channels, stored as float or Half.
//
// Layout (documented, relied on by readers, factorisations and tests):
//   index(x, y, v, l, c) = ((((v · n_light + l) · H + y) · W + x) · 3 + c
// so one (view, light) image is a contiguous, dense W×H RGB image with the top-left origin,
// and one texel's ABRDF is strided by W·H·3.
#pragma once

#include <algorithm>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>

#include "btflod/core/half.hpp"
#include "btflod/core/image.hpp"
#include "btflod/core/result.hpp"
#include "btflod/offline/angular/directions.hpp"

namespace btflod {

/// What a BTF sample holds. Bonn's measured BTFs store the apparent BRDF times the cosine of
/// the light's polar angle (ρ·cosθ_l: the reflected radiance under unit irradiance along the
/// normal); btflod follows that convention by default. A Bonn .btf file says which one it
/// holds in its cosine flag (1 = ρ·cosθ_l, offline/btf/bonn_btf.hpp).
enum class BtfValueConvention : unsigned char {
  abrdf_cos_light = 0,  ///< ρ · cosθ_l (default, what Bonn BTFs hold)
  brdf = 1,             ///< ρ alone
};

/// Converts a stored sample to float (identity for float).
constexpr float to_float(float v) noexcept { return v; }
constexpr float to_float(Half v) noexcept { return v.to_float(); }

/// A non-owning view of one texel's ABRDF: n_view × n_light × 3 values.
template <class T>
class AbrdfView {
 public:
  AbrdfView(T* base, size_t n_view, size_t n_light, ptrdiff_t image_stride) noexcept
      : base_(base), n_view_(n_view), n_light_(n_light), image_stride_(image_stride) {}
  size_t view_count() const noexcept { return n_view_; }
  size_t light_count() const noexcept { return n_light_; }
  /// Precondition: v < view_count(), l < light_count(), c < 3.
  T& at(size_t v, size_t l, int c) const noexcept {
    assert(v < n_view_ && l < n_light_ && c >= 0 && c < 3);
    return base_[static_cast<ptrdiff_t>(v * n_light_ + l) * image_stride_ + c];
  }

 private:
  T* base_;
  size_t n_view_;
  size_t n_light_;
  ptrdiff_t image_stride_;
};

template <class T>
class TabulatedBtf {
  static_assert(std::is_same_v<T, float> || std::is_same_v<T, Half>, "BTF samples are float or Half");

 public:
  using value_type = T;
  static constexpr int kChannels = 3;

  TabulatedBtf() = default;
  /// Allocates a zero-filled BTF. Precondition: width, height > 0; direction sets non-empty.
  TabulatedBtf(int width, int height, DirectionSet views, DirectionSet lights)
      : width_(width),
        height_(height),
        views_(std::move(views)),
        lights_(std::move(lights)),
        data_(sample_count(width, height, views_.size(), lights_.size())) {}

  /// Number of stored values for the given shape (no overflow check: see checked_sample_count).
  static size_t sample_count(int width, int height, size_t n_view, size_t n_light) noexcept {
    return static_cast<size_t>(width) * static_cast<size_t>(height) * n_view * n_light * kChannels;
  }
  /// Sample count with overflow and limit checks, for readers sizing from untrusted headers.
  /// Returns an error naming the shape when it is empty, overflows or exceeds max_samples.
  static Result<size_t> checked_sample_count(uint64_t width, uint64_t height, uint64_t n_view, uint64_t n_light,
                                             uint64_t max_samples = uint64_t{1} << 33) {
    if (width == 0 || height == 0 || n_view == 0 || n_light == 0)
      return make_error(Status::bad_data, "BTF shape %llux%llu texels, %llu views, %llu lights is empty",
                        (unsigned long long)width, (unsigned long long)height, (unsigned long long)n_view,
                        (unsigned long long)n_light);
    uint64_t n = 0;
    const bool overflow = __builtin_mul_overflow(width, height, &n) || __builtin_mul_overflow(n, n_view, &n) ||
                          __builtin_mul_overflow(n, n_light, &n) || __builtin_mul_overflow(n, uint64_t{kChannels}, &n);
    if (overflow || n > max_samples)
      return make_error(Status::insufficient_space,
                        "BTF shape %llux%llu texels, %llu views, %llu lights exceeds the limit of %llu samples",
                        (unsigned long long)width, (unsigned long long)height, (unsigned long long)n_view,
                        (unsigned long long)n_light, (unsigned long long)max_samples);
    return static_cast<size_t>(n);
  }

  int width() const noexcept { return width_; }
  int height() const noexcept { return height_; }
  size_t view_count() const noexcept { return views_.size(); }
  size_t light_count() const noexcept { return lights_.size(); }
  size_t texel_count() const noexcept { return static_cast<size_t>(width_) * static_cast<size_t>(height_); }
  const DirectionSet& views() const noexcept { return views_; }
  const DirectionSet& lights() const noexcept { return lights_; }
  std::span<T> samples() noexcept { return data_; }
  std::span<const T> samples() const noexcept { return data_; }
  size_t size_bytes() const noexcept { return data_.size() * sizeof(T); }
  bool empty() const noexcept { return data_.empty(); }

  /// Flat index of a sample. Precondition: all arguments in range.
  size_t index(int x, int y, size_t v, size_t l, int c) const noexcept {
    assert(x >= 0 && x < width_ && y >= 0 && y < height_ && v < views_.size() && l < lights_.size() && c >= 0 &&
           c < kChannels);
    return (((v * lights_.size() + l) * static_cast<size_t>(height_) + static_cast<size_t>(y)) *
                static_cast<size_t>(width_) +
            static_cast<size_t>(x)) *
               kChannels +
           static_cast<size_t>(c);
  }
  T& at(int x, int y, size_t v, size_t l, int c) noexcept { return data_[index(x, y, v, l, c)]; }
  const T& at(int x, int y, size_t v, size_t l, int c) const noexcept { return data_[index(x, y, v, l, c)]; }
  /// The sample as float, whatever the storage.
  float value(int x, int y, size_t v, size_t l, int c) const noexcept { return to_float(at(x, y, v, l, c)); }

  /// The W×H RGB image for view v and light l (dense, top-left origin).
  ImageView<T> image(size_t v, size_t l) noexcept {
    return ImageView<T>(data_.data() + index(0, 0, v, l, 0), width_, height_, kChannels);
  }
  ImageView<const T> image(size_t v, size_t l) const noexcept {
    return ImageView<const T>(data_.data() + index(0, 0, v, l, 0), width_, height_, kChannels);
  }
  /// The ABRDF of texel (x, y): n_view × n_light × 3 values.
  AbrdfView<T> abrdf(int x, int y) noexcept {
    return AbrdfView<T>(data_.data() + index(x, y, 0, 0, 0), views_.size(), lights_.size(), image_stride());
  }
  AbrdfView<const T> abrdf(int x, int y) const noexcept {
    return AbrdfView<const T>(data_.data() + index(x, y, 0, 0, 0), views_.size(), lights_.size(), image_stride());
  }
  ptrdiff_t image_stride() const noexcept { return static_cast<ptrdiff_t>(texel_count()) * kChannels; }

  /// A copy with another storage type (float ↔ Half; Half rounds to nearest even).
  template <class U>
  TabulatedBtf<U> convert() const {
    TabulatedBtf<U> out(width_, height_, views_, lights_);
    auto dst = out.samples();
    if constexpr (std::is_same_v<T, U>) {
      std::copy(data_.begin(), data_.end(), dst.begin());
    } else if constexpr (std::is_same_v<U, Half>) {
      float_to_half(data_, std::span<uint16_t>(reinterpret_cast<uint16_t*>(dst.data()), dst.size()));
    } else {
      half_to_float(std::span<const uint16_t>(reinterpret_cast<const uint16_t*>(data_.data()), data_.size()), dst);
    }
    return out;
  }

 private:
  int width_ = 0;
  int height_ = 0;
  DirectionSet views_;
  DirectionSet lights_;
  std::vector<T> data_;
};

using BtfFloat = TabulatedBtf<float>;
using BtfHalf = TabulatedBtf<Half>;

}  // namespace btflod
