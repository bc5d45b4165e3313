// btflod — bit_cast that works on every supported standard library.
//
// std::bit_cast needs libc++ 14 / libstdc++ 11; Debian's emscripten 3.1.6 ships libc++ 13
// without it. GCC (>= 11), clang (>= 9) and MSVC (>= 19.27) all provide __builtin_bit_cast,
// which std::bit_cast is built on, so btflod uses the builtin directly.
#pragma once

#include <type_traits>

namespace btflod {

/// Reinterprets the object representation of `from` as a `To` (same size, both trivially
/// copyable), like std::bit_cast. constexpr, thread-safe, no allocation.
template <class To, class From>
  requires(sizeof(To) == sizeof(From) && std::is_trivially_copyable_v<To> && std::is_trivially_copyable_v<From>)
constexpr To bit_cast(const From& from) noexcept { return __builtin_bit_cast(To, from); }

}  // namespace btflod
