// btflod — small math helpers on top of GLM: angles and directions in the local frame
// (z = surface normal; θ measured from +z; φ = atan2(y, x); DESIGN.md).
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

#include <glm/glm.hpp>

#include "btflod/core/vec.hpp"

namespace btflod {

inline constexpr float kPi = std::numbers::pi_v<float>;
inline constexpr float kTwoPi = 2.0f * std::numbers::pi_v<float>;

/// splitmix64 finaliser: a bijective 64-bit mix with full avalanche (the hash behind the
/// deterministic random numbers of the synthetic materials and the renderer). noexcept.
constexpr uint64_t mix_bits64(uint64_t z) noexcept {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

constexpr float degrees_to_radians(float deg) noexcept { return deg * (kPi / 180.0f); }
constexpr float radians_to_degrees(float rad) noexcept { return rad * (180.0f / kPi); }

/// Unit vector for polar angle theta (from +z) and azimuth phi, both in radians.
inline glm::vec3 direction_from_spherical(float theta, float phi) noexcept {
  return unit_vector_from_spherical(theta, phi);
}

/// (theta, phi) in radians of a direction; phi in (−π, π]. The input need not be normalised;
/// a zero vector gives (0, 0).
inline glm::vec2 spherical_from_direction(glm::vec3 d) noexcept {
  const float len = glm::length(d);
  if (!(len > 0.0f)) return {0.0f, 0.0f};
  const float z = glm::clamp(d.z / len, -1.0f, 1.0f);
  return {std::acos(z), std::atan2(d.y, d.x)};
}

/// Wraps an angle in degrees to [−180, 180).
inline float wrap_degrees_signed(float deg) noexcept {
  float r = std::fmod(deg + 180.0f, 360.0f);
  if (r < 0.0f) r += 360.0f;
  return r - 180.0f;
}

}  // namespace btflod
