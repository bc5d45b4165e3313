// btflod — the common result of every angular interpolator: up to three measured-direction
// indices with non-negative weights that sum to 1 (unused slots have weight 0 and repeat a
// valid index, so a consumer may always read all three).
#pragma once

#include <array>
#include <concepts>
#include <cstdint>

#include <glm/glm.hpp>

namespace btflod {

struct AngularSample {
  std::array<uint32_t, 3> index{0, 0, 0};
  std::array<float, 3> weight{1.0f, 0.0f, 0.0f};
};

/// What every interpolator offers: query a direction (local frame, unit length, z ≥ 0
/// expected; others are clamped to the hemisphere as each interpolator documents).
/// query() is thread-safe, allocation-free and noexcept.
template <class T>
concept AngularInterpolator = requires(const T& interp, glm::vec3 dir) {
  { interp.query(dir) } noexcept -> std::same_as<AngularSample>;
  { interp.direction_count() } -> std::convertible_to<uint32_t>;
};

}  // namespace btflod
