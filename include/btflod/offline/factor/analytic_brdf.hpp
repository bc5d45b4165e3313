// btflod — the dictionary of analytic BRDFs of the Sparse Parametric Mixture Model
// (paper 003 §3 after its ref. [8], Wu, Dorsey, Rushmeier 2011): Lambert, Oren–Nayar,
// Blinn–Phong, Ward, Cook–Torrance, Lafortune and Ashikhmin–Shirley, and the cosine-weighted
// rotated basis function of paper 003 eq. 2:
//
//   ρ_j(ω_i, ω_o) = f_j(κ_j, R(ω_i), R(ω_o)) · max(n_j·ω_i, 0)
//
// where R expresses a direction in the frame whose +z is the basis normal n_j. That frame is
// the image of the surface frame under the minimal rotation taking +z to n_j (tangent and
// bitangent follow n_j continuously, so the anisotropic models keep their orientation when
// n_j is edited). Every f_j is 0 when either rotated direction is at or below its horizon.
//
// Each model has at most kAnalyticMaxParams parameters κ with documented ranges
// (analytic_param_info); validate_analytic_basis() checks them, so evaluation never sees NaN,
// a negative exponent or a zero roughness. Models are monochrome: an SPMM weight α carries the
// colour. Evaluation is allocation-free, noexcept and thread-safe (usable per frame).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <span>

#include <glm/glm.hpp>

#include "btflod/core/enum_names.hpp"
#include "btflod/core/result.hpp"

