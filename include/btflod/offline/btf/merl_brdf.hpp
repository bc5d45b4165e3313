// btflod — isotropic BRDFs in the MERL database's ".binary" format (Matusik et al., "A
// Data-Driven Reflectance Model", 2003: 100 measured materials), read into MeasuredBrdf
// (offline/btf/measured_brdf.hpp) by resampling onto its (θ_in, θ_out, φ_diff) grid.
//
// File layout (little-endian):
//   i32 dims[3] = 90, 90, 180            (θ_h, θ_d, φ_d sample counts)
//   f64 values[3 · 90 · 90 · 180]        three colour planes (R, G, B), 1,458,000 each
// Sample (i_h, i_d, i_p) of plane c is values[c · N + (i_h · 90 + i_d) · 180 + i_p] with
// N = 1,458,000, in Rusinkiewicz's half/difference coordinates (θ_h, θ_d, φ_d):
//   θ_h = (i_h / 90)² · π/2   (square-root mapping: more samples near the specular peak)
//   θ_d = i_d · (π/2) / 90
//   φ_d = i_p · π / 180       (φ_d ∈ [0, π); reciprocity maps φ_d < 0 to φ_d + π)
// and the BRDF value is values · scale_c with scale = (1/1500, 1.15/1500, 1.66/1500).
// Negative values mean "not measured" (MERL's grazing-angle holes): they are never used as
// data; the reader counts them and interpolates from the measured neighbours only.
// Facts only (the published format description); no code copied.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/core/bytes.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/result.hpp"
#include "btflod/offline/btf/measured_brdf.hpp"

namespace btflod {

inline constexpr int32_t kMerlThetaHalfCount = 90;
inline constexpr int32_t kMerlThetaDiffCount = 90;
inline constexpr int32_t kMerlPhiDiffCount = 180;
/// Samples per colour plane: 90 · 90 · 180 = 1,458,000.
inline constexpr size_t kMerlPlaneSize = size_t{90} * 90 * 180;
/// Exact size of a MERL .binary file: 12 header bytes + 3 planes of doubles.
inline constexpr size_t kMerlFileBytes = 12 + 3 * kMerlPlaneSize * sizeof(double);
/// Colour scales applied to the stored values (R, G, B).
inline constexpr std::array<double, 3> kMerlScale{1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};

/// Rusinkiewicz half/difference angles of an isotropic BRDF sample, radians.
struct HalfDiffAngles {
  double theta_half = 0.0;  ///< [0, π/2]
  double theta_diff = 0.0;  ///< [0, π/2]
  double phi_diff = 0.0;    ///< (−π, π]
};

/// Half/difference angles of a light and a view direction (local frame, z = normal, both
/// pointing away from the surface, need not be normalised): h = normalise(l + v), θ_h = acos h_z,
/// φ_h = atan2(h_y, h_x); d = l rotated by −φ_h about z then by −θ_h about y; θ_d = acos d_z,
/// φ_d = atan2(d_y, d_x). Returns zeros for a zero or non-finite input. noexcept, thread-safe.
inline HalfDiffAngles half_diff_from_directions(glm::dvec3 light, glm::dvec3 view) noexcept {
  const double ll = glm::length(light), lv = glm::length(view);
  if (!(ll > 0.0) || !(lv > 0.0) || !std::isfinite(ll) || !std::isfinite(lv)) return {};
  light /= ll;
  view /= lv;
  glm::dvec3 h = light + view;
  const double lh = glm::length(h);
  if (!(lh > 1e-12)) return {0.5 * 3.14159265358979323846, 0.5 * 3.14159265358979323846, 0.0};
  h /= lh;
  HalfDiffAngles a;
  a.theta_half = std::acos(std::clamp(h.z, -1.0, 1.0));
  const double phi_half = std::atan2(h.y, h.x);
  // Rotate the light by −φ_h about z, then by −θ_h about y.
  const double cz = std::cos(-phi_half), sz = std::sin(-phi_half);
  const glm::dvec3 t(light.x * cz - light.y * sz, light.x * sz + light.y * cz, light.z);
  const double cy = std::cos(-a.theta_half), sy = std::sin(-a.theta_half);
  const glm::dvec3 d(t.x * cy + t.z * sy, t.y, -t.x * sy + t.z * cy);
  a.theta_diff = std::acos(std::clamp(d.z, -1.0, 1.0));
  a.phi_diff = std::atan2(d.y, d.x);
  return a;
}

/// Light and view directions (unit, local frame) of half/difference angles with φ_h = 0: the
/// inverse of half_diff_from_directions for isotropic BRDFs. noexcept, thread-safe.
inline void directions_from_half_diff(const HalfDiffAngles& a, glm::dvec3& light, glm::dvec3& view) noexcept {
  const double st = std::sin(a.theta_diff), ct = std::cos(a.theta_diff);
  const glm::dvec3 d(st * std::cos(a.phi_diff), st * std::sin(a.phi_diff), ct);
  const glm::dvec3 e(-d.x, -d.y, d.z);  // the view in the half-vector frame
  const double cy = std::cos(a.theta_half), sy = std::sin(a.theta_half);
  auto rot = [&](glm::dvec3 p) { return glm::dvec3(p.x * cy + p.z * sy, p.y, -p.x * sy + p.z * cy); };
  light = rot(d);
  view = rot(e);
}

/// A MERL table as stored: 3 planes of kMerlPlaneSize doubles (unscaled; negative = not
/// measured). Lookups interpolate trilinearly in index space (θ_h through the square-root
/// mapping, φ_d periodic with period π) over measured samples only.
class MerlTable {
 public:
  MerlTable() = default;
  /// Precondition: values.size() == 3 · kMerlPlaneSize.
  explicit MerlTable(std::vector<double> values) : values_(std::move(values)) {}

