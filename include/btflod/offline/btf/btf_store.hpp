// btflod — an on-disk BTF store for data larger than RAM: the input of the out-of-core and
// distributed factorisations (offline/factor/out_of_core_svd.hpp).
//
// The FMF matrix of a BTF (paper 000 §4) has rows r = (v·n_light + l)·3 + c and one column per
// texel. A factorisation pass reads it in column blocks; the synthesiser and readers produce it
// one view at a time. The store is laid out for both: texels are grouped into blocks of
// `block_texels` consecutive texels (t = y·W + x), and a block holds all rows of its texels,
// image after image:
//
//   block b (texels t0 = b·B … t0 + bt − 1, bt = min(B, n − t0)) at data_offset + t0·m·s:
//     for v in views, for l in lights: bt texels × 3 channels (RGB), values of size s
//
// so one pass over the matrix is one sequential read of the file, and one view is one
// contiguous chunk of n_light·bt·3 values in every block (one pwrite per block per view).
//
// File format, version 1, little-endian:
//   header   "BTFLODST", u32 version, u32 header_bytes, u32 value_type (1 float32, 2 float16),
//            u32 width, u32 height, u32 n_view, u32 n_light, u32 block_texels,
//            u32 convention (BtfValueConvention), u32 flags (bit 0: complete), u64 data_offset,
//            char[32] view-set name, char[32] light-set name, n_view + n_light (θ, φ) float32
//            pairs in radians, u32 CRC-32 of all the header bytes before it
//   data     at data_offset (4096-aligned): the blocks above, m·n values
//   checksums  one u32 CRC-32 per (block, view) chunk, block-major, then a u32 CRC-32 of the
//            table; the file ends there (its size is checked exactly)
// A store is `complete` once every view has been written and finish() rewrote the header; a
// reader refuses an incomplete store (a writer that was killed) and checks every chunk's CRC
// when it reads a block.
//
// I/O is POSIX pread/pwrite on a file descriptor: never memory-mapped (mapped pages would count
// towards the resident set of a run with a memory budget) and never loaded whole.
#pragma once

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "btflod/core/bytes.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/result.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"

namespace btflod {

/// How a BtfStore holds its values.
enum class BtfStoreValueType : uint32_t {
  float32 = 1,  ///< IEEE binary32
  float16 = 2,  ///< IEEE binary16 (half): half the bytes, ~3 significant digits
};

/// Bytes of one value of the given type (0 for an unknown type).
constexpr size_t btf_store_value_size(BtfStoreValueType t) noexcept {
  return t == BtfStoreValueType::float32 ? 4 : t == BtfStoreValueType::float16 ? 2 : 0;
}

/// Everything the header of a store says. Plain data.
struct BtfStoreInfo {
  static constexpr uint32_t kVersion = 1;
  static constexpr uint32_t kMaxDirections = 65536;
  static constexpr uint32_t kMaxSide = 1u << 20;
  static constexpr uint32_t kMaxBlockTexels = 1u << 20;
  static constexpr uint64_t kDataAlignment = 4096;

  BtfStoreValueType value_type = BtfStoreValueType::float16;
  int width = 0;
  int height = 0;
  DirectionSet views;
  DirectionSet lights;
  uint32_t block_texels = 256;
  BtfValueConvention convention = BtfValueConvention::abrdf_cos_light;
  bool complete = false;
  uint64_t data_offset = 0;
  uint32_t header_crc = 0;  ///< identifies the store's contents together with the checksum table

