// btflod — measured isotropic BRDFs in NVIDIA's "ARC MBSDF V1" format (the car paints in
// ../shared/data/measured/, from the MDL SDK sample data), their evaluation in the local
// frame, and sampling into a tabulated BTF.
//
// File layout (little-endian), as described in ../shared/data/measured/README.md:
//   "NVIDIA ARC MBSDF V1\n"
//   one or two parts, each: "MBSDF_DATA_REFLECTION=\n" or "MBSDF_DATA_TRANSMISSION=\n",
//     u32 type (0 = scalar, 1 = RGB), u32 res_theta, u32 res_phi,
//     f32 values[res_theta · res_theta · res_phi · channels], value (i = θ_in, j = θ_out,
//     k = φ_diff, c) at channels · (i · res_phi · res_theta + j · res_phi + k) + c.
// θ_in and θ_out cover [0, π/2) in res_theta equal cells, φ_diff covers [0, π] in res_phi equal
// cells. As in the MDL SDK (3D texture with normalised coordinates and linear filtering), the
// stored value belongs to the cell centre: θ_i = (i + ½)·(π/2)/res_theta, φ_k = (k + ½)·π/res_phi,
// and lookups between centres are trilinear with clamping at the ends of each axis.
// θ_in is the light (incoming) direction and θ_out the view (outgoing) direction, as in the
// SDK's df::bsdf_measurement_evaluate(theta_phi_in, theta_phi_out).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/core/bytes.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/result.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/math/math.hpp"

namespace btflod {

/// Largest res_theta / res_phi a file may declare; the real data uses 45 × 90. Larger values
/// are rejected before any allocation (a hostile header cannot make the reader allocate more
/// than kMbsdfMaxResolution² · kMbsdfMaxResolution · 3 floats, and only when the file holds them).
inline constexpr uint32_t kMbsdfMaxResolution = 1024;

/// Largest |value| a table may hold. Measured BRDFs stay below ~10⁴ even at mirror peaks; the
/// bound keeps trilinear interpolation (differences and weighted sums of up to eight entries)
/// finite, which values near FLT_MAX would overflow to infinity.
inline constexpr float kMbsdfMaxMagnitude = 1e30f;

/// A tabulated isotropic BRDF on the (θ_in, θ_out, φ_diff) grid of the MBSDF format.
/// Immutable after construction; all const methods are thread-safe.
class MeasuredBrdf {
 public:
  MeasuredBrdf() = default;

  /// Builds a BRDF from a table laid out like the file (see the header comment).
  /// Returns invalid_argument when a resolution is 0 or above kMbsdfMaxResolution, channels is
  /// not 1 or 3, values has the wrong size, and bad_data when it holds a NaN, an infinity or a
  /// magnitude above kMbsdfMaxMagnitude (the message names the first bad cell). Safe for
  /// untrusted input.
  static Result<MeasuredBrdf> from_table(uint32_t res_theta, uint32_t res_phi, int channels,
                                         std::vector<float> values) {
    if (res_theta == 0 || res_phi == 0 || res_theta > kMbsdfMaxResolution || res_phi > kMbsdfMaxResolution)
      return make_error(Status::invalid_argument, "MBSDF resolution %u x %u outside [1, %u]", res_theta, res_phi,
                        kMbsdfMaxResolution);
    if (channels != 1 && channels != 3)
      return make_error(Status::invalid_argument, "MBSDF channel count %d, expected 1 or 3", channels);
    const size_t expected = static_cast<size_t>(res_theta) * res_theta * res_phi * static_cast<size_t>(channels);
    if (values.size() != expected)
      return make_error(Status::invalid_argument, "MBSDF table has %zu values, expected %zu", values.size(), expected);
    MeasuredBrdf out;
    out.res_theta_ = res_theta;
    out.res_phi_ = res_phi;
    out.channels_ = channels;
    for (size_t n = 0; n < values.size(); ++n) {
      const float v = values[n];
      if (!(std::abs(v) <= kMbsdfMaxMagnitude)) {
        const size_t cell = n / static_cast<size_t>(channels);
        return make_error(Status::bad_data,
                          "MBSDF value %zu (theta_in %zu, theta_out %zu, phi %zu, channel %zu) is %s, expected a "
                          "finite number of magnitude at most %g",
                          n, cell / (static_cast<size_t>(res_phi) * res_theta), (cell / res_phi) % res_theta,
                          cell % res_phi, n % static_cast<size_t>(channels),
                          std::isnan(v) ? "NaN" : (std::isinf(v) ? "infinite" : "too large"),
                          static_cast<double>(kMbsdfMaxMagnitude));
      }
      if (v < 0.0f) ++out.negative_count_;
      out.max_value_ = std::max(out.max_value_, v);
    }
    out.values_ = std::move(values);
    return out;
  }

