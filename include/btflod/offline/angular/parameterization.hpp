// btflod — hemisphere parameterisations: maps between directions (local frame, z = normal)
// and the unit square [0, 1]², the plane in which angular tables are triangulated, rasterised
// and resampled.
//
// Every map is a struct with two static noexcept functions (the HemisphereParameterization
// concept): to_square(direction) and from_square(st). The formulas use only +, −, ×, ÷,
// sqrt, abs, atan2, cos and sin and are written line by line so that the shader generator can
// emit the same arithmetic in GLSL (see docs/angular.md, "GLSL mirror"). The double-precision
// forms (to_square_precise) are runtime/angular/hemisphere_maps.hpp's, which builds a streamed
// material's angular tables without GLM.
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>

#include <glm/glm.hpp>

#include "btflod/core/vec.hpp"
#include "btflod/offline/math/math.hpp"
#include "btflod/runtime/angular/hemisphere_maps.hpp"

namespace btflod {

/// A map between the upper hemisphere and the unit square [0, 1]².
/// - to_square(d): d is any vector; it is normalised and clamped onto the hemisphere first
///   (clamp_to_hemisphere), so every input gives a point of [0, 1]².
/// - from_square(st): st is clamped to [0, 1]²; returns a unit vector with z ≥ 0. Points of the
///   square outside the image of the hemisphere (parabolic/orthographic corners) are pulled
///   radially onto the horizon.
template <class P>
concept HemisphereParameterization = requires(glm::vec3 d, glm::vec2 st) {
  { P::to_square(d) }
  noexcept->std::same_as<glm::vec2>;
  { P::from_square(st) }
  noexcept->std::same_as<glm::vec3>;
  { P::kName } -> std::convertible_to<const char*>;
};

/// Normalises d and moves it onto the closed upper hemisphere: z < 0 is set to 0 (the
/// direction is projected onto the horizon along z). Returns (0, 0, 1) for zero, NaN or
/// straight-down inputs. Safe for any input; noexcept.
inline glm::vec3 clamp_to_hemisphere(glm::vec3 d) noexcept { return detail::clamp_to_hemisphere_in(Vector3f(d)); }

namespace detail {
/// Double-precision clamp_to_hemisphere (same rules).
inline glm::dvec3 clamp_to_hemisphere_precise(glm::dvec3 d) noexcept { return clamp_to_hemisphere_in(Vector3d(d)); }
/// Pulls a disk point with |p| > 1 back onto the unit circle.
inline glm::vec2 clamp_unit_disk(glm::vec2 p) noexcept {
  const float r2 = p.x * p.x + p.y * p.y;
  if (r2 <= 1.0f) return p;
  return p / std::sqrt(r2);
}
}  // namespace detail

/// Parabolic map (paper 000 §4, after [ND06]): p = (x, y) / (1 + z), a point of the unit
/// disk; the square coordinate is st = (p + 1) / 2. Inverse: r² = |p|²,
/// (x, y, z) = (2p, 1 − r²) / (1 + r²).
struct ParabolicMap {
  static constexpr const char* kName = "parabolic";

  /// Direction → [0, 1]². noexcept, thread-safe, any input (clamped to the hemisphere).
  static glm::vec2 to_square(glm::vec3 d) noexcept {
    d = clamp_to_hemisphere(d);
    const float inv = 1.0f / (1.0f + d.z);  // 1 + z ≥ 1 on the hemisphere
    return {0.5f * (d.x * inv + 1.0f), 0.5f * (d.y * inv + 1.0f)};
  }

  /// to_square() in double precision (the triangulation's inputs). noexcept, thread-safe.
  static glm::dvec2 to_square_precise(glm::dvec3 d) noexcept { return parabolic_to_square_precise(d); }

  /// [0, 1]² → unit direction with z ≥ 0 (corners outside the disk map onto the horizon).
  static glm::vec3 from_square(glm::vec2 st) noexcept {
    st = detail::clamp_unit_square(st);
    const glm::vec2 p = detail::clamp_unit_disk(2.0f * st - 1.0f);
    const float r2 = p.x * p.x + p.y * p.y;
    const float inv = 1.0f / (1.0f + r2);
    return {2.0f * p.x * inv, 2.0f * p.y * inv, (1.0f - r2) * inv};
  }
};

/// Elevated concentric map (paper 002 §6.1): Shirley–Chiu concentric square → disk map Φ
/// followed by the elevation Ψ(ρ, φ) = (ρ√(2 − ρ²) cos φ, ρ√(2 − ρ²) sin φ, 1 − ρ²). It is
/// area-preserving: uniform points on the square become uniform points on the hemisphere.
/// Inverse: the disk point is (x, y) / √(1 + z) (since ρ² = 1 − z and x² + y² = 1 − z²),
/// then the inverse concentric map.
struct ElevatedConcentricMap {
  static constexpr const char* kName = "concentric";

  /// Unit disk → [−1, 1]² (inverse Shirley–Chiu map).
  static glm::vec2 disk_to_centered_square(glm::vec2 p) noexcept {
    const float r = std::sqrt(p.x * p.x + p.y * p.y);
    if (!(r > 0.0f)) return {0.0f, 0.0f};
    constexpr float kQuarter = 0.25f * kPi;
    float phi = std::atan2(p.y, p.x);                                     // (−π, π]
    if (phi < -kQuarter) phi += kTwoPi;                                   // [−π/4, 7π/4)
    const float k = r / kQuarter;                                         // (4/π)·r
    if (phi < kQuarter) return {r, phi * k};                              // region 1: a = ρ, φ = (π/4)·b/a
    if (phi < 3.0f * kQuarter) return {(2.0f * kQuarter - phi) * k, r};   // region 2: b = ρ, φ = π/2 − (π/4)·a/b
    if (phi < 5.0f * kQuarter) return {-r, (4.0f * kQuarter - phi) * k};  // region 3: a = −ρ
    return {(phi - 6.0f * kQuarter) * k, -r};                             // region 4: b = −ρ
  }

