// Tests for runtime/lod/feedback_trace.hpp: round trip (words, frame information, camera), the writer
// and recorder agree, failure classes of the reader (truncated, trailing bytes, wrong
// signature/version, CRCs, sizes that do not match, decompression bomb, limits), and a trace
// replayed twice through the scheduler gives the same schedule bit for bit.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdio>
#include <filesystem>
#include <random>
#include <vector>

#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/lod/feedback_trace.hpp"
#include "btflod/runtime/vt/scheduler.hpp"
#include "test_deflate_bomb.hpp"

using namespace btflod;

namespace {

// A feedback-like frame: screen regions of a few materials, levels growing towards the bottom,
// scrolling with the frame number, some background.
std::vector<uint32_t> make_words(uint32_t w, uint32_t h, uint32_t frame, uint32_t materials = 3, uint32_t finest = 4) {
  std::vector<uint32_t> out(size_t{w} * h);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const uint32_t m = ((x * 2) / w + frame / 8) % materials;  // two of the materials in view, panning
      if ((x + y + frame) % 17 == 0) {
        out[size_t{y} * w + x] = kFeedbackNone;
        continue;
      }
      const uint32_t level = std::min(finest, 1 + y * finest / h);
      const uint32_t n = 1u << level;
      out[size_t{y} * w + x] = pack_feedback({m, level, (x + frame) % n, (y / 2) % n});
    }
  return out;
}

struct Recorded {
  std::vector<FeedbackFrameInfo> infos;
  std::vector<std::vector<uint32_t>> words;
  std::vector<uint8_t> bytes;
};

Recorded record(uint32_t frames, uint32_t w = 40, uint32_t h = 24, uint32_t d = 4) {
  Recorded r;
  for (uint32_t f = 0; f < frames; ++f) {
    FeedbackFrameInfo info;
    info.frame_index = 10 + 3 * f;
    info.width = w;
    info.height = h;
    info.decimation = d;
    feedback_sample_offset(f, d, info.sample_dx, info.sample_dy);
    info.has_camera = f % 2 == 0;
    info.camera.position[0] = static_cast<float>(f);
    info.camera.fov_y = 0.8f;
    r.infos.push_back(info);
    r.words.push_back(make_words(w, h, f));
  }
  std::vector<std::span<const uint32_t>> spans(r.words.begin(), r.words.end());
  auto bytes = write_feedback_trace(r.infos, spans, {4096, 1});
  EXPECT_TRUE(bytes.ok()) << bytes.message();
  r.bytes = std::move(*bytes);
  return r;
}

void put_u32(std::vector<uint8_t>& b, size_t at, uint32_t v) { std::memcpy(b.data() + at, &v, 4); }
uint32_t get_u32(const std::vector<uint8_t>& b, size_t at) {
  uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}
// Recomputes the CRC of the first frame's record header after editing it.
void fix_frame_header_crc(std::vector<uint8_t>& b, size_t at = kFeedbackTraceHeaderSize) {
  put_u32(b, at + 100, crc32_of({b.data() + at, 100}));
}

}  // namespace

TEST(FeedbackTrace, RoundTripKeepsWordsInfoAndCamera) {
  const Recorded r = record(7);
  auto t = read_feedback_trace(r.bytes);
  ASSERT_TRUE(t.ok()) << t.message();
  ASSERT_EQ(t->frame_count(), 7u);
  EXPECT_EQ(t->max_frame_words, 4096u);
  for (size_t i = 0; i < 7; ++i) {
    const FeedbackFrameInfo& a = r.infos[i];
    const FeedbackFrameInfo& b = t->frames[i];
    EXPECT_EQ(a.frame_index, b.frame_index);
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    EXPECT_EQ(a.decimation, b.decimation);
    EXPECT_EQ(a.sample_dx, b.sample_dx);
    EXPECT_EQ(a.sample_dy, b.sample_dy);
    EXPECT_EQ(a.has_camera, b.has_camera);
    if (a.has_camera) {
      EXPECT_EQ(b.camera.position[0], a.camera.position[0]);
      EXPECT_EQ(b.camera.fov_y, 0.8f);
    }
    const auto words = t->frame_words(i);
    ASSERT_EQ(words.size(), r.words[i].size());
    EXPECT_TRUE(std::equal(words.begin(), words.end(), r.words[i].begin())) << "frame " << i;
  }
  // Feedback compresses: the file is much smaller than the raw words.
  EXPECT_LT(r.bytes.size() * 4, 7u * 40 * 24 * 4);
}