  uint32_t res_theta() const noexcept { return res_theta_; }
  uint32_t res_phi() const noexcept { return res_phi_; }
  /// 1 (scalar, evaluate() replicates it to RGB) or 3 (RGB); 0 for a default-constructed BRDF.
  int channels() const noexcept { return channels_; }
  bool empty() const noexcept { return values_.empty(); }
  /// The table as stored in the file (negative measurement noise kept).
  std::span<const float> values() const noexcept { return values_; }
  /// Number of negative table entries (measurement noise; evaluate() clamps them to 0).
  size_t negative_count() const noexcept { return negative_count_; }
  /// Largest table entry.
  float max_value() const noexcept { return max_value_; }
  /// True when the file also held a transmission part (read and validated, not evaluated).
  bool had_transmission() const noexcept { return had_transmission_; }
  void set_had_transmission(bool v) noexcept { had_transmission_ = v; }

  /// Table entry for cell (θ_in index i, θ_out index j, φ index k), channel c (c is taken
  /// modulo channels(), so a scalar table answers every channel). Precondition: indices in range.
  float raw(uint32_t i, uint32_t j, uint32_t k, int c) const noexcept {
    const size_t cell = (static_cast<size_t>(i) * res_theta_ + j) * res_phi_ + k;
    return values_[cell * static_cast<size_t>(channels_) + static_cast<size_t>(c % channels_)];
  }

  /// Polar angle of the centre of θ cell i, radians: (i + ½)·(π/2)/res_theta.
  float theta_center(uint32_t i) const noexcept {
    return (static_cast<float>(i) + 0.5f) * (0.5f * kPi) / static_cast<float>(res_theta_);
  }
  /// Azimuth difference of the centre of φ cell k, radians: (k + ½)·π/res_phi.
  float phi_center(uint32_t k) const noexcept {
    return (static_cast<float>(k) + 0.5f) * kPi / static_cast<float>(res_phi_);
  }

  /// BRDF value ρ (1/sr, linear RGB, not multiplied by any cosine) for polar angles theta_in
  /// (light) and theta_out (view) in [0, π/2] and the azimuth difference phi_diff (any real
  /// value: folded into [0, π] by 2π-periodicity and the isotropy/reciprocity mirror
  /// φ ↦ 2π − φ). Trilinear between cell centres, clamped at the ends of each axis; negative
  /// table values are clamped to 0 after interpolation. θ outside [0, π/2] or NaN gives 0.
  /// An empty BRDF gives 0. Thread-safe, noexcept, no allocation.
  glm::vec3 evaluate_angles(float theta_in, float theta_out, float phi_diff) const noexcept {
    if (values_.empty()) return glm::vec3(0.0f);
    const float half_pi = 0.5f * kPi;
    if (!(theta_in >= 0.0f && theta_in <= half_pi && theta_out >= 0.0f && theta_out <= half_pi)) return glm::vec3(0.0f);
    if (!std::isfinite(phi_diff)) return glm::vec3(0.0f);
    float phi = std::fmod(std::abs(phi_diff), kTwoPi);  // |φ|: the mirror φ ↦ −φ
    if (phi > kPi) phi = kTwoPi - phi;                  // isotropy/reciprocity mirror of (π, 2π)
    Axis ai = axis(theta_in / half_pi, res_theta_);
    Axis aj = axis(theta_out / half_pi, res_theta_);
    Axis ak = axis(phi / kPi, res_phi_);
    glm::vec3 out(0.0f);
    for (int c = 0; c < 3; ++c) {
      float acc = 0.0f;
      for (int di = 0; di < 2; ++di) {
        const float wi = di ? ai.t : 1.0f - ai.t;
        const uint32_t i = di ? ai.i1 : ai.i0;
        for (int dj = 0; dj < 2; ++dj) {
          const float wj = dj ? aj.t : 1.0f - aj.t;
          const uint32_t j = dj ? aj.i1 : aj.i0;
          const float lo = raw(i, j, ak.i0, c);
          const float hi = raw(i, j, ak.i1, c);
          acc += wi * wj * (lo + ak.t * (hi - lo));
        }
      }
      out[c] = std::max(acc, 0.0f);
      if (channels_ == 1) return glm::vec3(out[0]);
    }
    return out;
  }

