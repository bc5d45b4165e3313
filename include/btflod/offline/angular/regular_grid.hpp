// btflod — regular-grid resampling of a 4D angular function onto the (s_v, t_v, s_l, t_l)
// grid of a hemisphere parameterisation (paper 002 §6.1, the elevated concentric map by
// default), stored as ONE 3D texture, and its evaluation with "3D linear + one manual lerp"
// (paper 002 §6.2), on the CPU.
//
// Layout: a volume of width n_view (s_v), height n_view (t_v) and depth n_light · n_light.
// Slab i (light t_l fixed to node i) occupies depths [i·n_light, (i+1)·n_light) and holds
// S_i(s_v, t_v, s_l) = E(s_v, t_v, s_l, t_{l_i}). Grid nodes sit at s = k / (n − 1), k = 0 … n−1,
// i.e. on texel centres, so a GPU sampling with linear filtering uses the texture coordinates
//   u  = (s_v · (n_view − 1) + 0.5) / n_view,      v = (t_v · (n_view − 1) + 0.5) / n_view,
//   z_i = (i · n_light + s_l · (n_light − 1) + 0.5) / (n_light · n_light),
// and blends the two fetches at z_i and z_{i+1} with w = frac(t_l · (n_light − 1)). This is the
// paper's z = t_{l_i} + s_l / n(t_l) with the half-texel terms that keep the hardware filter
// inside one slab. evaluate() does exactly that arithmetic.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/core/result.hpp"
#include "btflod/offline/angular/parameterization.hpp"

namespace btflod {

/// The texture coordinates a shader needs for one light direction (paper 002 §6.3 keeps them
/// in a cube map): the two slab depths (normalised) and the lerp weight.
struct LightSlabCoordinates {
  int slab0 = 0;    ///< i: lower t_l node
  int slab1 = 0;    ///< i + 1 (clamped to the last node)
  float w = 0.0f;   ///< weight of slab1
  float z0 = 0.0f;  ///< normalised depth of s_l inside slab0
  float z1 = 0.0f;  ///< normalised depth of s_l inside slab1
};

/// A resampled 4D angular function (see the file comment). Built once (allocates); evaluate()
/// is noexcept, allocation-free and thread-safe.
template <HemisphereParameterization P = ElevatedConcentricMap>
class RegularAngularGrid {
 public:
  /// Samples f at every node: f(glm::vec3 light, glm::vec3 view, float* out) writes `channels`
  /// floats, light/view = P::from_square(node). n_view, n_light in [2, 256], channels in
  /// [1, 16], total size ≤ 2^30 floats; otherwise returns invalid_argument. Allocates; f is
  /// called n_view² · n_light² times from this thread.
  template <class F>
  static Result<RegularAngularGrid> resample(int n_view, int n_light, int channels, F&& f) {
    if (n_view < 2 || n_view > 256 || n_light < 2 || n_light > 256 || channels < 1 || channels > 16)
      return make_error(Status::invalid_argument,
                        "regular grid: n_view %d, n_light %d (expected 2..256), channels %d (expected 1..16)", n_view,
                        n_light, channels);
    const double total =
        std::pow(static_cast<double>(n_view), 2) * std::pow(static_cast<double>(n_light), 2) * channels;
    if (total > 1073741824.0)
      return make_error(Status::invalid_argument, "regular grid: %.0f floats exceeds the limit of 2^30", total);
    RegularAngularGrid g;
    g.nv_ = n_view;
    g.nl_ = n_light;
    g.ch_ = channels;
    g.data_.assign(static_cast<size_t>(total), 0.0f);
    for (int i = 0; i < n_light; ++i)
      for (int k = 0; k < n_light; ++k) {
        const glm::vec3 light = P::from_square({node(k, n_light), node(i, n_light)});  // (s_l, t_l)
        for (int y = 0; y < n_view; ++y)
          for (int x = 0; x < n_view; ++x) {
            const glm::vec3 view = P::from_square({node(x, n_view), node(y, n_view)});
            f(light, view, g.data_.data() + g.offset(x, y, i * n_light + k));
          }
      }
    return g;
  }

  /// The texel (x, y, depth) of the volume: `channels()` floats.
  const float* texel(int x, int y, int depth) const noexcept { return data_.data() + offset(x, y, depth); }

  /// Slab coordinates for a light square point (st = (s_l, t_l), clamped to [0, 1]²).
  LightSlabCoordinates light_slabs(glm::vec2 light_st) const noexcept {
    light_st = detail::clamp_unit_square(light_st);
    LightSlabCoordinates c;
    const float ut = light_st.y * static_cast<float>(nl_ - 1);  // paper 002: t_{l_i} ≤ t_l < t_{l_i+1}
    c.slab0 = glm::min(static_cast<int>(ut), nl_ - 1);
    c.slab1 = glm::min(c.slab0 + 1, nl_ - 1);
    c.w = ut - static_cast<float>(c.slab0);
    const float depth = static_cast<float>(nl_) * static_cast<float>(nl_);
    const float in_slab = light_st.x * static_cast<float>(nl_ - 1) + 0.5f;
    c.z0 = (static_cast<float>(c.slab0 * nl_) + in_slab) / depth;
    c.z1 = (static_cast<float>(c.slab1 * nl_) + in_slab) / depth;
    return c;
  }

