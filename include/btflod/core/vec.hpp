// btflod — small 2D and 3D vectors over float or double for code that must not depend on a
// math library (the runtime's angular tables are built at load time by engines without GLM).
//
// Every operation computes exactly what GLM computes for the same types, operation by
// operation, so results are bit-identical to the GLM code they replace: component-wise +, −,
// ×, ÷; dot(a, b) = (a.x·b.x + a.y·b.y) + a.z·b.z; length = sqrt(dot(v, v)); min/max as
// `b < a ? b : a` / `a < b ? b : a` per component.
//
// Any math library's types convert both ways without this header knowing them (as the std140
// types do): from a vector with members x, y (and z) of exactly the component type, and to any
// type constructible from the components (glm::vec2(x, y), glm::dvec3(x, y, z)). Between
// Vector2f and Vector2d (or Vector3f and Vector3d) the conversion is explicit.
#pragma once

#include <cmath>
#include <concepts>

namespace btflod {

namespace detail {
/// A type other than the vectors of this header, which name themselves with a member type
/// CoreVectorTag (conversions to and from foreign types are implicit).
template <class V>
concept ForeignVector = !requires {
  typename V::CoreVectorTag;
};
// Members of exactly the component type: a glm::dvec2 never becomes a Vector2f silently.
template <class V, class T>
concept HasMembersXy = requires(const V& v) {
  { v.x } -> std::same_as<const T&>;
  { v.y } -> std::same_as<const T&>;
};
template <class V, class T>
concept HasMembersXyz = HasMembersXy<V, T> && requires(const V& v) {
  { v.z } -> std::same_as<const T&>;
};
}  // namespace detail

// clang-format 14 reads `ForeignVector<V> && …` in a requires clause as an rvalue reference;
// the conversion templates below keep their hand layout.
// clang-format off
/// A 2D vector (T = float or double).
template <class T>
struct Vector2 {
  using CoreVectorTag = void;
  T x{}, y{};

  constexpr Vector2() noexcept = default;
  constexpr Vector2(T x_, T y_) noexcept : x(x_), y(y_) {}
  /// From the other precision: each component is static_cast (as glm::vec2(glm::dvec2)).
  template <class U>
    requires(!std::same_as<U, T>)
  constexpr explicit Vector2(const Vector2<U>& v) noexcept : x(static_cast<T>(v.x)), y(static_cast<T>(v.y)) {}
  /// From any type with members x and y of type T (glm::vec2, glm::dvec2).
  template <class V>
    requires(detail::ForeignVector<V> && detail::HasMembersXy<V, T>)
  constexpr Vector2(const V& v) noexcept : x(v.x), y(v.y) {}  // NOLINT: implicit
  /// To any type constructible from two T (glm::vec2, glm::dvec2).
  template <class V>
    requires(detail::ForeignVector<V> && std::constructible_from<V, T, T>)
  constexpr operator V() const noexcept {  // NOLINT: implicit
    return V(x, y);
  }

  friend constexpr bool operator==(const Vector2&, const Vector2&) noexcept = default;
  friend constexpr Vector2 operator+(Vector2 a, Vector2 b) noexcept { return {a.x + b.x, a.y + b.y}; }
  friend constexpr Vector2 operator-(Vector2 a, Vector2 b) noexcept { return {a.x - b.x, a.y - b.y}; }
  friend constexpr Vector2 operator+(Vector2 a, T s) noexcept { return {a.x + s, a.y + s}; }
  friend constexpr Vector2 operator-(Vector2 a, T s) noexcept { return {a.x - s, a.y - s}; }
  friend constexpr Vector2 operator*(T s, Vector2 a) noexcept { return {s * a.x, s * a.y}; }
  friend constexpr Vector2 operator*(Vector2 a, T s) noexcept { return {a.x * s, a.y * s}; }
  friend constexpr Vector2 operator/(Vector2 a, T s) noexcept { return {a.x / s, a.y / s}; }
  constexpr Vector2& operator/=(T s) noexcept { return *this = *this / s; }
};

/// A 3D vector (T = float or double).
template <class T>
struct Vector3 {
  using CoreVectorTag = void;
  T x{}, y{}, z{};

