// btflod — the packed 32-bit feedback word, decimated feedback, and the votes of paper 000 eq. 9.
//
// Feedback word bit budget (most significant first):
//   [31..22] material  10 bits  0 … 1022   (1023 with all other bits set is kFeedbackNone)
//   [21..18] level      4 bits  0 … 15     (paper-000 level, 0 = coarsest)
//   [17..9]  tile y     9 bits  0 … 511
//   [8..0]   tile x     9 bits  0 … 511
// Limits: at most 1023 materials per feedback buffer (a material stands for all of its ⌈C/4⌉
// virtual textures: their votes are the same, paper 000 §5.2), and at most 512 × 512 tiles at
// the requested level, i.e. finest level ≤ 9, or 32,768 × 32,768 texels at T = 64. A finer
// hierarchy can still be used: the feedback pass then clamps its level to 9.
// kFeedbackNone (0xffffffff) marks pixels that show no streamed material (background).
//
// VoteCounter turns a span of words into v(i, l) (eq. 9: a pixel votes for its tile and every
// ancestor) with flat arrays: one run of equal words at a time is added to the tile's direct
// count, then each distinct voted tile pushes its count up its ancestor chain once. Cost:
// O(pixels) sequential reads + O(runs) + O(distinct tiles · L); no hash maps, no allocation per
// frame. The runs are found without a branch per word (SimdKernels::run_marks, core/simd.hpp:
// one bit per word, set where it differs from the one before, 128 words at a time; AVX2 and
// AVX-512 builds, bit-identical to the scalar twin), and a small direct-mapped memo of recently seen words
// skips the decoding and range checks of a word met a few runs earlier (the rows of a feedback
// buffer repeat the tiles of the row above): at 1280×720 words this made count() 1.6–2.1×
// faster than scanning each run 8 words per step, with identical results (docs/vt.md).
//
// Decimated feedback with a rotating sample position (feedback_sample_offset: one pixel of each
// d×d block per frame, every pixel once per d² frames) needs its votes accumulated over the
// rotation cycle: one frame's votes are a 1/d² subsample that differs from frame to frame, so
// at a fixed view with a full cache the scheduler sees different priorities every frame and
// keeps swapping. VoteCounter::accumulate() sums the direct votes of the last N frames (a
// sliding window; N = d² makes every pixel of the screen count exactly once), then applies
// eq. 9 to the sum. Why a sliding window and not exponentially decayed votes:
//  - exact: with N = d² the window's sum at a fixed view no longer depends on the rotation
//    phase, so from frame N on the votes are constant (equal to a full-resolution count with
//    weight 1) and the scheduler's input stops changing; decayed votes keep a phase-dependent
//    ripple (the newest sample position weighs most) that can flip near-equal priorities;
//  - integer sums and differences: bit-identical replays, no rounding drift, no threshold to
//    drop small decayed votes;
//  - bounded memory of the past: a tile that left the view loses its last vote exactly N frames
//    later (the latency cost of accumulation: choose d, and so N, with it in mind).
// Cost per frame: the frame's count, plus O(distinct tiles of the window · L); memory: a ring
// of N frames × (at most) the distinct tiles voted directly per frame, allocated up front.
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <span>
#include <vector>

#include "btflod/core/allocator.hpp"
#include "btflod/core/range_list.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/simd.hpp"