  /// BRDF value ρ for a light and a view direction in the local frame (z = normal, both
  /// pointing away from the surface; need not be normalised). Returns 0 when either direction
  /// is at or below the horizon (z ≤ 0), zero or not finite. See evaluate_angles() for the
  /// lookup. Thread-safe, noexcept, no allocation.
  glm::vec3 evaluate(glm::vec3 light, glm::vec3 view) const noexcept {
    if (!(light.z > 0.0f) || !(view.z > 0.0f)) return glm::vec3(0.0f);
    if (!std::isfinite(light.x + light.y + light.z + view.x + view.y + view.z)) return glm::vec3(0.0f);
    const glm::vec2 sl = spherical_from_direction(light);
    const glm::vec2 sv = spherical_from_direction(view);
    // At the pole φ is meaningless; atan2(0, 0) = 0 there, which is as good as any value.
    return evaluate_angles(std::min(sl.x, 0.5f * kPi), std::min(sv.x, 0.5f * kPi), sv.y - sl.y);
  }

 private:
  struct Axis {
    uint32_t i0, i1;
    float t;
  };
  // Cell-centre convention: u in [0, 1] maps to continuous index u·res − ½; clamp at both ends.
  static Axis axis(float u, uint32_t res) noexcept {
    const float x = u * static_cast<float>(res) - 0.5f;
    if (!(x > 0.0f)) return {0, 0, 0.0f};
    const float last = static_cast<float>(res - 1);
    if (x >= last) return {res - 1, res - 1, 0.0f};
    const uint32_t i0 = static_cast<uint32_t>(x);
    return {i0, std::min(i0 + 1, res - 1), x - static_cast<float>(i0)};
  }

