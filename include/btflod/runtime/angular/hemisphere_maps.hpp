// btflod — the arithmetic of the hemisphere parameterisations that angular lookup tables are
// triangulated in (parabolic, paper 000 §4; elevated concentric, paper 002 §6.1), on core
// vectors so that an engine without a math library builds a material's tables at load time.
//
// The double-precision forms here are what the triangulation sees; the offline map structs
// (offline/angular/parameterization.hpp: ParabolicMap, ElevatedConcentricMap) forward to them.
// Formulas and rounding are the maps' own: each step rounds to the vector's precision.
#pragma once

#include <algorithm>
#include <cmath>

#include "btflod/core/vec.hpp"
#include "btflod/runtime/shader/shader_config.hpp"

namespace btflod {

namespace detail {
/// clamp_to_hemisphere in the precision T of the vector (every step rounds to T): normalises d
/// and projects z < 0 onto the horizon; (0, 0, 1) for zero, NaN or straight-down inputs.
template <class T>
Vector3<T> clamp_to_hemisphere_in(Vector3<T> d) noexcept {
  const T len = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  if (!(len > T(0)) || !std::isfinite(len)) return {T(0), T(0), T(1)};
  d /= len;
  if (d.z >= T(0)) return d;
  const T lxy = std::sqrt(d.x * d.x + d.y * d.y);
  if (!(lxy > T(0))) return {T(0), T(0), T(1)};
  return {d.x / lxy, d.y / lxy, T(0)};
}

/// st clamped to [0, 1]²; NaN maps to the centre so that no caller indexes with garbage.
inline Vector2f clamp_unit_square(Vector2f st) noexcept {
  if (!(st.x == st.x) || !(st.y == st.y)) return {0.5f, 0.5f};
  return {std::min(std::max(st.x, 0.0f), 1.0f), std::min(std::max(st.y, 0.0f), 1.0f)};
}

/// Double-precision clamp to [0, 1]² (inputs are finite: the maps' outputs).
inline Vector2d clamp_unit_square_precise(Vector2d st) noexcept {
  return {std::clamp(st.x, 0.0, 1.0), std::clamp(st.y, 0.0, 1.0)};
}
}  // namespace detail

/// The direction (θ, φ) in double precision when the float `vector` is that direction (sets
/// built from angles: the float vector is unit_vector_from_spherical(theta, phi)), else `vector`
/// promoted to double. Points on one ring of a measured set then keep their exact relations
/// (equal θ) in the parameter plane. noexcept, thread-safe.
inline Vector3d direction_precise(float theta, float phi, Vector3f vector) noexcept {
  const double t = theta, p = phi, s = std::sin(t);
  const Vector3d v(s * std::cos(p), s * std::sin(p), std::cos(t));
  const Vector3d f(vector);
  return length(v - f) <= 1e-5 * std::max(1.0, length(f)) ? v : f;
}

/// Parabolic map (paper 000 §4, after [ND06]) in double: p = (x, y) / (1 + z) after
/// clamping d onto the hemisphere; returns st = (p + 1) / 2 in [0, 1]². noexcept, any input.
inline Vector2d parabolic_to_square_precise(Vector3d d) noexcept {
  d = detail::clamp_to_hemisphere_in(d);
  const double inv = 1.0 / (1.0 + d.z);
  return {0.5 * (d.x * inv + 1.0), 0.5 * (d.y * inv + 1.0)};
}

/// Inverse Shirley–Chiu map, unit disk → [−1, 1]², in double precision. Points of one ring
/// (equal ρ) that lie on one side of the square land on exactly the same line in double (in
/// float, rounding of ρ moves them apart by ~1e-7, enough to make sliver triangles of area
/// ~1e-9). noexcept.
inline Vector2d concentric_disk_to_centered_square_precise(Vector2d p) noexcept {
  const double r = std::sqrt(p.x * p.x + p.y * p.y);
  if (!(r > 0.0)) return {0.0, 0.0};
  constexpr double kPiD = 3.14159265358979323846;
  constexpr double kQuarter = 0.25 * kPiD;
  double phi = std::atan2(p.y, p.x);
  if (phi < -kQuarter) phi += 2.0 * kPiD;
  const double k = r / kQuarter;
  if (phi < kQuarter) return {r, phi * k};
  if (phi < 3.0 * kQuarter) return {(2.0 * kQuarter - phi) * k, r};
  if (phi < 5.0 * kQuarter) return {-r, (4.0 * kQuarter - phi) * k};
  return {(phi - 6.0 * kQuarter) * k, -r};
}

/// Elevated concentric map (paper 002 §6.1) in double: the disk point (x, y) / √(1 + z) after
/// clamping d onto the hemisphere, then the inverse concentric map; returns st in [0, 1]².
/// noexcept, any input.
inline Vector2d elevated_concentric_to_square_precise(Vector3d d) noexcept {
  d = detail::clamp_to_hemisphere_in(d);
  const double inv = 1.0 / std::sqrt(1.0 + d.z);
  const Vector2d ab = concentric_disk_to_centered_square_precise({d.x * inv, d.y * inv});
  return detail::clamp_unit_square_precise({0.5 * (ab.x + 1.0), 0.5 * (ab.y + 1.0)});
}

/// The square point of direction d under the shader's parameterisation p, in double (the
/// triangulation's input). noexcept, any input.
inline Vector2d direction_to_square_precise(DirectionParameterisation p, Vector3d d) noexcept {
  return p == DirectionParameterisation::parabolic ? parabolic_to_square_precise(d)
                                                   : elevated_concentric_to_square_precise(d);
}

}  // namespace btflod
