// btflod — level-of-detail selectors behind one concept.
//
// Both return a continuous paper-000 level (0 = coarsest, L = finest) clamped to [0, L]:
//  * DerivativeLod: paper 000 eq. 1, l = L − log2 max(‖∂Π/∂x‖, ‖∂Π/∂y‖) − bias, with an optional
//    anisotropy allowance (the footprint's major axis is divided by up to max_anisotropy, as an
//    anisotropic filter with that many taps would, but never below the minor axis).
//  * RangeLod: paper 001 §3.4, the range-based continuous parameter λ = min(λmax, max(log2 d, 0))
//    with d the eye distance in units of reference_distance, mapped to l = L − λ − bias.
// feedback_level() turns the continuous level into the tile level the feedback pass requests.
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstdint>

namespace btflod {

/// What a selector may look at for one pixel.
struct LodInput {
  float footprint_x = 1.0f;  ///< ‖∂Π/∂x‖: finest-level texels per screen pixel along x
  float footprint_y = 1.0f;  ///< ‖∂Π/∂y‖: finest-level texels per screen pixel along y
  float distance = 1.0f;     ///< eye-to-surface distance (scene units)
};

/// A selector maps a LodInput and the finest level L to a continuous level in [0, L].
/// level() must be noexcept, allocation-free and thread-safe.
template <class S>
concept LodSelector = requires(const S& s, const LodInput& in, uint32_t finest_level) {
  { s.level(in, finest_level) }
  noexcept->std::same_as<float>;
};

/// Paper 000 eq. 1 with bias and anisotropy. bias > 0 selects coarser levels.
struct DerivativeLod {
  float bias = 0.0f;            ///< subtracted from the level (global LOD bias under overload)
  float max_anisotropy = 1.0f;  ///< 1 = isotropic (eq. 1 as printed); e.g. 4 or 16 with aniso filtering

  /// Continuous level in [0, L]. Non-finite or non-positive footprints give L (finest).
  float level(const LodInput& in, uint32_t finest_level) const noexcept {
    const float major = std::max(in.footprint_x, in.footprint_y);
    const float minor = std::min(in.footprint_x, in.footprint_y);
    float rho = major;
    if (max_anisotropy > 1.0f) rho = std::max(major / max_anisotropy, minor);
    const float top = static_cast<float>(finest_level);
    if (!(rho > 0.0f) || !std::isfinite(rho)) return rho > 0.0f ? 0.0f : top;  // inf → coarsest, NaN/0 → finest
    const float l = top - std::log2(rho) - bias;                               // paper 000 eq. 1
    return std::clamp(l, 0.0f, top);
  }
};

/// Paper 001 §3.4 range-based LOD: λ = min(λmax, max(log2(d / d0), 0)), level = L − λ − bias.
struct RangeLod {
  float reference_distance = 1.0f;  ///< d0: distance up to which the finest level is used
  float bias = 0.0f;

  /// Continuous level in [0, L]. Non-finite distances give level 0.
  float level(const LodInput& in, uint32_t finest_level) const noexcept {
    const float top = static_cast<float>(finest_level);
    const float d = in.distance / reference_distance;
    if (!(d == d) || !std::isfinite(d)) return 0.0f;
    const float lambda = std::min(top, std::max(d > 0.0f ? std::log2(d) : 0.0f, 0.0f));  // paper 001 §3.4
    return std::clamp(top - lambda - bias, 0.0f, top);
  }
};

/// The tile level the feedback pass requests for a continuous level: the finer of the two
/// levels trilinear filtering blends (ceil), clamped to [0, L]. Levels within 1/256 above an
/// integer count as that integer, so float noise in the derivatives (a footprint of 3.9999
/// texels) does not request a level twice as fine. noexcept, thread-safe.
inline uint32_t feedback_level(float continuous_level, uint32_t finest_level) noexcept {
  if (!(continuous_level > 0.0f)) return 0;
  const float c = std::ceil(continuous_level - 1.0f / 256.0f);
  return c >= static_cast<float>(finest_level) ? finest_level : static_cast<uint32_t>(c);
}

static_assert(LodSelector<DerivativeLod>);
static_assert(LodSelector<RangeLod>);

}  // namespace btflod
