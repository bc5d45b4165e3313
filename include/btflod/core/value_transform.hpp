// btflod — the dynamic-range reduction a factorisation may be computed in.
//
// Measured glossy materials span orders of magnitude: a few mirror-direction samples (values
// up to ~34 in the demo's tiles material) against a diffuse body of 0.05–0.25. A least-squares
// rank-C fit (paper 000 eq. 4) spends its first components on those few samples, and colour and
// texture are lost at small C (paper 000, Fig. 4: "washed-out highlights and false colors").
// Bonn's DFMF factorises a log-compressed BTF for this reason. Here the BTF values x are
// encoded as s = E(x) before the factorisation, and the renderer decodes the sum of eq. 5 —
// after the angular interpolation and the filtered eigen-texture fetch, as the shaders do —
// ρ = D(Σ_c U_c · V_c):
//
//   linear  E(x) = x                 D(s) = s                  (paper 000 as printed)
//   sqrt    E(x) = √max(x, 0)        D(s) = s·|s|              (odd, so negative sums stay ≤ 0)
//   log     E(x) = ln(max(x, 0) + ε) D(s) = e^s − ε            (ε = log_offset > 0)
//
// and one that decorrelates colour as Bonn's DFMF does (log luminance, chroma normalised by it),
// per RGB triple of a (texel, light, view) sample; the colour rows of U then hold (s_Y, s_b, s_r):
//
//   log_ycbcr  Y, Cb, Cr = YCbCr(max(rgb, 0))  (BT.601 full range: rgb_to_ycbcr, core/color.hpp)
//              w = Y + ε,  E = (ln w, Cb / w, Cr / w)
//              D(s): w = e^{s_Y}, Y = w − ε, Cb = s_b·w, Cr = s_r·w, rgb = RGB(Y, Cb, Cr)
//
// encode()/decode() are per value and serve the per-channel encodings; encode_rgb()/decode_rgb()
// serve all four (code that handles RGB triples uses them).
//
// The same decode runs in the GLSL/HLSL generators (shader/), the CPU reference
// (offline/render/cpu_reference.hpp) and Fmf::evaluate (offline/factor/fmf.hpp), so every renderer evaluates
// the factorisation exactly. docs/fidelity.md measures the effect on the demo materials.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "btflod/core/color.hpp"
#include "btflod/core/enum_names.hpp"

namespace btflod {

/// Which encoding the factorised values are in (stored in factor files and .bsvtf containers).
enum class ValueEncoding : uint32_t { linear = 0, sqrt = 1, log = 2, log_ycbcr = 3 };

/// The encoding and its parameter. Default: linear (the identity).
struct ValueTransform {
  ValueEncoding encoding = ValueEncoding::linear;
  float log_offset = 0.05f;  ///< ε of the log encoding (ignored otherwise); > 0

  constexpr bool is_linear() const noexcept { return encoding == ValueEncoding::linear; }
  /// True when each colour channel is encoded on its own (encode()/decode() apply); false for
  /// log_ycbcr, whose channels mix (encode_rgb()/decode_rgb()).
  constexpr bool per_channel() const noexcept { return encoding != ValueEncoding::log_ycbcr; }
  /// True when the encoding uses log_offset.
  constexpr bool uses_log_offset() const noexcept {
    return encoding == ValueEncoding::log || encoding == ValueEncoding::log_ycbcr;
  }
  /// True for a known encoding with a finite ε > 0 (when it matters). Use on values read from files.
  bool valid() const noexcept {
    switch (encoding) {
      case ValueEncoding::linear:
      case ValueEncoding::sqrt:
        return true;
      case ValueEncoding::log:
      case ValueEncoding::log_ycbcr:
        return std::isfinite(log_offset) && log_offset > 0.0f;
    }
    return false;
  }
  /// E(x): a BTF value to the factorised domain (per-channel encodings; log_ycbcr: encode_rgb()).
  float encode(float x) const noexcept {
    switch (encoding) {
      case ValueEncoding::sqrt:
        return std::sqrt(x > 0.0f ? x : 0.0f);
      case ValueEncoding::log:
        return std::log((x > 0.0f ? x : 0.0f) + log_offset);
      default:
        return x;
    }
  }
  /// D(s): a sum of eq. 5 back to reflectance (per-channel encodings; log_ycbcr: decode_rgb()).
  float decode(float s) const noexcept {
    switch (encoding) {
      case ValueEncoding::sqrt:
        return s * std::fabs(s);
      case ValueEncoding::log:
        return std::exp(s) - log_offset;
      default:
        return s;
    }
  }
  /// E of one RGB sample, in place (every encoding).
  void encode_rgb(float* rgb) const noexcept {
    if (per_channel()) {
      for (int c = 0; c < 3; ++c) rgb[c] = encode(rgb[c]);
      return;
    }
    const auto ycc =
        rgb_to_ycbcr(rgb[0] > 0.0f ? rgb[0] : 0.0f, rgb[1] > 0.0f ? rgb[1] : 0.0f, rgb[2] > 0.0f ? rgb[2] : 0.0f);
    const float w = ycc[0] + log_offset;
    rgb[0] = std::log(w);
    rgb[1] = ycc[1] / w;
    rgb[2] = ycc[2] / w;
  }
  /// D of one summed RGB (or (s_Y, s_b, s_r)) triple, in place (every encoding).
  void decode_rgb(float* s) const noexcept {
    if (per_channel()) {
      for (int c = 0; c < 3; ++c) s[c] = decode(s[c]);
      return;
    }
    const float w = std::exp(s[0]);
    const auto rgb = ycbcr_to_rgb(w - log_offset, s[1] * w, s[2] * w);
    s[0] = rgb[0];
    s[1] = rgb[1];
    s[2] = rgb[2];
  }
  /// E, resp. D, over consecutive RGB triples (values.size() a multiple of 3).
  void encode_triples(float* values, size_t count) const noexcept {
    for (size_t i = 0; i + 3 <= count; i += 3) encode_rgb(values + i);
  }
  void decode_triples(float* values, size_t count) const noexcept {
    for (size_t i = 0; i + 3 <= count; i += 3) decode_rgb(values + i);
  }
  friend constexpr bool operator==(const ValueTransform& a, const ValueTransform& b) noexcept {
    return a.encoding == b.encoding && (!a.uses_log_offset() || a.log_offset == b.log_offset);
  }
};

namespace detail {
/// value_encoding_name()'s table: one name per ValueEncoding, in value order.
inline constexpr const char* kValueEncodingNames[] = {"linear", "sqrt", "log", "log_ycbcr"};
}  // namespace detail

/// "linear", "sqrt", "log", "log_ycbcr" (or "unknown").
constexpr const char* value_encoding_name(ValueEncoding e) noexcept {
  return enum_value_name<ValueEncoding::log_ycbcr>(e, detail::kValueEncodingNames);
}

/// Parses a name of value_encoding_name(). Returns false (and leaves `out`) for anything else.
constexpr bool parse_value_encoding(std::string_view name, ValueEncoding& out) noexcept {
  for (ValueEncoding e : {ValueEncoding::linear, ValueEncoding::sqrt, ValueEncoding::log, ValueEncoding::log_ycbcr})
    if (name == value_encoding_name(e)) {
      out = e;
      return true;
    }
  return false;
}

}  // namespace btflod