  /// Rows of the FMF matrix: n_view · n_light · 3.
  size_t rows() const noexcept { return views.size() * lights.size() * 3; }
  /// Columns of the FMF matrix: texels W · H.
  size_t columns() const noexcept { return static_cast<size_t>(width) * static_cast<size_t>(height); }
  /// Number of texel blocks.
  size_t block_count() const noexcept { return (columns() + block_texels - 1) / block_texels; }
  size_t value_size() const noexcept { return btf_store_value_size(value_type); }
  /// Bytes of the data part: rows · columns · value size.
  uint64_t data_bytes() const noexcept { return static_cast<uint64_t>(rows()) * columns() * value_size(); }
  /// Bytes of the checksum table including its own CRC.
  uint64_t checksum_bytes() const noexcept { return (static_cast<uint64_t>(block_count()) * views.size() + 1) * 4; }
  /// The exact size of a complete store file.
  uint64_t file_bytes() const noexcept { return data_offset + data_bytes() + checksum_bytes(); }
  /// Texels in block b. Precondition: b < block_count().
  size_t block_width(size_t b) const noexcept {
    return std::min<size_t>(block_texels, columns() - b * static_cast<size_t>(block_texels));
  }
  /// File offset of block b.
  uint64_t block_offset(size_t b) const noexcept {
    return data_offset + static_cast<uint64_t>(b) * block_texels * rows() * value_size();
  }
};

namespace detail {

constexpr char kBtfStoreMagic[9] = "BTFLODST";

/// Serialises a header (with its CRC) for `info`; data_offset is written as given.
inline std::vector<uint8_t> btf_store_header_bytes(const BtfStoreInfo& info) {
  ByteWriter w;
  w.text(std::string_view(kBtfStoreMagic, 8));
  w.u32(BtfStoreInfo::kVersion);
  const size_t header_bytes = 8 + 4 * 10 + 8 + 64 + (info.views.size() + info.lights.size()) * 8 + 4;
  w.u32(static_cast<uint32_t>(header_bytes));
  w.u32(static_cast<uint32_t>(info.value_type));
  w.u32(static_cast<uint32_t>(info.width));
  w.u32(static_cast<uint32_t>(info.height));
  w.u32(static_cast<uint32_t>(info.views.size()));
  w.u32(static_cast<uint32_t>(info.lights.size()));
  w.u32(info.block_texels);
  w.u32(static_cast<uint32_t>(info.convention));
  w.u32(info.complete ? 1u : 0u);
  w.u64(info.data_offset);
  for (const DirectionSet* set : {&info.views, &info.lights}) {
    char name[32] = {};
    std::memcpy(name, set->name().data(), std::min<size_t>(31, set->name().size()));
    w.raw(name, 32);
  }
  for (const DirectionSet* set : {&info.views, &info.lights})
    for (const Direction& d : *set) {
      w.f32(d.theta);
      w.f32(d.phi);
    }
  std::vector<uint8_t> bytes = w.take();
  const uint32_t crc = crc32_of(bytes);
  bytes.resize(bytes.size() + 4);
  std::memcpy(bytes.data() + bytes.size() - 4, &crc, 4);
  return bytes;
}

/// pread of exactly `size` bytes at `offset`; retries short reads and EINTR.
inline VoidResult pread_exact(int fd, void* dst, size_t size, uint64_t offset, const std::string& path) {
  auto* p = static_cast<uint8_t*>(dst);
  while (size > 0) {
    const ssize_t got = ::pread(fd, p, size, static_cast<off_t>(offset));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0)
      return make_error(Status::io_error, "%s: read of %zu bytes at %llu failed: %s", path.c_str(), size,
                        static_cast<unsigned long long>(offset), std::strerror(errno));
    if (got == 0)
      return make_error(Status::short_output, "%s: file ends at %llu, %zu more bytes expected", path.c_str(),
                        static_cast<unsigned long long>(offset), size);
    p += got;
    size -= static_cast<size_t>(got);
    offset += static_cast<uint64_t>(got);
  }
  return {};
}

/// pwrite of exactly `size` bytes at `offset`; retries short writes and EINTR.
inline VoidResult pwrite_exact(int fd, const void* src, size_t size, uint64_t offset, const std::string& path) {
  const auto* p = static_cast<const uint8_t*>(src);
  while (size > 0) {
    const ssize_t put = ::pwrite(fd, p, size, static_cast<off_t>(offset));
    if (put < 0 && errno == EINTR) continue;
    if (put <= 0)
      return make_error(Status::io_error, "%s: write of %zu bytes at %llu failed: %s", path.c_str(), size,
                        static_cast<unsigned long long>(offset), put < 0 ? std::strerror(errno) : "no progress");
    p += put;
    size -= static_cast<size_t>(put);
    offset += static_cast<uint64_t>(put);
  }
  return {};
}

/// Owns a file descriptor (closed on destruction).
class FileDescriptor {
 public:
  FileDescriptor() = default;
  explicit FileDescriptor(int fd) noexcept : fd_(fd) {}
  FileDescriptor(FileDescriptor&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}
  FileDescriptor& operator=(FileDescriptor&& o) noexcept {
    if (this != &o) {
      reset();
      fd_ = std::exchange(o.fd_, -1);
    }
    return *this;
  }
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  ~FileDescriptor() { reset(); }
  int get() const noexcept { return fd_; }
  void reset() noexcept {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

}  // namespace detail

/// Parses and validates a store header from its first bytes (`header`, at least the whole
/// header) for a file of `file_size` bytes. Checks the magic, version, CRC, every dimension
/// against its limit, the direction angles (finite, θ in [0, π]), the data offset alignment and
/// that the file size equals exactly what the header implies (so a truncated or padded store is
/// refused before any data is read). An incomplete store parses (complete = false); opening it
/// for reading refuses it. Safe for untrusted input; allocates only the direction sets (at most
/// kMaxDirections each, bounded by header.size()). Thread-safe.
inline Result<BtfStoreInfo> parse_btf_store_header(std::span<const uint8_t> header, uint64_t file_size) {
  ByteReader r(header);
  if (!r.match(std::string_view(detail::kBtfStoreMagic, 8)))
    return make_error(Status::bad_data, "BTF store: bad magic (expected \"BTFLODST\")");
  const uint32_t version = r.u32();
  const uint32_t header_bytes = r.u32();
  if (!r.ok()) return make_error(Status::short_output, "BTF store: header truncated at %zu bytes", header.size());
  if (version != BtfStoreInfo::kVersion)
    return make_error(Status::unsupported, "BTF store: version %u, this build reads version %u", version,
                      BtfStoreInfo::kVersion);
  constexpr size_t kFixed = 8 + 4 * 10 + 8 + 64 + 4;
  if (header_bytes < kFixed || header_bytes > header.size())
    return make_error(header_bytes > header.size() ? Status::short_output : Status::bad_data,
                      "BTF store: header of %u bytes, %zu available (minimum %zu)", header_bytes, header.size(),
                      kFixed);
  uint32_t stored_crc = 0;
  std::memcpy(&stored_crc, header.data() + header_bytes - 4, 4);
  const uint32_t crc = crc32_of(header.first(header_bytes - 4));
  if (crc != stored_crc)
    return make_error(Status::bad_data, "BTF store: header CRC-32 %08x, stored %08x", crc, stored_crc);
  BtfStoreInfo info;
  info.header_crc = crc;
  const uint32_t value_type = r.u32();
  const uint32_t width = r.u32(), height = r.u32(), n_view = r.u32(), n_light = r.u32();
  info.block_texels = r.u32();
  const uint32_t convention = r.u32(), flags = r.u32();
  info.data_offset = r.u64();
  const std::string view_name = r.fixed_string(32), light_name = r.fixed_string(32);
  if (!r.ok()) return make_error(Status::short_output, "BTF store: header truncated");
  if (value_type != 1 && value_type != 2)
    return make_error(Status::unsupported, "BTF store: value type %u (expected 1 float32 or 2 float16)", value_type);
  info.value_type = static_cast<BtfStoreValueType>(value_type);
  if (width == 0 || height == 0 || width > BtfStoreInfo::kMaxSide || height > BtfStoreInfo::kMaxSide)
    return make_error(Status::bad_data, "BTF store: %ux%u texels (expected 1..%u per side)", width, height,
                      BtfStoreInfo::kMaxSide);
  if (n_view == 0 || n_light == 0 || n_view > BtfStoreInfo::kMaxDirections || n_light > BtfStoreInfo::kMaxDirections)
    return make_error(Status::bad_data, "BTF store: %u views, %u lights (expected 1..%u each)", n_view, n_light,
                      BtfStoreInfo::kMaxDirections);
  if (info.block_texels == 0 || info.block_texels > BtfStoreInfo::kMaxBlockTexels)
    return make_error(Status::bad_data, "BTF store: %u texels per block (expected 1..%u)", info.block_texels,
                      BtfStoreInfo::kMaxBlockTexels);
  if (convention > 1)
    return make_error(Status::bad_data, "BTF store: value convention %u (expected 0 or 1)", convention);
  if (flags > 1) return make_error(Status::bad_data, "BTF store: unknown flags %08x", flags);
  info.convention = static_cast<BtfValueConvention>(convention);
  info.complete = (flags & 1u) != 0;
  if (header_bytes != kFixed + (static_cast<uint64_t>(n_view) + n_light) * 8)
    return make_error(Status::bad_data, "BTF store: header of %u bytes, %u + %u directions need %llu", header_bytes,
                      n_view, n_light, static_cast<unsigned long long>(kFixed + (uint64_t{n_view} + n_light) * 8));
  for (int set = 0; set < 2; ++set) {
    const uint32_t count = set == 0 ? n_view : n_light;
    std::vector<std::pair<float, float>> tp(count);
    for (auto& [t, p] : tp) {
      t = r.f32();
      p = r.f32();
      if (!(std::isfinite(t) && std::isfinite(p) && t >= 0.0f && t <= 3.1416f && std::fabs(p) <= 7.0f))
        return make_error(Status::bad_data, "BTF store: %s direction (theta %g, phi %g) out of range",
                          set == 0 ? "view" : "light", static_cast<double>(t), static_cast<double>(p));
    }
    (set == 0 ? info.views : info.lights) = DirectionSet::from_radians(set == 0 ? view_name : light_name, tp);
  }
  if (!r.ok()) return make_error(Status::short_output, "BTF store: header truncated in the directions");
  info.width = static_cast<int>(width);
  info.height = static_cast<int>(height);
  if (info.data_offset < header_bytes || info.data_offset % BtfStoreInfo::kDataAlignment != 0)
    return make_error(Status::bad_data, "BTF store: data offset %llu (expected a multiple of %llu after the header)",
                      static_cast<unsigned long long>(info.data_offset),
                      static_cast<unsigned long long>(BtfStoreInfo::kDataAlignment));
  // rows ≤ 2^32·3, columns ≤ 2^40, value ≤ 4 bytes: the product needs a check, not just a multiply.
  uint64_t data = 0;
  if (__builtin_mul_overflow(static_cast<uint64_t>(info.rows()), static_cast<uint64_t>(info.columns()), &data) ||
      __builtin_mul_overflow(data, static_cast<uint64_t>(info.value_size()), &data) || data > (uint64_t{1} << 56))
    return make_error(Status::bad_data, "BTF store: %ux%u texels x %u x %u directions is too large", width, height,
                      n_view, n_light);
  if (info.file_bytes() != file_size)
    return make_error(file_size < info.file_bytes() ? Status::short_output : Status::bad_data,
                      "BTF store: file is %llu bytes, the header implies %llu (%s)",
                      static_cast<unsigned long long>(file_size), static_cast<unsigned long long>(info.file_bytes()),
                      file_size < info.file_bytes() ? "truncated" : "trailing bytes");
  return info;
}

/// Writes a store view by view (any view order, each view once), then finish(). The file is
/// created at its final size up front (sparse where not yet written); until finish() succeeds
/// it is marked incomplete and readers refuse it. Not thread-safe (one writer per store);
/// distinct writers on distinct files are independent.
class BtfStoreWriter {
 public:
  /// Creates (truncates) `path` for a BTF of the given shape. Returns invalid_argument for an
  /// empty or oversized shape, more than 2^32−1 views/lights or a bad block size; io_error when
  /// the file cannot be created or sized. Memory: n_view · block_count · 4 bytes of checksums
  /// plus one block's worth of conversion buffer while writing.
  static Result<BtfStoreWriter> create(const std::string& path, int width, int height, DirectionSet views,
                                       DirectionSet lights, BtfStoreValueType value_type = BtfStoreValueType::float16,
                                       uint32_t block_texels = 256,
                                       BtfValueConvention convention = BtfValueConvention::abrdf_cos_light) {
    BtfStoreWriter w;
    w.path_ = path;
    BtfStoreInfo& info = w.info_;
    if (btf_store_value_size(value_type) == 0)
      return make_error(Status::invalid_argument, "BTF store %s: unknown value type", path.c_str());
    if (width <= 0 || height <= 0 || static_cast<uint32_t>(width) > BtfStoreInfo::kMaxSide ||
        static_cast<uint32_t>(height) > BtfStoreInfo::kMaxSide || views.empty() || lights.empty() ||
        views.size() > BtfStoreInfo::kMaxDirections || lights.size() > BtfStoreInfo::kMaxDirections ||
        block_texels == 0 || block_texels > BtfStoreInfo::kMaxBlockTexels)
      return make_error(Status::invalid_argument,
                        "BTF store %s: shape %dx%d, %zu views, %zu lights, %u texels per block out of range",
                        path.c_str(), width, height, views.size(), lights.size(), block_texels);
    info.value_type = value_type;
    info.width = width;
    info.height = height;
    info.views = std::move(views);
    info.lights = std::move(lights);
    info.block_texels = block_texels;
    info.convention = convention;
    const size_t header_size = detail::btf_store_header_bytes(info).size();
    info.data_offset =
        (header_size + BtfStoreInfo::kDataAlignment - 1) / BtfStoreInfo::kDataAlignment * BtfStoreInfo::kDataAlignment;
    w.fd_ = detail::FileDescriptor(::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
    if (w.fd_.get() < 0)
      return make_error(Status::io_error, "BTF store %s: cannot create: %s", path.c_str(), std::strerror(errno));
    if (::ftruncate(w.fd_.get(), static_cast<off_t>(info.file_bytes())) != 0)
      return make_error(Status::io_error, "BTF store %s: cannot size to %llu bytes: %s", path.c_str(),
                        static_cast<unsigned long long>(info.file_bytes()), std::strerror(errno));
    if (auto s = w.write_header(); !s) return s.error();
    w.crcs_.assign(info.block_count() * info.views.size(), 0);
    w.written_.assign(info.views.size(), 0);
    return w;
  }

  /// The header being written (shape, directions, layout). Thread-safe (const).
  const BtfStoreInfo& info() const noexcept { return info_; }

  /// Writes view `view`: `block` holds n_light × H × W × 3 floats in the TabulatedBtf layout of
  /// one view (what SynthesisViewSink receives). Values are rounded to the store's type (half:
  /// nearest even). Returns invalid_argument for a wrong size, an out-of-range or repeated view;
  /// io_error on a failed write.
  VoidResult write_view(size_t view, std::span<const float> block) {
    const size_t nl = info_.lights.size(), n = info_.columns(), vs = info_.value_size();
    if (view >= info_.views.size() || written_[view])
      return make_error(Status::invalid_argument, "BTF store %s: view %zu %s", path_.c_str(), view,
                        view >= info_.views.size() ? "out of range" : "written twice");
    if (block.size() != nl * n * 3)
      return make_error(Status::invalid_argument, "BTF store %s: view %zu has %zu values, expected %zu", path_.c_str(),
                        view, block.size(), nl * n * 3);
    for (size_t b = 0; b < info_.block_count(); ++b) {
      const size_t t0 = b * info_.block_texels, bt = info_.block_width(b);
      staging_.resize(nl * bt * 3);
      for (size_t l = 0; l < nl; ++l)
        std::copy_n(block.data() + (l * n + t0) * 3, bt * 3, staging_.data() + l * bt * 3);
      bytes_.resize(staging_.size() * vs);
      if (info_.value_type == BtfStoreValueType::float32)
        std::memcpy(bytes_.data(), staging_.data(), bytes_.size());
      else
        float_to_half(staging_, std::span<uint16_t>(reinterpret_cast<uint16_t*>(bytes_.data()), staging_.size()));
      const uint64_t offset = info_.block_offset(b) + static_cast<uint64_t>(view) * nl * bt * 3 * vs;
      if (auto s = detail::pwrite_exact(fd_.get(), bytes_.data(), bytes_.size(), offset, path_); !s) return s;
      crcs_[b * info_.views.size() + view] = crc32_of(bytes_);
    }
    written_[view] = 1;
    return {};
  }

  /// Writes the checksum table and marks the store complete. Returns invalid_argument when a view
  /// is missing, io_error on a failed write or fsync. After success the writer is closed.
  VoidResult finish() {
    for (size_t v = 0; v < written_.size(); ++v)
      if (!written_[v])
        return make_error(Status::invalid_argument, "BTF store %s: view %zu was never written", path_.c_str(), v);
    std::vector<uint8_t> table(crcs_.size() * 4 + 4);
    std::memcpy(table.data(), crcs_.data(), crcs_.size() * 4);
    const uint32_t crc = crc32_of(std::span<const uint8_t>(table.data(), crcs_.size() * 4));
    std::memcpy(table.data() + crcs_.size() * 4, &crc, 4);
    if (auto s =
            detail::pwrite_exact(fd_.get(), table.data(), table.size(), info_.data_offset + info_.data_bytes(), path_);
        !s)
      return s;
    info_.complete = true;
    if (auto s = write_header(); !s) return s;
    if (::fsync(fd_.get()) != 0)
      return make_error(Status::io_error, "BTF store %s: fsync failed: %s", path_.c_str(), std::strerror(errno));
    fd_.reset();
    return {};
  }

 private:
  BtfStoreWriter() = default;
  VoidResult write_header() {
    const auto bytes = detail::btf_store_header_bytes(info_);
    info_.header_crc = crc32_of(std::span<const uint8_t>(bytes.data(), bytes.size() - 4));
    return detail::pwrite_exact(fd_.get(), bytes.data(), bytes.size(), 0, path_);
  }

  std::string path_;
  BtfStoreInfo info_;
  detail::FileDescriptor fd_;
  std::vector<uint32_t> crcs_;
  std::vector<uint8_t> written_;
  std::vector<float> staging_;
  std::vector<uint8_t> bytes_;
};

/// A complete store opened for reading. Reads are pread calls on one descriptor, so any number
/// of threads may read concurrently (each with its own scratch buffer).
class BtfStore {
 public:
  /// Opens and validates `path`: the header (parse_btf_store_header), completeness, the checksum
  /// table's own CRC. Returns io_error when the file cannot be opened, short_output for a
  /// truncated store, bad_data for a corrupt or incomplete one, unsupported for another version.
  /// Safe for untrusted files. Memory: block_count · n_view · 4 bytes of checksums.
  static Result<BtfStore> open(const std::string& path) {
    BtfStore s;
    s.path_ = path;
    s.fd_ = detail::FileDescriptor(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
    if (s.fd_.get() < 0)
      return make_error(Status::io_error, "BTF store %s: cannot open: %s", path.c_str(), std::strerror(errno));
    struct stat st {};
    if (::fstat(s.fd_.get(), &st) != 0)
      return make_error(Status::io_error, "BTF store %s: fstat failed: %s", path.c_str(), std::strerror(errno));
    const uint64_t size = static_cast<uint64_t>(st.st_size);
    // The fixed part first, then exactly the header length it declares (bounded by the limits).
    std::vector<uint8_t> head(static_cast<size_t>(std::min<uint64_t>(size, 16)));
    if (auto r = detail::pread_exact(s.fd_.get(), head.data(), head.size(), 0, path); !r) return r.error();
    uint32_t header_bytes = 0;
    if (head.size() >= 16) std::memcpy(&header_bytes, head.data() + 12, 4);
    const uint64_t max_header = 128 + uint64_t{2} * BtfStoreInfo::kMaxDirections * 8;
    head.resize(static_cast<size_t>(std::min<uint64_t>({size, std::max<uint64_t>(header_bytes, 16), max_header})));
    if (auto r = detail::pread_exact(s.fd_.get(), head.data(), head.size(), 0, path); !r) return r.error();
    auto info = parse_btf_store_header(head, size);
    if (!info) return make_error(info.status(), "%s: %s", path.c_str(), info.message().c_str());
    if (!info->complete)
      return make_error(Status::bad_data, "%s: BTF store is incomplete (its writer did not finish)", path.c_str());
    s.info_ = std::move(*info);
    const size_t entries = s.info_.block_count() * s.info_.views.size();
    std::vector<uint8_t> table(entries * 4 + 4);
    if (auto r = detail::pread_exact(s.fd_.get(), table.data(), table.size(),
                                     s.info_.data_offset + s.info_.data_bytes(), path);
        !r)
      return r.error();
    uint32_t stored = 0;
    std::memcpy(&stored, table.data() + entries * 4, 4);
    if (crc32_of(std::span<const uint8_t>(table.data(), entries * 4)) != stored)
      return make_error(Status::bad_data, "%s: BTF store checksum table is corrupt", path.c_str());
    s.crcs_.resize(entries);
    std::memcpy(s.crcs_.data(), table.data(), entries * 4);
    return s;
  }

  /// The validated header: shape, directions, value type, block layout. Thread-safe (const).
  const BtfStoreInfo& info() const noexcept { return info_; }
  /// The path the store was opened from.
  const std::string& path() const noexcept { return path_; }
  /// Rows of the FMF matrix (n_view · n_light · 3).
  size_t rows() const noexcept { return info_.rows(); }
  /// Columns of the FMF matrix (texels).
  size_t columns() const noexcept { return info_.columns(); }
  /// A 64-bit identity of the contents (header CRC and checksum table CRC): checkpoints use it
  /// to refuse resuming against another store.
  uint64_t content_id() const noexcept {
    const uint32_t table =
        crc32_of(std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(crcs_.data()), crcs_.size() * 4));
    return (static_cast<uint64_t>(info_.header_crc) << 32) | table;
  }

