// Tests for lod/: LOD selectors (paper 000 eq. 1, paper 001 §3.4), the feedback word and the
// votes of paper 000 eq. 9 (checked against a brute-force count).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <span>
#include <tuple>
#include <vector>

#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/lod/lod_selector.hpp"

using namespace btflod;

TEST(LodSelector, DerivativeFollowsEquation1) {
  DerivativeLod d;
  EXPECT_FLOAT_EQ(d.level({1.0f, 1.0f, 1.0f}, 5), 5.0f);
  EXPECT_FLOAT_EQ(d.level({2.0f, 1.0f, 1.0f}, 5), 4.0f);  // max of the two axes
  EXPECT_FLOAT_EQ(d.level({1.0f, 4.0f, 1.0f}, 5), 3.0f);
  EXPECT_FLOAT_EQ(d.level({0.25f, 0.25f, 1.0f}, 5), 5.0f);   // magnification clamps to L
  EXPECT_FLOAT_EQ(d.level({1024.0f, 1.0f, 1.0f}, 5), 0.0f);  // clamps to the root
  d.bias = 1.0f;
  EXPECT_FLOAT_EQ(d.level({2.0f, 1.0f, 1.0f}, 5), 3.0f);
  EXPECT_FLOAT_EQ(d.level({std::nanf(""), 1.0f, 1.0f}, 5), 5.0f);
}

TEST(LodSelector, AnisotropyUsesMinorAxisUpToRatio) {
  DerivativeLod iso, aniso;
  aniso.max_anisotropy = 4.0f;
  // 8:1 footprint: isotropic takes 8 (L − 3); 4× anisotropic takes max(8/4, 1) = 2 (L − 1).
  EXPECT_FLOAT_EQ(iso.level({8.0f, 1.0f, 1.0f}, 6), 3.0f);
  EXPECT_FLOAT_EQ(aniso.level({8.0f, 1.0f, 1.0f}, 6), 5.0f);
  // 2:1 within the ratio: the minor axis (1) decides → L.
  EXPECT_FLOAT_EQ(aniso.level({2.0f, 1.0f, 1.0f}, 6), 6.0f);
}

TEST(LodSelector, RangeBasedFollowsPaper001) {
  RangeLod r;
  r.reference_distance = 2.0f;
  EXPECT_FLOAT_EQ(r.level({1, 1, 1.0f}, 4), 4.0f);  // d < d0 → λ = 0
  EXPECT_FLOAT_EQ(r.level({1, 1, 8.0f}, 4), 2.0f);  // λ = log2(4) = 2
  EXPECT_FLOAT_EQ(r.level({1, 1, 1e9f}, 4), 0.0f);  // λ clamped to λmax = L
  EXPECT_FLOAT_EQ(r.level({1, 1, std::numeric_limits<float>::infinity()}, 4), 0.0f);
}

TEST(LodSelector, FeedbackLevelIsTheFinerTrilinearLevel) {
  EXPECT_EQ(feedback_level(2.0f, 5), 2u);
  EXPECT_EQ(feedback_level(2.1f, 5), 3u);
  EXPECT_EQ(feedback_level(2.001f, 5), 2u);  // float noise above an integer
  EXPECT_EQ(feedback_level(-1.0f, 5), 0u);
  EXPECT_EQ(feedback_level(7.5f, 5), 5u);
}

TEST(FeedbackWord, RoundTripsEveryFieldAtItsLimits) {
  std::mt19937 rng(3);
  for (int i = 0; i < 10000; ++i) {
    FeedbackTile t{uint32_t(rng()) % kFeedbackMaxMaterials, uint32_t(rng()) % 16, uint32_t(rng()) % 512,
                   uint32_t(rng()) % 512};
    const uint32_t w = pack_feedback(t);
    ASSERT_NE(w, kFeedbackNone);
    EXPECT_EQ(unpack_feedback(w), t);
  }
  EXPECT_EQ(unpack_feedback(pack_feedback({1022, 15, 511, 511})), (FeedbackTile{1022, 15, 511, 511}));
  EXPECT_EQ(pack_feedback({1023, 0, 0, 0}), kFeedbackNone);
  EXPECT_EQ(pack_feedback({0, 16, 0, 0}), kFeedbackNone);
  EXPECT_EQ(pack_feedback({0, 9, 512, 0}), kFeedbackNone);
  EXPECT_EQ(pack_feedback({0, 9, 0, 512}), kFeedbackNone);
}