namespace btflod {

inline constexpr uint32_t kFeedbackNone = 0xffffffffu;
inline constexpr uint32_t kFeedbackMaxMaterials = 1023;
inline constexpr uint32_t kFeedbackMaxLevel = 9;  ///< 512 tiles per side
inline constexpr uint32_t kFeedbackMaxTiles = 512;

/// The fields of one feedback word.
struct FeedbackTile {
  uint32_t material = 0;
  uint32_t level = 0;
  uint32_t x = 0;
  uint32_t y = 0;
  friend constexpr bool operator==(const FeedbackTile&, const FeedbackTile&) = default;
};

/// Packs a tile into a feedback word. Returns kFeedbackNone when a field exceeds its budget
/// (material ≥ 1023, level > 15, x or y ≥ 512). constexpr, noexcept.
constexpr uint32_t pack_feedback(const FeedbackTile& t) noexcept {
  if (t.material >= kFeedbackMaxMaterials || t.level > 15 || t.x >= kFeedbackMaxTiles || t.y >= kFeedbackMaxTiles)
    return kFeedbackNone;
  return (t.material << 22) | (t.level << 18) | (t.y << 9) | t.x;
}

/// Inverse of pack_feedback. For kFeedbackNone returns material 1023 (check the word first).
constexpr FeedbackTile unpack_feedback(uint32_t word) noexcept {
  return FeedbackTile{word >> 22, (word >> 18) & 0xfu, word & 0x1ffu, (word >> 9) & 0x1ffu};
}

/// Sample position inside a factor×factor block for decimated feedback at frame `frame`:
/// every position is visited once every factor² frames, in an order that spreads consecutive
/// samples apart (bit-reversed index scattered over the block). Writes dx, dy in [0, factor).
/// Precondition: factor ≥ 1. noexcept, thread-safe.
inline void feedback_sample_offset(uint64_t frame, uint32_t factor, uint32_t& dx, uint32_t& dy) noexcept {
  if (factor <= 1) {
    dx = dy = 0;
    return;
  }
  const uint64_t n = static_cast<uint64_t>(factor) * factor;
  uint64_t bits = 0;
  while ((1ull << bits) < n) ++bits;
  // Bit-reverse the frame index over `bits` bits, skip values ≥ n (still a permutation of 0 … n−1).
  uint64_t idx = frame % n;
  uint64_t k = 0;
  for (uint64_t candidate = 0;; ++candidate) {
    uint64_t r = 0;
    for (uint64_t b = 0; b < bits; ++b) r |= ((candidate >> b) & 1ull) << (bits - 1 - b);
    if (r < n) {
      if (k == idx) {
        idx = r;
        break;
      }
      ++k;
    }
  }
  dx = static_cast<uint32_t>(idx % factor);
  dy = static_cast<uint32_t>(idx / factor);
}

/// Shape of one material's tile hierarchy as the vote counter needs it: the finest level and
/// the tile counts there (level l has ⌈tiles / 2^(L−l)⌉ tiles per side).
struct VoteLayout {
  uint32_t finest_level = 0;
  uint32_t tiles_x = 1;  ///< tiles per row at the finest level
  uint32_t tiles_y = 1;  ///< tiles per column at the finest level
};

/// Accumulation window of VoteCounter::accumulate().
struct VoteWindowConfig {
  /// N: frames summed. d² for feedback decimated d×d with feedback_sample_offset's rotation
  /// (every pixel once per window); 1 = no accumulation (accumulate() ≡ count()).
  uint32_t frames = 1;
  /// Distinct directly voted tiles remembered per frame (0: every tile of the hierarchy, which
  /// can never overflow). A frame with more keeps the first ones in feedback order and counts
  /// the rest in window_overflow(). Bounds the ring's memory to frames × this × 8 bytes.
  uint32_t max_tiles_per_frame = 0;
};

/// Room a VoteCounter reserves for materials added later (add_material); 0: what the layouts
/// given at construction need.
struct VoteCapacity {
  uint32_t materials = 0;  ///< material ids
  uint32_t tiles = 0;      ///< Σ over live materials of their tiles (all levels)
};

/// Counts votes v(i, l) of paper 000 eq. 9 per material and tile, for one frame (count()) or
/// summed over a sliding window of frames (accumulate()). Set-up allocates; count() and
/// accumulate() do not. Not thread-safe (one counter per thread); deterministic. Hostile words
/// are safe: they are counted in rejected() and ignored.
class VoteCounter {
 public:
  VoteCounter() = default;
  /// One entry per material, in material order. Precondition: finest_level ≤ 15.
  /// `window` sets accumulate()'s window (frames = 0 is taken as 1). Every array is allocated
  /// here through `allocator` (core/allocator.hpp; default: operator new), none later; a
  /// failing callback aborts (set-up memory is not optional).
  explicit VoteCounter(std::span<const VoteLayout> materials, VoteWindowConfig window = {},
                       const RuntimeAllocator& allocator = {}, const VoteCapacity& capacity = {})
      : materials_(Alloc<Material>(allocator)),
        votes_(Alloc<uint32_t>(allocator)),
        direct_(Alloc<uint32_t>(allocator)),
        touched_(Alloc<uint32_t>(allocator)),
        touched_words_(Alloc<uint32_t>(allocator)),
        ring_(Alloc<WindowEntry>(allocator)),
        ring_size_(Alloc<uint32_t>(allocator)),
        window_(Alloc<uint32_t>(allocator)),
        in_live_(Alloc<uint8_t>(allocator)),
        live_(Alloc<uint32_t>(allocator)),
        live_words_(Alloc<uint32_t>(allocator)),
        free_tiles_(allocator) {
    materials_.assign(std::max<size_t>(materials.size(), capacity.materials), Material{});
    uint32_t needed = 0;
    for (size_t i = 0; i < materials.size(); ++i) needed += shape(materials[i]).offset[16];
    const uint32_t total = std::max<uint32_t>(needed, capacity.tiles);
    free_tiles_.reset(total, materials_.size());
    for (size_t i = 0; i < materials.size(); ++i) {
      Material mm = shape(materials[i]);
      const uint32_t tiles = mm.offset[16];
      if (tiles == 0) continue;  // a free id
      mm.base = static_cast<uint32_t>(free_tiles_.allocate(tiles));
      mm.live = true;
      materials_[i] = mm;
    }
    votes_.assign(total, 0);
    direct_.assign(total, 0);
    touched_.reserve(total);
    touched_words_.reserve(total);
    window_frames_ = std::max<uint32_t>(window.frames, 1);
    if (window_frames_ > 1) {
      ring_cap_ = window.max_tiles_per_frame == 0 ? total : std::min(window.max_tiles_per_frame, total);
      ring_.assign(static_cast<size_t>(window_frames_) * ring_cap_, WindowEntry{});
      ring_size_.assign(window_frames_, 0);
      window_.assign(total, 0);
      in_live_.assign(total, 0);
      live_.reserve(total);
      live_words_.reserve(total);
    }
  }

