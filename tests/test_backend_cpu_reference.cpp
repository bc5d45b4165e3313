// Tests for offline/render/cpu_reference.hpp: ray–shape hits and tangent frames, the eq. 1 footprint,
// feedback words, eq. 3 sampling through the page table against the pyramid, 9-tap FMF shading,
// the eq. 7 error, and the whole loop (feedback → votes → scheduler → cache) replaying exactly;
// and backend.hpp's subsample_feedback (the readback of a bsvtf_feedback frame).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/vt/scheduler.hpp"

using namespace btflod;

namespace {
EigenTextures make_fmf(int w, int h, int c, uint32_t seed) {
  EigenTextures e;
  e.textures.resize(w, h, c);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> d(-1.0f, 1.0f);
  // Smooth low frequencies plus fine noise, so coarse levels differ from fine ones.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k)
        e.textures.at(x, y, k) =
            std::sin(0.05f * (k + 1) * x) * std::cos(0.03f * y) / float(k + 1) + 0.3f * d(rng) / float(k + 1);
  e.light_count = 3;
  e.view_count = 2;
  e.angular.resize(static_cast<size_t>(3 * 2 * 3 * c));
  for (float& v : e.angular) v = d(rng);
  return e;
}

struct World {
  std::vector<TilePyramid> pyramids;
  std::vector<const TilePyramid*> pointers;
  VtSet set;
  std::unique_ptr<TileCache> cache;
  std::unique_ptr<CpuCacheTexture> texture;

  explicit World(uint32_t materials, uint32_t slots_side = 16) {
    for (uint32_t m = 0; m < materials; ++m) {
      pyramids.push_back(std::move(TilePyramid::build(make_fmf(256, 256, 8, 10 + m)).value()));
      const uint32_t id = set.add_material(pyramids.back().geometry(), pyramids.back().texture_count());
      pyramids.back().copy_weights_to(set, id);
    }
    for (const auto& p : pyramids) pointers.push_back(&p);
    cache = std::make_unique<TileCache>(std::move(TileCache::create(set, {slots_side, slots_side}).value()));
    texture = std::make_unique<CpuCacheTexture>(*cache);
    for (uint32_t t = 0; t < set.texture_count(); ++t) upload(TileId{t, 0, 0, 0});
  }
  void upload(const TileId& t) {
    const uint32_t m = set.material_of(t.texture);
    const uint32_t k = t.texture - set.material(m).first_texture;
    ASSERT_TRUE(
        texture->upload(*cache, cache->slot_of(t), pyramids[m].tile_texels(k, set.levels_of(t.texture).index(t))));
  }
  double error(const Scene& scene, const Camera& cam) const {
    return mean_abrdf_error(
        scene, cam, pointers, [&](uint32_t m, uint32_t k, const SurfaceHit& h, float, float, float* out) {
          texture->sample(*cache, set.material(m).first_texture + k, h.texcoord.x, h.texcoord.y, out);
        });
  }
};
}  // namespace