TEST(FeedbackDecimation, VisitsEveryPositionOncePerCycle) {
  for (uint32_t factor : {1u, 2u, 3u, 4u, 8u}) {
    std::set<std::pair<uint32_t, uint32_t>> seen;
    for (uint64_t f = 0; f < factor * factor; ++f) {
      uint32_t dx = 99, dy = 99;
      feedback_sample_offset(f, factor, dx, dy);
      ASSERT_LT(dx, factor);
      ASSERT_LT(dy, factor);
      seen.insert({dx, dy});
    }
    EXPECT_EQ(seen.size(), factor * factor) << "factor " << factor;
  }
  // Consecutive frames do not sample neighbouring positions in a 4×4 block.
  uint32_t x0, y0, x1, y1;
  feedback_sample_offset(0, 4, x0, y0);
  feedback_sample_offset(1, 4, x1, y1);
  EXPECT_GE(std::abs(int(x0) - int(x1)) + std::abs(int(y0) - int(y1)), 2);
}

namespace {
// Brute force of eq. 9: v(i, l) = #{pixels whose tile (i', l') has l' ≥ l and i = ⌊2^(l−l') i'⌋}.
std::map<std::tuple<uint32_t, uint32_t, uint32_t, uint32_t>, uint32_t> brute_votes(
    const std::vector<uint32_t>& words, const std::vector<VoteLayout>& layouts) {
  std::map<std::tuple<uint32_t, uint32_t, uint32_t, uint32_t>, uint32_t> v;
  for (uint32_t w : words) {
    if (w == kFeedbackNone) continue;
    const FeedbackTile t = unpack_feedback(w);
    if (t.material >= layouts.size()) continue;
    const VoteLayout& m = layouts[t.material];
    if (t.level > m.finest_level) continue;
    const uint32_t s = m.finest_level - t.level;
    if (t.x >= ((m.tiles_x + (1u << s) - 1) >> s) || t.y >= ((m.tiles_y + (1u << s) - 1) >> s)) continue;
    for (uint32_t l = 0; l <= t.level; ++l) ++v[{t.material, l, t.x >> (t.level - l), t.y >> (t.level - l)}];
  }
  return v;
}

// A word naming a random tile of a random material at a random level of `layouts` (rng draws:
// material, level, x, y).
uint32_t random_valid_word(const std::vector<VoteLayout>& layouts, std::mt19937& rng) {
  const uint32_t m = uint32_t(rng()) % static_cast<uint32_t>(layouts.size());
  const uint32_t l = uint32_t(rng()) % (layouts[m].finest_level + 1);
  const uint32_t s = layouts[m].finest_level - l;
  const uint32_t tx = (layouts[m].tiles_x + (1u << s) - 1) >> s, ty = (layouts[m].tiles_y + (1u << s) - 1) >> s;
  return pack_feedback({m, l, uint32_t(rng()) % tx, uint32_t(rng()) % ty});
}
}  // namespace

TEST(Votes, MatchBruteForceEquation9OnRandomBuffers) {
  const std::vector<VoteLayout> layouts = {{3, 8, 8}, {4, 13, 5}, {0, 1, 1}};
  VoteCounter counter(layouts);
  std::mt19937 rng(7);
  for (int round = 0; round < 20; ++round) {
    std::vector<uint32_t> words;
    for (int i = 0; i < 3000; ++i) {
      const uint32_t r = uint32_t(rng()) % 10;
      if (r == 0)
        words.push_back(kFeedbackNone);
      else if (r == 1)
        words.push_back(uint32_t(rng()));  // hostile: any bits
      else if (r < 5 && !words.empty())
        words.push_back(words.back());  // runs
      else
        words.push_back(random_valid_word(layouts, rng));
    }
    counter.count(words);
    const auto want = brute_votes(words, layouts);
    size_t nonzero = 0;
    for (uint32_t m = 0; m < layouts.size(); ++m)
      for (uint32_t l = 0; l <= layouts[m].finest_level; ++l) {
        const uint32_t s = layouts[m].finest_level - l;
        for (uint32_t y = 0; y < ((layouts[m].tiles_y + (1u << s) - 1) >> s); ++y)
          for (uint32_t x = 0; x < ((layouts[m].tiles_x + (1u << s) - 1) >> s); ++x) {
            auto it = want.find({m, l, x, y});
            const uint32_t expected = it == want.end() ? 0 : it->second;
            ASSERT_EQ(counter.votes(m, l, x, y), expected) << m << " " << l << " " << x << " " << y;
            nonzero += expected > 0;
          }
      }
    EXPECT_EQ(counter.touched().size(), nonzero);
  }
  EXPECT_GT(counter.rejected(), 0u);
}

