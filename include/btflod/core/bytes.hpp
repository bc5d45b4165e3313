// btflod — bounds-checked little-endian byte reading and writing for file formats.
//
// ByteReader never reads past its span: every read reports failure instead, and the first
// failure is sticky, so a parser can read a whole header and check ok() once. All files
// btflod reads and writes are little-endian (DESIGN.md); these helpers assume a
// little-endian host (static_assert below) and use memcpy, so unaligned data is fine.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace btflod {

static_assert(std::endian::native == std::endian::little, "btflod file formats assume a little-endian host");

/// CRC-32 (zlib polynomial) of a byte span, continuing from `seed` (0 for a new checksum); the
/// checksum of every variable-length file part. Defined in the implementation TU (zlib's
/// crc32). Thread-safe, no allocation.
uint32_t crc32_of(std::span<const uint8_t> bytes, uint32_t seed = 0) noexcept;

/// Sequential bounds-checked reader over untrusted bytes.
class ByteReader {
 public:
  explicit ByteReader(std::span<const uint8_t> bytes) noexcept : bytes_(bytes) {}

  bool ok() const noexcept { return ok_; }
  size_t offset() const noexcept { return offset_; }
  size_t remaining() const noexcept { return bytes_.size() - offset_; }
  size_t size() const noexcept { return bytes_.size(); }
  std::span<const uint8_t> bytes() const noexcept { return bytes_; }

  /// Reads a trivially copyable value; returns T{} and marks failure when too few bytes remain.
  template <class T>
  T read() noexcept {
    static_assert(std::is_trivially_copyable_v<T>);
    T value{};
    if (!ok_ || remaining() < sizeof(T)) {
      ok_ = false;
      return value;
    }
    std::memcpy(&value, bytes_.data() + offset_, sizeof(T));
    offset_ += sizeof(T);
    return value;
  }
  uint8_t u8() noexcept { return read<uint8_t>(); }
  uint16_t u16() noexcept { return read<uint16_t>(); }
  uint32_t u32() noexcept { return read<uint32_t>(); }
  uint64_t u64() noexcept { return read<uint64_t>(); }
  int32_t i32() noexcept { return read<int32_t>(); }
  float f32() noexcept { return read<float>(); }
  double f64() noexcept { return read<double>(); }

  /// Returns a view of the next n bytes, or an empty span (and failure) when fewer remain.
  std::span<const uint8_t> take(size_t n) noexcept {
    if (!ok_ || remaining() < n) {
      ok_ = false;
      return {};
    }
    auto out = bytes_.subspan(offset_, n);
    offset_ += n;
    return out;
  }
  /// Copies n bytes into dst. Precondition: dst holds n bytes.
  bool copy_to(void* dst, size_t n) noexcept {
    auto s = take(n);
    if (!ok_) return false;
    if (n) std::memcpy(dst, s.data(), n);
    return true;
  }
  bool skip(size_t n) noexcept { return !take(n).empty() || (ok_ && n == 0); }
  /// Reads a fixed-size char field and trims it at the first NUL.
  std::string fixed_string(size_t n) {
    auto s = take(n);
    if (!ok_) return {};
    const auto* c = reinterpret_cast<const char*>(s.data());
    return std::string(c, strnlen(c, n));
  }
  /// True when the next bytes equal `literal` (the cursor advances only on a match).
  bool match(std::string_view literal) noexcept {
    if (!ok_ || remaining() < literal.size()) return false;
    if (std::memcmp(bytes_.data() + offset_, literal.data(), literal.size()) != 0) return false;
    offset_ += literal.size();
    return true;
  }
  /// Moves the cursor to an absolute offset; fails when it lies beyond the end.
  bool seek(size_t offset) noexcept {
    if (!ok_ || offset > bytes_.size()) {
      ok_ = false;
      return false;
    }
    offset_ = offset;
    return true;
  }
  /// True when count * element_size bytes remain without overflow: the check to make before
  /// trusting a count read from a file.
  bool can_hold(uint64_t count, uint64_t element_size) const noexcept {
    if (element_size != 0 && count > UINT64_MAX / element_size) return false;
    return count * element_size <= remaining();
  }

 private:
  std::span<const uint8_t> bytes_;
  size_t offset_ = 0;
  bool ok_ = true;
};

/// Appending little-endian writer into a growable buffer (offline code: may allocate).
class ByteWriter {
 public:
  template <class T>
  void write(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const uint8_t*>(&value);
    bytes_.insert(bytes_.end(), p, p + sizeof(T));
  }
  void u8(uint8_t v) { write(v); }
  void u16(uint16_t v) { write(v); }
  void u32(uint32_t v) { write(v); }
  void u64(uint64_t v) { write(v); }
  void f32(float v) { write(v); }
  void raw(const void* data, size_t n) {
    const auto* p = static_cast<const uint8_t*>(data);
    bytes_.insert(bytes_.end(), p, p + n);
  }
  void raw(std::span<const uint8_t> s) { bytes_.insert(bytes_.end(), s.begin(), s.end()); }
  void text(std::string_view s) { raw(s.data(), s.size()); }
  /// Writes s into a fixed field of n bytes, NUL-padded (and truncated to n).
  void fixed_string(std::string_view s, size_t n) {
    const size_t k = s.size() < n ? s.size() : n;
    raw(s.data(), k);
    bytes_.insert(bytes_.end(), n - k, uint8_t{0});
  }
  /// Overwrites a value written earlier (e.g. a size known only at the end).
  template <class T>
  void patch(size_t offset, const T& value) {
    std::memcpy(bytes_.data() + offset, &value, sizeof(T));
  }
  size_t size() const noexcept { return bytes_.size(); }
  std::vector<uint8_t>& bytes() noexcept { return bytes_; }
  std::vector<uint8_t> take() noexcept { return std::move(bytes_); }

 private:
  std::vector<uint8_t> bytes_;
};

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
#include <zlib.h>

namespace btflod {

uint32_t crc32_of(std::span<const uint8_t> bytes, uint32_t seed) noexcept {
  uLong crc = seed;
  const uint8_t* p = bytes.data();
  size_t left = bytes.size();
  while (left > 0) {  // zlib takes uInt lengths
    const uInt chunk = static_cast<uInt>(left > (1u << 30) ? (1u << 30) : left);
    crc = ::crc32(crc, p, chunk);
    p += chunk;
    left -= chunk;
  }
  return static_cast<uint32_t>(crc);
}

}  // namespace btflod
#endif  // BTFLOD_IMPLEMENTATION
