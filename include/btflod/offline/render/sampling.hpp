// btflod — Monte Carlo sampling helpers for a ray tracer shading btflod materials (paper 003
// §4.1): a counter-based per-pixel random generator (the same numbers for a pixel whatever the
// thread that renders it, so images do not depend on the thread count), cosine-distributed
// hemisphere directions (ambient occlusion, eq. 7) and uniform solid-angle sampling of a
// rectangular area light (eq. 4–5) with the area-preserving parameterisation of spherical
// rectangles (Ureña, Fajardo, King 2013).
//
// Everything here is noexcept, allocation-free and thread-safe (no shared state).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

#include <glm/glm.hpp>

#include "btflod/offline/math/math.hpp"

namespace btflod {

/// A small counter-based random generator (splitmix64 over a keyed counter). The stream is
/// fully determined by (seed, pixel, sample index, purpose), so a pixel draws the same numbers
/// whichever thread renders it and in whatever order pixels are visited.
class PixelRng {
 public:
  /// The stream of pixel (x, y) for its `sample`-th progressive sample (the accumulated frame
  /// index) and a `purpose` (distinct numbers for e.g. the area light and the AO ray, so that
  /// enabling one term does not change the other's noise). noexcept.
  static constexpr PixelRng for_pixel(uint64_t seed, uint32_t x, uint32_t y, uint32_t sample,
                                      uint32_t purpose = 0) noexcept {
    uint64_t k = mix_bits64(seed ^ 0x5851F42D4C957F2Dull);
    k = mix_bits64(k ^ (static_cast<uint64_t>(x) | static_cast<uint64_t>(y) << 32));
    k = mix_bits64(k ^ (static_cast<uint64_t>(sample) | static_cast<uint64_t>(purpose) << 32));
    return PixelRng(k);
  }
  /// A stream from a raw 64-bit state (any value).
  explicit constexpr PixelRng(uint64_t state) noexcept : state_(state) {}