  /// Evaluates the resampled function: two trilinear fetches of the volume at
  /// (u, v, z0) and (u, v, z1) and one lerp by w (paper 002 §6.2). Writes channels() floats.
  /// noexcept, allocation-free, thread-safe. Directions are clamped to the hemisphere.
  void evaluate(glm::vec3 light, glm::vec3 view, float* out) const noexcept {
    evaluate_square(P::to_square(light), P::to_square(view), out);
  }

  /// Same with square coordinates (s_l, t_l) and (s_v, t_v).
  void evaluate_square(glm::vec2 light_st, glm::vec2 view_st, float* out) const noexcept {
    view_st = detail::clamp_unit_square(view_st);
    const LightSlabCoordinates c = light_slabs(light_st);
    // Texel-space position of s_l inside a slab; the same value as z·depth − 0.5 − i·n_light
    // of the GPU formula, computed directly so float rounding cannot leak into the next slab.
    const float ul = detail::clamp_unit_square(light_st).x * static_cast<float>(nl_ - 1);
    float a[16];
    float b[16];
    trilinear(view_st.x, view_st.y, c.slab0, ul, a);
    trilinear(view_st.x, view_st.y, c.slab1, ul, b);
    for (int ch = 0; ch < ch_; ++ch) out[ch] = (1.0f - c.w) * a[ch] + c.w * b[ch];  // the one manual lerp
  }

  int view_resolution() const noexcept { return nv_; }
  int light_resolution() const noexcept { return nl_; }
  int channels() const noexcept { return ch_; }
  /// Volume dimensions for upload: width = height = n_view, depth = n_light².
  int volume_depth() const noexcept { return nl_ * nl_; }
  /// Raw volume, x fastest, then y, then depth; channels interleaved.
  const std::vector<float>& data() const noexcept { return data_; }

 private:
  static float node(int k, int n) noexcept { return static_cast<float>(k) / static_cast<float>(n - 1); }

  size_t offset(int x, int y, int z) const noexcept {
    return ((static_cast<size_t>(z) * static_cast<size_t>(nv_) + static_cast<size_t>(y)) * static_cast<size_t>(nv_) +
            static_cast<size_t>(x)) *
           static_cast<size_t>(ch_);
  }

  // Hardware-style trilinear filter inside slab `slab` at in-slab texel position ul (centres at
  // integers); s, t are view square coordinates. Clamp-to-edge addressing.
  void trilinear(float s, float t, int slab, float ul, float* out) const noexcept {
    const float ux = s * static_cast<float>(nv_ - 1);
    const float uy = t * static_cast<float>(nv_ - 1);
    const int x0 = glm::clamp(static_cast<int>(std::floor(ux)), 0, nv_ - 1), x1 = glm::min(x0 + 1, nv_ - 1);
    const int y0 = glm::clamp(static_cast<int>(std::floor(uy)), 0, nv_ - 1), y1 = glm::min(y0 + 1, nv_ - 1);
    const int k0 = glm::clamp(static_cast<int>(std::floor(ul)), 0, nl_ - 1);
    const int z0 = slab * nl_ + k0, z1 = slab * nl_ + glm::min(k0 + 1, nl_ - 1);
    const float fx = glm::clamp(ux - static_cast<float>(x0), 0.0f, 1.0f);
    const float fy = glm::clamp(uy - static_cast<float>(y0), 0.0f, 1.0f);
    const float fz = glm::clamp(ul - static_cast<float>(k0), 0.0f, 1.0f);
    const float* c000 = texel(x0, y0, z0);
    const float* c100 = texel(x1, y0, z0);
    const float* c010 = texel(x0, y1, z0);
    const float* c110 = texel(x1, y1, z0);
    const float* c001 = texel(x0, y0, z1);
    const float* c101 = texel(x1, y0, z1);
    const float* c011 = texel(x0, y1, z1);
    const float* c111 = texel(x1, y1, z1);
    for (int ch = 0; ch < ch_; ++ch) {
      const float e00 = c000[ch] + fx * (c100[ch] - c000[ch]);
      const float e10 = c010[ch] + fx * (c110[ch] - c010[ch]);
      const float e01 = c001[ch] + fx * (c101[ch] - c001[ch]);
      const float e11 = c011[ch] + fx * (c111[ch] - c011[ch]);
      const float f0 = e00 + fy * (e10 - e00);
      const float f1 = e01 + fy * (e11 - e01);
      out[ch] = f0 + fz * (f1 - f0);
    }
  }

  int nv_ = 0;
  int nl_ = 0;
  int ch_ = 0;
  std::vector<float> data_;
};

}  // namespace btflod