  /// What the constructor allocates for no initial materials and `capacity` (the runtime's
  /// case: materials are added later). No allocation.
  static AllocationTally memory_required(const VoteCapacity& capacity, VoteWindowConfig window = {}) noexcept {
    const uint64_t total = capacity.tiles;
    AllocationTally t;
    t.array<decltype(materials_)>(capacity.materials);
    t += detail::RangeList::reserved_memory(capacity.materials);
    t.array<decltype(votes_)>(total);
    t.array<decltype(direct_)>(total);
    t.array<decltype(touched_)>(total);
    t.array<decltype(touched_words_)>(total);
    const uint64_t frames = std::max<uint32_t>(window.frames, 1);
    if (frames > 1) {
      const uint64_t ring =
          window.max_tiles_per_frame == 0 ? total : std::min<uint64_t>(window.max_tiles_per_frame, total);
      t.array<decltype(ring_)>(frames * ring);
      t.array<decltype(ring_size_)>(frames);
      t.array<decltype(window_)>(total);
      t.array<decltype(in_live_)>(total);
      t.array<decltype(live_)>(total);
      t.array<decltype(live_words_)>(total);
    }
    return t;
  }

  /// Starts counting votes for material id `material` (free: never given or removed) with the
  /// given shape, in tiles reserved at construction (VoteCapacity). insufficient_space when no
  /// free range of its tiles is left, invalid_argument for an id out of range or live.
  /// noexcept, no allocation.
  Status add_material(uint32_t material, const VoteLayout& layout) noexcept {
    if (material >= materials_.size() || materials_[material].live) return Status::invalid_argument;
    Material mm = shape(layout);
    const uint32_t tiles = mm.offset[16];
    if (tiles == 0) return Status::invalid_argument;
    const uint64_t base = free_tiles_.allocate(tiles);
    if (base == ~0ull) return Status::insufficient_space;
    mm.base = static_cast<uint32_t>(base);
    mm.live = true;
    materials_[material] = mm;
    return Status::success;
  }
  /// Stops counting votes for a material: its tiles leave this frame's votes and the window
  /// (words naming it are rejected from now on) and its range becomes free. invalid_argument
  /// for an id that is not live. noexcept, no allocation; O(window entries + its tiles).
  Status remove_material(uint32_t material) noexcept {
    if (material >= materials_.size() || !materials_[material].live) return Status::invalid_argument;
    const Material mm = materials_[material];
    const uint32_t lo = mm.base, hi = mm.base + mm.offset[16];
    const auto inside = [&](uint32_t idx) { return idx >= lo && idx < hi; };
    size_t o = 0;
    for (size_t i = 0; i < touched_.size(); ++i)
      if (!inside(touched_[i])) {
        touched_[o] = touched_[i];
        touched_words_[o] = touched_words_[i];
        ++o;
      } else if (i < direct_tiles_) {
        --direct_tiles_;
      }
    touched_.resize(o);  // shrinking: no allocation
    touched_words_.resize(o);
    if (window_frames_ > 1) {
      for (uint32_t f = 0; f < window_frames_; ++f) {
        WindowEntry* slot = ring_.data() + static_cast<size_t>(f) * ring_cap_;
        uint32_t n = 0;
        for (uint32_t k = 0; k < ring_size_[f]; ++k)
          if (!inside(slot[k].index)) slot[n++] = slot[k];
        ring_size_[f] = n;
      }
      o = 0;
      for (size_t i = 0; i < live_.size(); ++i)
        if (!inside(live_[i])) {
          live_[o] = live_[i];
          live_words_[o] = live_words_[i];
          ++o;
        }
      live_.resize(o);
      live_words_.resize(o);
      std::fill(window_.begin() + lo, window_.begin() + hi, 0u);
      std::fill(in_live_.begin() + lo, in_live_.begin() + hi, uint8_t{0});
    }
    std::fill(votes_.begin() + lo, votes_.begin() + hi, 0u);
    std::fill(direct_.begin() + lo, direct_.begin() + hi, 0u);
    free_tiles_.release(lo, hi - lo);
    materials_[material] = Material{};
    return Status::success;
  }
  /// The most tiles one add_material() can still take (the largest free range).
  uint64_t largest_free_tiles() const noexcept { return free_tiles_.largest(); }
  /// True when material ids' votes are counted (constructed with a shape or added).
  bool material_live(uint32_t material) const noexcept {
    return material < materials_.size() && materials_[material].live;
  }