  /// Copies columns (texels) [t0, t0 + count) of the FMF matrix into `out`, column-major with
  /// leading dimension `ld` ≥ rows(): out[j·ld + r] = A(r, t0 + j), r = (v·n_light + l)·3 + c.
  /// Reads every overlapping block whole into `scratch` (resized as needed; one block of bytes)
  /// and checks the CRC of each of its view chunks. Returns invalid_argument for a range beyond
  /// the store, bad_data on a checksum mismatch (naming block and view), io_error/short_output
  /// on a failed read. Thread-safe for concurrent calls with distinct outputs and scratch.
  VoidResult read_columns(size_t t0, size_t count, float* out, size_t ld, std::vector<uint8_t>& scratch,
                          bool verify = true) const {
    const size_t m = rows(), n = columns(), nv = info_.views.size(), nl = info_.lights.size();
    const size_t vs = info_.value_size(), bb = info_.block_texels;
    if (t0 > n || count > n - t0 || ld < m)
      return make_error(Status::invalid_argument, "%s: columns [%zu, %zu) of %zu (ld %zu, %zu rows)", path_.c_str(), t0,
                        t0 + count, n, ld, m);
    std::vector<float> conv;
    for (size_t b = t0 / bb; count > 0 && b * bb < t0 + count; ++b) {
      const size_t bt = info_.block_width(b), base = b * bb;
      scratch.resize(m * bt * vs);
      if (auto s = detail::pread_exact(fd_.get(), scratch.data(), scratch.size(), info_.block_offset(b), path_); !s)
        return s;
      const size_t chunk = nl * bt * 3 * vs;
      if (verify)
        for (size_t v = 0; v < nv; ++v)
          if (crc32_of(std::span<const uint8_t>(scratch.data() + v * chunk, chunk)) != crcs_[b * nv + v])
            return make_error(Status::bad_data, "%s: block %zu (texels %zu..%zu), view %zu: CRC-32 mismatch",
                              path_.c_str(), b, base, base + bt - 1, v);
      const size_t j0 = std::max(t0, base) - base, j1 = std::min(t0 + count, base + bt) - base;
      // Image i of the block is bt × 3 values; column j of the output gets rows 3i..3i+2.
      const size_t images = nv * nl;
      for (size_t i = 0; i < images; ++i) {
        const float* src = nullptr;
        if (info_.value_type == BtfStoreValueType::float32) {
          src = reinterpret_cast<const float*>(scratch.data()) + i * bt * 3;
        } else {
          conv.resize(bt * 3);
          half_to_float(
              std::span<const uint16_t>(reinterpret_cast<const uint16_t*>(scratch.data()) + i * bt * 3, bt * 3), conv);
          src = conv.data();
        }
        for (size_t j = j0; j < j1; ++j) {
          float* dst = out + (base + j - t0) * ld + 3 * i;
          dst[0] = src[j * 3];
          dst[1] = src[j * 3 + 1];
          dst[2] = src[j * 3 + 2];
        }
      }
    }
    return {};
  }