TEST(FeedbackTrace, EmptyTraceRoundTrips) {
  auto bytes = write_feedback_trace({}, {});
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ(bytes->size(), kFeedbackTraceHeaderSize + kFeedbackTraceEndSize);
  auto t = read_feedback_trace(*bytes);
  ASSERT_TRUE(t.ok()) << t.message();
  EXPECT_EQ(t->frame_count(), 0u);
}

TEST(FeedbackTrace, RecorderWritesTheSameBytesAsTheWriter) {
  const Recorded r = record(5);
  const std::string path = (std::filesystem::temp_directory_path() / "btflod_test_trace.btftrace").string();
  {
    auto rec = FeedbackTraceRecorder::open(path, {4096, 1});
    ASSERT_TRUE(rec.ok()) << rec.message();
    for (size_t i = 0; i < r.infos.size(); ++i) ASSERT_EQ(rec->record(r.infos[i], r.words[i]), Status::success);
    EXPECT_EQ(rec->frame_count(), 5u);
    ASSERT_TRUE(rec->close().ok());
    EXPECT_EQ(rec->record(r.infos[0], r.words[0]), Status::io_error);  // closed
  }
  auto file = read_file_bytes(path);
  ASSERT_TRUE(file.ok());
  EXPECT_EQ(*file, r.bytes);
  auto t = read_feedback_trace_file(path);
  ASSERT_TRUE(t.ok()) << t.message();
  EXPECT_EQ(t->frame_count(), 5u);
  std::remove(path.c_str());
  auto missing = read_feedback_trace_file(path);
  EXPECT_EQ(missing.status(), Status::io_error);
}

TEST(FeedbackTrace, WriterRefusesInconsistentFrames) {
  auto w = FeedbackTraceWriter::create({64, 1});
  ASSERT_TRUE(w.ok());
  std::vector<uint32_t> words(8 * 8, 0);
  std::span<const uint8_t> out;
  FeedbackFrameInfo f;
  f.width = 8, f.height = 8;
  EXPECT_EQ(w->encode_frame(f, std::span(words).first(63), out), Status::invalid_argument);  // size mismatch
  f.decimation = 0;
  EXPECT_EQ(w->encode_frame(f, words, out), Status::invalid_argument);
  f.decimation = 2, f.sample_dx = 2;
  EXPECT_EQ(w->encode_frame(f, words, out), Status::invalid_argument);  // sample outside the block
  f.sample_dx = 1;
  EXPECT_EQ(w->encode_frame(f, words, out), Status::success);
  EXPECT_FALSE(out.empty());
  EXPECT_EQ(w->encode_frame(f, words, out), Status::invalid_argument);  // same frame index again
  f.frame_index = 1, f.width = 16;
  std::vector<uint32_t> big(16 * 8, 0);
  EXPECT_EQ(w->encode_frame(f, big, out), Status::invalid_argument);  // above max_frame_words
  EXPECT_EQ(w->frame_count(), 1u);
  EXPECT_FALSE(FeedbackTraceWriter::create({0, 1}).ok());
  EXPECT_FALSE(FeedbackTraceWriter::create({64, 12}).ok());
}

TEST(FeedbackTraceFailure, TruncatedAnywhereIsRefused) {
  const Recorded r = record(3);
  for (size_t n = 0; n < r.bytes.size(); ++n) {
    auto t = read_feedback_trace(std::span(r.bytes).first(n));
    ASSERT_FALSE(t.ok()) << "accepted a prefix of " << n << " bytes";
    EXPECT_TRUE(t.status() == Status::short_output || t.status() == Status::bad_data) << n << ": " << t.message();
  }
  // Cut exactly before the end record: a recording that stopped without closing.
  auto t = read_feedback_trace(std::span(r.bytes).first(r.bytes.size() - kFeedbackTraceEndSize));
  EXPECT_EQ(t.status(), Status::short_output);
  EXPECT_NE(t.message().find("no end record"), std::string::npos) << t.message();
}

TEST(FeedbackTraceFailure, TrailingBytesAreRefused) {
  Recorded r = record(2);
  r.bytes.push_back(0);
  auto t = read_feedback_trace(r.bytes);
  EXPECT_EQ(t.status(), Status::bad_data);
  EXPECT_NE(t.message().find("trailing"), std::string::npos) << t.message();
}

TEST(FeedbackTraceFailure, WrongSignatureAndVersion) {
  Recorded r = record(1);
  std::vector<uint8_t> b = r.bytes;
  b[0] = 'X';
  EXPECT_NE(read_feedback_trace(b).message().find("signature"), std::string::npos);
  b = r.bytes;
  put_u32(b, 8, 2);
  put_u32(b, 44, crc32_of({b.data(), 44}));
  auto t = read_feedback_trace(b);
  EXPECT_EQ(t.status(), Status::unsupported);
  EXPECT_NE(t.message().find("version 2"), std::string::npos) << t.message();
}

