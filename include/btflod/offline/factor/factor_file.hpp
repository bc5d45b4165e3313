// btflod — the shared on-disk format of the factorised representations (factor/), plus small
// helpers every representation uses (BTF shape, angular tap combination, reconstruction at the
// measured directions, the common start of a reader).
//
// File layout (little-endian):
//   char[8]  magic "BTFLODFR"
//   u32      format version (1)
//   u32      kind (FactorKind)
//   u32      section count S (≤ 64)
//   S × { u32 tag (four ASCII chars), u64 payload bytes, u32 CRC-32 of the payload, payload }
// and nothing after the last section. Every representation stores a "SHAP" section
// (width, height, n_view, n_light as u32 plus the view and light directions as float θ, φ
// pairs) and its own sections; readers check every length against the shape before use, and
// reject NaN/Inf floats.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/core/bytes.hpp"
#include "btflod/core/result.hpp"
#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"

namespace btflod {

/// Which representation a factor file holds.
enum class FactorKind : uint32_t { fmf = 1, pca_views = 2, laplacian_pca = 3, local_pca = 4, spmm = 5 };

inline constexpr uint32_t kFactorFormatVersion = 1;
inline constexpr char kFactorMagic[8] = {'B', 'T', 'F', 'L', 'O', 'D', 'F', 'R'};
inline constexpr uint32_t kFactorMaxSections = 64;
/// Largest dimension a reader accepts (texels per side, directions per set).
inline constexpr uint32_t kFactorMaxExtent = 1u << 16;

/// Four-character section tag, e.g. factor_tag("SHAP").
constexpr uint32_t factor_tag(const char (&s)[5]) noexcept {
  return static_cast<uint32_t>(static_cast<uint8_t>(s[0])) | static_cast<uint32_t>(static_cast<uint8_t>(s[1])) << 8 |
         static_cast<uint32_t>(static_cast<uint8_t>(s[2])) << 16 |
         static_cast<uint32_t>(static_cast<uint8_t>(s[3])) << 24;
}

/// Texel and direction counts of a factorised BTF plus its direction sets.
struct BtfShape {
  int width = 0;
  int height = 0;
  DirectionSet views;
  DirectionSet lights;
  size_t texel_count() const noexcept { return static_cast<size_t>(width) * static_cast<size_t>(height); }
  size_t view_count() const noexcept { return views.size(); }
  size_t light_count() const noexcept { return lights.size(); }
  /// Bytes of the source BTF stored as float RGB (the reference for compression ratios).
  size_t float_bytes() const noexcept { return texel_count() * view_count() * light_count() * 3 * sizeof(float); }
};

/// Combines an evaluator at measured directions over the 3 × 3 taps of a light and a view
/// AngularSample (weights multiply; zero-weight taps are skipped). `f(view, light)` returns a
/// glm::vec3. Allocation-free.
template <class F>
inline glm::vec3 combine_angular_taps(const AngularSample& light, const AngularSample& view, F&& f) {
  glm::vec3 acc(0.0f);
  for (int i = 0; i < 3; ++i) {
    const float wv = view.weight[static_cast<size_t>(i)];
    if (wv == 0.0f) continue;
    for (int j = 0; j < 3; ++j) {
      const float wl = light.weight[static_cast<size_t>(j)];
      if (wl == 0.0f) continue;
      acc += (wv * wl) * f(view.index[static_cast<size_t>(i)], light.index[static_cast<size_t>(j)]);
    }
  }
  return acc;
}

/// The whole BTF of `shape` at its measured directions (allocates): every texel (x, y), view and
/// light holds the RGB `f(x, y, view, light)` returns (a glm::vec3; x and y int, view and light
/// uint32_t). How every representation's reconstruct() fills its output.
template <class F>
BtfFloat reconstruct_measured(const BtfShape& shape, F&& f) {
  BtfFloat out(shape.width, shape.height, shape.views, shape.lights);
  for (size_t v = 0; v < shape.view_count(); ++v)
    for (size_t l = 0; l < shape.light_count(); ++l)
      for (int y = 0; y < shape.height; ++y)
        for (int x = 0; x < shape.width; ++x) {
          const glm::vec3 c = f(x, y, static_cast<uint32_t>(v), static_cast<uint32_t>(l));
          for (int ch = 0; ch < 3; ++ch) out.at(x, y, v, l, ch) = c[ch];
        }
  return out;
}

/// Assembles a factor file from sections. Offline code: allocates.
class FactorFileWriter {
 public:
  explicit FactorFileWriter(FactorKind kind) : kind_(kind) {}
  void add(uint32_t tag, std::vector<uint8_t> payload) { sections_.emplace_back(tag, std::move(payload)); }
  template <class T>
  void add_array(uint32_t tag, std::span<const T> values) {
    std::vector<uint8_t> bytes(values.size_bytes());
    if (!bytes.empty()) std::memcpy(bytes.data(), values.data(), bytes.size());
    add(tag, std::move(bytes));
  }
  /// Adds the SHAP section of `shape`.
  void add_shape(const BtfShape& shape) {
    ByteWriter w;
    w.u32(static_cast<uint32_t>(shape.width));
    w.u32(static_cast<uint32_t>(shape.height));
    w.u32(static_cast<uint32_t>(shape.views.size()));
    w.u32(static_cast<uint32_t>(shape.lights.size()));
    for (const auto* set : {&shape.views, &shape.lights})
      for (const auto& d : *set) {
        w.f32(d.theta);
        w.f32(d.phi);
      }
    add(factor_tag("SHAP"), w.take());
  }
  /// The whole file.
  std::vector<uint8_t> finish() const {
    ByteWriter w;
    w.raw(kFactorMagic, sizeof kFactorMagic);
    w.u32(kFactorFormatVersion);
    w.u32(static_cast<uint32_t>(kind_));
    w.u32(static_cast<uint32_t>(sections_.size()));
    for (const auto& [tag, payload] : sections_) {
      w.u32(tag);
      w.u64(payload.size());
      w.u32(crc32_of(payload));
      w.raw(payload);
    }
    return w.take();
  }