  /// Clears the previous frame and counts `words`. Each word adds `weight` votes (use the
  /// decimation factor² to keep vote units independent of the feedback resolution). level_drop
  /// coarsens every request by that many levels (global LOD bias under overload). Returns the
  /// number of words that named a valid tile. noexcept; no allocation.
  size_t count(std::span<const uint32_t> words, uint32_t weight = 1, uint32_t level_drop = 0) noexcept {
    clear();
    const size_t n = words.size();
    const uint32_t* w = words.data();
    for (MemoEntry& e : memo_) e.word = kFeedbackNone;
    RunTotals totals;
    if (n > 0) {
      // Runs of equal words: a branch-free SIMD pass sets a bit where a word differs from the
      // one before, then each run is counted once.
      const auto run_marks = simd_kernels().run_marks;
      uint64_t marks[kRunChunk / 64];
      size_t start = 0;
      for (size_t base = 1; base < n; base += kRunChunk) {
        const size_t m = std::min(kRunChunk, n - base);
        run_marks(w + base, m, marks);
        for (size_t q = 0; q * 64 < m; ++q) {
          for (uint64_t bits = marks[q]; bits != 0; bits &= bits - 1) {
            const size_t end = base + q * 64 + static_cast<size_t>(std::countr_zero(bits));
            add_run(w[start], static_cast<uint32_t>(end - start), weight, level_drop, totals);
            start = end;
          }
        }
      }
      add_run(w[start], static_cast<uint32_t>(n - start), weight, level_drop, totals);
    }
    rejected_ += totals.rejected;
    const size_t valid = totals.valid;
    direct_tiles_ = touched_.size();
    push_to_ancestors();
    return valid;
  }