TEST(FeedbackTraceFailure, EveryFlippedByteIsCaught) {
  // Every byte of the file is covered by a CRC or a checked field: flipping any bit of any byte
  // must be refused (or, for the unused camera floats of a frame without a camera, still refused
  // by the header CRC).
  const Recorded r = record(2, 12, 8, 2);
  for (size_t i = 0; i < r.bytes.size(); ++i) {
    std::vector<uint8_t> b = r.bytes;
    b[i] ^= 0x10;
    EXPECT_FALSE(read_feedback_trace(b).ok()) << "byte " << i << " flipped and accepted";
  }
}

TEST(FeedbackTraceFailure, SizesThatDoNotMatch) {
  const Recorded r = record(2, 12, 8, 2);
  const size_t f0 = kFeedbackTraceHeaderSize;
  {  // width larger than the header's max frame words
    std::vector<uint8_t> b = r.bytes;
    put_u32(b, f0 + 16, 1000);
    fix_frame_header_crc(b);
    auto t = read_feedback_trace(b);
    EXPECT_EQ(t.status(), Status::bad_data);
    EXPECT_NE(t.message().find("1000x8"), std::string::npos) << t.message();
  }
  {  // width smaller than the payload holds: inflates to more words than declared
    std::vector<uint8_t> b = r.bytes;
    put_u32(b, f0 + 16, 6);
    fix_frame_header_crc(b);
    auto t = read_feedback_trace(b);
    EXPECT_EQ(t.status(), Status::bad_data);
    EXPECT_NE(t.message().find("end record"), std::string::npos) << t.message();  // total words disagree first
  }
  {  // payload size beyond the file
    std::vector<uint8_t> b = r.bytes;
    put_u32(b, f0 + 92, 1u << 30);
    fix_frame_header_crc(b);
    auto t = read_feedback_trace(b);
    EXPECT_EQ(t.status(), Status::short_output);
    EXPECT_NE(t.message().find("payload"), std::string::npos) << t.message();
  }
  {  // frame indices must increase
    std::vector<uint8_t> b = r.bytes;
    const size_t f1 = f0 + kFeedbackTraceFrameHeaderSize + get_u32(b, f0 + 92);
    std::memcpy(b.data() + f1 + 8, b.data() + f0 + 8, 8);
    fix_frame_header_crc(b, f1);
    EXPECT_NE(read_feedback_trace(b).message().find("does not follow"), std::string::npos);
  }
  {  // the header's max frame words above the reader's limit
    FeedbackTraceLimits limits;
    limits.max_frame_words = 10;
    EXPECT_EQ(read_feedback_trace(r.bytes, limits).status(), Status::insufficient_space);
    limits = {};
    limits.max_total_words = 100;  // 2 frames × 96 words
    EXPECT_EQ(read_feedback_trace(r.bytes, limits).status(), Status::insufficient_space);
  }
}

TEST(FeedbackTraceFailure, DecompressionBombIsRefusedWithoutAllocatingIt) {
  // A payload that inflates to 64 MiB of zeros behind a frame that declares 4×4 words. The
  // reader inflates into exactly 16 words and stops.
  const std::vector<uint8_t> deflated = btflod_test::deflated_zeros(64u << 20);
  ASSERT_FALSE(deflated.empty());
  EXPECT_LT(deflated.size(), 100000u);

  auto w = FeedbackTraceWriter::create({16, 1});
  ASSERT_TRUE(w.ok());
  std::vector<uint8_t> b(w->file_header().begin(), w->file_header().end());
  FeedbackFrameInfo f;
  f.width = 4, f.height = 4;
  std::vector<uint32_t> words(16, 0);
  std::span<const uint8_t> rec;
  ASSERT_EQ(w->encode_frame(f, words, rec), Status::success);
  std::vector<uint8_t> header(rec.begin(), rec.begin() + kFeedbackTraceFrameHeaderSize);
  put_u32(header, 92, static_cast<uint32_t>(deflated.size()));
  put_u32(header, 96, crc32_of(deflated));
  put_u32(header, 100, crc32_of({header.data(), 100}));
  b.insert(b.end(), header.begin(), header.end());
  b.insert(b.end(), deflated.begin(), deflated.end());
  // End record for the edited frame (its chained CRC covers the frame header CRC).
  std::vector<uint8_t> e(w->end_record().begin(), w->end_record().end());
  put_u32(e, 8, crc32_of({header.data() + 100, 4}));
  put_u32(e, 20, crc32_of({e.data(), 20}));
  b.insert(b.end(), e.begin(), e.end());
  auto t = read_feedback_trace(b);
  ASSERT_FALSE(t.ok());
  EXPECT_EQ(t.status(), Status::bad_data);
  EXPECT_NE(t.message().find("more than width x height"), std::string::npos) << t.message();
}

