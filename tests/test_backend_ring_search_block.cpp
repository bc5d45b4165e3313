// The ring search's uniform block (offline/packing/ring_search_block.hpp) against the interpolator it
// is packed from, its limits, and the generated ring_search / pca_rings text that reads it.
#include <gtest/gtest.h>

#include <cstring>
#include <set>
#include <string>
#include <vector>

#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/packing/ring_search_block.hpp"
#include "btflod/runtime/shader/glsl_generator.hpp"
#include "test_shader_text_cases.hpp"

using namespace btflod;

namespace {

// Checks every ring and slot of table `t` of `b` against `r`, and that the unused entries are 0.
void expect_table(const RingSearchBlock& b, uint32_t t, const RingSearchInterpolator& r, size_t directions) {
  ASSERT_EQ(b.counts[t], static_cast<int32_t>(r.rings().size()));
  for (size_t i = 0; i < kRingSearchMaxRings; ++i) {
    const float* v = b.rings[t * kRingSearchMaxRings + i];
    if (i >= r.rings().size()) {
      EXPECT_EQ(v[0], 0.0f);
      EXPECT_EQ(v[2], 0.0f);
      continue;
    }
    const DirectionRing& ring = r.rings()[i];
    EXPECT_EQ(v[0], ring.theta);
    EXPECT_EQ(v[1], ring.phi0);
    EXPECT_EQ(v[2], static_cast<float>(ring.count));
    EXPECT_EQ(v[3], static_cast<float>(ring.first_slot));
  }
  // Every direction index sits in exactly one slot, in the interpolator's slot order.
  std::set<uint32_t> seen;
  for (size_t s = 0; s < directions; ++s) {
    const uint32_t id = b.slots[t * kRingSearchMaxSlots + s];
    EXPECT_EQ(id, r.slots()[s]);
    EXPECT_LT(id, directions);
    seen.insert(id);
  }
  EXPECT_EQ(seen.size(), directions);
  for (size_t s = directions; s < kRingSearchMaxSlots; ++s) EXPECT_EQ(b.slots[t * kRingSearchMaxSlots + s], 0u);
}

// A ring's slot k must point at the direction at azimuth φ0 + k·2π/n and polar angle θ: what the
// shader computes from the block alone (btflod_ring_dir) is the measured direction.
void expect_geometry(const RingSearchBlock& b, uint32_t t, const DirectionSet& set) {
  for (int32_t i = 0; i < b.counts[t]; ++i) {
    const float* v = b.rings[t * kRingSearchMaxRings + i];
    for (uint32_t k = 0; k < static_cast<uint32_t>(v[2]); ++k) {
      const uint32_t id = b.slots[t * kRingSearchMaxSlots + static_cast<uint32_t>(v[3]) + k];
      const float phi = v[1] + static_cast<float>(k) * kTwoPi / std::max(v[2], 1.0f);
      const glm::vec3 d(std::sin(v[0]) * std::cos(phi), std::sin(v[0]) * std::sin(phi), std::cos(v[0]));
      EXPECT_GT(glm::dot(d, set[id].vector), 0.99999f) << "table " << t << " ring " << i << " slot " << k;
    }
  }
}

}  // namespace

TEST(BackendRingSearchBlock, PacksTheRingsAndSlotsOfBothTables) {
  const DirectionSet lights = DirectionSet::ubo2003(), views = DirectionSet::ubo2014();
  auto l = RingSearchInterpolator::build(lights);
  auto v = RingSearchInterpolator::build(views);
  ASSERT_TRUE(l.ok() && v.ok());
  auto b = pack_ring_search_block(*l, *v);
  ASSERT_TRUE(b.ok()) << b.message();
  EXPECT_EQ(sizeof(RingSearchBlock), 2576u);
  expect_table(*b, 0, *l, lights.size());
  expect_table(*b, 1, *v, views.size());
  EXPECT_EQ(b->counts[0], 6);
  EXPECT_EQ(b->counts[1], 10);
  EXPECT_EQ(b->counts[2], 0);
  expect_geometry(*b, 0, lights);
  expect_geometry(*b, 1, views);
}