TEST(CpuReference, PlaneSphereTorusHitsAndFrames) {
  Scene scene;
  scene.add(Shape::torus(2, {0, 0, 0}, 1.0f, 0.25f));
  const SurfaceHit ht = scene.intersect(Ray{{1, 0, 5}, {0, 0, -1}});
  ASSERT_TRUE(ht.hit);
  EXPECT_NEAR(ht.t, 5.0f - 0.75f, 1e-3f);  // (1, 0, 0.75): √(1 + z²) − 1 = 0.25
  EXPECT_EQ(ht.material, 2u);
  EXPECT_NEAR(std::abs(glm::dot(glm::normalize(ht.dpdu), ht.normal)), 0.0f, 1e-3f);
  EXPECT_NEAR(std::abs(glm::dot(glm::normalize(ht.dpdv), ht.normal)), 0.0f, 1e-3f);
  EXPECT_GT(glm::dot(ht.normal, glm::vec3(0, 0, 1)), 0.0f);  // faces the ray origin

  Scene s2;
  s2.add(Shape::sphere(1, {0, 0, 0}, 2.0f, {2, 1}));
  const SurfaceHit hs = s2.intersect(Ray{{0, 0, 10}, {0, 0, -1}});
  ASSERT_TRUE(hs.hit);
  EXPECT_NEAR(hs.t, 8.0f, 1e-4f);
  EXPECT_NEAR(hs.texcoord.x, 0.5f, 1e-4f);                         // φ = 90° → u = 0.25, ×2 repeats
  EXPECT_NEAR(hs.texcoord.y, 0.5f, 1e-4f);                         // θ = 90°
  EXPECT_NEAR(glm::length(hs.dpdu), kTwoPi * 2.0f / 2.0f, 1e-3f);  // scaled by the repeat

  Scene s3;
  s3.add(Shape::plane(0, {-1, 0, -1}, {1, 0, 0}, {0, 0, 1}, 2.0f, 2.0f));
  s3.add(Shape::sphere(1, {0, 3, 0}, 0.5f));  // in front of the plane: nearer hit wins
  const SurfaceHit hp = s3.intersect(Ray{{0.5f, 5, 0.5f}, {0, -1, 0}});
  ASSERT_TRUE(hp.hit);
  EXPECT_EQ(hp.material, 0u);
  EXPECT_NEAR(hp.texcoord.x, 0.75f, 1e-5f);
  EXPECT_NEAR(hp.texcoord.y, 0.75f, 1e-5f);
  EXPECT_NEAR(hp.normal.y, 1.0f, 1e-6f);
  EXPECT_EQ(s3.intersect(Ray{{0, 5, 0}, {0, -1, 0}}).material, 1u);
  EXPECT_FALSE(s3.intersect(Ray{{5, 5, 5}, {0, -1, 0}}).hit);
}

// The local frame is (t along dpdu, b on dpdv's side, n): a direction along +dpdv has local
// y > 0 on every shape, also where dpdu × dpdv points against the normal (a torus seen from
// outside, whose mesh carries tangent.w = −1 for the shaders). A frame built as n × t alone
// mirrors y there, so the CPU ray-caster and the GPU disagree on every torus.
TEST(CpuReference, LocalFrameFollowsTheParameterisationOnEveryShape) {
  Scene scene;
  scene.add(Shape::torus(0, {0, 0, 0}, 1.0f, 0.25f));
  scene.add(Shape::sphere(1, {0, 0, 10}, 0.5f));
  scene.add(Shape::plane(2, {-1, -3, -1}, {1, 0, 0}, {0, 0, 1}, 2.0f, 2.0f));
  const Ray rays[] = {Ray{{1, 0, 5}, {0, 0, -1}}, Ray{{0.3f, 0.2f, 5}, {0, 0, 1}}, Ray{{0.2f, 0, 0.3f}, {0, -1, 0}},
                      Ray{{0.2f, -5, 0.3f}, {0, 1, 0}}};  // torus, sphere, plane from above and below
  int hits = 0;
  for (const Ray& r : rays) {
    const SurfaceHit h = scene.intersect(r);
    ASSERT_TRUE(h.hit);
    ++hits;
    const glm::vec3 along_u = glm::normalize(h.dpdu), along_v = glm::normalize(h.dpdv);
    EXPECT_GT(to_local(h, along_u).x, 0.99f);
    EXPECT_GT(to_local(h, along_v).y, 0.99f) << "material " << h.material;
    EXPECT_NEAR(to_local(h, h.normal).z, 1.0f, 1e-5f);
  }
  EXPECT_EQ(hits, 4);
  // The torus from outside is left-handed: dpdu × dpdv points inwards.
  const SurfaceHit ht = scene.intersect(rays[0]);
  EXPECT_LT(glm::dot(glm::cross(ht.dpdu, ht.dpdv), ht.normal), 0.0f);
}

