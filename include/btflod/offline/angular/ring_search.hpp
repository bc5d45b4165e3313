// btflod — UBO ring search (paper 004 §4.4.1) with tetrahedron-volume weights (§4.4.2) for
// direction sets made of rings: ring r has n_r directions at polar angle θ_r and azimuths
// φ_r0 + k·2π/n_r (UBO2003, UBO2014).
//
// Generalisation of the thesis: it assumes a constant Δθ (θ_L = Δθ·⌊θ/Δθ⌋); UBO2014's rings
// are not evenly spaced, so the bracketing rings are found by a search over the sorted ring
// angles (≤ a few dozen rings), and each ring keeps its own azimuth offset φ_r0.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "btflod/core/result.hpp"
#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/angular/parameterization.hpp"
#include "btflod/offline/math/math.hpp"

namespace btflod {

/// One ring of a ring-sampled direction set.
struct DirectionRing {
  float theta = 0.0f;       ///< polar angle, radians
  float phi0 = 0.0f;        ///< azimuth of slot 0, radians
  uint32_t count = 0;       ///< directions on the ring (1 for the pole)
  uint32_t first_slot = 0;  ///< slot k of the ring is RingSearchInterpolator::slots()[first_slot + k]
};

/// Interpolator for ring sets (paper 004 §4.4). query() is noexcept, allocation-free and
/// thread-safe; satisfies AngularInterpolator.
///
/// For P = (θ, φ): rings L and U with θ_L ≤ θ < θ_U; on each, the azimuth neighbours
/// A, B (ring L) and C, D (ring U) with φ between them. If P is closer to A than to D (larger
/// dot product, the thesis' d′) the triangle is ABC, else BCD; when L is the pole (one
/// direction) the triangle is pole-C-D. Weights are the volumes of the tetrahedra PP₂P₃O,
/// PP₃P₁O, PP₁P₂O, normalised (§4.4.2). Beyond the last ring (θ ≥ θ_last) the thesis
/// interpolates linearly between the two neighbours on the last ring: we use the azimuth
/// fraction. Below the first ring of a set without a pole, the first ring is used the same way.
class RingSearchInterpolator {
 public:
  /// Detects the rings of `set`: directions with equal θ (within tolerance_deg) form a ring
  /// and their azimuths must be φ0 + k·360°/n (within tolerance_deg) with distinct k. Returns
  /// an error naming the first direction that breaks the pattern. Allocates; not per-frame.
  static Result<RingSearchInterpolator> build(const DirectionSet& set, float tolerance_deg = 0.05f) {
    if (set.empty()) return make_error(Status::invalid_argument, "ring search: the direction set is empty");
    const float tol = degrees_to_radians(tolerance_deg);
    std::vector<uint32_t> order(set.size());
    for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return set[a].theta < set[b].theta; });
    RingSearchInterpolator out;
    out.count_ = static_cast<uint32_t>(set.size());
    out.vectors_.reserve(set.size());
    for (const Direction& d : set) out.vectors_.push_back(d.vector);
    size_t k = 0;
    while (k < order.size()) {
      size_t e = k + 1;
      while (e < order.size() && set[order[e]].theta - set[order[k]].theta <= tol) ++e;
      DirectionRing ring;
      ring.theta = set[order[k]].theta;
      ring.count = static_cast<uint32_t>(e - k);
      ring.first_slot = static_cast<uint32_t>(out.slots_.size());
      // φ0 = the smallest azimuth of the ring, so that slot k sits at φ0 + k·Δφ.
      float phi0 = kTwoPi;
      for (size_t i = k; i < e; ++i) phi0 = std::min(phi0, wrap_two_pi(set[order[i]].phi));
      ring.phi0 = ring.count == 1 ? 0.0f : phi0;
      out.slots_.resize(out.slots_.size() + ring.count, kUnset);
      const float step = kTwoPi / static_cast<float>(ring.count);
      for (size_t i = k; i < e; ++i) {
        const uint32_t id = order[i];
        if (ring.count == 1) {
          out.slots_[ring.first_slot] = id;
          break;
        }
        const float rel = wrap_two_pi(set[id].phi - phi0);
        const float fk = rel / step;
        const long slot = std::lround(fk);
        if (std::abs(fk - static_cast<float>(slot)) * step > tol || slot < 0 || slot > static_cast<long>(ring.count))
          return make_error(Status::invalid_argument,
                            "ring search: direction %u (theta %.3f deg, phi %.3f deg) is not on the even azimuth "
                            "grid of its ring (%u directions, phi0 %.3f deg)",
                            id, radians_to_degrees(set[id].theta), radians_to_degrees(set[id].phi), ring.count,
                            radians_to_degrees(phi0));
        const uint32_t s = ring.first_slot + static_cast<uint32_t>(slot % static_cast<long>(ring.count));
        if (out.slots_[s] != kUnset)
          return make_error(Status::invalid_argument, "ring search: directions %u and %u share azimuth slot %ld",
                            out.slots_[s], id, slot);
        out.slots_[s] = id;
      }
      out.rings_.push_back(ring);
      k = e;
    }
    return out;
  }

  /// See the class comment. Input is clamped to the hemisphere. noexcept, allocation-free.
  AngularSample query(glm::vec3 dir) const noexcept {
    const glm::vec3 p = clamp_to_hemisphere(dir);
    const float theta = std::acos(glm::clamp(p.z, -1.0f, 1.0f));
    const float phi = std::atan2(p.y, p.x);
    AngularSample out;
    if (rings_.empty()) return out;
    // Bracketing rings (paper 004: θ_L = f^l(θ), θ_U = f^u(θ), here by search).
    size_t upper = 0;
    while (upper < rings_.size() && rings_[upper].theta <= theta) ++upper;
    if (upper == rings_.size() || upper == 0) {
      // Beyond the last ring (or before the first): linear in φ on that ring.
      const DirectionRing& r = rings_[upper == 0 ? 0 : rings_.size() - 1];
      uint32_t a, b;
      float w;
      neighbours(r, phi, a, b, w);
      out.index = {a, b, a};
      out.weight = {1.0f - w, w, 0.0f};
      return out;
    }
    const DirectionRing& rl = rings_[upper - 1];
    const DirectionRing& ru = rings_[upper];
    uint32_t a, b, c, d;
    float unused;
    neighbours(rl, phi, a, b, unused);
    neighbours(ru, phi, c, d, unused);
    std::array<uint32_t, 3> t;
    if (rl.count == 1) {
      t = {a, c, d};
    } else if (glm::dot(p, vectors_[a]) >= glm::dot(p, vectors_[d])) {  // d′ of §4.4.1
      t = {a, b, c};
    } else {
      t = {b, c, d};
    }
    // §4.4.2: w_i = |det(P, P_j, P_k)| / 6 (the 4×4 determinant with O reduces to a triple product).
    const glm::vec3 p1 = vectors_[t[0]], p2 = vectors_[t[1]], p3 = vectors_[t[2]];
    float v1 = std::abs(glm::dot(p, glm::cross(p2, p3)));
    float v2 = std::abs(glm::dot(p, glm::cross(p3, p1)));
    float v3 = std::abs(glm::dot(p, glm::cross(p1, p2)));
    const float sum = v1 + v2 + v3;
    if (!(sum > 0.0f)) {
      v1 = 1.0f;
      v2 = v3 = 0.0f;
    } else {
      v1 /= sum;
      v2 /= sum;
      v3 /= sum;
    }
    out.index = t;
    out.weight = {v1, v2, v3};
    return out;
  }

  uint32_t direction_count() const noexcept { return count_; }
  /// Rings sorted by θ.
  const std::vector<DirectionRing>& rings() const noexcept { return rings_; }
  /// Direction index of each ring slot (see DirectionRing::first_slot).
  const std::vector<uint32_t>& slots() const noexcept { return slots_; }

  /// The thesis' quadrilateral for a direction strictly between two rings: A, B on the lower
  /// ring and C, D on the upper one (A = B for the pole). Returns false outside the rings.
  /// Exposed for tests and for comparing against the triangulation.
  bool bracket(glm::vec3 dir, std::array<uint32_t, 4>& abcd) const noexcept {
    const glm::vec3 p = clamp_to_hemisphere(dir);
    const float theta = std::acos(glm::clamp(p.z, -1.0f, 1.0f));
    const float phi = std::atan2(p.y, p.x);
    size_t upper = 0;
    while (upper < rings_.size() && rings_[upper].theta <= theta) ++upper;
    if (upper == rings_.size() || upper == 0) return false;
    float w;
    neighbours(rings_[upper - 1], phi, abcd[0], abcd[1], w);
    neighbours(rings_[upper], phi, abcd[2], abcd[3], w);
    return true;
  }

 private:
  static constexpr uint32_t kUnset = 0xffffffffu;

  static float wrap_two_pi(float a) noexcept {
    float r = std::fmod(a, kTwoPi);
    if (r < 0.0f) r += kTwoPi;
    if (r >= kTwoPi) r -= kTwoPi;
    return r;
  }

  // Lower/upper azimuth neighbours on a ring (paper 004: f^l(φ, Δφ_n), f^u = f^l + Δφ_n)
  // and the fraction of φ between them.
  void neighbours(const DirectionRing& r, float phi, uint32_t& lo, uint32_t& hi, float& frac) const noexcept {
    if (r.count <= 1) {
      lo = hi = slots_[r.first_slot];
      frac = 0.0f;
      return;
    }
    const float step = kTwoPi / static_cast<float>(r.count);
    const float rel = wrap_two_pi(phi - r.phi0) / step;
    uint32_t k = static_cast<uint32_t>(rel);
    if (k >= r.count) k = r.count - 1;
    frac = glm::clamp(rel - static_cast<float>(k), 0.0f, 1.0f);
    lo = slots_[r.first_slot + k];
    hi = slots_[r.first_slot + (k + 1) % r.count];
  }

  uint32_t count_ = 0;
  std::vector<glm::vec3> vectors_;
  std::vector<DirectionRing> rings_;
  std::vector<uint32_t> slots_;
};

static_assert(AngularInterpolator<RingSearchInterpolator>);

}  // namespace btflod
