// btflod — Bonn University binary BTF files (BTFDBB / UBO2014): reading, reconstruction,
// writing, and an exact-SVD factorisation of a tabulated BTF into the DFMF form.
//
// Two signatures are handled (10 bytes, no NUL):
//   "!DFMF08FCR"  decorrelated full matrix factorisation (the UBO2014 downloads): the colour
//                 channels are decorrelated by a colour model, then each channel's
//                 (nL·nV) × (w·h) matrix is stored as U · SxVᵀ (paper 000, §3: the FMF/SVD
//                 factorisation, S folded into SxV).
//   "!FMF12FCER"  full matrix factorisation of all channels at once.
//
// File layout (little-endian, packed; every count is checked against the remaining bytes
// before anything is allocated):
//   signature[10]
//   meta block:  u32 size (counted from the size field itself to the block's end), u32 version,
//                char[80] measurement_setup, char[80] image_sensor, char[80] light_source,
//                f32 ppmm, f32[3] rgb_scale,
//                version > 1: u32 cosine flag (cos θ_light multiplied into the data),
//                version > 2: u32 n + char[n] XML,
//                version > 3: u32 channel count, per channel u32 n + char[n] name.
//   sampling:    u32 nV, per view: f32 θ, f32 φ (radians), u32 nL, nL × (f32 θ, f32 φ).
//   u32 width, u32 height
//   signature ends in 'R': u32 nR, nR × f32[9] rotation matrices (local frames).
//   DFMF:  u32 max components, i32 colour model, f32[3] colour mean, f32[9] colour matrix
//          (row-major), then per channel: u8 scalar size (2 = half, 4 = float, 8 = double),
//          u32 k, u32 rows (= nL·nV), u32 cols (= w·h), S[k], U[rows × k], SxV[cols × k]
//          (matrices row-major: the k components of one row are contiguous).
//   FMF:   u8 header version; ≥ 1: u32 dynamic-range reduction method; ≥ 2: u32 rows, u32 cols
//          + rows·cols half-float height map (btflod reads and writes rows first, as btflib's
//          reader does; btflib's writer stores the width first — a non-square map of the
//          texture's size is read in whichever order its header has, see
//          BonnBtfFile::height_map_width_first); then u32 max components, u8 scalar size, u32 k,
//          u32 rows (= nC·nL·nV), u32 cols (= w·h), S, U, SxV as above.
//   value(c, l, v, x, y) = Σ_j U[l + nL·v][j] · SxV[x + w·y][j]   (DFMF, per channel c)
//
// Where this comes from: the layout follows the format description and was checked against the field
// order of Bonn's public btflib reader/writer (read_meta_data, read_bidir_sampling,
// read_common_header, read_ubo_dfmf, read_ubo_fmf, write_ubo_dfmf, fread_matrix: "stored in
// row-major order"), and its decoder (undecorrelate, restore_dynamic_range; the order is
// undecorrelate → restore dynamic range → divide by cos θ_light). Facts only, no code copied.
// Details that could NOT be confirmed and are implemented as documented interpretations:
//   * FMF row order: rows = nC·nL·nV with row index c + nC·(l + nL·v) (btflib documents a
//     "(nC·nL·nV) × P" U but not the order; channel-fastest matches its BDI tensor order
//     nC × nL × nV × w × h).
//   * rgb_scale is kept in the metadata but not applied (btflib's decoder does not apply it).
//   * The log-domain epsilon is not stored in files; btflib hard-codes 1e-5 (dynamic_range_eps).
//   * A file whose matrices are stored transposed (rows = w·h, cols = nL·nV; btflib's writer
//     accepts both orientations) is read by swapping U and SxV, with a warning.
//   * Per-view light sets: btflib requires the same light count for every view and keeps the
//     first view's directions; so do we (a warning is added when later views differ).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "btflod/core/bytes.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/progress.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/thread_pool.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/math/math.hpp"
#include "btflod/offline/math/thin_svd.hpp"  // Eigen (as a system header) and exact_thin_svd