  std::span<const double> values() const noexcept { return values_; }
  bool empty() const noexcept { return values_.size() != 3 * kMerlPlaneSize; }

  /// Stored value of sample (i_h, i_d, i_p), plane c. Precondition: indices in range.
  double raw(int i_h, int i_d, int i_p, int c) const noexcept {
    return values_[static_cast<size_t>(c) * kMerlPlaneSize +
                   (static_cast<size_t>(i_h) * kMerlThetaDiffCount + static_cast<size_t>(i_d)) * kMerlPhiDiffCount +
                   static_cast<size_t>(i_p)];
  }

  /// Scaled BRDF value ρ (linear RGB, 1/sr) at half/difference angles; `measured` (optional)
  /// receives false when no measured sample surrounds the point or an angle is NaN (the value
  /// is then 0). Any input is safe: infinite angles clamp to the table's range.
  /// noexcept, allocation-free, thread-safe.
  glm::dvec3 lookup(const HalfDiffAngles& a, bool* measured = nullptr) const noexcept {
    if (measured) *measured = false;
    if (empty()) return glm::dvec3(0.0);
    // NaN angles name no direction (std::clamp passes NaN through, and NaN → int is undefined):
    // reported as not measured.
    if (std::isnan(a.theta_half) || std::isnan(a.theta_diff)) return glm::dvec3(0.0);
    constexpr double kHalfPi = 0.5 * 3.14159265358979323846, kPiD = 3.14159265358979323846;
    const double th = std::clamp(a.theta_half, 0.0, kHalfPi);
    const double td = std::clamp(a.theta_diff, 0.0, kHalfPi);
    double pd = std::isfinite(a.phi_diff) ? std::fmod(a.phi_diff, kPiD) : 0.0;
    if (pd < 0.0) pd += kPiD;  // reciprocity: φ_d and φ_d + π are the same sample
    const double uh = std::sqrt(th / kHalfPi) * kMerlThetaHalfCount;
    const double ud = td / kHalfPi * kMerlThetaDiffCount;
    const double up = pd / kPiD * kMerlPhiDiffCount;
    auto split = [](double u, int n, int& i0, int& i1, double& t) {
      u = std::clamp(u, 0.0, static_cast<double>(n - 1));
      i0 = std::min(static_cast<int>(u), n - 1);
      i1 = std::min(i0 + 1, n - 1);
      t = u - i0;
    };
    int h0, h1, d0, d1;
    double thh, tdd;
    split(uh, kMerlThetaHalfCount, h0, h1, thh);
    split(ud, kMerlThetaDiffCount, d0, d1, tdd);
    const int p0 = std::min(static_cast<int>(up), kMerlPhiDiffCount - 1);
    const int p1 = (p0 + 1) % kMerlPhiDiffCount;
    const double tpp = std::clamp(up - p0, 0.0, 1.0);
    glm::dvec3 out(0.0);
    for (int c = 0; c < 3; ++c) {
      double acc = 0.0, wsum = 0.0;
      for (int k = 0; k < 8; ++k) {
        const double w = ((k & 1) ? thh : 1.0 - thh) * ((k & 2) ? tdd : 1.0 - tdd) * ((k & 4) ? tpp : 1.0 - tpp);
        if (w <= 0.0) continue;
        const double v = raw((k & 1) ? h1 : h0, (k & 2) ? d1 : d0, (k & 4) ? p1 : p0, c);
        if (!(v >= 0.0)) continue;  // not measured
        acc += w * v;
        wsum += w;
      }
      if (!(wsum > 0.0)) {
        // The point sits exactly on missing samples: take the nearest measured corner, if any.
        for (int k = 0; k < 8 && !(wsum > 0.0); ++k) {
          const double v = raw((k & 1) ? h1 : h0, (k & 2) ? d1 : d0, (k & 4) ? p1 : p0, c);
          if (v >= 0.0) {
            acc = v;
            wsum = 1.0;
          }
        }
      }
      if (!(wsum > 0.0)) return glm::dvec3(0.0);
      out[c] = acc / wsum * kMerlScale[static_cast<size_t>(c)];
    }
    if (measured) *measured = true;
    return out;
  }