TEST(BackendRingSearchBlock, SetsBeyondTheBlockAreRefused) {
  auto ok = RingSearchInterpolator::build(DirectionSet::ubo2003());
  ASSERT_TRUE(ok.ok());
  // 17 rings: one more than the block holds.
  std::vector<float> thetas;
  std::vector<int> counts;
  for (int r = 0; r < 17; ++r) {
    thetas.push_back(4.0f * static_cast<float>(r));
    counts.push_back(r == 0 ? 1 : 4);
  }
  auto many_rings = RingSearchInterpolator::build(DirectionSet::from_rings("r17", thetas, counts, {}, false));
  ASSERT_TRUE(many_rings.ok()) << many_rings.message();
  auto r1 = pack_ring_search_block(*many_rings, *ok);
  ASSERT_FALSE(r1.ok());
  EXPECT_EQ(r1.status(), Status::invalid_argument);
  EXPECT_NE(r1.message().find("light"), std::string::npos) << r1.message();
  // 3 rings of 100 directions: more directions than slots.
  const float t3[] = {20.0f, 40.0f, 60.0f};
  const int c3[] = {100, 100, 100};
  auto many_dirs = RingSearchInterpolator::build(DirectionSet::from_rings("d300", t3, c3, {}, false));
  ASSERT_TRUE(many_dirs.ok()) << many_dirs.message();
  auto r2 = pack_ring_search_block(*ok, *many_dirs);
  ASSERT_FALSE(r2.ok());
  EXPECT_NE(r2.message().find("view"), std::string::npos) << r2.message();
}

TEST(BackendRingSearchBlock, GeneratedBlockMatchesTheMirror) {
  // The block the generated functions declare: the member names and array sizes the mirror
  // (and every host that uploads it) assumes.
  ShaderConfig c;
  auto fn = generate_functions(glsl_pieces({GlslPiece::pca_rings}), GlslTarget::es300, c);
  ASSERT_TRUE(fn.ok()) << fn.message();
  const std::string& s = fn->code;
  shader_text::expect_contains(
      s, {"layout(std140) uniform btflod_DirectionRings {", "vec4 btflod_rings[2 * btflod_kRingMax];",
          "uvec4 btflod_ring_slots[btflod_kRingSlots / 2];", "ivec4 btflod_ring_counts;",
          "const int btflod_kRingMax = 16;", "const int btflod_kRingSlots = 256;"});
  // pca_rings reads the ring search, never the angular tables.
  EXPECT_NE(s.find("btflod_ring_search(0, wl, il, al);"), std::string::npos);
  EXPECT_EQ(s.find("angular_index"), std::string::npos);
  // GL 4.5 / Vulkan: the block at the binding (and set) of ShaderBinding::direction_rings.
  GlslFunctionOptions o;
  o.resource(ShaderBinding::direction_rings).binding = 7;
  o.resource(ShaderBinding::direction_rings).set = 2;
  auto gl = generate_functions(glsl_pieces({GlslPiece::ring_search}), GlslTarget::gl450_core, c, o);
  auto vk = generate_functions(glsl_pieces({GlslPiece::ring_search}), GlslTarget::vulkan450, c, o);
  ASSERT_TRUE(gl.ok() && vk.ok());
  EXPECT_NE(gl->code.find("layout(std140, binding = 7) uniform btflod_DirectionRings"), std::string::npos);
  EXPECT_NE(vk->code.find("layout(std140, set = 2, binding = 7) uniform btflod_DirectionRings"), std::string::npos);
  // With both PCA programs' functions in one generation, L and R are declared once.
  auto both = generate_functions(glsl_pieces({GlslPiece::pca_views, GlslPiece::pca_rings}), GlslTarget::es300, c);
  ASSERT_TRUE(both.ok()) << both.message();
  EXPECT_EQ(both->samplers.size(), 4u);  // angular index and weight, L, R
  // The pca_views text is the same whether or not pca_rings shares its declarations.
  auto views = generate_functions(glsl_pieces({GlslPiece::pca_views}), GlslTarget::es300, c);
  ASSERT_TRUE(views.ok());
  EXPECT_EQ(both->code.substr(0, views->code.size()), views->code);
}
