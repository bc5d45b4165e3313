// btflod — the name of an enum value from a table indexed by the value (status_name(),
// simd_isa_name(), analytic_model_name(), …): one lookup, bounds-checked, instead of a switch
// per enum.
#pragma once

#include <cstddef>

namespace btflod {

/// The entry of `names` at the underlying value of `value`, or "unknown" when the value lies
/// outside the table (an id read from a file, a cast integer). Precondition: `names` holds one
/// non-null name per enumerator, in value order from 0. constexpr, noexcept; never returns null.
template <class E, std::size_t N>
constexpr const char* enum_value_name(E value, const char* const (&names)[N]) noexcept {
  const auto i = static_cast<std::size_t>(value);
  return i < N ? names[i] : "unknown";
}

}  // namespace btflod