namespace btflod {

/// The analytic BRDF models of paper 003 §3 (stored ids; never renumber).
enum class AnalyticModel : uint32_t {
  lambert = 0,
  oren_nayar = 1,
  blinn_phong = 2,
  ward = 3,
  cook_torrance = 4,
  lafortune = 5,
  ashikhmin_shirley = 6,
};
inline constexpr uint32_t kAnalyticModelCount = 7;
inline constexpr int kAnalyticMaxParams = 3;
/// Largest tilt of a basis normal n_j from the surface normal that btflod accepts (84.3°,
/// n_j.z ≥ 0.1): beyond it the cosine factor of eq. 2 is close to zero everywhere.
inline constexpr float kAnalyticMinNormalZ = 0.1f;

/// One parameter κ_i of a model: its name, valid closed range and whether fitting searches it
/// on a log scale (exponents and roughnesses).
struct AnalyticParamInfo {
  const char* name;
  float min;
  float max;
  float initial;
  bool log_scale;
};

/// Name of a model ("lambert", "oren-nayar", "blinn-phong", "ward", "cook-torrance",
/// "lafortune", "ashikhmin-shirley"). Unknown ids give "unknown".
inline const char* analytic_model_name(AnalyticModel m) noexcept {
  static constexpr const char* kNames[] = {"lambert",       "oren-nayar", "blinn-phong",      "ward",
                                           "cook-torrance", "lafortune",  "ashikhmin-shirley"};
  return enum_value_name<AnalyticModel::ashikhmin_shirley>(m, kNames);
}

/// The parameter table of a model (empty span for Lambert and unknown ids).
///  - oren-nayar: σ, surface roughness (std. dev. of facet slope angle, radians) ∈ [0, 1]
///  - blinn-phong: e, exponent ∈ [1, 10⁴], normalised (e + 8)/(8π)·(n·h)^e
///  - ward: α_x, α_y, RMS slopes along tangent / bitangent ∈ [0.02, 1]
///  - cook-torrance: m, Beckmann RMS slope ∈ [0.02, 1]; F0, Schlick reflectance at 0° ∈ [0.01, 1]
///  - lafortune: C_xy ∈ [−1, 1], C_z ∈ [0, 1], exponent e ∈ [1, 10³] of one generalised cosine lobe
///  - ashikhmin-shirley: n_u, n_v exponents ∈ [1, 10⁴] (tangent / bitangent), R_s ∈ [0, 1]
inline std::span<const AnalyticParamInfo> analytic_param_info(AnalyticModel m) noexcept {
  static constexpr AnalyticParamInfo kOren[] = {{"sigma", 0.0f, 1.0f, 0.3f, false}};
  static constexpr AnalyticParamInfo kBlinn[] = {{"exponent", 1.0f, 1e4f, 32.0f, true}};
  static constexpr AnalyticParamInfo kWard[] = {{"alpha_x", 0.02f, 1.0f, 0.2f, true},
                                                {"alpha_y", 0.02f, 1.0f, 0.2f, true}};
  static constexpr AnalyticParamInfo kCook[] = {{"m", 0.02f, 1.0f, 0.2f, true}, {"f0", 0.01f, 1.0f, 0.5f, false}};
  static constexpr AnalyticParamInfo kLaf[] = {
      {"c_xy", -1.0f, 1.0f, -1.0f, false}, {"c_z", 0.0f, 1.0f, 1.0f, false}, {"exponent", 1.0f, 1e3f, 16.0f, true}};
  static constexpr AnalyticParamInfo kAsh[] = {
      {"n_u", 1.0f, 1e4f, 32.0f, true}, {"n_v", 1.0f, 1e4f, 32.0f, true}, {"r_s", 0.0f, 1.0f, 0.5f, false}};
  // Indexed by model id (AnalyticModel order).
  static constexpr std::span<const AnalyticParamInfo> kByModel[kAnalyticModelCount] = {{},    kOren, kBlinn, kWard,
                                                                                       kCook, kLaf,  kAsh};
  const uint32_t id = static_cast<uint32_t>(m);
  return id < kAnalyticModelCount ? kByModel[id] : std::span<const AnalyticParamInfo>{};
}

/// Number of parameters κ of a model (0 for Lambert, 3 at most; 0 for unknown ids): the size of
/// its analytic_param_info() table.
inline int analytic_param_count(AnalyticModel m) noexcept { return static_cast<int>(analytic_param_info(m).size()); }

/// Converts a stored id to a model. Safe for untrusted input: unknown ids give Status::bad_data
/// naming the id.
inline Result<AnalyticModel> analytic_model_from_id(uint32_t id) {
  if (id >= kAnalyticModelCount)
    return make_error(Status::bad_data, "analytic BRDF: unknown model id %u (expected 0..%u)", id,
                      kAnalyticModelCount - 1);
  return static_cast<AnalyticModel>(id);
}

/// One basis function of eq. 2: model, parameters κ (unused entries 0) and normal n_j (unit,
/// surface frame, n_j.z ≥ kAnalyticMinNormalZ).
struct AnalyticBasis {
  AnalyticModel model = AnalyticModel::lambert;
  std::array<float, kAnalyticMaxParams> kappa{0.0f, 0.0f, 0.0f};
  glm::vec3 normal{0.0f, 0.0f, 1.0f};
};

/// Checks a basis: known model, every κ_i finite and within its range, unused κ entries 0,
/// normal finite, unit length (±1e-3) and within kAnalyticMinNormalZ of the surface normal.
/// Safe for untrusted input; the message names the model, parameter, value and range.
inline VoidResult validate_analytic_basis(const AnalyticBasis& b) {
  if (static_cast<uint32_t>(b.model) >= kAnalyticModelCount)
    return make_error(Status::bad_data, "analytic BRDF: unknown model id %u", static_cast<uint32_t>(b.model));
  const auto info = analytic_param_info(b.model);
  for (size_t i = 0; i < static_cast<size_t>(kAnalyticMaxParams); ++i) {
    const float k = b.kappa[i];
    if (i >= info.size()) {
      if (k != 0.0f)
        return make_error(Status::bad_data, "analytic BRDF %s: parameter %zu is %g, the model has %zu parameters",
                          analytic_model_name(b.model), i, static_cast<double>(k), info.size());
      continue;
    }
    if (!(k >= info[i].min && k <= info[i].max))  // also rejects NaN
      return make_error(Status::bad_data, "analytic BRDF %s: %s = %g outside [%g, %g]", analytic_model_name(b.model),
                        info[i].name, static_cast<double>(k), static_cast<double>(info[i].min),
                        static_cast<double>(info[i].max));
  }
  const glm::vec3 n = b.normal;
  const float len = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
  if (!(std::abs(len - 1.0f) <= 1e-3f) || !(n.z >= kAnalyticMinNormalZ))
    return make_error(Status::bad_data, "analytic BRDF %s: normal (%g, %g, %g) not unit or tilted beyond n.z >= %g",
                      analytic_model_name(b.model), static_cast<double>(n.x), static_cast<double>(n.y),
                      static_cast<double>(n.z), static_cast<double>(kAnalyticMinNormalZ));
  return {};
}

/// The frame of a basis normal: tangent, bitangent, normal = the images of x, y, z under the
/// minimal rotation taking +z to n (Rodrigues). Precondition: unit n with n.z > −1.
struct AnalyticFrame {
  glm::vec3 t, b, n;
  explicit AnalyticFrame(glm::vec3 normal) noexcept : n(normal) {
    const float k = 1.0f / (1.0f + normal.z);
    t = glm::vec3(1.0f - normal.x * normal.x * k, -normal.x * normal.y * k, -normal.x);
    b = glm::vec3(-normal.x * normal.y * k, 1.0f - normal.y * normal.y * k, -normal.y);
  }
  /// R(ω) of eq. 2: ω in this frame.
  glm::vec3 to_local(glm::vec3 w) const noexcept { return {glm::dot(w, t), glm::dot(w, b), glm::dot(w, n)}; }
};

/// f(κ, ω_i, ω_o) of a model with both unit directions in the model's own frame (z = normal).
/// Returns 0 when either direction is at or below the horizon. Precondition: κ valid
/// (validate_analytic_basis); the result is then finite and ≥ 0. Allocation-free, noexcept.
inline float evaluate_analytic_brdf(AnalyticModel model, const float* kappa, glm::vec3 wi, glm::vec3 wo) noexcept {
  constexpr float kInvPi = 0.318309886f;
  if (wi.z <= 0.0f || wo.z <= 0.0f) return 0.0f;
  switch (model) {
    case AnalyticModel::lambert:
      return kInvPi;
    case AnalyticModel::oren_nayar: {
      // Oren & Nayar 1994, the "qualitative" model: (A + B·max(0, cos(φi − φo))·sin α·tan β)/π,
      // α = max(θi, θo), β = min(θi, θo).
      const float s2 = kappa[0] * kappa[0];
      const float a = 1.0f - 0.5f * s2 / (s2 + 0.33f), bb = 0.45f * s2 / (s2 + 0.09f);
      const float pi = std::sqrt(std::max(0.0f, wi.x * wi.x + wi.y * wi.y));
      const float po = std::sqrt(std::max(0.0f, wo.x * wo.x + wo.y * wo.y));
      float cos_phi = 0.0f;
      if (pi > 1e-6f && po > 1e-6f) cos_phi = std::max(0.0f, (wi.x * wo.x + wi.y * wo.y) / (pi * po));
      const float cos_a = std::min(wi.z, wo.z), cos_b = std::max(wi.z, wo.z);  // α is the larger angle
      const float sin_a = std::sqrt(std::max(0.0f, 1.0f - cos_a * cos_a));
      const float tan_b = std::sqrt(std::max(0.0f, 1.0f - cos_b * cos_b)) / cos_b;
      return kInvPi * (a + bb * cos_phi * sin_a * tan_b);
    }
    case AnalyticModel::blinn_phong: {
      // Normalised Blinn–Phong (Akenine-Möller et al., Real-Time Rendering): (e + 8)/(8π)·(n·h)^e.
      const glm::vec3 h = wi + wo;
      const float len = std::sqrt(h.x * h.x + h.y * h.y + h.z * h.z);
      if (len <= 0.0f) return 0.0f;
      const float e = kappa[0];
      return (e + 8.0f) * (kInvPi / 8.0f) * std::pow(std::max(h.z / len, 0.0f), e);
    }
    case AnalyticModel::ward: {
      // Ward 1992, anisotropic Gaussian: exp(−tan²θh (cos²φh/αx² + sin²φh/αy²)) / (4π αx αy √(cos θi cos θo)).
      const glm::vec3 h = wi + wo;  // unnormalised: tan²θh cos²φh = h_x²/h_z²
      const float ax = kappa[0], ay = kappa[1];
      const float ex = (h.x * h.x / (ax * ax) + h.y * h.y / (ay * ay)) / (h.z * h.z);
      return std::exp(-ex) / (4.0f * 3.14159265f * ax * ay * std::sqrt(wi.z * wo.z));
    }
    case AnalyticModel::cook_torrance: {
      // Cook & Torrance 1982 with the Beckmann distribution, Schlick's Fresnel and the V-cavity
      // shadowing term: D·F·G / (4 cos θi cos θo).
      glm::vec3 h = wi + wo;
      h /= std::sqrt(h.x * h.x + h.y * h.y + h.z * h.z);
      const float m = kappa[0], f0 = kappa[1];
      const float c2 = h.z * h.z, t2 = (1.0f - c2) / c2;
      const float d = std::exp(-t2 / (m * m)) / (3.14159265f * m * m * c2 * c2);
      const float vh = std::max(glm::dot(wo, h), 1e-6f);
      const float f = f0 + (1.0f - f0) * std::pow(1.0f - std::min(vh, 1.0f), 5.0f);
      const float g = std::min(1.0f, std::min(2.0f * h.z * wo.z / vh, 2.0f * h.z * wi.z / vh));
      return d * f * g / (4.0f * wi.z * wo.z);
    }
    case AnalyticModel::lafortune: {
      // Lafortune et al. 1997, one lobe (e + 2)/(2π)·max(0, C_xy(x_i x_o + y_i y_o) + C_z z_i z_o)^e;
      // C_xy = −1, C_z = 1 is the normalised Phong lobe around the mirror direction.
      const float s = kappa[0] * (wi.x * wo.x + wi.y * wo.y) + kappa[1] * wi.z * wo.z;
      if (s <= 0.0f) return 0.0f;
      const float e = kappa[2];
      return (e + 2.0f) * (kInvPi / 2.0f) * std::pow(s, e);
    }
    case AnalyticModel::ashikhmin_shirley: {
      // Ashikhmin & Shirley 2000, the anisotropic specular term:
      // √((n_u+1)(n_v+1))/(8π) · (n·h)^((n_u h_x² + n_v h_y²)/(1 − (n·h)²)) / ((h·k) max(cos θi, cos θo)) · F(h·k).
      glm::vec3 h = wi + wo;
      h /= std::sqrt(h.x * h.x + h.y * h.y + h.z * h.z);
      const float nu = kappa[0], nv = kappa[1], rs = kappa[2];
      const float sin2 = h.x * h.x + h.y * h.y;
      const float expo = sin2 > 1e-12f ? (nu * h.x * h.x + nv * h.y * h.y) / sin2 : 0.5f * (nu + nv);
      const float hk = std::max(glm::dot(h, wi), 1e-6f);
      const float f = rs + (1.0f - rs) * std::pow(1.0f - std::min(hk, 1.0f), 5.0f);
      return std::sqrt((nu + 1.0f) * (nv + 1.0f)) * (kInvPi / 8.0f) * std::pow(std::max(h.z, 0.0f), expo) /
             (hk * std::max(wi.z, wo.z)) * f;
    }
  }
  return 0.0f;
}

/// ρ_j(ω_i, ω_o) of paper 003 eq. 2 with both unit directions in the surface frame: the model
/// evaluated in the frame of b.normal, times max(n_j·ω_i, 0). Precondition: b valid.
/// Allocation-free, noexcept, thread-safe.
inline float evaluate_analytic_basis(const AnalyticBasis& b, glm::vec3 wi, glm::vec3 wo) noexcept {
  if (b.normal.z >= 0.999999f && b.normal.x == 0.0f && b.normal.y == 0.0f)
    return evaluate_analytic_brdf(b.model, b.kappa.data(), wi, wo) * std::max(wi.z, 0.0f);
  const AnalyticFrame frame(b.normal);
  const glm::vec3 li = frame.to_local(wi), lo = frame.to_local(wo);
  return evaluate_analytic_brdf(b.model, b.kappa.data(), li, lo) * std::max(li.z, 0.0f);
}

}  // namespace btflod