  /// disk_to_centered_square() in double precision (concentric_disk_to_centered_square_precise).
  static glm::dvec2 disk_to_centered_square_precise(glm::dvec2 p) noexcept {
    return concentric_disk_to_centered_square_precise(p);
  }

  /// [−1, 1]² → unit disk (Shirley–Chiu map, paper 002 §6.1 "first region" and its analogues).
  static glm::vec2 centered_square_to_disk(glm::vec2 ab) noexcept {
    const float a = ab.x;
    const float b = ab.y;
    if (a == 0.0f && b == 0.0f) return {0.0f, 0.0f};
    constexpr float kQuarter = 0.25f * kPi;
    float r;
    float phi;
    if (std::abs(a) > std::abs(b)) {
      r = a;
      phi = kQuarter * (b / a);
    } else {
      r = b;
      phi = 2.0f * kQuarter - kQuarter * (a / b);
    }
    return {r * std::cos(phi), r * std::sin(phi)};
  }

  /// Direction → [0, 1]². noexcept, thread-safe, any input (clamped to the hemisphere).
  static glm::vec2 to_square(glm::vec3 d) noexcept {
    d = clamp_to_hemisphere(d);
    const float inv = 1.0f / std::sqrt(1.0f + d.z);
    const glm::vec2 ab = disk_to_centered_square({d.x * inv, d.y * inv});
    return {glm::clamp(0.5f * (ab.x + 1.0f), 0.0f, 1.0f), glm::clamp(0.5f * (ab.y + 1.0f), 0.0f, 1.0f)};
  }

  /// to_square() in double precision (the triangulation's inputs). noexcept, thread-safe.
  static glm::dvec2 to_square_precise(glm::dvec3 d) noexcept { return elevated_concentric_to_square_precise(d); }

  /// [0, 1]² → unit direction with z ≥ 0. The whole square maps onto the hemisphere.
  static glm::vec3 from_square(glm::vec2 st) noexcept {
    st = detail::clamp_unit_square(st);
    const glm::vec2 p = centered_square_to_disk(2.0f * st - 1.0f);
    const float r2 = glm::min(p.x * p.x + p.y * p.y, 1.0f);
    const float s = std::sqrt(2.0f - r2);  // Ψ: x = ρ√(2 − ρ²) cos φ
    return {p.x * s, p.y * s, 1.0f - r2};
  }
};

/// Orthographic projection onto the tangent plane (paper 003 §4.2: "projected onto the XY
/// plane by ignoring the Z component"): st = ((x, y) + 1) / 2, inverse z = √(1 − x² − y²).
/// Precision drops near the horizon (dz/dr → ∞); prefer the other two maps there.
struct OrthographicMap {
  static constexpr const char* kName = "orthographic";

  /// Direction → [0, 1]². noexcept, thread-safe, any input (clamped to the hemisphere).
  static glm::vec2 to_square(glm::vec3 d) noexcept {
    d = clamp_to_hemisphere(d);
    return {0.5f * (d.x + 1.0f), 0.5f * (d.y + 1.0f)};
  }

  /// to_square() in double precision (the triangulation's inputs). noexcept, thread-safe.
  static glm::dvec2 to_square_precise(glm::dvec3 d) noexcept {
    d = detail::clamp_to_hemisphere_precise(d);
    return {0.5 * (d.x + 1.0), 0.5 * (d.y + 1.0)};
  }

  /// [0, 1]² → unit direction with z ≥ 0 (corners outside the disk map onto the horizon).
  static glm::vec3 from_square(glm::vec2 st) noexcept {
    st = detail::clamp_unit_square(st);
    const glm::vec2 p = detail::clamp_unit_disk(2.0f * st - 1.0f);
    const float z = std::sqrt(glm::max(0.0f, 1.0f - p.x * p.x - p.y * p.y));
    return {p.x, p.y, z};
  }
};

/// A parameterisation that also offers to_square_precise(glm::dvec3) → glm::dvec2 (all of
/// btflod's do); triangulate_directions() uses it when present.
template <class P>
concept PreciseHemisphereParameterization = HemisphereParameterization<P> && requires(glm::dvec3 d) {
  { P::to_square_precise(d) }
  noexcept->std::same_as<glm::dvec2>;
};

/// The square point of a direction in double precision: P::to_square_precise when P has it,
/// else P::to_square promoted to double. noexcept, thread-safe.
template <HemisphereParameterization P>
glm::dvec2 to_square_precise(glm::dvec3 d) noexcept {
  if constexpr (PreciseHemisphereParameterization<P>) {
    return P::to_square_precise(d);
  } else {
    return glm::dvec2(P::to_square(glm::vec3(d)));
  }
}

static_assert(HemisphereParameterization<ParabolicMap>);
static_assert(HemisphereParameterization<ElevatedConcentricMap>);
static_assert(HemisphereParameterization<OrthographicMap>);
static_assert(PreciseHemisphereParameterization<ParabolicMap>);
static_assert(PreciseHemisphereParameterization<ElevatedConcentricMap>);
static_assert(PreciseHemisphereParameterization<OrthographicMap>);

}  // namespace btflod