 private:
  FactorKind kind_;
  std::vector<std::pair<uint32_t, std::vector<uint8_t>>> sections_;
};

/// A parsed factor file: kind and section views into the caller's buffer (which must outlive it).
class FactorFile {
 public:
  FactorKind kind = FactorKind::fmf;

  /// Refused at compile time: the section views would point into a buffer destroyed at the end of
  /// the full expression. Keep the bytes alive in a named variable and parse that.
  static Result<FactorFile> parse(std::vector<uint8_t>&& temporary_bytes) = delete;

  /// Parses and validates the container (magic, version, section lengths and CRCs, no
  /// trailing bytes, no duplicate tags). Safe for untrusted input; does not copy payloads.
  static Result<FactorFile> parse(std::span<const uint8_t> bytes) {
    ByteReader r(bytes);
    if (!r.match(std::string_view(kFactorMagic, sizeof kFactorMagic)))
      return make_error(Status::bad_data, "factor file: bad magic at offset 0 (expected \"BTFLODFR\", %zu bytes)",
                        bytes.size());
    const uint32_t version = r.u32(), kind = r.u32(), count = r.u32();
    if (!r.ok()) return make_error(Status::short_output, "factor file: header truncated (%zu bytes)", bytes.size());
    if (version != kFactorFormatVersion)
      return make_error(Status::unsupported, "factor file: version %u, expected %u", version, kFactorFormatVersion);
    if (kind < 1 || kind > 5) return make_error(Status::bad_data, "factor file: unknown kind %u (expected 1..5)", kind);
    if (count > kFactorMaxSections)
      return make_error(Status::bad_data, "factor file: %u sections, at most %u allowed", count, kFactorMaxSections);
    FactorFile f;
    f.kind = static_cast<FactorKind>(kind);
    for (uint32_t i = 0; i < count; ++i) {
      const size_t at = r.offset();
      const uint32_t tag = r.u32();
      const uint64_t len = r.u64();
      const uint32_t crc = r.u32();
      if (!r.ok())
        return make_error(Status::short_output, "factor file: section %u header truncated at offset %zu", i, at);
      if (len > r.remaining())
        return make_error(Status::short_output, "factor file: section %u at offset %zu declares %llu bytes, %zu remain",
                          i, at, static_cast<unsigned long long>(len), r.remaining());
      const auto payload = r.take(static_cast<size_t>(len));
      const uint32_t actual = crc32_of(payload);
      if (actual != crc)
        return make_error(Status::bad_data, "factor file: section %u (offset %zu) CRC %08x, expected %08x", i, at,
                          actual, crc);
      for (const auto& s : f.sections_)
        if (s.first == tag) return make_error(Status::bad_data, "factor file: duplicate section tag %08x", tag);
      f.sections_.emplace_back(tag, payload);
    }
    if (r.remaining() != 0)
      return make_error(Status::bad_data, "factor file: %zu trailing bytes after the last section", r.remaining());
    return f;
  }

  /// True when the file has a section `tag` (optional sections).
  bool has_section(uint32_t tag) const noexcept {
    for (const auto& s : sections_)
      if (s.first == tag) return true;
    return false;
  }

  /// The payload of section `tag`, or an error naming it when missing.
  Result<std::span<const uint8_t>> section(uint32_t tag) const {
    for (const auto& s : sections_)
      if (s.first == tag) return s.second;
    const char name[5] = {static_cast<char>(tag & 0xff), static_cast<char>((tag >> 8) & 0xff),
                          static_cast<char>((tag >> 16) & 0xff), static_cast<char>(tag >> 24), 0};
    return make_error(Status::bad_data, "factor file: missing section \"%s\"", name);
  }

