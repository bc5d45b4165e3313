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
// The same decode runs in the GLSL/HLSL generators (shader/), the CPU reference
// (backend/cpu_reference.hpp) and Fmf::evaluate (factor/fmf.hpp), so every renderer evaluates
// the factorisation exactly. docs/fidelity.md measures the effect on the demo materials.
#pragma once

#include <cmath>
#include <cstdint>
#include <string_view>

namespace btflod {

/// Which encoding the factorised values are in (stored in factor files and .bsvtf containers).
enum class ValueEncoding : uint32_t { linear = 0, sqrt = 1, log = 2 };

/// The encoding and its parameter. Default: linear (the identity).
struct ValueTransform {
  ValueEncoding encoding = ValueEncoding::linear;
  float log_offset = 0.05f;  ///< ε of the log encoding (ignored otherwise); > 0

  constexpr bool is_linear() const noexcept { return encoding == ValueEncoding::linear; }
  /// True for a known encoding with a finite ε > 0 (when it matters). Use on values read from files.
  bool valid() const noexcept {
    switch (encoding) {
      case ValueEncoding::linear:
      case ValueEncoding::sqrt:
        return true;
      case ValueEncoding::log:
        return std::isfinite(log_offset) && log_offset > 0.0f;
    }
    return false;
  }
  /// E(x): a BTF value to the factorised domain.
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
  /// D(s): a sum of eq. 5 back to reflectance.
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
  friend constexpr bool operator==(const ValueTransform& a, const ValueTransform& b) noexcept {
    return a.encoding == b.encoding && (a.encoding != ValueEncoding::log || a.log_offset == b.log_offset);
  }
};

/// "linear", "sqrt", "log" (or "unknown").
constexpr const char* value_encoding_name(ValueEncoding e) noexcept {
  switch (e) {
    case ValueEncoding::linear:
      return "linear";
    case ValueEncoding::sqrt:
      return "sqrt";
    case ValueEncoding::log:
      return "log";
  }
  return "unknown";
}

/// Parses a name of value_encoding_name(). Returns false (and leaves `out`) for anything else.
constexpr bool parse_value_encoding(std::string_view name, ValueEncoding& out) noexcept {
  for (ValueEncoding e : {ValueEncoding::linear, ValueEncoding::sqrt, ValueEncoding::log})
    if (name == value_encoding_name(e)) {
      out = e;
      return true;
    }
  return false;
}

}  // namespace btflod