namespace btflod {

inline constexpr std::string_view kBonnDfmfSignature = "!DFMF08FCR";
inline constexpr std::string_view kBonnFmfSignature = "!FMF12FCER";
/// Epsilon of the log-domain colour models and dynamic-range reduction (not stored in files;
/// btflib's value).
inline constexpr float kBonnLogEpsilon = 1e-5f;

enum class BonnFormat : uint8_t { dfmf, fmf };

/// Colour models of DFMF files, numbered as in the files (btflib's undecorrelate).
enum class BonnColorModel : int32_t {
  rgb = 0,
  yuv = 1,
  lab = 2,  ///< not supported by reconstruct()
  pca = 3,  ///< rgb = decorrelated · colour_matrix + colour_mean
  ycocg = 4,
  spectral = 5,         ///< not supported (needs spectral channels)
  spectral_linear = 6,  ///< not supported
  ylog_uv = 9,
  ylog_ulog_vlog = 10,
  ylog_udivy_vdivy = 11,
  log_rgb = 12,
};

/// Row-major float matrix: the file's storage order, so the factorisation code can use U and
/// SxV directly with Eigen.
using BonnMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// One factorised matrix A ≈ U · SxVᵀ (S already folded into SxV).
struct BonnFactors {
  uint8_t scalar_size = 4;  ///< as stored in the file: 2 half, 4 float, 8 double
  std::vector<float> s;     ///< k singular values (informational)
  BonnMatrix u;             ///< rows × k, angular: row l + nL·v (FMF: c + nC·(l + nL·v))
  BonnMatrix sxv;           ///< cols × k, spatial: row x + w·y
};

/// Everything a Bonn .btf file holds, with the data kept in factor form.
struct BonnBtfFile {
  BonnFormat format = BonnFormat::dfmf;
  uint32_t meta_version = 4;
  std::string measurement_setup;
  std::string image_sensor;
  std::string light_source;
  float ppmm = 0.0f;
  std::array<float, 3> rgb_scale{1.0f, 1.0f, 1.0f};
  bool cosine_in_data = false;  ///< values were multiplied by cos θ_light; reconstruct() divides
  std::string xml;
  std::vector<std::string> channel_names{"R", "G", "B"};
  DirectionSet views;
  DirectionSet lights;
  int width = 0;
  int height = 0;
  std::vector<std::array<float, 9>> rotations;
  // DFMF
  uint32_t max_components = 0;
  int32_t color_model = 0;  ///< a BonnColorModel value
  std::array<float, 3> color_mean{0.0f, 0.0f, 0.0f};
  std::array<float, 9> color_matrix{1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< row-major
  // FMF
  uint8_t fmf_header_version = 2;
  uint32_t dynamic_range_reduction = 0;  ///< 0 none, else values are log(v + eps)
  /// Height map size. btflod reads the header's first value as rows (as btflib's reader does)
  /// and writes rows first; btflib's writer stores the width first. When the map has the
  /// texture's size and the texture is not square, the file decides: a header of (width,
  /// height) is read as width first (height_map_width_first, with a warning); otherwise (square
  /// maps, other sizes) rows first. The samples are row-major (x fastest) in either case.
  int height_map_rows = 0;
  int height_map_cols = 0;
  std::vector<float> height_map;  ///< rows × cols, row-major
  /// The header stores (cols, rows) (btflib's writer); encode_bonn_btf() keeps the order.
  bool height_map_width_first = false;
  /// DFMF: one per channel; FMF: exactly one.
  std::vector<BonnFactors> factors;
  /// Things the reader accepted but a person may want to know (transposed matrices, differing
  /// per-view light sets, trailing bytes when allowed).
  std::vector<std::string> warnings;

  size_t channel_count() const noexcept { return channel_names.size(); }
};

/// Options of read_bonn_btf().
struct BonnReadOptions {
  /// Accept bytes after the last matrix (recorded in warnings) instead of failing.
  bool allow_trailing_bytes = false;
  /// Largest file read by the path overload.
  uint64_t max_file_bytes = uint64_t{1} << 36;
};

/// Options of reconstruct_bonn_btf(). bonn_reconstruct_options(convention) sets the cosine
/// fields for a wanted BtfValueConvention.
struct BonnReconstructOptions {
  /// Largest number of float samples (W·H·nV·nL·3) to allocate.
  uint64_t max_samples = uint64_t{1} << 31;
  /// Divide by cos θ_light when the file says the cosine is in the data (btflib's decoder:
  /// the result is ρ whatever the flag).
  bool remove_cosine = true;
  /// Multiply by cos θ_light when the file says the cosine is NOT in the data (used with
  /// remove_cosine = false: the result is then ρ·cosθ_l whatever the flag, btflod's default
  /// BtfValueConvention). Ignored when remove_cosine is true.
  bool add_cosine = false;
  /// Pool for the matrix products; null uses default_thread_pool().
  ThreadPool* pool = nullptr;
};

/// Reconstruction options whose result holds `convention` whatever the file's cosine flag:
/// brdf divides by cos θ_light when the flag is 1; abrdf_cos_light multiplies by it when the
/// flag is 0. Other fields keep their defaults. Thread-safe.
inline BonnReconstructOptions bonn_reconstruct_options(BtfValueConvention convention) {
  BonnReconstructOptions o;
  o.remove_cosine = convention == BtfValueConvention::brdf;
  o.add_cosine = convention == BtfValueConvention::abrdf_cos_light;
  return o;
}

namespace detail {

inline std::string printable_signature(std::span<const uint8_t> bytes) {
  std::string out;
  for (uint8_t b : bytes) {
    if (b >= 32 && b < 127) {
      out.push_back(static_cast<char>(b));
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", b);
      out += buf;
    }
  }
  return out;
}

/// Cursor over untrusted bytes that turns every failure into an Error naming the field and
/// the offset. All reads check the remaining size first.
class BonnParser {
 public:
  explicit BonnParser(std::span<const uint8_t> bytes) : r_(bytes) {}

  ByteReader& reader() noexcept { return r_; }
  const Error& error() const noexcept { return error_; }

#if defined(__GNUC__)
  __attribute__((format(printf, 3, 4)))
#endif
  bool
  fail(Status status, const char* fmt, ...) {
    va_list args;
    va_start(args, fmt);
    error_ = Error{status, format_message("bonn btf: at byte %zu: ", r_.offset()) + vformat_message(fmt, args)};
    va_end(args);
    return false;
  }

  /// Fixed-size field: too few bytes means the file is truncated.
  bool need(uint64_t count, uint64_t element_size, const char* what) {
    if (r_.can_hold(count, element_size)) return true;
    return fail(Status::short_output, "truncated input: %s needs %llu bytes, only %zu remain", what,
                static_cast<unsigned long long>(count * element_size), r_.remaining());
  }
  /// A count read from the file, already checked against its absolute limit (a count above the
  /// limit is bad_data: no valid file holds it). When its elements cannot fit in the rest of the
  /// file, the file is reported as truncated (short_output), before any allocation: a file cut
  /// anywhere gives short_output, whichever field the cut falls in.
  bool count_fits(uint64_t count, uint64_t min_element_size, const char* what) {
    if (r_.can_hold(count, min_element_size)) return true;
    return fail(Status::short_output, "truncated input: %s = %llu needs at least %llu bytes each, only %zu remain",
                what, static_cast<unsigned long long>(count), static_cast<unsigned long long>(min_element_size),
                r_.remaining());
  }
  bool u8(uint8_t& out, const char* what) { return scalar(out, what); }
  bool u32(uint32_t& out, const char* what) { return scalar(out, what); }
  bool i32(int32_t& out, const char* what) { return scalar(out, what); }
  /// A header float: NaN and ±Inf are rejected.
  bool finite_f32(float& out, const char* what) {
    if (!need(1, 4, what)) return false;
    const size_t at = r_.offset();
    out = r_.f32();
    if (std::isfinite(out)) return true;
    r_.seek(at);
    return fail(Status::bad_data, "NaN in header: %s is %g, expected a finite number", what, static_cast<double>(out));
  }
  bool fixed_string(std::string& out, size_t n, const char* what) {
    if (!need(n, 1, what)) return false;
    out = r_.fixed_string(n);
    return true;
  }
  bool sized_string(std::string& out, uint64_t max_len, const char* what) {
    uint32_t n = 0;
    if (!u32(n, what)) return false;
    if (n > max_len)
      return fail(Status::bad_data, "oversized count: %s length %u exceeds the limit %llu", what, n,
                  static_cast<unsigned long long>(max_len));
    if (!count_fits(n, 1, what)) return false;
    auto s = r_.take(n);
    out.assign(reinterpret_cast<const char*>(s.data()), s.size());
    return true;
  }