TEST(CpuReference, FootprintAndFeedbackFollowEquations1And2) {
  // Camera 4 units above a 2×2 plane of a 512² texture, looking straight down; 128 px high with
  // fov 2·atan(0.25) → the view is 2 units tall: 64 px per unit, 256 texels per unit → 4 texels
  // per pixel → level L − 2.
  Scene scene;
  scene.add(Shape::plane(0, {-1, 0, -1}, {1, 0, 0}, {0, 0, 1}, 2.0f, 2.0f));
  Camera cam;
  cam.position = {0, 4, 0};
  cam.target = {0, 0, 0};
  cam.up = {0, 0, -1};
  cam.fov_y_degrees = radians_to_degrees(2.0f * std::atan(0.25f));
  cam.width = cam.height = 128;
  const SurfaceHit h = scene.intersect(cam.ray(64.5f, 64.5f));
  ASSERT_TRUE(h.hit);
  const LodInput in = surface_footprint(cam, h, 64.5f, 64.5f, 512, 512);
  EXPECT_NEAR(in.footprint_x, 4.0f, 0.05f);
  EXPECT_NEAR(in.footprint_y, 4.0f, 0.05f);
  EXPECT_NEAR(in.distance, 4.0f, 1e-4f);
  VtSet set;
  set.add_material(VtGeometry::make(512, 512), 1);  // L = 3
  std::vector<uint32_t> fb(128 * 128);
  ASSERT_TRUE(render_feedback(scene, cam, set, DerivativeLod{}, 1, 0, fb));
  const FeedbackTile centre = unpack_feedback(fb[64 * 128 + 64]);
  EXPECT_EQ(centre.material, 0u);
  EXPECT_EQ(centre.level, 1u);  // L − log2 4 = 1
  // Level 1 has 2×2 tiles; the image centre is at texcoord (0.5, 0.5) → tiles change there.
  EXPECT_EQ(unpack_feedback(fb[10 * 128 + 10]).x, 0u);
  EXPECT_EQ(unpack_feedback(fb[100 * 128 + 100]).x, 1u);
  // Decimated by 4: 32×32 words, rotating sample positions give different buffers.
  std::vector<uint32_t> d0(32 * 32), d1(32 * 32);
  ASSERT_TRUE(render_feedback(scene, cam, set, DerivativeLod{}, 4, 0, d0));
  ASSERT_TRUE(render_feedback(scene, cam, set, DerivativeLod{}, 4, 1, d1));
  for (uint64_t f : {0u, 1u}) {
    uint32_t dx, dy;
    feedback_sample_offset(f, 4, dx, dy);
    const std::vector<uint32_t>& d = f == 0 ? d0 : d1;
    for (uint32_t y = 0; y < 32; ++y)
      for (uint32_t x = 0; x < 32; ++x) ASSERT_EQ(d[y * 32 + x], fb[(y * 4 + dy) * 128 + x * 4 + dx]);
  }
  std::vector<uint32_t> small(10);
  EXPECT_FALSE(render_feedback(scene, cam, set, DerivativeLod{}, 4, 0, small));
  // Range-based LOD through the same concept: d = 4 with d0 = 1 → λ = 2 → level 1.
  std::vector<uint32_t> fr(128 * 128);
  ASSERT_TRUE(render_feedback(scene, cam, set, RangeLod{}, 1, 0, fr));
  EXPECT_EQ(unpack_feedback(fr[64 * 128 + 64]).level, 1u);
}