  /// Copies the images of view `view` and lights [l0, l1) into `out`, image after image, each
  /// H × W × 3 floats in the TabulatedBtf image layout: out[((l − l0)·H·W + t)·3 + c], t = y·W + x.
  /// Reads the view's chunk of every block (n_light · bt · 3 values, one pread each, in file
  /// order) into `scratch` and checks its CRC, so memory is one chunk plus `out`. Returns
  /// invalid_argument for an out-of-range view or light range or a wrong `out` size, bad_data on
  /// a checksum mismatch (naming block and view), io_error/short_output on a failed read.
  /// Thread-safe for concurrent calls with distinct outputs and scratch.
  VoidResult read_view_images(size_t view, size_t l0, size_t l1, std::span<float> out, std::vector<uint8_t>& scratch,
                              bool verify = true) const {
    const size_t nv = info_.views.size(), nl = info_.lights.size(), n = columns(), vs = info_.value_size();
    if (view >= nv || l0 >= l1 || l1 > nl)
      return make_error(Status::invalid_argument, "%s: view %zu, lights [%zu, %zu) of %zu x %zu", path_.c_str(), view,
                        l0, l1, nv, nl);
    if (out.size() != (l1 - l0) * n * 3)
      return make_error(Status::invalid_argument, "%s: %zu output values for %zu images of %zu texels", path_.c_str(),
                        out.size(), l1 - l0, n);
    for (size_t b = 0; b < info_.block_count(); ++b) {
      const size_t bt = info_.block_width(b), base = b * info_.block_texels;
      const size_t chunk = nl * bt * 3 * vs;
      scratch.resize(chunk);
      const uint64_t offset = info_.block_offset(b) + static_cast<uint64_t>(view) * chunk;
      if (auto s = detail::pread_exact(fd_.get(), scratch.data(), chunk, offset, path_); !s) return s;
      if (verify && crc32_of(std::span<const uint8_t>(scratch.data(), chunk)) != crcs_[b * nv + view])
        return make_error(Status::bad_data, "%s: block %zu (texels %zu..%zu), view %zu: CRC-32 mismatch", path_.c_str(),
                          b, base, base + bt - 1, view);
      for (size_t l = l0; l < l1; ++l) {
        float* dst = out.data() + ((l - l0) * n + base) * 3;
        if (info_.value_type == BtfStoreValueType::float32) {
          std::memcpy(dst, scratch.data() + l * bt * 3 * 4, bt * 3 * 4);
        } else {
          half_to_float(
              std::span<const uint16_t>(reinterpret_cast<const uint16_t*>(scratch.data()) + l * bt * 3, bt * 3),
              std::span<float>(dst, bt * 3));
        }
      }
    }
    return {};
  }

