// btflod — status codes and Result<T> for I/O, parsing and codecs.
//
// Per-frame code and codecs return a Status (never throw); I/O and parsing return a
// Result<T> that carries a readable message: what failed, where, expected vs found.
#pragma once

#include <cstdarg>
#include <cstdio>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>

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

/// Returns a stable lower-case name for a status, e.g. "bad_data". Never returns null.
constexpr const char* status_name(Status s) noexcept {
  switch (s) {
    case Status::success: return "success";
    case Status::bad_data: return "bad_data";
    case Status::short_output: return "short_output";
    case Status::insufficient_space: return "insufficient_space";
    case Status::invalid_argument: return "invalid_argument";
    case Status::io_error: return "io_error";
    case Status::unsupported: return "unsupported";
    case Status::cancelled: return "cancelled";
  }
  return "unknown";
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
inline std::string format_message(const char* fmt, ...) {
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
inline Error make_error(Status status, const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  Error e{status, vformat_message(fmt, args)};
  va_end(args);
  return e;
}

/// Either a value or an Error. A small stand-in for C++23 std::expected.
/// Accessing value() of a failed result is a precondition violation (asserted in debug).
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : storage_(std::in_place_index<0>, std::move(value)) {}  // NOLINT: implicit by design
  Result(Error error) : storage_(std::in_place_index<1>, std::move(error)) {}  // NOLINT

  bool ok() const noexcept { return storage_.index() == 0; }
  explicit operator bool() const noexcept { return ok(); }

  T& value() & { return std::get<0>(storage_); }
  const T& value() const& { return std::get<0>(storage_); }
  T&& value() && { return std::get<0>(std::move(storage_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  const Error& error() const { return std::get<1>(storage_); }
  Status status() const noexcept { return ok() ? Status::success : std::get<1>(storage_).status; }
  /// Returns the error message, or an empty string on success.
  std::string message() const { return ok() ? std::string() : std::get<1>(storage_).message; }

 private:
  std::variant<T, Error> storage_;
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