TEST(CpuReference, PageTableSamplingMatchesThePyramidAtTheResidentLevel) {
  World w(1, 12);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> d(0.0f, 0.9999f);
  const auto compare = [&](int samples) {
    for (int i = 0; i < samples; ++i) {
      const float u = d(rng), v = d(rng);
      for (uint32_t k = 0; k < 2; ++k) {
        float got[4], want[4];
        const uint32_t level = w.texture->sample(*w.cache, k, u, v, got);
        w.pyramids[0].sample(k, level, u, v, want);
        for (int c = 0; c < 4; ++c) ASSERT_NEAR(got[c], want[c], 2e-3f + 1e-3f * std::abs(want[c])) << u << "," << v;
      }
    }
  };
  compare(300);  // roots only: level 0 everywhere
  // Random adds (uploading each tile) keep matching at whatever level the page table names.
  for (int step = 0; step < 200; ++step) {
    const SlotInfo& si = w.cache->slot(rng() % w.cache->slot_count());
    if (si.state != SlotInfo::State::used || si.tile.level == w.pyramids[0].geometry().finest_level) continue;
    const TileId child = si.tile.child(rng() % 4);
    if (w.cache->resident(child)) continue;
    const uint32_t s = w.cache->reserve_slot();
    if (s == kNoSlot) break;
    ASSERT_EQ(w.cache->add(child, s, 0), Status::success);
    w.upload(child);
  }
  compare(500);
}

TEST(CpuReference, ShadeFmfMultipliesLightAndViewWeights) {
  const EigenTextures e = make_fmf(8, 8, 3, 1);
  AngularSample l, v;
  l.index = {0, 2, 1};
  l.weight = {0.5f, 0.3f, 0.2f};
  v.index = {1, 0, 0};
  v.weight = {0.75f, 0.25f, 0.0f};
  const float comp[3] = {0.3f, -0.7f, 2.0f};
  const glm::vec3 got = shade_fmf(e, l, v, comp);
  for (int colour = 0; colour < 3; ++colour) {
    double want = 0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (uint32_t c = 0; c < 3; ++c)
          want += double(l.weight[i]) * v.weight[j] * e.u(l.index[i], v.index[j], colour, c) * comp[c];
    EXPECT_NEAR(got[colour], want, 1e-5);
  }
  // Components past the span count as zero (U' packets not yet streamed).
  const glm::vec3 first = shade_fmf(e, l, v, std::span<const float>(comp, 1));
  double want0 = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      want0 += double(l.weight[i]) * v.weight[j] * e.u(l.index[i], v.index[j], 0, 0) * comp[0];
  EXPECT_NEAR(first[0], want0, 1e-5);
}

TEST(CpuReference, WholeLoopLowersEquation7ErrorAndReplaysExactly) {
  Scene scene;
  scene.add(Shape::plane(0, {-2, 0, -2}, {1, 0, 0}, {0, 0, 1}, 4.0f, 4.0f));
  scene.add(Shape::sphere(1, {0, 0.8f, 0}, 0.8f, {2, 1}));
  scene.add(Shape::torus(1, {1.2f, 0.3f, 1.0f}, 0.5f, 0.2f, {3, 1}));
  const auto run = [&](std::vector<double>& errors, std::vector<uint64_t>& schedule, std::vector<double>* roots) {
    World w(2, 8);  // 64 slots for 4 virtual textures of 21 tiles each: a real limit
    SchedulerConfig cfg;
    cfg.budgets.uploads_per_frame = 8;
    auto sched = std::move(Scheduler::create(*w.cache, cfg).value());
    VoteCounter votes(vote_layouts(w.set));
    Camera cam;
    cam.width = 160;
    cam.height = 120;
    std::vector<uint32_t> fb(40 * 30);
    for (uint64_t f = 0; f < 12; ++f) {
      const float a = 0.15f * static_cast<float>(f);
      cam.position = {3.0f * std::cos(a), 2.0f, 3.0f * std::sin(a)};
      render_feedback(scene, cam, w.set, DerivativeLod{}, 4, f, fb);
      votes.count(fb, 16);
      const auto req = sched.plan(*w.cache, votes, f);
      for (const TileRequest& r : req) {
        schedule.push_back(r.tile.key());
        if (sched.begin_decode(r.id)) sched.finish_decode(r.id);
      }
      sched.apply_uploads(*w.cache);
      // Copy texels for every resident tile (cheap at this size) so the CPU texture matches
      // the cache exactly, whichever tiles the uploads and removals touched.
      for (uint32_t s = 0; s < w.cache->slot_count(); ++s)
        if (w.cache->slot(s).state == SlotInfo::State::used) w.upload(w.cache->slot(s).tile);
      std::string why;
      ASSERT_TRUE(w.cache->check_invariants(&why)) << why;
      errors.push_back(w.error(scene, cam));
      if (roots != nullptr)  // the same frame with only the pinned roots (level 0)
        roots->push_back(mean_abrdf_error(scene, cam, w.pointers,
                                          [&](uint32_t m, uint32_t k, const SurfaceHit& h, float, float, float* out) {
                                            w.pyramids[m].sample(k, 0, h.texcoord.x, h.texcoord.y, out);
                                          }));
    }
  };
  std::vector<double> e1, e2, r1;
  std::vector<uint64_t> s1, s2;
  run(e1, s1, &r1);
  run(e2, s2, nullptr);
  EXPECT_EQ(e1, e2);  // bit-identical replay
  EXPECT_EQ(s1, s2);
  ASSERT_EQ(e1.size(), 12u);
  for (size_t f = 3; f < e1.size(); ++f) EXPECT_LT(e1[f], 0.7 * r1[f]) << "frame " << f << ": streaming must reduce E";
  EXPECT_GT(s1.size(), 10u);
}

