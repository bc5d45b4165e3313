// btflod — status codes and Result<T> for I/O, parsing and codecs.
//
// Per-frame code and codecs return a Status (never throw); I/O and parsing return a
// Result<T> that carries a readable message: what failed, where, expected vs found.
#pragma once

#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>
#include <type_traits>
#include <utility>

#include "btflod/core/enum_names.hpp"

namespace btflod {

/// Outcome of a codec, reader or pipeline step. Modelled on libdeflate's result enum.
enum class Status : unsigned char {
  success = 0,
  bad_data,            ///< input is malformed, hostile or fails a checksum
  short_output,        ///< input ended before the declared amount of data (truncated)
  insufficient_space,  ///< the caller's output buffer is too small
  invalid_argument,    ///< the call itself is wrong (null span, out-of-range id, NaN parameter)
  io_error,            ///< the operating system reported a failure
  unsupported,         ///< valid input using a feature this build does not handle
  cancelled,           ///< the operation was cancelled by the caller
};

namespace detail {
/// status_name()'s table: one name per Status, in value order.
inline constexpr const char* kStatusNames[] = {"success",          "bad_data", "short_output", "insufficient_space",
                                               "invalid_argument", "io_error", "unsupported",  "cancelled"};
}  // namespace detail

/// Returns a stable lower-case name for a status, e.g. "bad_data". Never returns null.
constexpr const char* status_name(Status s) noexcept {
  return enum_value_name<Status::cancelled>(s, detail::kStatusNames);
}

/// A failed operation: a status plus a message meant for a person.
struct Error {
  Status status = Status::bad_data;
  std::string message;
};

/// vprintf-style formatting into a std::string (std::format is not in GCC 12's libstdc++).
/// Returns the formatted text; an encoding error yields an empty string. Does not end `args`.
inline std::string vformat_message(const char* fmt, va_list args) {
  va_list copy;
  va_copy(copy, args);
  const int n = std::vsnprintf(nullptr, 0, fmt, copy);
  va_end(copy);
  std::string out;
  if (n > 0) {
    out.resize(static_cast<size_t>(n));
    std::vsnprintf(out.data(), out.size() + 1, fmt, args);
  }
  return out;
}

/// printf-style formatting into a std::string.
#if defined(__GNUC__)
__attribute__((format(printf, 1, 2)))
#endif
inline std::string
format_message(const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  std::string out = vformat_message(fmt, args);
  va_end(args);
  return out;
}

/// Builds an Error; `make_error(Status::bad_data, "tile %d: checksum %08x != %08x", ...)`.
#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
inline Error
make_error(Status status, const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  Error e{status, vformat_message(fmt, args)};
  va_end(args);
  return e;
}

/// Either a value or an Error. A small stand-in for C++23 std::expected.
/// Accessing value() of a failed result (or error() of a successful one) is a precondition
/// violation: it aborts the program (like std::get on the wrong alternative without exceptions).
/// A tagged union rather than std::variant: every Result<T> instantiation of std::variant's
/// visitation machinery cost compile time in every translation unit (README "Compile cost").
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : value_(std::move(value)), ok_(true) {}       // NOLINT: implicit by design
  Result(Error error) : error_(std::move(error)), ok_(false) {}  // NOLINT
  /// Copies are available when T is copyable.
  Result(const Result& other) requires std::is_copy_constructible_v<T> : ok_(other.ok_) {
    if (ok_)
      ::new (static_cast<void*>(&value_)) T(other.value_);
    else
      ::new (static_cast<void*>(&error_)) Error(other.error_);
  }
  Result(Result&& other) noexcept(std::is_nothrow_move_constructible_v<T>) : ok_(other.ok_) {
    if (ok_)
      ::new (static_cast<void*>(&value_)) T(std::move(other.value_));
    else
      ::new (static_cast<void*>(&error_)) Error(std::move(other.error_));
  }
  /// Copies first, then moves the copy in: a copy that throws leaves *this unchanged.
  Result& operator=(const Result& other) requires std::is_copy_constructible_v<T> {
    if (this != &other) {
      Result copy(other);
      *this = std::move(copy);
    }
    return *this;
  }
  Result& operator=(Result&& other) noexcept(std::is_nothrow_move_constructible_v<T>) {
    if (this != &other) {
      destroy();
      ok_ = other.ok_;
      if (ok_)
        ::new (static_cast<void*>(&value_)) T(std::move(other.value_));
      else
        ::new (static_cast<void*>(&error_)) Error(std::move(other.error_));
    }
    return *this;
  }
  ~Result() { destroy(); }

  bool ok() const noexcept { return ok_; }
  explicit operator bool() const noexcept { return ok_; }

  T& value() & { return checked_value(); }
  const T& value() const& { return const_cast<Result*>(this)->checked_value(); }
  T&& value() && { return std::move(checked_value()); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  const Error& error() const {
    if (ok_) std::abort();  // precondition: !ok()
    return error_;
  }
  Status status() const noexcept { return ok_ ? Status::success : error_.status; }
  /// Returns the error message, or an empty string on success.
  std::string message() const { return ok_ ? std::string() : error_.message; }

 private:
  T& checked_value() {
    if (!ok_) std::abort();  // precondition: ok()
    return value_;
  }
  void destroy() noexcept {
    if (ok_)
      value_.~T();
    else
      error_.~Error();
  }

  union {
    T value_;
    Error error_;
  };
  bool ok_;
};

/// Result of an operation that produces no value.
template <>
class [[nodiscard]] Result<void> {
 public:
  Result() = default;
  Result(Error error) : error_(std::move(error)), failed_(true) {}  // NOLINT

  bool ok() const noexcept { return !failed_; }
  explicit operator bool() const noexcept { return ok(); }
  const Error& error() const { return error_; }
  Status status() const noexcept { return failed_ ? error_.status : Status::success; }
  std::string message() const { return failed_ ? error_.message : std::string(); }

 private:
  Error error_{Status::success, {}};
  bool failed_ = false;
};

using VoidResult = Result<void>;

}  // namespace btflod
