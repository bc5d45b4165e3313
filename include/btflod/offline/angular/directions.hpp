// btflod — sets of measured directions (UBO2003: 81, UBO2014: 151, or custom).
#pragma once

#include <cmath>
#include <cstddef>
#include <initializer_list>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/offline/math/math.hpp"

namespace btflod {

/// One direction of a set: spherical angles in radians and the unit vector (local frame).
struct Direction {
  float theta = 0.0f;  ///< polar angle from +z, radians
  float phi = 0.0f;    ///< azimuth, radians, in the convention of the set that made it
  glm::vec3 vector{0.0f, 0.0f, 1.0f};
};

/// An ordered set of directions. Indices are stable and are what BTF tables index by.
class DirectionSet {
 public:
  DirectionSet() = default;
  DirectionSet(std::string name, std::vector<Direction> directions)
      : name_(std::move(name)), directions_(std::move(directions)) {}

  /// A custom set from (theta, phi) pairs in radians.
  static DirectionSet from_radians(std::string name, std::span<const std::pair<float, float>> theta_phi) {
    std::vector<Direction> dirs;
    dirs.reserve(theta_phi.size());
    for (auto [t, p] : theta_phi) dirs.push_back({t, p, direction_from_spherical(t, p)});
    return DirectionSet(std::move(name), std::move(dirs));
  }

  /// A set made of rings: ring r has counts[r] directions at polar angle thetas_deg[r],
  /// φ = k·360/n + offsets_deg[r] (degrees). When wrap_signed, φ is wrapped to [−180, 180).
  static DirectionSet from_rings(std::string name, std::span<const float> thetas_deg, std::span<const int> counts,
                                 std::span<const float> offsets_deg, bool wrap_signed) {
    std::vector<Direction> dirs;
    for (size_t r = 0; r < thetas_deg.size(); ++r) {
      for (int k = 0; k < counts[r]; ++k) {
        float phi_deg = static_cast<float>(k) * 360.0f / static_cast<float>(counts[r]) +
                        (offsets_deg.empty() ? 0.0f : offsets_deg[r]);
        if (wrap_signed) phi_deg = wrap_degrees_signed(phi_deg);
        const float t = degrees_to_radians(thetas_deg[r]);
        const float p = degrees_to_radians(phi_deg);
        dirs.push_back({t, p, direction_from_spherical(t, p)});
      }
    }
    return DirectionSet(std::move(name), std::move(dirs));
  }

  /// The 81 directions of the Bonn UBO2003 database: θ = 0, 15, …, 75° with 1, 6, 12, 18, 20,
  /// 24 directions per ring, φ = k·360/n starting at 0 and kept in [0, 360) as the data set's
  /// file names spell it.
  static DirectionSet ubo2003() {
    static const float thetas[] = {0, 15, 30, 45, 60, 75};
    static const int counts[] = {1, 6, 12, 18, 20, 24};
    return from_rings("UBO2003", thetas, counts, {}, false);
  }

  /// The 151 directions of the Bonn UBO2014 database: θ = 0, 11, 23.5, 30, 37.5, 45, 52.5, 60,
  /// 67.5, 75° with 1, 6, 12, 12, 12, 18, 18, 24, 24, 24 per ring, φ = k·360/n + offset with
  /// offsets 0, 15, 0, 15, 0, 0, 7.5, 0, 7.5, 0°, wrapped to [−180, 180).
  static DirectionSet ubo2014() {
    static const float thetas[] = {0, 11, 23.5f, 30, 37.5f, 45, 52.5f, 60, 67.5f, 75};
    static const int counts[] = {1, 6, 12, 12, 12, 18, 18, 24, 24, 24};
    static const float offsets[] = {0, 15, 0, 15, 0, 0, 7.5f, 0, 7.5f, 0};
    return from_rings("UBO2014", thetas, counts, offsets, true);
  }

  const std::string& name() const noexcept { return name_; }
  size_t size() const noexcept { return directions_.size(); }
  bool empty() const noexcept { return directions_.empty(); }
  const Direction& operator[](size_t i) const noexcept { return directions_[i]; }
  std::span<const Direction> directions() const noexcept { return directions_; }
  auto begin() const noexcept { return directions_.begin(); }
  auto end() const noexcept { return directions_.end(); }

  /// Index of the direction with the largest dot product with v (v need not be normalised);
  /// returns size() for an empty set. O(n): for per-frame use see angular/.
  size_t nearest(glm::vec3 v) const noexcept {
    size_t best = directions_.size();
    float best_dot = -2.0f;
    const float len = glm::length(v);
    if (!(len > 0.0f)) return best;
    v /= len;
    for (size_t i = 0; i < directions_.size(); ++i) {
      const float d = glm::dot(directions_[i].vector, v);
      if (d > best_dot) {
        best_dot = d;
        best = i;
      }
    }
    return best;
  }

  /// Index of the direction within tolerance_deg of (theta_deg, phi_deg), comparing φ modulo
  /// 360 (and ignoring φ at the pole), or size() when none matches. Used by readers that
  /// receive angles in file names.
  size_t find_degrees(float theta_deg, float phi_deg, float tolerance_deg = 0.6f) const noexcept {
    for (size_t i = 0; i < directions_.size(); ++i) {
      const float t = radians_to_degrees(directions_[i].theta);
      if (std::abs(t - theta_deg) > tolerance_deg) continue;
      if (t < tolerance_deg && theta_deg < tolerance_deg) return i;  // the pole: φ is meaningless
      const float dp = std::abs(wrap_degrees_signed(radians_to_degrees(directions_[i].phi) - phi_deg));
      if (dp <= tolerance_deg) return i;
    }
    return directions_.size();
  }

 private:
  std::string name_;
  std::vector<Direction> directions_;
};

}  // namespace btflod