TEST(BackendFeedback, SubsampleTakesTheSamplePixelOfEveryBlock) {
  // 10 × 7 screen, 3 × 2 feedback texels → blocks of ⌈10/3⌉ × ⌈7/2⌉ = 4 × 4 pixels; the last
  // block column and row are cut by the screen edge.
  FrameDesc f;
  f.width = 10;
  f.height = 7;
  f.feedback_width = 3;
  f.feedback_height = 2;
  f.feedback_sample_x = 1;
  f.feedback_sample_y = 3;
  ASSERT_EQ(f.feedback_block_width(), 4u);
  ASSERT_EQ(f.feedback_block_height(), 4u);
  std::vector<uint32_t> top_down(70), bottom_up(70);
  for (uint32_t y = 0; y < 7; ++y)
    for (uint32_t x = 0; x < 10; ++x) {
      top_down[y * 10 + x] = 100 * y + x;         // row 0 = top
      bottom_up[(6 - y) * 10 + x] = 100 * y + x;  // row 0 = bottom, as GL reads back
    }
  const uint32_t empty = 0xffffffffu;
  std::vector<uint32_t> out(6, 7u);
  ASSERT_EQ(subsample_feedback(top_down, false, f, empty, out), Status::success);
  // texel (x, y) = pixel (4x + 1, 4y + 3); y = 1 asks for row 7, past the 7-row screen
  EXPECT_EQ(out, (std::vector<uint32_t>{301, 305, 309, empty, empty, empty}));
  std::vector<uint32_t> flipped(6, 7u);
  ASSERT_EQ(subsample_feedback(bottom_up, true, f, empty, flipped), Status::success);
  EXPECT_EQ(flipped, out);
  f.feedback_sample_x = 3;  // texel (2, ·) → pixel 11, past the 10-column screen
  f.feedback_sample_y = 2;
  ASSERT_EQ(subsample_feedback(top_down, false, f, empty, out), Status::success);
  EXPECT_EQ(out, (std::vector<uint32_t>{203, 207, empty, 603, 607, empty}));
  // Bad calls write nothing.
  std::vector<uint32_t> untouched(6, 7u);
  f.feedback_sample_x = 4;  // outside the block
  EXPECT_EQ(subsample_feedback(top_down, false, f, empty, untouched), Status::invalid_argument);
  f.feedback_sample_x = 0;
  EXPECT_EQ(subsample_feedback(std::span<const uint32_t>(top_down).first(69), false, f, empty, untouched),
            Status::invalid_argument);
  EXPECT_EQ(subsample_feedback(top_down, false, f, empty, std::span<uint32_t>(untouched).first(5)),
            Status::invalid_argument);
  f.feedback_width = 0;
  EXPECT_EQ(subsample_feedback(top_down, false, f, empty, untouched), Status::invalid_argument);
  EXPECT_EQ(untouched, std::vector<uint32_t>(6, 7u));
}