  /// The largest value in the store (one sequential pass over every block, CRCs checked), the
  /// data range compare_btfs() takes from btf_peak(): 1 for an all-zero or negative store.
  /// Memory: one block. Errors as read_columns().
  Result<double> peak(bool verify = true) const {
    std::vector<float> cols;
    std::vector<uint8_t> scratch;
    float m = 0.0f;
    const size_t rows_ = rows(), n = columns();
    for (size_t t0 = 0; t0 < n; t0 += info_.block_texels) {
      const size_t cnt = std::min<size_t>(info_.block_texels, n - t0);
      cols.resize(rows_ * cnt);
      if (auto s = read_columns(t0, cnt, cols.data(), rows_, scratch, verify); !s) return s.error();
      for (float v : cols)
        if (v > m) m = v;
    }
    return m > 0.0f ? static_cast<double>(m) : 1.0;
  }

  /// Loads the whole store as a BTF (for small stores, tests and evaluation). Returns the errors
  /// of read_columns() and insufficient_space above `max_samples`. Allocates the whole BTF.
  Result<BtfFloat> read_all(uint64_t max_samples = uint64_t{1} << 31) const {
    auto count = BtfFloat::checked_sample_count(static_cast<uint64_t>(info_.width), static_cast<uint64_t>(info_.height),
                                                info_.views.size(), info_.lights.size(), max_samples);
    if (!count) return count.error();
    BtfFloat btf(info_.width, info_.height, info_.views, info_.lights);
    const size_t m = rows(), n = columns();
    std::vector<float> cols;
    std::vector<uint8_t> scratch;
    for (size_t t0 = 0; t0 < n; t0 += info_.block_texels) {
      const size_t cnt = std::min<size_t>(info_.block_texels, n - t0);
      cols.resize(m * cnt);
      if (auto s = read_columns(t0, cnt, cols.data(), m, scratch); !s) return s.error();
      for (size_t i = 0; i < m / 3; ++i)
        for (size_t j = 0; j < cnt; ++j)
          for (size_t c = 0; c < 3; ++c) btf.samples()[(i * n + t0 + j) * 3 + c] = cols[j * m + 3 * i + c];
    }
    return btf;
  }

 private:
  BtfStore() = default;
  std::string path_;
  BtfStoreInfo info_;
  detail::FileDescriptor fd_;
  std::vector<uint32_t> crcs_;
};

/// Writes an in-memory BTF as a store (view by view). Errors as BtfStoreWriter.
inline VoidResult write_btf_store(const BtfFloat& btf, const std::string& path,
                                  BtfStoreValueType value_type = BtfStoreValueType::float16,
                                  uint32_t block_texels = 256,
                                  BtfValueConvention convention = BtfValueConvention::abrdf_cos_light) {
  auto w = BtfStoreWriter::create(path, btf.width(), btf.height(), btf.views(), btf.lights(), value_type, block_texels,
                                  convention);
  if (!w) return w.error();
  const size_t per_view = btf.light_count() * btf.texel_count() * 3;
  for (size_t v = 0; v < btf.view_count(); ++v)
    if (auto s = w->write_view(v, btf.samples().subspan(v * per_view, per_view)); !s) return s;
  return w->finish();
}

}  // namespace btflod
