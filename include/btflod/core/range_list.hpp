// btflod — a first-fit list of free ranges over [0, capacity): the ids, page-table layers and
// per-tile entries that materials added to a running world take and give back
// (runtime/vt/vt_layout.hpp's VtSet, runtime/lod/feedback.hpp's VoteCounter). Room for the list itself is
// reserved up front, so taking and returning ranges never allocates.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "btflod/core/allocator.hpp"

namespace btflod {

namespace detail {
// Free ranges of [0, capacity), sorted by offset, first fit; adjacent ranges merge on free.
// Capacity for the range list itself is reserved up front (live materials + 1 ranges at most),
// so allocate()/release() never allocate.
class RangeList {
 public:
  explicit RangeList(const RuntimeAllocator& a = {}) : ranges_(CallbackAllocator<Range>(a)) {}
  RangeList(const RangeList& o, const RuntimeAllocator& a) : ranges_(CallbackAllocator<Range>(a)) {
    ranges_.reserve(o.ranges_.capacity());
    ranges_.assign(o.ranges_.begin(), o.ranges_.end());
  }
  // What reset(…, max_ranges) allocates (and a copy of such a list).
  static AllocationTally reserved_memory(size_t max_ranges) noexcept {
    AllocationTally t;
    t.array<decltype(ranges_)>(max_ranges + 1);
    return t;
  }
  void reset(uint64_t capacity, size_t max_ranges) {
    ranges_.clear();
    ranges_.reserve(max_ranges + 1);
    if (capacity > 0) ranges_.push_back(Range{0, capacity});
  }
  // Appends [offset, offset + n) at the end (grow mode; allocates).
  void grow(uint64_t offset, uint64_t n) {
    if (n == 0) return;
    ranges_.reserve(ranges_.size() + 2);  // room for release() to split a range later
    if (!ranges_.empty() && ranges_.back().offset + ranges_.back().size == offset)
      ranges_.back().size += n;
    else
      ranges_.push_back(Range{offset, n});
  }
  // Offset of a free range of n (first fit), or ~0 when none is large enough.
  uint64_t allocate(uint64_t n) noexcept {
    for (size_t i = 0; i < ranges_.size(); ++i) {
      Range& r = ranges_[i];
      if (r.size < n) continue;
      const uint64_t at = r.offset;
      r.offset += n;
      r.size -= n;
      if (r.size == 0) ranges_.erase(ranges_.begin() + static_cast<ptrdiff_t>(i));
      return at;
    }
    return ~0ull;
  }
  void release(uint64_t offset, uint64_t n) noexcept {
    if (n == 0) return;
    size_t i = 0;
    while (i < ranges_.size() && ranges_[i].offset < offset) ++i;
    const bool join_left = i > 0 && ranges_[i - 1].offset + ranges_[i - 1].size == offset;
    const bool join_right = i < ranges_.size() && offset + n == ranges_[i].offset;
    if (join_left && join_right) {
      ranges_[i - 1].size += n + ranges_[i].size;
      ranges_.erase(ranges_.begin() + static_cast<ptrdiff_t>(i));
    } else if (join_left) {
      ranges_[i - 1].size += n;
    } else if (join_right) {
      ranges_[i].offset = offset;
      ranges_[i].size += n;
    } else if (ranges_.size() < ranges_.capacity()) {  // never full: ranges ≤ live materials + 1
      ranges_.insert(ranges_.begin() + static_cast<ptrdiff_t>(i), Range{offset, n});
    }
  }
  uint64_t largest() const noexcept {
    uint64_t m = 0;
    for (const Range& r : ranges_) m = std::max(m, r.size);
    return m;
  }

 private:
  struct Range {
    uint64_t offset = 0, size = 0;
  };
  std::vector<Range, CallbackAllocator<Range>> ranges_;
};
}  // namespace detail

}  // namespace btflod
