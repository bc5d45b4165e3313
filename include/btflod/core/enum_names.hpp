// btflod — the name of an enum value from a table indexed by the value (status_name(),
// simd_isa_name(), analytic_model_name(), …): one lookup, bounds-checked, instead of a switch
// per enum.
#pragma once

#include <cstddef>
#include <type_traits>

namespace btflod {

/// The entry of `names` at the underlying value of `value`, or "unknown" when the value lies
/// outside the table (an id read from a file, a cast integer). `Last` is the enum's last
/// enumerator: `names` holds one non-null name per enumerator, in value order from 0 to Last
/// (checked at compile time by count). constexpr, noexcept; never returns null.
template <auto Last, class E, std::size_t N>
constexpr const char* enum_value_name(E value, const char* const (&names)[N]) noexcept {
  static_assert(std::is_same_v<decltype(Last), E> && N == static_cast<std::size_t>(Last) + 1,
                "enum_value_name: one name per enumerator, 0 … Last");
  const auto i = static_cast<std::size_t>(value);
  return i < N ? names[i] : "unknown";
}

}  // namespace btflod