  constexpr Vector3() noexcept = default;
  constexpr Vector3(T x_, T y_, T z_) noexcept : x(x_), y(y_), z(z_) {}
  /// From the other precision: each component is static_cast (as glm::vec3(glm::dvec3)).
  template <class U>
    requires(!std::same_as<U, T>)
  constexpr explicit Vector3(const Vector3<U>& v) noexcept
      : x(static_cast<T>(v.x)), y(static_cast<T>(v.y)), z(static_cast<T>(v.z)) {}
  /// From any type with members x, y and z of type T (glm::vec3, glm::dvec3).
  template <class V>
    requires(detail::ForeignVector<V> && detail::HasMembersXyz<V, T>)
  constexpr Vector3(const V& v) noexcept : x(v.x), y(v.y), z(v.z) {}  // NOLINT: implicit
  /// To any type constructible from three T (glm::vec3, glm::dvec3).
  template <class V>
    requires(detail::ForeignVector<V> && std::constructible_from<V, T, T, T>)
  constexpr operator V() const noexcept {  // NOLINT: implicit
    return V(x, y, z);
  }

  friend constexpr bool operator==(const Vector3&, const Vector3&) noexcept = default;
  friend constexpr Vector3 operator+(Vector3 a, Vector3 b) noexcept { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
  friend constexpr Vector3 operator-(Vector3 a, Vector3 b) noexcept { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
  friend constexpr Vector3 operator*(T s, Vector3 a) noexcept { return {s * a.x, s * a.y, s * a.z}; }
  friend constexpr Vector3 operator*(Vector3 a, T s) noexcept { return {a.x * s, a.y * s, a.z * s}; }
  friend constexpr Vector3 operator/(Vector3 a, T s) noexcept { return {a.x / s, a.y / s, a.z / s}; }
  constexpr Vector3& operator/=(T s) noexcept { return *this = *this / s; }
};
// clang-format on

using Vector2f = Vector2<float>;
using Vector2d = Vector2<double>;
using Vector3f = Vector3<float>;
using Vector3d = Vector3<double>;

/// a.x·b.x + a.y·b.y (GLM's order). noexcept.
template <class T>
constexpr T dot(Vector2<T> a, Vector2<T> b) noexcept {
  return a.x * b.x + a.y * b.y;
}
/// (a.x·b.x + a.y·b.y) + a.z·b.z (GLM's order). noexcept.
template <class T>
constexpr T dot(Vector3<T> a, Vector3<T> b) noexcept {
  return (a.x * b.x + a.y * b.y) + a.z * b.z;
}
/// Euclidean length, sqrt(dot(v, v)). noexcept.
template <class T>
T length(Vector2<T> v) noexcept {
  return std::sqrt(dot(v, v));
}
/// Euclidean length, sqrt(dot(v, v)). noexcept.
template <class T>
T length(Vector3<T> v) noexcept {
  return std::sqrt(dot(v, v));
}
/// Component-wise minimum, b < a ? b : a per component (a NaN in a is kept). noexcept.
template <class T>
constexpr Vector2<T> min(Vector2<T> a, Vector2<T> b) noexcept {
  return {b.x < a.x ? b.x : a.x, b.y < a.y ? b.y : a.y};
}
/// Component-wise maximum, a < b ? b : a per component (a NaN in a is kept). noexcept.
template <class T>
constexpr Vector2<T> max(Vector2<T> a, Vector2<T> b) noexcept {
  return {a.x < b.x ? b.x : a.x, a.y < b.y ? b.y : a.y};
}
/// Component-wise maximum, a < b ? b : a per component (a NaN in a is kept). noexcept.
template <class T>
constexpr Vector3<T> max(Vector3<T> a, Vector3<T> b) noexcept {
  return {a.x < b.x ? b.x : a.x, a.y < b.y ? b.y : a.y, a.z < b.z ? b.z : a.z};
}

/// Unit vector (sin θ cos φ, sin θ sin φ, cos θ) for polar angle theta (from +z) and azimuth
/// phi, both in radians, computed in float. noexcept.
inline Vector3f unit_vector_from_spherical(float theta, float phi) noexcept {
  const float s = std::sin(theta);
  return {s * std::cos(phi), s * std::sin(phi), std::cos(theta)};
}

}  // namespace btflod
