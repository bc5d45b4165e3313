// btflod — move-only owners of a pointer (a handle with its own release function, or an array
// from new[]) for the runtime headers.
//
// Why not std::unique_ptr: with libstdc++ 12 in C++20, <memory> brings in <ostream> (for
// unique_ptr's operator<<) and with it the iostream and locale machinery, ~0.5 s of CPU in every
// translation unit that includes a runtime header (README "Compile cost"). These owners need
// only <cstddef> and <utility>.
#pragma once

#include <cstddef>
#include <utility>

namespace btflod {

/// Deleter of UniqueArray: delete[].
template <class T>
struct DeleteArray {
  void operator()(T* p) const noexcept { delete[] p; }
};

/// Owns a T* released by `Deleter{}(p)` (a stateless function object) when the owner is
/// destroyed, reset or assigned; nullptr is never passed to the deleter. Move-only, like
/// std::unique_ptr<T, Deleter>, with the subset of its interface btflod uses. Not thread-safe
/// (like any object): one owner, one thread at a time.
template <class T, class Deleter>
class UniqueHandle {
 public:
  /// An empty owner.
  constexpr UniqueHandle() noexcept = default;
  /// Takes ownership of `p` (may be nullptr).
  explicit constexpr UniqueHandle(T* p) noexcept : p_(p) {}
  UniqueHandle(const UniqueHandle&) = delete;
  UniqueHandle& operator=(const UniqueHandle&) = delete;
  /// Takes `other`'s pointer; `other` becomes empty.
  UniqueHandle(UniqueHandle&& other) noexcept : p_(std::exchange(other.p_, nullptr)) {}
  /// Releases the current pointer, then takes `other`'s; `other` becomes empty.
  UniqueHandle& operator=(UniqueHandle&& other) noexcept {
    if (this != &other) reset(std::exchange(other.p_, nullptr));
    return *this;
  }
  ~UniqueHandle() { reset(); }

  /// Releases the current pointer (when not null) and takes ownership of `p`.
  void reset(T* p = nullptr) noexcept {
    T* old = std::exchange(p_, p);
    if (old) Deleter{}(old);
  }
  /// Gives up ownership without releasing; returns the pointer (the caller now owns it).
  [[nodiscard]] T* release() noexcept { return std::exchange(p_, nullptr); }
  /// The owned pointer (nullptr when empty); ownership stays here.
  T* get() const noexcept { return p_; }
  /// True when a pointer is owned.
  explicit operator bool() const noexcept { return p_ != nullptr; }
  /// The owned object. Precondition: not empty.
  T& operator*() const noexcept { return *p_; }
  /// Member access to the owned object. Precondition: not empty.
  T* operator->() const noexcept { return p_; }
  /// Element i of an owned array. Precondition: not empty and i within the array.
  T& operator[](size_t i) const noexcept { return p_[i]; }

 private:
  T* p_ = nullptr;
};

/// An array from new T[n], released with delete[].
template <class T>
using UniqueArray = UniqueHandle<T, DeleteArray<T>>;

/// new T[n]() (value-initialised: zero for arithmetic types, like std::make_unique<T[]>(n)).
/// Allocates with the global operator new[]; throws std::bad_alloc on failure (terminates under
/// -fno-exceptions). Set-up code only.
template <class T>
UniqueArray<T> make_unique_array(size_t n) {
  return UniqueArray<T>(new T[n]());
}

/// new T[n] without initialisation (for buffers that are written before they are read).
/// Allocates like make_unique_array. Set-up code only.
template <class T>
UniqueArray<T> make_unique_array_for_overwrite(size_t n) {
  return UniqueArray<T>(new T[n]);
}

}  // namespace btflod