  /// Adds this frame's words to the sliding window of the last `window.frames` frames (the
  /// oldest frame drops out once the window is full) and sets v(i, l) to eq. 9 applied to the
  /// window's summed direct votes; touched(), votes_at() and direct_votes_at() then describe
  /// the window. With feedback decimated d×d at feedback_sample_offset(frame, d) and a window
  /// of d² frames, use weight 1: the window then counts every screen pixel once, and at a fixed
  /// view its votes are constant from the d²-th frame on (see the file comment for why a
  /// window and not decay). level_drop applies to this frame's words (entries keep the tile
  /// they were counted for, so a changing bias never corrupts the sums). Returns this frame's
  /// valid words. Window of 1 frame: same as count(). noexcept; no allocation; deterministic.
  size_t accumulate(std::span<const uint32_t> words, uint32_t weight = 1, uint32_t level_drop = 0) noexcept {
    const size_t valid = count(words, weight, level_drop);
    if (window_frames_ <= 1) return valid;
    // Retire the oldest frame of the ring (its slot is reused for this frame).
    WindowEntry* slot = ring_.data() + static_cast<size_t>(head_) * ring_cap_;
    if (filled_ == window_frames_) {
      for (uint32_t k = 0; k < ring_size_[head_]; ++k) window_[slot[k].index] -= slot[k].count;
    } else {
      ++filled_;
    }
    uint32_t n = 0;
    for (size_t k = 0; k < direct_tiles_; ++k) {
      const uint32_t idx = touched_[k];
      if (n == ring_cap_) {
        window_overflow_ += direct_[idx];
        continue;
      }
      slot[n++] = WindowEntry{idx, direct_[idx]};
      if (!in_live_[idx]) {
        in_live_[idx] = 1;
        live_.push_back(idx);
        live_words_.push_back(touched_words_[k]);
      }
      window_[idx] += direct_[idx];
    }
    ring_size_[head_] = n;
    head_ = head_ + 1 == window_frames_ ? 0 : head_ + 1;
    // Tiles whose window sum fell to 0 leave the live list (stable order: deterministic).
    size_t o = 0;
    for (size_t i = 0; i < live_.size(); ++i) {
      if (window_[live_[i]] == 0) {
        in_live_[live_[i]] = 0;
        continue;
      }
      live_[o] = live_[i];
      live_words_[o] = live_words_[i];
      ++o;
    }
    live_.resize(o);  // shrinking: no allocation
    live_words_.resize(o);
    // v(i, l) of the window: the live tiles' sums as direct votes, then eq. 9's ancestors.
    clear();
    for (size_t i = 0; i < live_.size(); ++i) {
      const uint32_t idx = live_[i];
      votes_[idx] = direct_[idx] = window_[idx];
      touched_.push_back(idx);
      touched_words_.push_back(live_words_[i]);
    }
    direct_tiles_ = touched_.size();
    push_to_ancestors();
    return valid;
  }

  /// Forgets the window (e.g. after a camera cut) and this frame's votes. noexcept.
  void reset_window() noexcept {
    clear();
    for (uint32_t idx : live_) {
      window_[idx] = 0;
      in_live_[idx] = 0;
    }
    live_.clear();
    live_words_.clear();
    std::fill(ring_size_.begin(), ring_size_.end(), 0u);
    head_ = filled_ = 0;
  }

  /// Frames summed by accumulate() (VoteWindowConfig::frames, at least 1).
  uint32_t window_frames() const noexcept { return window_frames_; }
  /// Votes accumulate() could not remember because a frame voted directly for more than
  /// max_tiles_per_frame tiles (0 unless that bound was set below the tile count).
  uint64_t window_overflow() const noexcept { return window_overflow_; }