  /// Reads `count` scalars of `scalar_size` bytes into floats. Precondition: need() passed.
  bool scalars(float* out, uint64_t count, uint8_t scalar_size, const char* what) {
    if (!need(count, scalar_size, what)) return false;
    const size_t start = r_.offset();
    auto bytes = r_.take(static_cast<size_t>(count * scalar_size));
    const uint8_t* p = bytes.data();
    if (scalar_size == 4) {
      if (count) std::memcpy(out, p, static_cast<size_t>(count) * 4);
    } else if (scalar_size == 2) {
      for (uint64_t i = 0; i < count; ++i) {
        uint16_t h;
        std::memcpy(&h, p + 2 * i, 2);
        out[i] = half_bits_to_float(h);
      }
    } else {
      for (uint64_t i = 0; i < count; ++i) {
        double d;
        std::memcpy(&d, p + 8 * i, 8);
        out[i] = static_cast<float>(d);
      }
    }
    for (uint64_t i = 0; i < count; ++i) {
      if (!std::isfinite(out[i])) {
        r_.seek(start + static_cast<size_t>(i * scalar_size));
        return fail(Status::bad_data, "%s: element %llu is not finite (%g)", what, static_cast<unsigned long long>(i),
                    static_cast<double>(out[i]));
      }
    }
    return true;
  }

 private:
  // Reads one little-endian T named `what` (false, with the error set, when it is truncated).
  template <class T>
  bool scalar(T& out, const char* what) {
    if (!need(1, sizeof(T), what)) return false;
    out = r_.read<T>();
    return true;
  }

