// btflod — plain vector and matrix types with the std140 layout of GLSL's vec2/vec4/uvec4/ivec2
// and mat4, for the uniform blocks the generated shaders read (ShaderParams) and the CPU twins of
// the shaders' lookups (Float3: a direction, not a block member).
//
// They carry data only; the math stays in the engine's own library. Any math library's types
// convert both ways without this header knowing them (no GLM; beyond <concepts> only core/vec.hpp):
//   - from a vector with members x, y, z, w (or x, y) — glm::vec4, glm::uvec4, glm::vec2, …;
//   - from a matrix indexed m[column][row] — glm::mat4, float[4][4];
//   - to any type constructible from the components — glm::vec4(x, y, z, w), glm::mat4(16 floats).
// so `params.model_view_proj = proj * view;` and `glm::vec4 l = params.light;` keep working in
// code that uses GLM. Matrices are column-major, as in GLSL and GLM. (The component-type checks
// are core/vec.hpp's, whose Vector2/Vector3 convert the same way.)
#pragma once

#include <concepts>
#include <cstddef>
#include <cstdint>

#include "btflod/core/vec.hpp"

namespace btflod {

template <class T>
struct Vec2;
template <class T>
struct Vec4;
struct Float3;
struct Float4x4;

namespace detail {
template <class V>
inline constexpr bool kIsStd140 = false;
template <class T>
inline constexpr bool kIsStd140<Vec2<T>> = true;
template <class T>
inline constexpr bool kIsStd140<Vec4<T>> = true;
template <>
inline constexpr bool kIsStd140<Float3> = true;
template <>
inline constexpr bool kIsStd140<Float4x4> = true;
/// A type other than the std140 types of this header: conversions go to and from the engine's
/// math types only, never silently between Float4 and UInt4 (or Float2 and Int2).
template <class V>
concept Foreign = !kIsStd140<V>;
// Members of exactly the component type (core/vec.hpp): a glm::vec2 never becomes an Int2 by
// truncation.
template <class V, class T>
concept HasXyzw = HasMembersXyz<V, T> && requires(const V& v) {
  { v.w } -> std::same_as<const T&>;
};
template <class M>
concept ColumnMajor4x4 = requires(const M& m) {
  { m[3][3] } -> std::convertible_to<float>;
};
}  // namespace detail

// clang-format 14 reads `Foreign<V> && …` in a requires clause as an rvalue reference and
// glues the `&&` to it; the conversion templates below keep their hand layout.
// clang-format off
/// GLSL vec2 / ivec2 (T = float / int32_t: 8 bytes, std140 alignment 8). Converts from any type
/// with members x and y (glm::vec2) and to any type constructible from two T.
template <class T>
struct alignas(8) Vec2 {
  T x{}, y{};

  constexpr Vec2() noexcept = default;
  constexpr Vec2(T x_, T y_) noexcept : x(x_), y(y_) {}
  /// From any type with members x and y (glm::vec2, glm::ivec2).
  template <class V>
    requires(detail::Foreign<V> && detail::HasMembersXy<V, T>)
  constexpr Vec2(const V& v) noexcept : x(static_cast<T>(v.x)), y(static_cast<T>(v.y)) {}  // NOLINT: implicit
  /// To any type constructible from two T (glm::vec2, glm::ivec2).
  template <class V>
    requires(detail::Foreign<V> && std::constructible_from<V, T, T>)
  constexpr operator V() const noexcept {  // NOLINT: implicit
    return V(x, y);
  }
  friend constexpr bool operator==(const Vec2&, const Vec2&) noexcept = default;
};
using Float2 = Vec2<float>;   ///< GLSL vec2
using Int2 = Vec2<int32_t>;   ///< GLSL ivec2

/// Three floats, e.g. a direction for the CPU twins of the shaders' lookups (12 bytes: not a
/// uniform-block member type, std140 aligns vec3 to 16). Converts like Vec2 with three members.
struct Float3 {
  float x = 0.0f, y = 0.0f, z = 0.0f;