 private:
  // Eq. 9: every pixel also votes for all ancestors. Push each directly voted tile's count up
  // the chain once (the touched list grows with newly reached ancestors, which are not pushed
  // again because their direct count is 0).
  void push_to_ancestors() noexcept {
    const size_t direct_tiles = direct_tiles_;
    for (size_t k = 0; k < direct_tiles; ++k) {
      const uint32_t idx = touched_[k];
      const uint32_t count = direct_[idx];
      FeedbackTile t = unpack_feedback(touched_words_[k]);
      const Material& m = materials_[t.material];
      while (t.level > 0) {
        --t.level;
        t.x >>= 1;
        t.y >>= 1;
        const uint32_t a = m.base + m.offset[t.level] + t.y * m.tiles_x[t.level] + t.x;
        if (votes_[a] == 0) {
          touched_.push_back(a);
          touched_words_.push_back(pack_feedback(t));
        }
        votes_[a] += count;
      }
    }
  }

 public:
  /// v(i, l): votes of a tile of a material (its own pixels and its descendants').
  /// Returns 0 for tiles outside the hierarchy. noexcept.
  uint32_t votes(uint32_t material, uint32_t level, uint32_t x, uint32_t y) const noexcept {
    if (material >= materials_.size()) return 0;
    const Material& m = materials_[material];
    if (!m.live || level > m.finest_level || x >= m.tiles_x[level] || y >= m.tiles_y[level]) return 0;
    return votes_[m.base + m.offset[level] + y * m.tiles_x[level] + x];
  }
  /// Votes by flat index within a material (VtLevelTable order: coarse to fine, row-major).
  /// Precondition: material and index in range.
  uint32_t votes_at(uint32_t material, uint32_t flat_index) const noexcept {
    return votes_[materials_[material].base + flat_index];
  }
  /// Pixels whose own requested tile this is (without descendants). Precondition: in range.
  uint32_t direct_votes_at(uint32_t material, uint32_t flat_index) const noexcept {
    return direct_[materials_[material].base + flat_index];
  }
  /// Every tile with v > 0 this frame, as feedback words (directly voted tiles first, in first-
  /// seen order, then ancestors). Valid until the next count().
  std::span<const uint32_t> touched() const noexcept { return touched_words_; }
  /// Words ignored since construction because they named no tile of a known material.
  uint64_t rejected() const noexcept { return rejected_; }
  /// Materials the counter was built for.
  uint32_t material_count() const noexcept { return static_cast<uint32_t>(materials_.size()); }
  /// Finest level of a material. Precondition: material < material_count().
  uint32_t finest_level(uint32_t material) const noexcept { return materials_[material].finest_level; }

 private:
  template <class T>
  using Alloc = CallbackAllocator<T>;
  template <class T>
  using Vector = std::vector<T, Alloc<T>>;

  struct Material {
    uint32_t finest_level = 0;
    uint32_t base = 0;
    uint32_t offset[17] = {};  // offset[16]: tiles over all levels
    uint32_t tiles_x[16] = {};
    uint32_t tiles_y[16] = {};
    bool live = false;
  };
  // Levels, tile counts and offsets of a layout (base 0, not live); offset[16] = its tiles.
  static Material shape(const VoteLayout& m) noexcept {
    Material mm;
    mm.finest_level = std::min<uint32_t>(m.finest_level, 15);
    uint32_t off = 0;
    for (uint32_t l = 0; l <= mm.finest_level; ++l) {
      const uint32_t s = mm.finest_level - l;
      mm.tiles_x[l] = (m.tiles_x + (1u << s) - 1) >> s;
      mm.tiles_y[l] = (m.tiles_y + (1u << s) - 1) >> s;
      mm.offset[l] = off;
      off += mm.tiles_x[l] * mm.tiles_y[l];
    }
    for (uint32_t l = mm.finest_level + 1; l <= 16; ++l) mm.offset[l] = off;
    return mm;
  }

  void clear() noexcept {
    for (uint32_t idx : touched_) {
      votes_[idx] = 0;
      direct_[idx] = 0;
    }
    touched_.clear();
    touched_words_.clear();
  }