  /// Next 64 random bits. noexcept.
  constexpr uint64_t next_u64() noexcept {
    state_ += 0x9E3779B97F4A7C15ull;
    uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform float in [0, 1) with 24 random bits (never returns 1). noexcept.
  constexpr float next_float() noexcept { return static_cast<float>(next_u64() >> 40) * 0x1.0p-24f; }
  /// Two uniform floats in [0, 1)². noexcept.
  glm::vec2 next_vec2() noexcept {
    const float a = next_float();
    return {a, next_float()};
  }

 private:
  uint64_t state_;
};

/// A cosine-distributed direction on the hemisphere around +z (local frame) from u ∈ [0, 1)²
/// (Malley's method: a uniform point on the disc lifted to the hemisphere); its density is
/// cos θ / π per steradian. Returns a unit vector with z ≥ 0. noexcept.
inline glm::vec3 sample_cosine_hemisphere(glm::vec2 u) noexcept {
  const float r = std::sqrt(u.x);
  const float phi = kTwoPi * u.y;
  const float z = std::sqrt(std::max(0.0f, 1.0f - u.x));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

/// Density (per steradian) of sample_cosine_hemisphere for a local direction. noexcept.
inline float cosine_hemisphere_pdf(glm::vec3 local_dir) noexcept { return std::max(local_dir.z, 0.0f) / kPi; }

/// A rectangle (corner + s·edge_u + t·edge_v, s, t ∈ [0, 1]) seen from a point as a spherical
/// rectangle: its solid angle and an area-preserving map from [0, 1)² onto it, so that points
/// drawn with sample() are uniformly distributed in solid angle as seen from the point (Ureña,
/// Fajardo, King, "An Area-Preserving Parametrization for Spherical Rectangles", EGSR 2013).
/// This is the uniform sampling of paper 003 eq. 4–5. Preconditions: edge_u ⟂ edge_v, both
/// non-zero; the point is not in the rectangle's plane (then solid_angle() is 0 and valid() is
/// false). build() and sample() are noexcept.
class SphericalRectangle {
 public:
  /// Prepares sampling of the rectangle as seen from `point`. Computed in double: the solid
  /// angle is a difference of O(1) angles, so a light far away or small would lose all its
  /// digits in float.
  static SphericalRectangle build(glm::vec3 point, glm::vec3 corner, glm::vec3 edge_u, glm::vec3 edge_v) noexcept {
    SphericalRectangle s;
    s.origin_ = point;
    const glm::dvec3 eu(edge_u), ev(edge_v);
    const double exl = glm::length(eu), eyl = glm::length(ev);
    if (!(exl > 0.0) || !(eyl > 0.0)) return s;
    s.x_ = eu / exl;
    s.y_ = ev / eyl;
    s.z_ = glm::cross(s.x_, s.y_);
    const glm::dvec3 d = glm::dvec3(corner) - glm::dvec3(point);
    s.x0_ = glm::dot(d, s.x_);
    s.y0_ = glm::dot(d, s.y_);
    s.z0_ = glm::dot(d, s.z_);
    if (s.z0_ > 0.0) {  // the local frame must look at the rectangle from its z > 0 side
      s.z0_ = -s.z0_;
      s.z_ = -s.z_;
    }
    if (!(s.z0_ < -1e-9 * std::max(exl, eyl))) return s;  // the point lies in the plane: Ω = 0
    s.x1_ = s.x0_ + exl;
    s.y1_ = s.y0_ + eyl;
    const glm::dvec3 v00(s.x0_, s.y0_, s.z0_), v01(s.x0_, s.y1_, s.z0_), v10(s.x1_, s.y0_, s.z0_),
        v11(s.x1_, s.y1_, s.z0_);
    const glm::dvec3 n0 = glm::normalize(glm::cross(v00, v10));
    const glm::dvec3 n1 = glm::normalize(glm::cross(v10, v11));
    const glm::dvec3 n2 = glm::normalize(glm::cross(v11, v01));
    const glm::dvec3 n3 = glm::normalize(glm::cross(v01, v00));
    const auto angle = [](glm::dvec3 a, glm::dvec3 b) { return std::acos(std::clamp(-glm::dot(a, b), -1.0, 1.0)); };
    const double g0 = angle(n0, n1), g1 = angle(n1, n2), g2 = angle(n2, n3), g3 = angle(n3, n0);
    s.b0_ = n0.z;
    s.b1_ = n2.z;
    s.k_ = 2.0 * std::numbers::pi - g2 - g3;
    s.solid_angle_ = std::max(0.0, g0 + g1 - s.k_);  // Girard: the four angles minus 2π
    return s;
  }

  /// Solid angle Ω of the rectangle seen from the point, steradians (0 when invalid).
  float solid_angle() const noexcept { return static_cast<float>(solid_angle_); }
  /// False when the rectangle is degenerate or the point lies in its plane.
  bool valid() const noexcept { return solid_angle_ > 0.0; }

  /// The point of the rectangle hit by a direction drawn uniformly in solid angle from
  /// u ∈ [0, 1)². Precondition: valid().
  glm::vec3 sample(glm::vec2 u) const noexcept {
    const double au = static_cast<double>(u.x) * solid_angle_ + k_;
    const double fu = (std::cos(au) * b0_ - b1_) / std::sin(au);
    double cu = (fu > 0.0 ? 1.0 : -1.0) / std::sqrt(fu * fu + b0_ * b0_);
    cu = std::clamp(cu, -1.0, 1.0);
    double xu = -(cu * z0_) / std::sqrt(std::max(1e-300, 1.0 - cu * cu));
    xu = std::clamp(xu, x0_, x1_);
    const double d = std::sqrt(xu * xu + z0_ * z0_);
    const double h0 = y0_ / std::sqrt(d * d + y0_ * y0_);
    const double h1 = y1_ / std::sqrt(d * d + y1_ * y1_);
    const double hv = h0 + static_cast<double>(u.y) * (h1 - h0), hv2 = hv * hv;
    const double yv = hv2 < 1.0 - 1e-12 ? (hv * d) / std::sqrt(1.0 - hv2) : y1_;
    return glm::vec3(glm::dvec3(origin_) + xu * x_ + std::clamp(yv, y0_, y1_) * y_ + z0_ * z_);
  }

 private:
  glm::vec3 origin_{0.0f};
  glm::dvec3 x_{1, 0, 0}, y_{0, 1, 0}, z_{0, 0, 1};
  double x0_ = 0, y0_ = 0, z0_ = 0, x1_ = 0, y1_ = 0;
  double b0_ = 0, b1_ = 0, k_ = 0, solid_angle_ = 0;
};

}  // namespace btflod