  constexpr Float3() noexcept = default;
  constexpr Float3(float x_, float y_, float z_) noexcept : x(x_), y(y_), z(z_) {}
  /// From any type with members x, y and z (glm::vec3).
  template <class V>
    requires(detail::Foreign<V> && detail::HasMembersXyz<V, float>)
  constexpr Float3(const V& v) noexcept  // NOLINT: implicit
      : x(static_cast<float>(v.x)), y(static_cast<float>(v.y)), z(static_cast<float>(v.z)) {}
  /// To any type constructible from three floats (glm::vec3).
  template <class V>
    requires(detail::Foreign<V> && std::constructible_from<V, float, float, float>)
  constexpr operator V() const noexcept {  // NOLINT: implicit
    return V(x, y, z);
  }
  friend constexpr bool operator==(const Float3&, const Float3&) noexcept = default;
};

/// GLSL vec4 / uvec4 (T = float / uint32_t: 16 bytes, std140 alignment 16). Converts from any
/// type with members x, y, z and w (glm::vec4, glm::uvec4), to any type constructible from four
/// T, and explicitly to one constructible from three (xyz: glm::vec3(params.light), as GLM's own
/// vec3(vec4) is explicit).
template <class T>
struct alignas(16) Vec4 {
  T x{}, y{}, z{}, w{};

  constexpr Vec4() noexcept = default;
  constexpr Vec4(T x_, T y_, T z_, T w_) noexcept : x(x_), y(y_), z(z_), w(w_) {}
  /// From any type with members x, y, z and w.
  template <class V>
    requires(detail::Foreign<V> && detail::HasXyzw<V, T>)
  constexpr Vec4(const V& v) noexcept  // NOLINT: implicit
      : x(static_cast<T>(v.x)), y(static_cast<T>(v.y)), z(static_cast<T>(v.z)), w(static_cast<T>(v.w)) {}
  /// To any type constructible from four T.
  template <class V>
    requires(detail::Foreign<V> && std::constructible_from<V, T, T, T, T>)
  constexpr operator V() const noexcept {  // NOLINT: implicit
    return V(x, y, z, w);
  }
  /// Explicitly to a type constructible from three T but not four (xyz).
  template <class V>
    requires(detail::Foreign<V> && !std::constructible_from<V, T, T, T, T> && std::constructible_from<V, T, T, T>)
  explicit constexpr operator V() const noexcept {
    return V(x, y, z);
  }
  friend constexpr bool operator==(const Vec4&, const Vec4&) noexcept = default;
};
using Float4 = Vec4<float>;    ///< GLSL vec4
using UInt4 = Vec4<uint32_t>;  ///< GLSL uvec4

/// GLSL mat4 (64 bytes: four vec4 columns, std140 stride 16): m[4·column + row], column-major.
/// Converts from any matrix indexed a[column][row] (glm::mat4) and to any type constructible
/// from 16 floats in column order (glm::mat4).
struct alignas(16) Float4x4 {
  float m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  ///< identity by default

  constexpr Float4x4() noexcept = default;
  /// From any matrix indexed a[column][row] with 4×4 elements.
  template <class M>
    requires(detail::Foreign<M> && detail::ColumnMajor4x4<M>)
  constexpr Float4x4(const M& a) noexcept {  // NOLINT: implicit
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r) m[4 * c + r] = static_cast<float>(a[c][r]);
  }
  /// To any type constructible from 16 floats in column-major order (glm::mat4).
  template <class M>
    requires(detail::Foreign<M> &&
             std::constructible_from<M, float, float, float, float, float, float, float, float, float, float, float,
                                     float, float, float, float, float>)
  constexpr operator M() const noexcept {  // NOLINT: implicit
    return M(m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8], m[9], m[10], m[11], m[12], m[13], m[14], m[15]);
  }
  /// Element (column, row). Precondition: both < 4.
  constexpr float operator()(int column, int row) const noexcept { return m[4 * column + row]; }
  friend constexpr bool operator==(const Float4x4&, const Float4x4&) noexcept = default;
};

// clang-format on

// std140 (GLSL 4.50 §7.6.2.2): vec4 and uvec4 are 16 bytes aligned to 16, mat4 is an array of
// four vec4 columns (stride 16); vec2/ivec2 are 8 bytes aligned to 8.
static_assert(sizeof(Float2) == 8 && alignof(Float2) == 8, "vec2: 8 bytes, std140 alignment 8");
static_assert(sizeof(Int2) == 8 && alignof(Int2) == 8, "ivec2: 8 bytes, std140 alignment 8");
static_assert(sizeof(Float4) == 16 && alignof(Float4) == 16, "vec4: 16 bytes, std140 alignment 16");
static_assert(sizeof(UInt4) == 16 && alignof(UInt4) == 16, "uvec4: 16 bytes, std140 alignment 16");
static_assert(sizeof(Float4x4) == 64 && alignof(Float4x4) == 16, "mat4: 4 columns of 16 bytes, alignment 16");
static_assert(offsetof(Float4, w) == 12 && offsetof(UInt4, w) == 12, "vec4 components are consecutive floats");

}  // namespace btflod