  static constexpr uint32_t kNoIndex = 0xffffffffu;
  static constexpr size_t kMemoSize = 256;
  struct MemoEntry {
    uint32_t word = kFeedbackNone;  // kFeedbackNone: empty (never memoised: skipped before)
    uint32_t index = 0;             // flat tile index after level_drop
    uint32_t packed = 0;            // the tile's word after level_drop
  };
  static size_t memo_slot(uint32_t word) noexcept { return ((word * 0x9e3779b1u) >> 24) & (kMemoSize - 1); }

  // Words per pass of count()'s run detection (a multiple of 64: marks are 64-bit words).
  static constexpr size_t kRunChunk = 128;
  struct RunTotals {
    size_t valid = 0;
    uint64_t rejected = 0;
  };
  // One run of `run` equal words: the tile's direct count (eq. 9's own pixels). The memo keeps
  // recently seen words (direct-mapped by a hash of the word): the rows of a feedback buffer
  // repeat the tiles of the row above, so most runs name a tile looked up a few runs earlier.
  void add_run(uint32_t word, uint32_t run, uint32_t weight, uint32_t level_drop, RunTotals& totals) noexcept {
    if (word == kFeedbackNone) return;
    MemoEntry& e = memo_[memo_slot(word)];
    if (e.word != word) {
      uint32_t packed = 0;
      const uint32_t idx = direct_index(word, level_drop, packed);
      if (idx == kNoIndex) {
        totals.rejected += run;
        return;
      }
      e = MemoEntry{word, idx, packed};
    }
    if (votes_[e.index] == 0) {
      touched_.push_back(e.index);
      touched_words_.push_back(e.packed);
    }  // (ancestors are pushed only after all runs, so v > 0 here means a direct count)
    votes_[e.index] += run * weight;
    direct_[e.index] += run * weight;
    totals.valid += run;
  }

  // Flat index of the tile a word votes for directly (after level_drop), and that tile's word;
  // kNoIndex when the word names no tile of a known material.
  uint32_t direct_index(uint32_t word, uint32_t level_drop, uint32_t& packed) const noexcept {
    FeedbackTile t = unpack_feedback(word);
    if (t.material >= materials_.size()) return kNoIndex;
    const Material& m = materials_[t.material];
    if (!m.live || t.level > m.finest_level || t.x >= m.tiles_x[t.level] || t.y >= m.tiles_y[t.level]) return kNoIndex;
    if (level_drop > 0) {
      const uint32_t drop = std::min(level_drop, t.level);
      t.level -= drop;
      t.x >>= drop;
      t.y >>= drop;
    }
    packed = pack_feedback(t);
    return m.base + m.offset[t.level] + t.y * m.tiles_x[t.level] + t.x;
  }

  Vector<Material> materials_;
  Vector<uint32_t> votes_;
  Vector<uint32_t> direct_;
  Vector<uint32_t> touched_;        // flat indices with v > 0 (for clearing)
  Vector<uint32_t> touched_words_;  // the same tiles as feedback words
  size_t direct_tiles_ = 0;         // leading entries of touched_ voted directly
  uint64_t rejected_ = 0;
  // accumulate()'s sliding window: ring of the last N frames' direct (tile, count) entries.
  struct WindowEntry {
    uint32_t index = 0;  // flat tile index (after level_drop)
    uint32_t count = 0;  // direct votes of that frame
  };
  uint32_t window_frames_ = 1;
  uint32_t ring_cap_ = 0;        // entries per frame
  uint32_t head_ = 0;            // ring slot of the next frame
  uint32_t filled_ = 0;          // frames in the window so far (≤ N)
  Vector<WindowEntry> ring_;     // N × ring_cap_
  Vector<uint32_t> ring_size_;   // entries used per ring slot
  Vector<uint32_t> window_;      // Σ direct votes over the window, per flat tile
  Vector<uint8_t> in_live_;      // tile is in live_
  Vector<uint32_t> live_;        // tiles with window_ > 0, first-seen order
  Vector<uint32_t> live_words_;  // the same tiles as feedback words
  uint64_t window_overflow_ = 0;
  detail::RangeList free_tiles_;  // free ranges of the tile arrays (VoteCapacity)
  MemoEntry memo_[kMemoSize];
};

}  // namespace btflod
