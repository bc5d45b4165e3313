// btflod — the uniform block of the generated ring search (GlslPiece::ring_search, paper 004
// §4.4) packed from two RingSearchInterpolator (light and view directions), and the CPU twin of
// the pca_rings program (PCA over groups of k views with the ring search instead of the angular
// tables).
//
// The block is std140: `vec4 rings[2 · kRingSearchMaxRings]` (table t, ring r at
// t · kRingSearchMaxRings + r: θ, φ0, direction count, first slot), `uvec4 ring_slots[2 ·
// kRingSearchMaxSlots / 4]` (table t, slot s at t · kRingSearchMaxSlots + s: the direction
// index of that ring slot) and `ivec4 ring_counts` (x: light rings, y: view rings).
//
// pack_ring_search_block allocates nothing but is set-up code; reference_pca_rings is noexcept,
// allocation-free and thread-safe on const data.
#pragma once

#include <cstdint>
#include <cstring>

#include <glm/glm.hpp>

#include "btflod/core/result.hpp"
#include "btflod/offline/angular/ring_search.hpp"
#include "btflod/offline/factor/pca_views.hpp"
#include "btflod/offline/packing/representation_packing.hpp"
#include "btflod/runtime/shader/glsl_generator.hpp"

namespace btflod {

/// The ring search's uniform block mirrored byte for byte (std140, 2576 bytes).
struct RingSearchBlock {
  float rings[2 * kRingSearchMaxRings][4];  ///< θ (rad), φ0 (rad), count, first slot
  uint32_t slots[2 * kRingSearchMaxSlots];  ///< direction index of each ring slot
  int32_t counts[4];                        ///< light rings, view rings, 0, 0
};
static_assert(sizeof(RingSearchBlock) == 16 * 2 * kRingSearchMaxRings + 4 * 2 * kRingSearchMaxSlots + 16,
              "RingSearchBlock must match the std140 block of the ring_search piece");

/// Packs the rings of `light` (table 0) and `view` (table 1) into the block the generated
/// ring_search functions read. Returns invalid_argument when a set has no ring, more than
/// kRingSearchMaxRings rings or more than kRingSearchMaxSlots directions (UBO2003: 6 rings /
/// 81 directions, UBO2014: 10 / 151). Deterministic; thread-safe; no allocation.
inline Result<RingSearchBlock> pack_ring_search_block(const RingSearchInterpolator& light,
                                                      const RingSearchInterpolator& view) {
  RingSearchBlock b;
  std::memset(&b, 0, sizeof b);
  const RingSearchInterpolator* tables[2] = {&light, &view};
  for (uint32_t t = 0; t < 2; ++t) {
    const auto& rings = tables[t]->rings();
    const auto& slots = tables[t]->slots();
    if (rings.empty() || rings.size() > kRingSearchMaxRings || slots.size() > kRingSearchMaxSlots)
      return make_error(Status::invalid_argument,
                        "ring search block: %s set has %zu rings and %zu directions, expected 1..%u rings and at "
                        "most %u directions",
                        t == 0 ? "light" : "view", rings.size(), slots.size(), kRingSearchMaxRings,
                        kRingSearchMaxSlots);
    for (size_t r = 0; r < rings.size(); ++r) {
      float* v = b.rings[t * kRingSearchMaxRings + r];
      v[0] = rings[r].theta;
      v[1] = rings[r].phi0;
      v[2] = static_cast<float>(rings[r].count);
      v[3] = static_cast<float>(rings[r].first_slot);
    }
    for (size_t s = 0; s < slots.size(); ++s) b.slots[t * kRingSearchMaxSlots + s] = slots[s];
    b.counts[t] = static_cast<int32_t>(rings.size());
  }
  return b;
}

/// What the pca_rings program computes at uv for local directions wl, wv: PcaViews::evaluate at
/// the texel ⌊fract(uv)·(W, H)⌋ with the ring search's 3 × 3 taps (paper 004 §4.4.3). RGB, not
/// multiplied by the light colour. Precondition: `light` and `view` were built from the
/// material's light and view sets. noexcept.
inline glm::vec3 reference_pca_rings(const PcaViews& p, const RingSearchInterpolator& light,
                                     const RingSearchInterpolator& view, glm::vec2 uv, glm::vec3 wl,
                                     glm::vec3 wv) noexcept {
  const glm::ivec2 t = representation_texel(uv, p.shape.width, p.shape.height);
  return p.evaluate(t.x, t.y, light.query(wl), view.query(wv));
}

}  // namespace btflod