namespace {
// count() as the file comment defines it, one word at a time: the touched list holds the
// directly voted tiles in first-seen order, then their ancestors in the order the chains are
// pushed; returns the valid words and the rejected ones.
struct ReferenceVotes {
  std::map<std::array<uint32_t, 4>, uint32_t> votes, direct;
  std::vector<uint32_t> touched;
  size_t valid = 0;
  uint64_t rejected = 0;
};
ReferenceVotes reference_count(const std::vector<uint32_t>& words, const std::vector<VoteLayout>& layouts,
                               uint32_t weight, uint32_t level_drop) {
  ReferenceVotes r;
  const auto tiles = [&](uint32_t m, uint32_t l, uint32_t& tx, uint32_t& ty) {
    const uint32_t s = layouts[m].finest_level - l;
    tx = (layouts[m].tiles_x + (1u << s) - 1) >> s;
    ty = (layouts[m].tiles_y + (1u << s) - 1) >> s;
  };
  for (uint32_t w : words) {
    if (w == kFeedbackNone) continue;
    FeedbackTile t = unpack_feedback(w);
    uint32_t tx = 0, ty = 0;
    if (t.material >= layouts.size() || t.level > layouts[t.material].finest_level) {
      ++r.rejected;
      continue;
    }
    tiles(t.material, t.level, tx, ty);
    if (t.x >= tx || t.y >= ty) {
      ++r.rejected;
      continue;
    }
    const uint32_t drop = std::min(level_drop, t.level);
    t = FeedbackTile{t.material, t.level - drop, t.x >> drop, t.y >> drop};
    const std::array<uint32_t, 4> key{t.material, t.level, t.x, t.y};
    if (r.direct[key] == 0) r.touched.push_back(pack_feedback(t));
    r.direct[key] += weight;
    ++r.valid;
  }
  r.votes = r.direct;
  const size_t direct_tiles = r.touched.size();
  for (size_t k = 0; k < direct_tiles; ++k) {
    FeedbackTile t = unpack_feedback(r.touched[k]);
    const uint32_t count = r.direct[{t.material, t.level, t.x, t.y}];
    while (t.level > 0) {
      t = FeedbackTile{t.material, t.level - 1, t.x >> 1, t.y >> 1};
      uint32_t& v = r.votes[{t.material, t.level, t.x, t.y}];
      if (v == 0) r.touched.push_back(pack_feedback(t));
      v += count;
    }
  }
  return r;
}
}  // namespace

// count() finds runs 256 words at a time and memoises recently seen words: runs that cross or
// fill whole passes, buffers of every length around the pass size, more distinct words than
// the memo holds (collisions), hostile words and a level drop must give exactly the touched
// order, votes, valid and rejected counts of a word-by-word count.
TEST(Votes, RunDetectionAndMemoGiveTheWordByWordResult) {
  const std::vector<VoteLayout> layouts = {{5, 32, 32}, {4, 13, 5}, {0, 1, 1}};
  VoteCounter counter(layouts);
  std::mt19937 rng(11);
  const size_t lengths[] = {0, 1, 2, 255, 256, 257, 258, 511, 512, 513, 4000, 20000};
  for (const size_t n : lengths)
    for (uint32_t level_drop = 0; level_drop < 3; level_drop += 2) {
      std::vector<uint32_t> words;
      while (words.size() < n) {
        const uint32_t r = uint32_t(rng()) % 16;
        uint32_t w = 0;
        if (r == 0) {
          w = kFeedbackNone;
        } else if (r == 1) {
          w = uint32_t(rng());  // hostile: any bits
        } else {
          w = random_valid_word(layouts, rng);
        }
        // Runs from 1 word to longer than a pass.
        const size_t run =
            r < 12 ? 1 + uint32_t(rng()) % 8 : (r < 15 ? 1 + uint32_t(rng()) % 90 : 200 + uint32_t(rng()) % 400);
        for (size_t i = 0; i < run && words.size() < n; ++i) words.push_back(w);
      }
      const uint64_t rejected_before = counter.rejected();
      const size_t valid = counter.count(words, 3, level_drop);
      const ReferenceVotes want = reference_count(words, layouts, 3, level_drop);
      ASSERT_EQ(valid, want.valid) << n;
      ASSERT_EQ(counter.rejected() - rejected_before, want.rejected) << n;
      const std::span<const uint32_t> touched = counter.touched();
      ASSERT_EQ(std::vector<uint32_t>(touched.begin(), touched.end()), want.touched) << n << " " << level_drop;
      for (const auto& [key, v] : want.votes) ASSERT_EQ(counter.votes(key[0], key[1], key[2], key[3]), v);
    }
}