 private:
  std::vector<double> values_;
};

/// Options of parse_merl_binary() / read_merl_binary().
struct MerlReadOptions {
  /// Grid of the MeasuredBrdf it is resampled onto (θ cells over [0, π/2), φ_diff cells over
  /// [0, π]); MERL's own resolution by default. 1 … kMbsdfMaxResolution.
  uint32_t res_theta = 90;
  uint32_t res_phi = 180;
};

/// What the reader found besides the BRDF.
struct MerlReadReport {
  size_t not_measured = 0;  ///< negative ("not measured") entries in the file, all planes
  size_t plane_samples = kMerlPlaneSize;
  size_t unfilled_cells = 0;  ///< resampled cells with no measured sample around them (set to 0)
};

/// A MERL BRDF read into btflod's representation.
struct MerlBrdf {
  MeasuredBrdf brdf;  ///< resampled onto res_theta × res_theta × res_phi, RGB, ρ (no cosine)
  MerlTable table;    ///< the file's samples, for exact lookups
  MerlReadReport report;
};

/// Resamples a MERL table onto MeasuredBrdf's grid: cell (i, j, k) is the table's lookup() at
/// the light (θ_in centre, φ = 0) and view (θ_out centre, φ = φ_diff centre). Returns
/// invalid_argument for an empty table or a resolution outside [1, kMbsdfMaxResolution].
/// unfilled (optional) receives the number of cells without measured samples around them.
/// Thread-safe; allocates res_theta² · res_phi · 3 floats.
inline Result<MeasuredBrdf> resample_merl(const MerlTable& table, uint32_t res_theta, uint32_t res_phi,
                                          size_t* unfilled = nullptr) {
  if (table.empty()) return make_error(Status::invalid_argument, "resample_merl: empty MERL table");
  if (res_theta == 0 || res_phi == 0 || res_theta > kMbsdfMaxResolution || res_phi > kMbsdfMaxResolution)
    return make_error(Status::invalid_argument, "resample_merl: resolution %u x %u outside [1, %u]", res_theta, res_phi,
                      kMbsdfMaxResolution);
  constexpr double kHalfPi = 0.5 * 3.14159265358979323846, kPiD = 3.14159265358979323846;
  std::vector<float> values(size_t{res_theta} * res_theta * res_phi * 3);
  size_t missing = 0;
  std::vector<double> sin_t(res_theta), cos_t(res_theta), cos_p(res_phi), sin_p(res_phi);
  for (uint32_t i = 0; i < res_theta; ++i) {
    const double t = (i + 0.5) * kHalfPi / res_theta;
    sin_t[i] = std::sin(t);
    cos_t[i] = std::cos(t);
  }
  for (uint32_t k = 0; k < res_phi; ++k) {
    const double p = (k + 0.5) * kPiD / res_phi;
    cos_p[k] = std::cos(p);
    sin_p[k] = std::sin(p);
  }
  size_t n = 0;
  for (uint32_t i = 0; i < res_theta; ++i)
    for (uint32_t j = 0; j < res_theta; ++j)
      for (uint32_t k = 0; k < res_phi; ++k, n += 3) {
        const glm::dvec3 light(sin_t[i], 0.0, cos_t[i]);
        const glm::dvec3 view(sin_t[j] * cos_p[k], sin_t[j] * sin_p[k], cos_t[j]);
        bool measured = false;
        const glm::dvec3 rho = table.lookup(half_diff_from_directions(light, view), &measured);
        missing += !measured;
        for (int c = 0; c < 3; ++c) values[n + static_cast<size_t>(c)] = static_cast<float>(rho[c]);
      }
  if (unfilled) *unfilled = missing;
  return MeasuredBrdf::from_table(res_theta, res_phi, 3, std::move(values));
}

/// Parses a MERL .binary file held in memory and resamples it (resample_merl). `name` labels
/// error messages. Errors (Status, message naming the byte offset):
///   short_output — fewer than the 12 header bytes, or fewer than the 3 × 1,458,000 doubles;
///   bad_data — dimensions other than 90, 90, 180; a NaN or infinite value (named by plane and
///              sample); no measured (non-negative) sample in a plane; bytes after the planes;
///   invalid_argument — a resolution outside [1, kMbsdfMaxResolution].
/// Safe for untrusted input: the size is checked before anything is allocated (the only
/// allocation is the fixed 35 MB table and the resampled grid). Thread-safe.
inline Result<MerlBrdf> parse_merl_binary(std::span<const uint8_t> bytes, std::string_view name = "merl",
                                          const MerlReadOptions& options = {}) {
  const std::string where(name);
  if (options.res_theta == 0 || options.res_phi == 0 || options.res_theta > kMbsdfMaxResolution ||
      options.res_phi > kMbsdfMaxResolution)
    return make_error(Status::invalid_argument, "%s: resampling resolution %u x %u outside [1, %u]", where.c_str(),
                      options.res_theta, options.res_phi, kMbsdfMaxResolution);
  ByteReader r(bytes);
  const int32_t dims[3] = {r.i32(), r.i32(), r.i32()};
  if (!r.ok())
    return make_error(Status::short_output, "%s: truncated input: the header needs 12 bytes, the file has %zu",
                      where.c_str(), bytes.size());
  if (dims[0] != kMerlThetaHalfCount || dims[1] != kMerlThetaDiffCount || dims[2] != kMerlPhiDiffCount)
    return make_error(Status::bad_data,
                      "%s: offset 0: dimensions %d x %d x %d, expected 90 x 90 x 180 (theta_h, "
                      "theta_d, phi_d)",
                      where.c_str(), dims[0], dims[1], dims[2]);
  if (!r.can_hold(3 * kMerlPlaneSize, sizeof(double)))
    return make_error(Status::short_output,
                      "%s: truncated input: offset 12: 3 x %zu doubles need %zu bytes, %zu remain", where.c_str(),
                      kMerlPlaneSize, 3 * kMerlPlaneSize * sizeof(double), r.remaining());
  if (r.remaining() != 3 * kMerlPlaneSize * sizeof(double))
    return make_error(Status::bad_data, "%s: trailing bytes: %zu bytes after the three colour planes (file has %zu)",
                      where.c_str(), r.remaining() - 3 * kMerlPlaneSize * sizeof(double), bytes.size());
  std::vector<double> values(3 * kMerlPlaneSize);
  r.copy_to(values.data(), values.size() * sizeof(double));
  MerlReadReport report;
  static const char* kPlane[3] = {"red", "green", "blue"};
  for (int c = 0; c < 3; ++c) {
    size_t measured = 0;
    for (size_t i = 0; i < kMerlPlaneSize; ++i) {
      const double v = values[static_cast<size_t>(c) * kMerlPlaneSize + i];
      if (!std::isfinite(v))
        return make_error(Status::bad_data,
                          "%s: offset %zu: %s plane sample %zu (theta_h %zu, theta_d %zu, phi_d %zu) "
                          "is %s, expected a finite number",
                          where.c_str(), 12 + (static_cast<size_t>(c) * kMerlPlaneSize + i) * sizeof(double), kPlane[c],
                          i, i / (90 * 180), (i / 180) % 90, i % 180, std::isnan(v) ? "NaN" : "infinite");
      if (v < 0.0) {
        ++report.not_measured;
      } else {
        ++measured;
      }
    }
    if (measured == 0)
      return make_error(Status::bad_data, "%s: the %s plane has no measured sample (all %zu are negative)",
                        where.c_str(), kPlane[c], kMerlPlaneSize);
  }
  MerlBrdf out;
  out.table = MerlTable(std::move(values));
  auto brdf = resample_merl(out.table, options.res_theta, options.res_phi, &report.unfilled_cells);
  if (!brdf) return Error{brdf.status(), where + ": " + brdf.message()};
  out.brdf = std::move(*brdf);
  out.report = report;
  return out;
}

/// Reads a MERL .binary file from disk (at most kMerlFileBytes + 1 bytes are read, so a huge
/// file fails as trailing bytes). See parse_merl_binary() for the errors; I/O failures return
/// io_error naming the path. Safe for untrusted files. Thread-safe.
inline Result<MerlBrdf> read_merl_binary(const std::string& path, const MerlReadOptions& options = {}) {
  auto bytes = read_file_bytes(path, kMerlFileBytes + 1);
  if (!bytes) return bytes.error();
  return parse_merl_binary(*bytes, path, options);
}

/// The bytes of a MERL .binary file holding `table` (3 · kMerlPlaneSize stored values).
/// Returns invalid_argument when the table has the wrong size. Thread-safe.
inline Result<std::vector<uint8_t>> encode_merl_binary(std::span<const double> table) {
  if (table.size() != 3 * kMerlPlaneSize)
    return make_error(Status::invalid_argument, "encode_merl_binary: %zu values, expected 3 x %zu", table.size(),
                      kMerlPlaneSize);
  std::vector<uint8_t> out(kMerlFileBytes);
  const int32_t dims[3] = {kMerlThetaHalfCount, kMerlThetaDiffCount, kMerlPhiDiffCount};
  std::memcpy(out.data(), dims, 12);
  std::memcpy(out.data() + 12, table.data(), table.size() * sizeof(double));
  return out;
}

/// Fills a MERL table from a BRDF given as a function of (light, view) unit directions
/// returning ρ in linear RGB: sample (i_h, i_d, i_p) is evaluated at the directions of its
/// half/difference angles (directions_from_half_diff) and stored divided by the colour scale.
/// Samples whose light or view lies below the horizon are stored as −1 ("not measured"), as in
/// MERL's files. Used to write test data and known analytic BRDFs in MERL's layout.
inline std::vector<double> merl_table_from_function(
    const std::function<glm::dvec3(const glm::dvec3& light, const glm::dvec3& view)>& rho) {
  constexpr double kHalfPi = 0.5 * 3.14159265358979323846, kPiD = 3.14159265358979323846;
  std::vector<double> values(3 * kMerlPlaneSize);
  for (int ih = 0; ih < kMerlThetaHalfCount; ++ih) {
    const double u = static_cast<double>(ih) / kMerlThetaHalfCount;
    for (int id = 0; id < kMerlThetaDiffCount; ++id)
      for (int ip = 0; ip < kMerlPhiDiffCount; ++ip) {
        HalfDiffAngles a{u * u * kHalfPi, id * kHalfPi / kMerlThetaDiffCount, ip * kPiD / kMerlPhiDiffCount};
        glm::dvec3 l, v;
        directions_from_half_diff(a, l, v);
        const size_t i = (static_cast<size_t>(ih) * kMerlThetaDiffCount + static_cast<size_t>(id)) * kMerlPhiDiffCount +
                         static_cast<size_t>(ip);
        const bool below = l.z <= 0.0 || v.z <= 0.0;
        const glm::dvec3 f = below ? glm::dvec3(0.0) : rho(l, v);
        for (int c = 0; c < 3; ++c)
          values[static_cast<size_t>(c) * kMerlPlaneSize + i] =
              below ? -1.0 : f[c] / kMerlScale[static_cast<size_t>(c)];
      }
  }
  return values;
}

}  // namespace btflod