TEST(FeedbackTraceFailure, CorruptPayloadFailsItsCrc) {
  Recorded r = record(1);
  r.bytes[kFeedbackTraceHeaderSize + kFeedbackTraceFrameHeaderSize + 3] ^= 0xff;
  auto t = read_feedback_trace(r.bytes);
  EXPECT_EQ(t.status(), Status::bad_data);
  EXPECT_NE(t.message().find("payload CRC"), std::string::npos) << t.message();
}

namespace {
// The scheduler's calls take the cache as an argument in newer versions; both forms are accepted.
template <class S>
std::span<const TileRequest> plan_frame(S& s, TileCache& cache, const VoteCounter& votes, uint64_t frame) {
  if constexpr (requires { s.plan(cache, votes, frame); })
    return s.plan(cache, votes, frame);
  else
    return s.plan(votes, frame);
}
template <class S>
void apply_frame_uploads(S& s, TileCache& cache) {
  if constexpr (requires { s.apply_uploads(cache); })
    s.apply_uploads(cache);
  else
    s.apply_uploads();
}
// Replays a trace through a fresh cache + scheduler and returns every request (frame, tile key,
// slot) and the counters of every frame, as one sequence of integers.
std::vector<uint64_t> replay(const FeedbackTrace& t) {
  VtSet set;
  for (int m = 0; m < 3; ++m) set.add_material(VtGeometry::make(1024, 1024), 2);
  for (uint32_t tex = 0; tex < set.texture_count(); ++tex)
    for (uint32_t i = 0; i < set.weights(tex).size(); ++i)
      set.weights(tex)[i] = Half(1.0f / static_cast<float>(1 + (i * 7 + tex) % 5));
  auto cache = TileCache::create(set, {6, 5});
  EXPECT_TRUE(cache.ok());
  SchedulerConfig cfg;
  cfg.budgets.uploads_per_frame = 4;
  auto sched = Scheduler::create(*cache, cfg);
  EXPECT_TRUE(sched.ok());
  VoteCounter votes(vote_layouts(set), VoteWindowConfig{4, 0});
  std::vector<uint64_t> out;
  std::vector<uint32_t> waiting;  // requests not yet decoded (an immediate source)
  for (size_t i = 0; i < t.frame_count(); ++i) {
    votes.accumulate(t.frame_words(i), 1, sched->lod_bias());
    for (const TileRequest& r : plan_frame(*sched, *cache, votes, t.frames[i].frame_index)) {
      out.push_back(t.frames[i].frame_index);
      out.push_back(r.tile.key());
      out.push_back(r.slot);
      waiting.push_back(r.id);
    }
    size_t keep = 0;
    for (const uint32_t id : waiting)
      if (sched->begin_decode(id))
        sched->finish_decode(id);
      else
        waiting[keep++] = id;
    waiting.resize(keep);
    apply_frame_uploads(*sched, *cache);
    const SchedulerCounters& c = sched->frame();
    out.insert(out.end(), {c.adds, c.swaps, c.uploads, c.bytes_requested, c.budget_hits(), sched->lod_bias()});
  }
  out.push_back(cache->used_count());
  out.push_back(sched->total().swaps);
  out.push_back(sched->total().adds);
  return out;
}
}  // namespace

TEST(FeedbackTraceReplay, SameTraceGivesTheSameScheduleBitForBit) {
  const Recorded r = record(40, 48, 27, 2);
  auto a = read_feedback_trace(r.bytes);
  auto b = read_feedback_trace(r.bytes);
  ASSERT_TRUE(a.ok() && b.ok());
  const std::vector<uint64_t> s1 = replay(*a), s2 = replay(*b);
  EXPECT_EQ(s1, s2);
  // The schedule is not trivial: tiles were added and swapped in a 30-slot cache.
  const uint64_t adds = s1[s1.size() - 1], swaps = s1[s1.size() - 2], used = s1[s1.size() - 3];
  EXPECT_GT(adds, 30u);
  EXPECT_GT(swaps, 0u);
  EXPECT_EQ(used, 30u);
  // A different trace gives a different schedule (the comparison is not vacuous).
  const Recorded other = record(40, 48, 30, 2);
  auto c = read_feedback_trace(other.bytes);
  ASSERT_TRUE(c.ok());
  EXPECT_NE(replay(*c), s1);
}