  uint32_t res_theta_ = 0;
  uint32_t res_phi_ = 0;
  int channels_ = 0;
  std::vector<float> values_;
  size_t negative_count_ = 0;
  float max_value_ = 0.0f;
  bool had_transmission_ = false;
};

namespace detail {
inline constexpr std::string_view kMbsdfMagic = "NVIDIA ARC MBSDF V1\n";
inline constexpr std::string_view kMbsdfReflection = "MBSDF_DATA_REFLECTION=\n";
inline constexpr std::string_view kMbsdfTransmission = "MBSDF_DATA_TRANSMISSION=\n";

inline std::string printable_prefix(std::span<const uint8_t> bytes, size_t n) {
  std::string s;
  for (size_t i = 0; i < std::min(n, bytes.size()); ++i) {
    const auto c = static_cast<char>(bytes[i]);
    if (c == '\n') {
      s += "\\n";
    } else if (bytes[i] >= 32 && bytes[i] < 127) {
      s += c;
    } else {
      s += '?';
    }
  }
  return s;
}
}  // namespace detail

/// Parses an MBSDF file held in memory. `name` only labels error messages. Returns the
/// reflection part; a transmission part, when present, is validated the same way and then
/// dropped (had_transmission() says so). Errors (Status, message naming the byte offset):
///   bad_data — wrong first line, unknown part line, type other than 0/1, resolution 0 or
///              above kMbsdfMaxResolution, a NaN/infinite value or one above kMbsdfMaxMagnitude, a repeated part, bytes
///              after the last part, no reflection part;
///   short_output — the file ends before the declared table.
/// Safe for untrusted input: sizes are checked against the remaining bytes before allocating.
/// Thread-safe (no shared state).
inline Result<MeasuredBrdf> parse_mbsdf(std::span<const uint8_t> bytes, std::string_view name = "mbsdf") {
  const std::string where(name);
  ByteReader r(bytes);
  if (!r.match(detail::kMbsdfMagic))
    return make_error(Status::bad_data, "%s: offset 0: expected the line \"NVIDIA ARC MBSDF V1\\n\", found \"%s\"",
                      where.c_str(), detail::printable_prefix(bytes, detail::kMbsdfMagic.size()).c_str());
  Result<MeasuredBrdf> reflection = make_error(Status::bad_data, "%s: no MBSDF_DATA_REFLECTION part", where.c_str());
  bool have_reflection = false;
  bool have_transmission = false;
  while (r.remaining() > 0) {
    const size_t part_offset = r.offset();
    bool is_reflection = false;
    if (r.match(detail::kMbsdfReflection)) {
      is_reflection = true;
    } else if (!r.match(detail::kMbsdfTransmission)) {
      return make_error(Status::bad_data,
                        "%s: offset %zu: expected \"MBSDF_DATA_REFLECTION=\\n\" or \"MBSDF_DATA_TRANSMISSION=\\n\", "
                        "found \"%s\" (%zu trailing bytes)",
                        where.c_str(), part_offset,
                        detail::printable_prefix(r.bytes().subspan(part_offset), 24).c_str(), r.remaining());
    }
    const char* part_name = is_reflection ? "reflection" : "transmission";
    if ((is_reflection && have_reflection) || (!is_reflection && have_transmission))
      return make_error(Status::bad_data, "%s: offset %zu: second %s part", where.c_str(), part_offset, part_name);
    const size_t header_offset = r.offset();
    const uint32_t type = r.u32();
    const uint32_t res_theta = r.u32();
    const uint32_t res_phi = r.u32();
    if (!r.ok())
      return make_error(Status::short_output, "%s: offset %zu: %s header needs 12 bytes, file has %zu", where.c_str(),
                        header_offset, part_name, bytes.size() - header_offset);
    if (type > 1)
      return make_error(Status::bad_data, "%s: offset %zu: %s type %u, expected 0 (scalar) or 1 (RGB)", where.c_str(),
                        header_offset, part_name, type);
    if (res_theta == 0 || res_phi == 0 || res_theta > kMbsdfMaxResolution || res_phi > kMbsdfMaxResolution)
      return make_error(Status::bad_data, "%s: offset %zu: %s resolution %u x %u (theta x phi) outside [1, %u]",
                        where.c_str(), header_offset + 4, part_name, res_theta, res_phi, kMbsdfMaxResolution);
    const int channels = type == 1 ? 3 : 1;
    const uint64_t count = uint64_t{res_theta} * res_theta * res_phi * static_cast<uint64_t>(channels);
    if (!r.can_hold(count, sizeof(float)))
      return make_error(Status::short_output,
                        "%s: offset %zu: %s table of %u x %u x %u x %d floats needs %llu bytes, %zu remain",
                        where.c_str(), r.offset(), part_name, res_theta, res_theta, res_phi, channels,
                        static_cast<unsigned long long>(count * sizeof(float)), r.remaining());
    const size_t table_offset = r.offset();
    std::vector<float> values(static_cast<size_t>(count));
    r.copy_to(values.data(), values.size() * sizeof(float));
    auto part = MeasuredBrdf::from_table(res_theta, res_phi, channels, std::move(values));
    if (!part)
      return make_error(Status::bad_data, "%s: %s table at offset %zu: %s", where.c_str(), part_name, table_offset,
                        part.message().c_str());
    if (is_reflection) {
      reflection = std::move(part);
      have_reflection = true;
    } else {
      have_transmission = true;
    }
  }
  if (have_reflection) reflection->set_had_transmission(have_transmission);
  return reflection;
}

/// Reads an MBSDF file from disk (at most 1 GiB). See parse_mbsdf() for the errors; I/O
/// failures return io_error naming the path. Safe for untrusted files. Thread-safe.
inline Result<MeasuredBrdf> read_mbsdf(const std::string& path) {
  auto bytes = read_file_bytes(path, uint64_t{1} << 30);
  if (!bytes) return bytes.error();
  return parse_mbsdf(*bytes, path);
}

/// Tabulates a measured BRDF as a spatially uniform BTF: every one of the width × height
/// texels holds the same ABRDF, sample (v, l) = evaluate(lights[l], views[v]) times cosθ_l
/// under the default convention (see BtfValueConvention). Directions below the horizon give 0.
/// Preconditions: width, height ≥ 1; non-empty direction sets. Thread-safe (reads brdf only).
inline BtfFloat sample_to_btf(const MeasuredBrdf& brdf, const DirectionSet& views, const DirectionSet& lights,
                              int width = 1, int height = 1,
                              BtfValueConvention convention = BtfValueConvention::abrdf_cos_light) {
  BtfFloat out(width, height, views, lights);
  for (size_t v = 0; v < views.size(); ++v) {
    for (size_t l = 0; l < lights.size(); ++l) {
      const glm::vec3 ld = lights[l].vector;
      glm::vec3 value = brdf.evaluate(ld, views[v].vector);
      if (convention == BtfValueConvention::abrdf_cos_light) value *= std::max(ld.z, 0.0f);
      auto img = out.image(v, l);
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
          for (int c = 0; c < 3; ++c) img.at(x, y, c) = value[c];
    }
  }
  return out;
}

}  // namespace btflod