TEST(Votes, PreviousFrameIsClearedAndWeightsScale) {
  const std::vector<VoteLayout> layouts = {{2, 4, 4}};
  VoteCounter counter(layouts);
  std::vector<uint32_t> a(100, pack_feedback({0, 2, 3, 3}));
  counter.count(a);
  EXPECT_EQ(counter.votes(0, 2, 3, 3), 100u);
  EXPECT_EQ(counter.votes(0, 1, 1, 1), 100u);
  EXPECT_EQ(counter.votes(0, 0, 0, 0), 100u);
  std::vector<uint32_t> b(10, pack_feedback({0, 1, 0, 0}));
  counter.count(b, 16);  // decimated 4×4: each word stands for 16 pixels
  EXPECT_EQ(counter.votes(0, 2, 3, 3), 0u);
  EXPECT_EQ(counter.votes(0, 1, 1, 1), 0u);
  EXPECT_EQ(counter.votes(0, 1, 0, 0), 160u);
  EXPECT_EQ(counter.direct_votes_at(0, 1), 160u);
  EXPECT_EQ(counter.votes(0, 0, 0, 0), 160u);
  EXPECT_EQ(counter.direct_votes_at(0, 0), 0u);
}

TEST(Votes, LevelDropCoarsensRequests) {
  const std::vector<VoteLayout> layouts = {{3, 8, 8}};
  VoteCounter counter(layouts);
  std::vector<uint32_t> w(5, pack_feedback({0, 3, 7, 6}));
  counter.count(w, 1, 2);
  EXPECT_EQ(counter.votes(0, 3, 7, 6), 0u);
  EXPECT_EQ(counter.votes(0, 1, 1, 1), 5u);
  EXPECT_EQ(counter.direct_votes_at(0, 1 + 3), 5u);  // level 1 starts at flat index 1; (1,1) → +3
}

namespace {
// A fixed "view": a full-resolution feedback image of size × size words with a hashed tile per
// pixel (many distinct tiles, so 1/d² subsamples of it differ from frame to frame), some
// background. decimate() takes one pixel per d×d block at feedback_sample_offset(frame, d).
std::vector<uint32_t> fixed_view(uint32_t size, const VoteLayout& m) {
  std::vector<uint32_t> img(static_cast<size_t>(size) * size);
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x) {
      uint32_t h = (x * 73856093u) ^ (y * 19349663u);
      h ^= h >> 13;
      h *= 0x5bd1e995u;
      h ^= h >> 15;
      const uint32_t l = h % 4 == 0 ? m.finest_level - 1 : m.finest_level;
      const uint32_t s = m.finest_level - l;
      img[y * size + x] = h % 11 == 0
                              ? kFeedbackNone
                              : pack_feedback({0, l, ((x * m.tiles_x) / size) >> s, (h >> 8) % (m.tiles_y >> s)});
    }
  return img;
}
std::vector<uint32_t> decimate(const std::vector<uint32_t>& img, uint32_t size, uint32_t d, uint64_t frame) {
  uint32_t dx = 0, dy = 0;
  feedback_sample_offset(frame, d, dx, dy);
  std::vector<uint32_t> out;
  for (uint32_t y = dy; y < size; y += d)
    for (uint32_t x = dx; x < size; x += d) out.push_back(img[y * size + x]);
  return out;
}
std::vector<uint32_t> all_votes(const VoteCounter& c, const VoteLayout& m) {
  std::vector<uint32_t> v;
  for (uint32_t l = 0; l <= m.finest_level; ++l) {
    const uint32_t s = m.finest_level - l;
    for (uint32_t y = 0; y < ((m.tiles_y + (1u << s) - 1) >> s); ++y)
      for (uint32_t x = 0; x < ((m.tiles_x + (1u << s) - 1) >> s); ++x) v.push_back(c.votes(0, l, x, y));
  }
  return v;
}
}  // namespace