  ByteReader r_;
  Error error_{Status::bad_data, {}};
};

inline constexpr uint32_t kBonnMaxChannels = 64;
inline constexpr uint32_t kBonnMaxDimension = 1u << 20;
inline constexpr uint64_t kBonnMaxXml = uint64_t{1} << 28;
/// Largest view or light count (UBO2014 has 151; counts above this are bad_data).
inline constexpr uint32_t kBonnMaxDirections = 1u << 16;
/// Largest rotation (local frame) count: one per texel at most.
inline constexpr uint64_t kBonnMaxRotations = uint64_t{1} << 24;

/// Names a direction set after UBO2003 or UBO2014 when its angles match one of them exactly
/// in order (the reader keeps the file's angles either way).
inline std::string bonn_direction_set_name(std::span<const std::pair<float, float>> theta_phi, const char* fallback) {
  for (const DirectionSet& known : {DirectionSet::ubo2014(), DirectionSet::ubo2003()}) {
    if (known.size() != theta_phi.size()) continue;
    bool same = true;
    for (size_t i = 0; i < theta_phi.size() && same; ++i) {
      same = known.find_degrees(radians_to_degrees(theta_phi[i].first), radians_to_degrees(theta_phi[i].second),
                                0.05f) == i;
    }
    if (same) return known.name();
  }
  return fallback;
}

inline bool parse_bonn_meta(BonnParser& p, BonnBtfFile& f) {
  auto& r = p.reader();
  const size_t start = r.offset();
  uint32_t size = 0;
  if (!p.u32(size, "meta block size") || !p.u32(f.meta_version, "meta block version")) return false;
  if (f.meta_version < 1) return p.fail(Status::bad_data, "meta block version is 0, expected 1 or more");
  if (size < 8 || !r.can_hold(size - 8, 1)) {
    if (size < 8) return p.fail(Status::bad_data, "size does not match: meta block size %u is smaller than 8", size);
    return p.fail(Status::short_output, "truncated input: meta block declares %u bytes, only %zu remain", size,
                  r.remaining() + 8);
  }
  if (!p.fixed_string(f.measurement_setup, 80, "measurement_setup") ||
      !p.fixed_string(f.image_sensor, 80, "image_sensor") || !p.fixed_string(f.light_source, 80, "light_source") ||
      !p.finite_f32(f.ppmm, "ppmm") || !p.finite_f32(f.rgb_scale[0], "rgb_scale[0]") ||
      !p.finite_f32(f.rgb_scale[1], "rgb_scale[1]") || !p.finite_f32(f.rgb_scale[2], "rgb_scale[2]"))
    return false;
  f.cosine_in_data = false;
  if (f.meta_version > 1) {
    uint32_t flag = 0;
    if (!p.u32(flag, "cosine flag")) return false;
    if (flag > 1) return p.fail(Status::bad_data, "cosine flag is %u, expected 0 or 1", flag);
    f.cosine_in_data = flag != 0;
  }
  f.xml.clear();
  if (f.meta_version > 2 && !p.sized_string(f.xml, kBonnMaxXml, "XML string")) return false;
  f.channel_names = {"R", "G", "B"};
  if (f.meta_version > 3) {
    uint32_t n = 0;
    if (!p.u32(n, "channel count")) return false;
    if (n == 0 || n > kBonnMaxChannels)
      return p.fail(Status::bad_data, "channel count %u, expected 1 to %u", n, kBonnMaxChannels);
    if (!p.count_fits(n, 4, "channel count")) return false;
    f.channel_names.assign(n, {});
    for (uint32_t c = 0; c < n; ++c)
      if (!p.sized_string(f.channel_names[c], 4096, "channel name")) return false;
  }
  const size_t consumed = r.offset() - start;
  if (consumed != size) {
    if (f.meta_version > 4 && consumed < size) {
      // A newer meta block: skip the fields this reader does not know (the size says where
      // the block ends).
      f.warnings.push_back(format_message("meta block version %u is newer than 4: skipped %zu unknown bytes",
                                          f.meta_version, size - consumed));
      return r.seek(start + size);
    }
    r.seek(start);
    return p.fail(Status::bad_data,
                  "size does not match: meta block (version %u) declares %u bytes, its fields use %zu", f.meta_version,
                  size, consumed);
  }
  return true;
}

inline bool parse_bonn_sampling(BonnParser& p, BonnBtfFile& f) {
  auto& r = p.reader();
  uint32_t n_view = 0;
  if (!p.u32(n_view, "view count")) return false;
  if (n_view == 0) return p.fail(Status::bad_data, "view count is 0");
  if (n_view > kBonnMaxDirections)
    return p.fail(Status::bad_data, "oversized count: view count = %u exceeds the limit %u", n_view,
                  kBonnMaxDirections);
  if (!p.count_fits(n_view, 12, "view count")) return false;  // θ, φ, nL per view at least
  std::vector<std::pair<float, float>> views(n_view);
  std::vector<std::pair<float, float>> lights;
  bool lights_differ = false;
  for (uint32_t v = 0; v < n_view; ++v) {
    float t = 0, ph = 0;
    if (!p.finite_f32(t, "view θ") || !p.finite_f32(ph, "view φ")) return false;
    if (t < 0.0f || t > kPi) return p.fail(Status::bad_data, "view %u: θ = %g rad, expected 0 to π", v, double(t));
    views[v] = {t, ph};
    uint32_t n_light = 0;
    if (!p.u32(n_light, "light count")) return false;
    if (n_light == 0) return p.fail(Status::bad_data, "view %u: light count is 0", v);
    if (n_light > kBonnMaxDirections)
      return p.fail(Status::bad_data, "oversized count: view %u: light count = %u exceeds the limit %u", v, n_light,
                    kBonnMaxDirections);
    if (!p.count_fits(n_light, 8, "light count")) return false;
    if (v == 0) {
      lights.resize(n_light);
    } else if (n_light != lights.size()) {
      return p.fail(Status::unsupported, "view %u has %u lights, view 0 has %zu: per-view light counts must agree", v,
                    n_light, lights.size());
    }
    for (uint32_t l = 0; l < n_light; ++l) {
      float lt = 0, lp = 0;
      if (!p.finite_f32(lt, "light θ") || !p.finite_f32(lp, "light φ")) return false;
      if (lt < 0.0f || lt > kPi)
        return p.fail(Status::bad_data, "view %u light %u: θ = %g rad, expected 0 to π", v, l, double(lt));
      if (v == 0) {
        lights[l] = {lt, lp};
      } else if (std::abs(lights[l].first - lt) > 1e-5f || std::abs(lights[l].second - lp) > 1e-5f) {
        lights_differ = true;
      }
    }
  }
  (void)r;
  if (lights_differ)
    f.warnings.push_back("light directions differ between views; view 0's directions are used for all views");
  f.views = DirectionSet::from_radians(bonn_direction_set_name(views, "Bonn views"), views);
  f.lights = DirectionSet::from_radians(bonn_direction_set_name(lights, "Bonn lights"), lights);
  return true;
}

inline bool parse_bonn_factors(BonnParser& p, BonnFactors& out, uint64_t rows_expected, uint64_t cols_expected,
                               uint32_t max_components, const char* what, std::vector<std::string>& warnings) {
  uint32_t k = 0, rows = 0, cols = 0;
  if (!p.u8(out.scalar_size, "scalar size")) return false;
  if (out.scalar_size != 2 && out.scalar_size != 4 && out.scalar_size != 8)
    return p.fail(Status::bad_data, "%s: scalar size %u, expected 2, 4 or 8", what, out.scalar_size);
  if (!p.u32(k, "component count") || !p.u32(rows, "row count") || !p.u32(cols, "column count")) return false;
  bool transposed = false;
  if (rows != rows_expected || cols != cols_expected) {
    if (rows == cols_expected && cols == rows_expected) {
      transposed = true;
    } else {
      return p.fail(Status::bad_data,
                    "size does not match: %s is %u × %u, expected %llu × %llu (angular × spatial samples)", what, rows,
                    cols, static_cast<unsigned long long>(rows_expected),
                    static_cast<unsigned long long>(cols_expected));
    }
  }
  if (k > max_components)
    return p.fail(Status::bad_data, "oversized count: %s has %u components, the header declares at most %u", what, k,
                  max_components);
  // All of S, U and SxV must be in the file before anything is allocated.
  const uint64_t elements = uint64_t{k} * (uint64_t{1} + uint64_t{rows} + uint64_t{cols});
  if (!p.need(elements, out.scalar_size, what)) return false;
  out.s.resize(k);
  if (!p.scalars(out.s.data(), k, out.scalar_size, "S")) return false;
  out.u.resize(rows, k);
  if (!p.scalars(out.u.data(), uint64_t{rows} * k, out.scalar_size, "U")) return false;
  out.sxv.resize(cols, k);
  if (!p.scalars(out.sxv.data(), uint64_t{cols} * k, out.scalar_size, "SxV")) return false;
  if (transposed) {
    std::swap(out.u, out.sxv);
    warnings.push_back(format_message("%s is stored transposed (%u × %u); U and SxV were swapped", what, rows, cols));
  }
  return true;
}

}  // namespace detail

/// Parses a Bonn .btf file held in memory, keeping the factor matrices (converted to float).
/// Returns, with a message naming the field and byte offset:
///   bad_data for a wrong signature, a meta block whose size does not match its fields, NaN/Inf
///   in header floats or matrices, counts that cannot fit in the rest of the file, matrix sizes
///   that do not match nL·nV × w·h, and trailing bytes (unless allowed);
///   short_output for truncated input, wherever the cut falls (a count within its limit whose
///   data does not fit in the rest of the file is truncation; counts above the fixed limits
///   kBonnMaxDirections, kBonnMaxRotations, kBonnMaxXml, kBonnMaxChannels, kBonnMaxDimension or
///   the header's component count are bad_data); unsupported for other Bonn formats (PVF, BDI,
///   older FMF).
/// Safe on untrusted input: every count is checked against the remaining bytes before any
/// allocation, so memory use is bounded by a small multiple of the input size. Thread-safe.
inline Result<BonnBtfFile> read_bonn_btf(std::span<const uint8_t> bytes, const BonnReadOptions& options = {}) {
  detail::BonnParser p(bytes);
  auto& r = p.reader();
  BonnBtfFile f;
  if (bytes.size() < 10)
    return make_error(Status::short_output, "bonn btf: truncated input: %zu bytes, the signature alone needs 10",
                      bytes.size());
  const std::string sig = detail::printable_signature(bytes.first(10));
  if (r.match(kBonnDfmfSignature)) {
    f.format = BonnFormat::dfmf;
  } else if (r.match(kBonnFmfSignature)) {
    f.format = BonnFormat::fmf;
  } else if (sig.rfind("!FMF06FC", 0) == 0 || sig.rfind("!PVF06FC", 0) == 0) {
    // Older Bonn formats btflib lists (FMF without the header-version byte, per-view PCA).
    return make_error(Status::unsupported,
                      "bonn btf: signature '%s' is a Bonn format this reader does not handle "
                      "(supported: %s, %s)",
                      sig.c_str(), kBonnDfmfSignature.data(), kBonnFmfSignature.data());
  } else {
    return make_error(Status::bad_data, "bonn btf: wrong signature '%s', expected '%s' or '%s'", sig.c_str(),
                      kBonnDfmfSignature.data(), kBonnFmfSignature.data());
  }
  if (!detail::parse_bonn_meta(p, f) || !detail::parse_bonn_sampling(p, f)) return p.error();
  uint32_t w = 0, h = 0;
  if (!p.u32(w, "width") || !p.u32(h, "height")) return p.error();
  if (w == 0 || h == 0 || w > detail::kBonnMaxDimension || h > detail::kBonnMaxDimension) {
    p.fail(Status::bad_data, "texture size %u × %u, expected 1 to %u per side", w, h, detail::kBonnMaxDimension);
    return p.error();
  }
  f.width = static_cast<int>(w);
  f.height = static_cast<int>(h);
  // Both supported signatures end in 'R': a rotations block follows.
  uint32_t n_rot = 0;
  if (!p.u32(n_rot, "rotation count")) return p.error();
  if (n_rot > detail::kBonnMaxRotations) {
    p.fail(Status::bad_data, "oversized count: rotation count = %u exceeds the limit %llu", n_rot,
           static_cast<unsigned long long>(detail::kBonnMaxRotations));
    return p.error();
  }
  if (!p.count_fits(n_rot, 36, "rotation count")) return p.error();
  f.rotations.resize(n_rot);
  for (auto& m : f.rotations)
    for (float& e : m)
      if (!p.finite_f32(e, "rotation matrix element")) return p.error();

  const uint64_t n_angular = uint64_t{f.views.size()} * f.lights.size();
  const uint64_t n_spatial = uint64_t{w} * h;
  if (f.format == BonnFormat::dfmf) {
    if (!p.u32(f.max_components, "component count") || !p.i32(f.color_model, "colour model")) return p.error();
    for (float& e : f.color_mean)
      if (!p.finite_f32(e, "colour mean")) return p.error();
    for (float& e : f.color_matrix)
      if (!p.finite_f32(e, "colour transformation matrix")) return p.error();
    // Each channel block is at least 13 bytes: reject a hostile channel count before resizing.
    if (!p.count_fits(f.channel_count(), 13, "channel count")) return p.error();
    f.factors.resize(f.channel_count());
    for (size_t c = 0; c < f.factors.size(); ++c) {
      const std::string what = "channel " + std::to_string(c) + " (" + f.channel_names[c] + ")";
      if (!detail::parse_bonn_factors(p, f.factors[c], n_angular, n_spatial, f.max_components, what.c_str(),
                                      f.warnings))
        return p.error();
    }
  } else {
    if (!p.u8(f.fmf_header_version, "FMF header version")) return p.error();
    if (f.fmf_header_version >= 3) {
      p.fail(Status::unsupported, "FMF header version %u, this reader handles 0 to 2", f.fmf_header_version);
      return p.error();
    }
    if (f.fmf_header_version >= 1 && !p.u32(f.dynamic_range_reduction, "dynamic range reduction method"))
      return p.error();
    if (f.fmf_header_version >= 2) {
      uint32_t hr = 0, hc = 0;
      if (!p.u32(hr, "height map rows") || !p.u32(hc, "height map columns")) return p.error();
      if (hr > detail::kBonnMaxDimension || hc > detail::kBonnMaxDimension) {
        p.fail(Status::bad_data, "oversized count: height map %u × %u", hr, hc);
        return p.error();
      }
      if (!p.count_fits(uint64_t{hr} * hc, 2, "height map samples")) return p.error();
      // btflib's writer stores (width, height), its reader and btflod read (rows, cols). The
      // texture size decides when it can: a non-square map of the texture's transposed size.
      f.height_map_width_first = hr != hc && hr == w && hc == h;
      if (f.height_map_width_first) {
        std::swap(hr, hc);
        f.warnings.push_back(
            format_message("FMF height map header stores width first (%u × %u for a %u × %u "
                           "texture); read as %u rows × %u columns",
                           hc, hr, w, h, hr, hc));
      }
      f.height_map_rows = static_cast<int>(hr);
      f.height_map_cols = static_cast<int>(hc);
      f.height_map.resize(uint64_t{hr} * hc);
      if (!p.scalars(f.height_map.data(), f.height_map.size(), 2, "height map")) return p.error();
    }
    if (!p.u32(f.max_components, "component count")) return p.error();
    f.factors.resize(1);
    if (!detail::parse_bonn_factors(p, f.factors[0], n_angular * f.channel_count(), n_spatial, f.max_components,
                                    "FMF matrix", f.warnings))
      return p.error();
  }
  if (r.remaining() != 0) {
    if (!options.allow_trailing_bytes) {
      p.fail(Status::bad_data, "trailing bytes: %zu bytes after the last matrix (file has %zu)", r.remaining(),
             r.size());
      return p.error();
    }
    f.warnings.push_back(format_message("ignored %zu trailing bytes at offset %zu", r.remaining(), r.offset()));
  }
  return f;
}

/// Reads and parses a Bonn .btf file; see the span overload. Errors are prefixed with the path.
inline Result<BonnBtfFile> read_bonn_btf(const std::string& path, const BonnReadOptions& options = {}) {
  auto bytes = read_file_bytes(path, options.max_file_bytes);
  if (!bytes) return bytes.error();
  auto f = read_bonn_btf(std::span<const uint8_t>(*bytes), options);
  if (!f) return Error{f.status(), path + ": " + f.message()};
  return f;
}

/// Converts one decorrelated sample (3 channels) back to RGB for a DFMF colour model
/// (btflib's undecorrelate). Returns false for models that are not supported.
inline bool bonn_undecorrelate(int32_t model, const std::array<float, 3>& mean, const std::array<float, 9>& matrix,
                               float eps, float (&v)[3]) noexcept {
  auto yuv_to_rgb = [](float(&c)[3]) {
    const float y = c[0], u = c[1], w = c[2];
    c[0] = y + 1.13983f * w;
    c[1] = y - 0.39465f * u - 0.5806f * w;
    c[2] = y + 2.03211f * u;
  };
  switch (static_cast<BonnColorModel>(model)) {
    case BonnColorModel::rgb:
      return true;
    case BonnColorModel::yuv:
      yuv_to_rgb(v);
      return true;
    case BonnColorModel::pca: {
      // row vector · matrix + mean
      const float a = v[0], b = v[1], c = v[2];
      for (int j = 0; j < 3; ++j)
        v[j] = a * matrix[0 * 3 + j] + b * matrix[1 * 3 + j] + c * matrix[2 * 3 + j] + mean[j];
      return true;
    }
    case BonnColorModel::ycocg: {
      const float y = v[0], co = v[1], cg = v[2];
      v[0] = y + co - cg;
      v[1] = y + cg;
      v[2] = y - co - cg;
      return true;
    }
    case BonnColorModel::ylog_uv:
      v[0] = std::exp(v[0]) - eps;
      yuv_to_rgb(v);
      return true;
    case BonnColorModel::ylog_ulog_vlog:
      v[0] = std::exp(v[0]) - eps;
      for (int j = 1; j < 3; ++j) v[j] = std::copysign(std::exp(std::abs(v[j]) + std::log(eps)), v[j]);
      yuv_to_rgb(v);
      return true;
    case BonnColorModel::ylog_udivy_vdivy:
      v[0] = std::exp(v[0]) - eps;
      v[1] *= v[0] + eps;
      v[2] *= v[0] + eps;
      yuv_to_rgb(v);
      return true;
    case BonnColorModel::log_rgb:
      for (float& c : v) c = std::exp(c) - eps;
      return true;
    default:
      return false;
  }
}

/// Multiplies the factors back into a tabulated BTF in linear RGB: U · SxVᵀ per channel, then
/// the colour model is undone (DFMF), the dynamic-range reduction undone (FMF: exp(v) − eps),
/// and the cosine divided out (when the file's flag says it is in the data and
/// options.remove_cosine; samples with cos θ_light ≤ 1e-6 become 0) or multiplied in (when the
/// flag says it is not, options.add_cosine and not options.remove_cosine).
/// Returns unsupported for colour models lab/spectral or a channel count other than 3;
/// insufficient_space when W·H·nV·nL·3 exceeds options.max_samples; invalid_argument when the
/// factor shapes are inconsistent (only possible for a hand-built BonnBtfFile).
/// Uses the thread pool for the products; the result is deterministic.
inline Result<BtfFloat> reconstruct_bonn_btf(const BonnBtfFile& f, const BonnReconstructOptions& options = {}) {
  if (f.channel_count() != 3)
    return make_error(Status::unsupported, "bonn btf: %zu channels; reconstruction to RGB needs 3", f.channel_count());
  if (f.format == BonnFormat::dfmf) {
    float probe[3] = {0.0f, 0.0f, 0.0f};
    if (!bonn_undecorrelate(f.color_model, f.color_mean, f.color_matrix, kBonnLogEpsilon, probe))
      return make_error(Status::unsupported, "bonn btf: colour model %d is not supported (supported: 0, 1, 3, 4, 9-12)",
                        f.color_model);
  }
  auto count = BtfFloat::checked_sample_count(f.width, f.height, f.views.size(), f.lights.size(), options.max_samples);
  if (!count) return count.error();
  const size_t n_angular = f.views.size() * f.lights.size();
  const size_t n_spatial = static_cast<size_t>(f.width) * static_cast<size_t>(f.height);
  const size_t expected_factors = f.format == BonnFormat::dfmf ? 3 : 1;
  if (f.factors.size() != expected_factors)
    return make_error(Status::invalid_argument, "bonn btf: %zu factor blocks, expected %zu", f.factors.size(),
                      expected_factors);
  for (const auto& fac : f.factors) {
    const size_t rows = f.format == BonnFormat::dfmf ? n_angular : n_angular * 3;
    if (static_cast<size_t>(fac.u.rows()) != rows || static_cast<size_t>(fac.sxv.rows()) != n_spatial ||
        fac.u.cols() != fac.sxv.cols())
      return make_error(Status::invalid_argument,
                        "bonn btf: factor shapes U %ldx%ld, SxV %ldx%ld do not match %zu x %zu",
                        static_cast<long>(fac.u.rows()), static_cast<long>(fac.u.cols()),
                        static_cast<long>(fac.sxv.rows()), static_cast<long>(fac.sxv.cols()), rows, n_spatial);
  }
  BtfFloat btf(f.width, f.height, f.views, f.lights);
  float* out = btf.samples().data();
  const size_t n_light = f.lights.size();
  ThreadPool& pool = options.pool ? *options.pool : default_thread_pool();
  // One angular row r = l + nL·v at a time: the BTF layout stores (v·nL + l) images
  // contiguously, so row r of U · SxVᵀ is exactly the image at offset r·W·H·3.
  pool.parallel_for(0, n_angular, 4, [&](size_t begin, size_t end) {
    Eigen::RowVectorXf row(static_cast<Eigen::Index>(n_spatial));
    for (size_t r = begin; r < end; ++r) {
      float* img = out + r * n_spatial * 3;
      for (int c = 0; c < 3; ++c) {
        if (f.format == BonnFormat::dfmf) {
          const auto& fac = f.factors[static_cast<size_t>(c)];
          row.noalias() = fac.u.row(static_cast<Eigen::Index>(r)) * fac.sxv.transpose();
        } else {
          // FMF: row c + nC·r (see the header comment: documented interpretation).
          const auto& fac = f.factors[0];
          row.noalias() = fac.u.row(static_cast<Eigen::Index>(c + 3 * r)) * fac.sxv.transpose();
        }
        for (size_t i = 0; i < n_spatial; ++i) img[i * 3 + static_cast<size_t>(c)] = row[static_cast<Eigen::Index>(i)];
      }
      const size_t l = r % n_light;
      const float cos_l = std::cos(f.lights[l].theta);
      const bool divide = f.cosine_in_data && options.remove_cosine;
      const bool multiply = !f.cosine_in_data && options.add_cosine && !options.remove_cosine;
      for (size_t i = 0; i < n_spatial; ++i) {
        float v[3] = {img[i * 3], img[i * 3 + 1], img[i * 3 + 2]};
        if (f.format == BonnFormat::dfmf) {
          bonn_undecorrelate(f.color_model, f.color_mean, f.color_matrix, kBonnLogEpsilon, v);
        } else if (f.dynamic_range_reduction != 0) {
          for (float& e : v) e = std::exp(e) - kBonnLogEpsilon;
        }
        if (divide) {
          for (float& e : v) e = cos_l > 1e-6f ? e / cos_l : 0.0f;
        } else if (multiply) {
          for (float& e : v) e *= std::max(cos_l, 0.0f);
        }
        img[i * 3] = v[0];
        img[i * 3 + 1] = v[1];
        img[i * 3 + 2] = v[2];
      }
    }
  });
  return btf;
}

namespace detail {

inline void write_bonn_scalars(ByteWriter& w, const float* v, size_t n, uint8_t scalar_size) {
  for (size_t i = 0; i < n; ++i) {
    if (scalar_size == 2) {
      w.u16(float_to_half_bits(v[i]));
    } else if (scalar_size == 8) {
      w.write(static_cast<double>(v[i]));
    } else {
      w.f32(v[i]);
    }
  }
}

inline void write_bonn_factors(ByteWriter& w, const BonnFactors& fac) {
  const auto k = static_cast<uint32_t>(fac.u.cols());
  w.u8(fac.scalar_size);
  w.u32(k);
  w.u32(static_cast<uint32_t>(fac.u.rows()));
  w.u32(static_cast<uint32_t>(fac.sxv.rows()));
  std::vector<float> s(fac.s);
  s.resize(k, 0.0f);
  write_bonn_scalars(w, s.data(), k, fac.scalar_size);
  write_bonn_scalars(w, fac.u.data(), static_cast<size_t>(fac.u.size()), fac.scalar_size);
  write_bonn_scalars(w, fac.sxv.data(), static_cast<size_t>(fac.sxv.size()), fac.scalar_size);
}

}  // namespace detail

/// Serialises a BonnBtfFile (DFMF or FMF, as f.format says) into the layout read by
/// read_bonn_btf(); the meta block is written in f.meta_version's layout (1 to 4), so a file
/// read and re-encoded gives the same bytes. Returns invalid_argument (naming the problem) for
/// inconsistent shapes, a scalar size other than 2/4/8, non-finite header floats, or an empty
/// BTF. Thread-safe.
inline Result<std::vector<uint8_t>> encode_bonn_btf(const BonnBtfFile& f) {
  if (f.width <= 0 || f.height <= 0 || f.views.empty() || f.lights.empty())
    return make_error(Status::invalid_argument, "encode_bonn_btf: empty BTF (%dx%d, %zu views, %zu lights)", f.width,
                      f.height, f.views.size(), f.lights.size());
  if (f.meta_version < 1 || f.meta_version > 4)
    return make_error(Status::invalid_argument, "encode_bonn_btf: meta version %u, expected 1 to 4", f.meta_version);
  if (f.meta_version <= 3 && f.channel_count() != 3)
    return make_error(Status::invalid_argument, "encode_bonn_btf: meta version %u implies 3 channels, have %zu",
                      f.meta_version, f.channel_count());
  if (f.channel_count() == 0 || f.channel_count() > detail::kBonnMaxChannels)
    return make_error(Status::invalid_argument, "encode_bonn_btf: %zu channels", f.channel_count());
  const size_t n_angular = f.views.size() * f.lights.size();
  const size_t n_spatial = static_cast<size_t>(f.width) * static_cast<size_t>(f.height);
  const size_t blocks = f.format == BonnFormat::dfmf ? f.channel_count() : 1;
  const size_t rows = f.format == BonnFormat::dfmf ? n_angular : n_angular * f.channel_count();
  if (f.factors.size() != blocks)
    return make_error(Status::invalid_argument, "encode_bonn_btf: %zu factor blocks, expected %zu", f.factors.size(),
                      blocks);
  uint32_t max_k = 0;
  for (const auto& fac : f.factors) {
    if (fac.scalar_size != 2 && fac.scalar_size != 4 && fac.scalar_size != 8)
      return make_error(Status::invalid_argument, "encode_bonn_btf: scalar size %u, expected 2, 4 or 8",
                        fac.scalar_size);
    if (static_cast<size_t>(fac.u.rows()) != rows || static_cast<size_t>(fac.sxv.rows()) != n_spatial ||
        fac.u.cols() != fac.sxv.cols() || fac.s.size() > static_cast<size_t>(fac.u.cols()))
      return make_error(Status::invalid_argument,
                        "encode_bonn_btf: U %ldx%ld, SxV %ldx%ld, S %zu do not match %zu x %zu with equal k",
                        static_cast<long>(fac.u.rows()), static_cast<long>(fac.u.cols()),
                        static_cast<long>(fac.sxv.rows()), static_cast<long>(fac.sxv.cols()), fac.s.size(), rows,
                        n_spatial);
    max_k = std::max(max_k, static_cast<uint32_t>(fac.u.cols()));
  }
  if (f.max_components > max_k) max_k = f.max_components;
  auto finite = [](std::span<const float> v) {
    return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
  };
  if (!std::isfinite(f.ppmm) || !finite(f.rgb_scale) || !finite(f.color_mean) || !finite(f.color_matrix))
    return make_error(Status::invalid_argument, "encode_bonn_btf: non-finite header float");

  ByteWriter w;
  w.text(f.format == BonnFormat::dfmf ? kBonnDfmfSignature : kBonnFmfSignature);
  const size_t meta_start = w.size();
  w.u32(0);  // patched below
  w.u32(f.meta_version);
  w.fixed_string(f.measurement_setup, 80);
  w.fixed_string(f.image_sensor, 80);
  w.fixed_string(f.light_source, 80);
  w.f32(f.ppmm);
  for (float v : f.rgb_scale) w.f32(v);
  if (f.meta_version > 1) w.u32(f.cosine_in_data ? 1u : 0u);
  if (f.meta_version > 2) {
    w.u32(static_cast<uint32_t>(f.xml.size()));
    w.text(f.xml);
  }
  if (f.meta_version > 3) {
    w.u32(static_cast<uint32_t>(f.channel_count()));
    for (const auto& name : f.channel_names) {
      w.u32(static_cast<uint32_t>(name.size()));
      w.text(name);
    }
  }
  w.patch(meta_start, static_cast<uint32_t>(w.size() - meta_start));
  w.u32(static_cast<uint32_t>(f.views.size()));
  for (const auto& v : f.views) {
    w.f32(v.theta);
    w.f32(v.phi);
    w.u32(static_cast<uint32_t>(f.lights.size()));
    for (const auto& l : f.lights) {
      w.f32(l.theta);
      w.f32(l.phi);
    }
  }
  w.u32(static_cast<uint32_t>(f.width));
  w.u32(static_cast<uint32_t>(f.height));
  w.u32(static_cast<uint32_t>(f.rotations.size()));
  for (const auto& m : f.rotations)
    for (float e : m) w.f32(e);
  if (f.format == BonnFormat::dfmf) {
    w.u32(max_k);
    w.write(f.color_model);
    for (float v : f.color_mean) w.f32(v);
    for (float v : f.color_matrix) w.f32(v);
    for (const auto& fac : f.factors) detail::write_bonn_factors(w, fac);
  } else {
    w.u8(f.fmf_header_version > 2 ? 2 : f.fmf_header_version);
    if (f.fmf_header_version >= 1) w.u32(f.dynamic_range_reduction);
    if (f.fmf_header_version >= 2) {
      if (f.height_map.size() != static_cast<size_t>(f.height_map_rows) * static_cast<size_t>(f.height_map_cols))
        return make_error(Status::invalid_argument, "encode_bonn_btf: height map has %zu samples, expected %d x %d",
                          f.height_map.size(), f.height_map_rows, f.height_map_cols);
      w.u32(static_cast<uint32_t>(f.height_map_width_first ? f.height_map_cols : f.height_map_rows));
      w.u32(static_cast<uint32_t>(f.height_map_width_first ? f.height_map_rows : f.height_map_cols));
      detail::write_bonn_scalars(w, f.height_map.data(), f.height_map.size(), 2);
    }
    w.u32(max_k);
    detail::write_bonn_factors(w, f.factors[0]);
  }
  return w.take();
}

/// Writes a DFMF file (signature !DFMF08FCR) from factor matrices. Precondition:
/// f.format == BonnFormat::dfmf (else invalid_argument). Errors as encode_bonn_btf() plus
/// io_error naming the path; the file is replaced atomically.
inline VoidResult write_bonn_dfmf(const std::string& path, const BonnBtfFile& f) {
  if (f.format != BonnFormat::dfmf)
    return make_error(Status::invalid_argument, "%s: write_bonn_dfmf needs a DFMF file, got FMF", path.c_str());
  auto bytes = encode_bonn_btf(f);
  if (!bytes) return Error{bytes.status(), path + ": " + bytes.message()};
  return write_file_bytes(path, *bytes);
}

/// Options of factorize_bonn_dfmf().
struct DfmfFactorizeOptions {
  /// Components kept per channel (clamped to min(nL·nV, W·H)).
  int components = 16;
  /// rgb, yuv or ycocg (the linear models); others return unsupported.
  BonnColorModel color_model = BonnColorModel::rgb;
  /// Scalar size written for the matrices: 2 (half, as btflib writes) or 4 (float).
  uint8_t scalar_size = 4;
  /// What the BTF's samples hold; sets the file's cosine flag (btflib: 1 = "the cosine is
  /// already multiplied into the data"). The default is btflod's convention (ρ·cosθ_l), which
  /// the synthesiser, sample_to_btf() and the image-folder readers produce.
  BtfValueConvention values = BtfValueConvention::abrdf_cos_light;
  ProgressCallback progress;
};

/// Factorises a tabulated BTF into DFMF form: the samples are decorrelated with the colour
/// model, then each channel's (nL·nV) × (W·H) matrix A_c (row l + nL·v, column x + W·y) gets an
/// exact truncated SVD A_c ≈ U_k · (V_k · diag(S_k))ᵀ with Eigen's BDCSVD (paper 000, §3.1:
/// FMF by SVD; Eckart–Young optimal at rank k). Cost is O(rows · cols · min(rows, cols)) per
/// channel: meant for small demo materials (e.g. 32×32 texels × 81×81 directions takes
/// seconds); the factor/ area has the scalable factorisations.
/// Returns invalid_argument for an empty BTF or components < 1, unsupported for a non-linear
/// colour model, cancelled when the progress callback asks. Thread-safe (no shared state).
inline Result<BonnBtfFile> factorize_bonn_dfmf(const BtfFloat& btf, const DfmfFactorizeOptions& options = {}) {
  if (btf.empty() || btf.width() <= 0 || btf.height() <= 0)
    return make_error(Status::invalid_argument, "factorize_bonn_dfmf: empty BTF");
  if (options.components < 1)
    return make_error(Status::invalid_argument, "factorize_bonn_dfmf: components = %d, expected >= 1",
                      options.components);
  if (options.scalar_size != 2 && options.scalar_size != 4 && options.scalar_size != 8)
    return make_error(Status::invalid_argument, "factorize_bonn_dfmf: scalar size %u", options.scalar_size);
  Eigen::Matrix3f to_rgb = Eigen::Matrix3f::Identity();
  switch (options.color_model) {
    case BonnColorModel::rgb:
      break;
    case BonnColorModel::yuv:
      to_rgb << 1, 0, 1.13983f, 1, -0.39465f, -0.5806f, 1, 2.03211f, 0;
      break;
    case BonnColorModel::ycocg:
      to_rgb << 1, 1, -1, 1, 0, 1, 1, -1, -1;
      break;
    default:
      return make_error(Status::unsupported, "factorize_bonn_dfmf: colour model %d is not linear",
                        static_cast<int>(options.color_model));
  }
  const Eigen::Matrix3f from_rgb = to_rgb.inverse();
  const auto rows = static_cast<Eigen::Index>(btf.view_count() * btf.light_count());
  const auto cols = static_cast<Eigen::Index>(btf.texel_count());
  const Eigen::Index k = std::min<Eigen::Index>(options.components, std::min(rows, cols));

  BonnBtfFile f;
  f.format = BonnFormat::dfmf;
  f.views = btf.views();
  f.lights = btf.lights();
  f.width = btf.width();
  f.height = btf.height();
  f.color_model = static_cast<int32_t>(options.color_model);
  f.cosine_in_data = options.values == BtfValueConvention::abrdf_cos_light;
  f.max_components = static_cast<uint32_t>(k);
  f.measurement_setup = "btflod factorize_bonn_dfmf";
  f.channel_names = {"R", "G", "B"};
  f.factors.resize(3);
  const float* samples = btf.samples().data();
  Eigen::MatrixXf a(rows, cols);
  for (int c = 0; c < 3; ++c) {
    if (!report_progress(options.progress, "factorize", c / 3.0))
      return make_error(Status::cancelled, "factorize_bonn_dfmf: cancelled");
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index i = 0; i < cols; ++i) {
        const float* px = samples + (static_cast<size_t>(r) * static_cast<size_t>(cols) + static_cast<size_t>(i)) * 3;
        a(r, i) = from_rgb(c, 0) * px[0] + from_rgb(c, 1) * px[1] + from_rgb(c, 2) * px[2];
      }
    const ThinSvd svd = exact_thin_svd(a);  // BDCSVD, instantiated once in the implementation TU
    auto& fac = f.factors[static_cast<size_t>(c)];
    fac.scalar_size = options.scalar_size;
    fac.s.resize(static_cast<size_t>(k));
    for (Eigen::Index j = 0; j < k; ++j) fac.s[static_cast<size_t>(j)] = svd.s[j];
    fac.u = svd.u.leftCols(k);
    fac.sxv = svd.v.leftCols(k) * svd.s.head(k).asDiagonal();
  }
  report_progress(options.progress, "factorize", 1.0);
  return f;
}

/// Convenience for demos: factorises `btf` (factorize_bonn_dfmf) and writes the DFMF file.
/// Errors as factorize_bonn_dfmf() and write_bonn_dfmf().
inline VoidResult write_bonn_dfmf(const std::string& path, const BtfFloat& btf,
                                  const DfmfFactorizeOptions& options = {}) {
  auto f = factorize_bonn_dfmf(btf, options);
  if (!f) return Error{f.status(), path + ": " + f.message()};
  return write_bonn_dfmf(path, *f);
}

/// Convenience: read_bonn_btf(path) followed by reconstruct_bonn_btf(). Errors of both, with
/// the path. Safe on untrusted files.
inline Result<BtfFloat> load_bonn_btf(const std::string& path, const BonnReadOptions& read_options = {},
                                      const BonnReconstructOptions& options = {}) {
  auto f = read_bonn_btf(path, read_options);
  if (!f) return f.error();
  auto btf = reconstruct_bonn_btf(*f, options);
  if (!btf) return Error{btf.status(), path + ": " + btf.message()};
  return btf;
}

}  // namespace btflod