  /// Copies section `tag` into `out` (resized to `count`), checking that its length is exactly
  /// count·sizeof(T) and, for floats, that every value is finite.
  template <class T>
  VoidResult read_array(uint32_t tag, size_t count, std::vector<T>& out) const {
    auto s = section(tag);
    if (!s) return s.error();
    const char name[5] = {static_cast<char>(tag & 0xff), static_cast<char>((tag >> 8) & 0xff),
                          static_cast<char>((tag >> 16) & 0xff), static_cast<char>(tag >> 24), 0};
    if (count > s->size() / sizeof(T) || s->size() != count * sizeof(T))
      return make_error(Status::bad_data, "factor file: section \"%s\" has %zu bytes, expected %zu (%zu values)", name,
                        s->size(), count * sizeof(T), count);
    out.resize(count);
    if (count) std::memcpy(out.data(), s->data(), s->size());
    if constexpr (std::is_floating_point_v<T>) {
      for (size_t i = 0; i < count; ++i)
        if (!std::isfinite(out[i]))
          return make_error(Status::bad_data, "factor file: section \"%s\" value %zu is not finite", name, i);
    }
    return {};
  }

  /// Reads the SHAP section; checks extents against kFactorMaxExtent and `max_values`
  /// (texels × views × lights).
  Result<BtfShape> shape(uint64_t max_values = uint64_t{1} << 33) const {
    auto s = section(factor_tag("SHAP"));
    if (!s) return s.error();
    ByteReader r(*s);
    const uint32_t w = r.u32(), h = r.u32(), nv = r.u32(), nl = r.u32();
    if (!r.ok()) return make_error(Status::short_output, "factor file: SHAP section truncated (%zu bytes)", s->size());
    if (w == 0 || h == 0 || nv == 0 || nl == 0 || w > kFactorMaxExtent || h > kFactorMaxExtent ||
        nv > kFactorMaxExtent || nl > kFactorMaxExtent)
      return make_error(Status::bad_data, "factor file: shape %ux%u texels, %u views, %u lights out of range", w, h, nv,
                        nl);
    if (static_cast<uint64_t>(w) * h * nv * nl > max_values)
      return make_error(Status::bad_data, "factor file: shape %ux%u x %u x %u exceeds %llu values", w, h, nv, nl,
                        static_cast<unsigned long long>(max_values));
    if (r.remaining() != (static_cast<size_t>(nv) + nl) * 8)
      return make_error(Status::bad_data, "factor file: SHAP has %zu direction bytes, expected %zu", r.remaining(),
                        (static_cast<size_t>(nv) + nl) * 8);
    BtfShape shape;
    shape.width = static_cast<int>(w);
    shape.height = static_cast<int>(h);
    for (int set = 0; set < 2; ++set) {
      const uint32_t n = set == 0 ? nv : nl;
      std::vector<std::pair<float, float>> tp(n);
      for (auto& [t, p] : tp) {
        t = r.f32();
        p = r.f32();
        if (!std::isfinite(t) || !std::isfinite(p))
          return make_error(Status::bad_data, "factor file: SHAP direction angle is not finite");
      }
      (set == 0 ? shape.views : shape.lights) = DirectionSet::from_radians(set == 0 ? "views" : "lights", tp);
    }
    return shape;
  }

 private:
  std::vector<std::pair<uint32_t, std::span<const uint8_t>>> sections_;
};

/// What every representation's deserialize() starts from: the parsed container, its shape (the
/// SHAP section) and its META section (a view into the caller's buffer, which must outlive it).
struct FactorFileHead {
  FactorFile file;
  BtfShape shape;
  std::span<const uint8_t> meta;
};

/// Parses `bytes` as a factor file holding representation `kind` (`kind_name` names it in the
/// error, e.g. "Local PCA") and reads its SHAP and META sections. Returns the first error: the
/// container's (FactorFile::parse), "factor file: kind K is not <kind_name> (<kind>)", the
/// shape's (FactorFile::shape) or the missing META section's. Safe for untrusted input; does not
/// copy payloads.
inline Result<FactorFileHead> parse_factor_file_head(std::span<const uint8_t> bytes, FactorKind kind,
                                                     const char* kind_name) {
  auto file = FactorFile::parse(bytes);
  if (!file) return file.error();
  if (file->kind != kind)
    return make_error(Status::bad_data, "factor file: kind %u is not %s (%u)", static_cast<unsigned>(file->kind),
                      kind_name, static_cast<unsigned>(kind));
  auto shape = file->shape();
  if (!shape) return shape.error();
  auto meta = file->section(factor_tag("META"));
  if (!meta) return meta.error();
  return FactorFileHead{std::move(*file), std::move(*shape), *meta};
}

}  // namespace btflod