TEST(VoteWindow, RotationCycleSumEqualsFullResolutionCountAndStaysConstant) {
  const VoteLayout m{3, 8, 8};
  const uint32_t size = 64, d = 4;
  const std::vector<uint32_t> img = fixed_view(size, m);
  VoteCounter full({&m, 1});
  full.count(img);
  const std::vector<uint32_t> want = all_votes(full, m);
  VoteCounter single({&m, 1});
  VoteCounter window({&m, 1}, VoteWindowConfig{d * d, 0});
  EXPECT_EQ(window.window_frames(), d * d);
  std::vector<uint32_t> prev_single;
  uint32_t single_changes = 0;
  for (uint64_t f = 0; f < 5 * d * d; ++f) {
    const std::vector<uint32_t> words = decimate(img, size, d, f);
    window.accumulate(words);
    single.count(words, d * d);
    const std::vector<uint32_t> s = all_votes(single, m);
    if (!prev_single.empty() && s != prev_single) ++single_changes;
    prev_single = s;
    if (f + 1 < d * d) {
      EXPECT_NE(all_votes(window, m), want) << "frame " << f << ": window not full yet";
    } else {
      // Every pixel counted exactly once per cycle: the full-resolution votes, every frame.
      ASSERT_EQ(all_votes(window, m), want) << "frame " << f;
      size_t nonzero = 0;
      for (uint32_t v : want) nonzero += v > 0;
      EXPECT_EQ(window.touched().size(), nonzero);
    }
  }
  // One frame's votes (weight d²) change from frame to frame: that is what needed the window.
  EXPECT_GE(single_changes, 5 * d * d - 2);
  EXPECT_EQ(window.window_overflow(), 0u);
}

TEST(VoteWindow, OldFramesLeaveAfterExactlyNFramesAndResetForgets) {
  const VoteLayout m{2, 4, 4};
  VoteCounter c({&m, 1}, VoteWindowConfig{3, 0});
  const std::vector<uint32_t> a(7, pack_feedback({0, 2, 1, 2}));
  const std::vector<uint32_t> b(5, pack_feedback({0, 2, 3, 0}));
  c.accumulate(a);
  EXPECT_EQ(c.votes(0, 2, 1, 2), 7u);
  c.accumulate(b);
  c.accumulate(b);
  EXPECT_EQ(c.votes(0, 2, 1, 2), 7u);  // frame 0 still in the 3-frame window
  EXPECT_EQ(c.votes(0, 2, 3, 0), 10u);
  EXPECT_EQ(c.votes(0, 0, 0, 0), 17u);  // eq. 9 over the window
  c.accumulate(b);
  EXPECT_EQ(c.votes(0, 2, 1, 2), 0u);  // frame 0 dropped out
  EXPECT_EQ(c.votes(0, 1, 0, 1), 0u);
  EXPECT_EQ(c.votes(0, 2, 3, 0), 15u);
  EXPECT_EQ(c.direct_votes_at(0, 5 + 3), 15u);  // level 2 starts at flat 5; (3,0) → +3
  EXPECT_EQ(c.touched().size(), 3u);            // the tile, its parent, the root
  c.count(a);                                   // count() is one frame and leaves the window alone
  EXPECT_EQ(c.votes(0, 2, 3, 0), 0u);
  c.accumulate({});
  EXPECT_EQ(c.votes(0, 2, 3, 0), 10u);
  c.reset_window();
  EXPECT_EQ(c.votes(0, 0, 0, 0), 0u);
  c.accumulate(a);
  EXPECT_EQ(c.votes(0, 0, 0, 0), 7u);
}

TEST(VoteWindow, OneFrameWindowIsCountAndOverflowIsCountedNotCorrupting) {
  const VoteLayout m{3, 8, 8};
  const std::vector<uint32_t> img = fixed_view(32, m);
  VoteCounter a({&m, 1}), b({&m, 1}, VoteWindowConfig{1, 0});
  a.count(img, 3, 1);
  b.accumulate(img, 3, 1);
  EXPECT_EQ(all_votes(a, m), all_votes(b, m));
  // At most 2 directly voted tiles remembered per frame: the rest is counted, and the sums
  // stay consistent (after the window passes, nothing is left).
  VoteCounter small({&m, 1}, VoteWindowConfig{2, 2});
  std::vector<uint32_t> hostile = img;
  hostile.push_back(0xfffffff0u);  // a material that does not exist
  small.accumulate(hostile);
  EXPECT_GT(small.window_overflow(), 0u);
  EXPECT_GT(small.rejected(), 0u);
  EXPECT_LE(small.touched().size(), 2u + 2u * 3u);  // 2 tiles and their ancestors
  small.accumulate({});
  small.accumulate({});
  EXPECT_TRUE(small.touched().empty());
  for (uint32_t v : all_votes(small, m)) ASSERT_EQ(v, 0u);
}
