// btflod — the AngularInterpolator concept over AngularSample (runtime/angular/angular_sample.hpp:
// up to three measured-direction indices with non-negative weights that sum to 1, in canonical
// form), for the offline interpolators that take GLM directions.
#pragma once

#include <concepts>
#include <cstdint>

#include <glm/glm.hpp>

#include "btflod/runtime/angular/angular_sample.hpp"

namespace btflod {

/// What every interpolator offers: query a direction (local frame, unit length, z ≥ 0
/// expected; others are clamped to the hemisphere as each interpolator documents).
/// query() is thread-safe, allocation-free and noexcept.
template <class T>
concept AngularInterpolator = requires(const T& interp, glm::vec3 dir) {
  { interp.query(dir) }
  noexcept->std::same_as<AngularSample>;
  { interp.direction_count() } -> std::convertible_to<uint32_t>;
};

}  // namespace btflod
