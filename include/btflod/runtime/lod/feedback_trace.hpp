// btflod — feedback traces: a recorded sequence of feedback frames (runtime/lod/feedback.hpp words), so
// an engine's own camera paths can be replayed through the scheduler in tests and benchmarks
// (DESIGN.md: "the same inputs give the same schedule"; btflod-bench scheduler --trace).
//
// File format, version 1 (docs/benchmarking.md has the tables). Little-endian throughout:
//   file header   48 bytes: signature "BTFTRACE", version, header size, flags, max words per
//                 frame, reserved, CRC-32 of the preceding 44 bytes
//   frame record  104-byte record header (tag "FRME", frame index, width, height, decimation,
//                 sample offset, flags, optional camera, CRC-32 of the raw words, payload size,
//                 CRC-32 of the payload, CRC-32 of the record header) + payload: the frame's
//                 width·height words (u32, row-major) compressed as one raw deflate stream
//   end record    24 bytes (tag "TEND", frame count, CRC-32 of every frame's header CRC in order,
//                 total words, CRC-32 of the end record)
// A file ends exactly after its end record: a recording that stopped without one (a crash) is
// reported as truncated, anything after it as trailing bytes.
//
// Recording (FeedbackTraceWriter, FeedbackTraceRecorder) is meant to stay on in development
// builds: create() allocates the deflate state and an output buffer for the largest frame once;
// encode_frame() then allocates nothing, throws nothing, and costs one CRC-32 of the words and
// one deflate at level 1 (the default; fast, feedback words compress well: runs of equal words).
// Reading (read_feedback_trace) is offline: it checks every size against the file size and its
// limits before allocating, every CRC, and inflates each frame into exactly width·height words
// (a stream that would inflate to more is rejected, so no decompression bomb can allocate more
// than FeedbackTraceLimits allows).
#pragma once

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <new>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "btflod/core/bytes.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/unique_handle.hpp"

namespace btflod {

inline constexpr uint8_t kFeedbackTraceMagic[8] = {'B', 'T', 'F', 'T', 'R', 'A', 'C', 'E'};
inline constexpr uint32_t kFeedbackTraceVersion = 1;
inline constexpr size_t kFeedbackTraceHeaderSize = 48;
inline constexpr size_t kFeedbackTraceFrameHeaderSize = 104;
inline constexpr size_t kFeedbackTraceEndSize = 24;
inline constexpr uint32_t kFeedbackTraceFrameTag = 0x454d5246u;  // "FRME"
inline constexpr uint32_t kFeedbackTraceEndTag = 0x444e4554u;    // "TEND"
inline constexpr uint32_t kFeedbackTraceMaxDecimation = 256;
/// Frame flag: the record carries a camera.
inline constexpr uint32_t kFeedbackTraceHasCamera = 1u;

/// The camera a feedback frame was rendered with (optional; for people reading a trace and for
/// tools that re-render it). Positions in world units, angles in radians.
struct FeedbackCamera {
  float position[3] = {0, 0, 0};
  float forward[3] = {0, 0, -1};  ///< unit view direction
  float up[3] = {0, 1, 0};
  float fov_y = 1.0f;  ///< vertical field of view
  float near_plane = 0.1f;
  float far_plane = 100.0f;
};

/// Everything about one feedback frame except its words.
struct FeedbackFrameInfo {
  uint64_t frame_index = 0;  ///< the engine's frame number (strictly increasing in a trace)
  uint32_t width = 0;        ///< feedback buffer width in words (screen width / decimation, rounded up)
  uint32_t height = 0;
  uint32_t decimation = 1;  ///< d: one feedback word per d×d screen pixels (1 … 256)
  uint32_t sample_dx = 0;   ///< position sampled inside each d×d block this frame (feedback_sample_offset)
  uint32_t sample_dy = 0;
  bool has_camera = false;
  FeedbackCamera camera;
};

namespace detail {
/// Raw-deflate state for FeedbackTraceWriter (zlib; defined in the implementation TU, so this
/// header includes no zlib). create allocates once; deflate allocates nothing.
struct TraceDeflater;
TraceDeflater* trace_deflater_create(int level) noexcept;
void trace_deflater_destroy(TraceDeflater* d) noexcept;
/// Worst-case raw-deflate size of n input bytes.
size_t trace_deflate_bound(TraceDeflater* d, size_t n) noexcept;
/// Compresses in[0, n) as one raw deflate stream into out; false when out is too small or zlib fails.
bool trace_deflate(TraceDeflater* d, const uint8_t* in, size_t n, uint8_t* out, size_t capacity,
                   size_t& written) noexcept;
/// Inflates one raw deflate stream into exactly out_size bytes. Returns nullptr on success or
/// what is wrong: more output than out_size (never written past it), fewer, invalid stream,
/// stream ends before its end, bytes after the stream. Allocates zlib's state (offline reader).
const char* trace_inflate_exact(const uint8_t* in, size_t n, uint8_t* out, size_t out_size) noexcept;

inline void trace_put_u32(uint8_t* p, uint32_t v) noexcept { std::memcpy(p, &v, 4); }
inline void trace_put_u64(uint8_t* p, uint64_t v) noexcept { std::memcpy(p, &v, 8); }
inline void trace_put_f32(uint8_t* p, float v) noexcept { std::memcpy(p, &v, 4); }

/// Serialises a frame record header (without its three trailing CRC/size fields' meaning
/// checked: the caller fills words_crc, payload size and payload CRC). Writes 104 bytes.
inline void trace_write_frame_header(uint8_t* p, const FeedbackFrameInfo& f, uint32_t words_crc, uint32_t payload_size,
                                     uint32_t payload_crc) noexcept {
  trace_put_u32(p + 0, kFeedbackTraceFrameTag);
  trace_put_u32(p + 4, static_cast<uint32_t>(kFeedbackTraceFrameHeaderSize));
  trace_put_u64(p + 8, f.frame_index);
  trace_put_u32(p + 16, f.width);
  trace_put_u32(p + 20, f.height);
  trace_put_u32(p + 24, f.decimation);
  trace_put_u32(p + 28, f.sample_dx);
  trace_put_u32(p + 32, f.sample_dy);
  trace_put_u32(p + 36, f.has_camera ? kFeedbackTraceHasCamera : 0u);
  const FeedbackCamera c = f.has_camera ? f.camera : FeedbackCamera{};
  const float cam[12] = {c.position[0], c.position[1], c.position[2], c.forward[0], c.forward[1], c.forward[2],
                         c.up[0],       c.up[1],       c.up[2],       c.fov_y,      c.near_plane, c.far_plane};
  for (int i = 0; i < 12; ++i) trace_put_f32(p + 40 + 4 * i, cam[i]);
  trace_put_u32(p + 88, words_crc);
  trace_put_u32(p + 92, payload_size);
  trace_put_u32(p + 96, payload_crc);
  trace_put_u32(p + 100, crc32_of({p, 100}));
}
}  // namespace detail

/// Options of FeedbackTraceWriter::create().
struct FeedbackTraceWriterConfig {
  uint32_t max_frame_words = 1280 * 720;  ///< largest width·height a frame may have (sizes the buffers)
  int deflate_level = 1;                  ///< zlib 0 … 9; 1 is fast and compresses feedback ~10–100×
};

/// Encodes feedback frames into trace bytes; the caller decides where they go (a file, a socket,
/// memory). Write file_header() first, then each encode_frame() output in order, then
/// end_record(). create() allocates; everything after it is allocation-free and noexcept.
/// Not thread-safe (one writer per trace); movable.
class FeedbackTraceWriter {
 public:
  /// Allocates the deflate state and one output buffer for the largest frame. Returns
  /// invalid_argument for max_frame_words = 0 or > 2^28, or a deflate level outside 0 … 9;
  /// insufficient_space when zlib cannot allocate its state.
  static Result<FeedbackTraceWriter> create(const FeedbackTraceWriterConfig& config = {}) {
    if (config.max_frame_words == 0 || config.max_frame_words > (1u << 28))
      return make_error(Status::invalid_argument, "feedback trace writer: max_frame_words %u not in 1 … 2^28",
                        config.max_frame_words);
    if (config.deflate_level < 0 || config.deflate_level > 9)
      return make_error(Status::invalid_argument, "feedback trace writer: deflate level %d not in 0 … 9",
                        config.deflate_level);
    FeedbackTraceWriter w;
    w.config_ = config;
    w.stream_.reset(detail::trace_deflater_create(config.deflate_level));
    if (!w.stream_) return make_error(Status::insufficient_space, "feedback trace writer: deflate set-up failed");
    const size_t bound = detail::trace_deflate_bound(w.stream_.get(), static_cast<size_t>(config.max_frame_words) * 4u);
    w.buffer_.resize(kFeedbackTraceFrameHeaderSize + bound);
    uint8_t* h = w.header_;
    std::memcpy(h, kFeedbackTraceMagic, 8);
    detail::trace_put_u32(h + 8, kFeedbackTraceVersion);
    detail::trace_put_u32(h + 12, static_cast<uint32_t>(kFeedbackTraceHeaderSize));
    detail::trace_put_u32(h + 16, 0);  // flags: none defined in version 1
    detail::trace_put_u32(h + 20, config.max_frame_words);
    std::memset(h + 24, 0, 20);
    detail::trace_put_u32(h + 44, crc32_of({h, 44}));
    return w;
  }

  FeedbackTraceWriter() = default;
  FeedbackTraceWriter(FeedbackTraceWriter&&) noexcept = default;
  FeedbackTraceWriter& operator=(FeedbackTraceWriter&&) noexcept = default;
  ~FeedbackTraceWriter() = default;

  /// The 48-byte file header (constant after create()).
  std::span<const uint8_t> file_header() const noexcept { return {header_, kFeedbackTraceHeaderSize}; }

  /// Encodes one frame: `words` holds info.width·info.height feedback words, row-major.
  /// On success `out` views the record bytes (valid until the next encode_frame() or
  /// end_record() call). Returns invalid_argument when the writer was not created, the word
  /// count does not match width·height or exceeds max_frame_words, the decimation is not in
  /// 1 … 256, the sample offset is not inside the block, or frame_index does not increase;
  /// bad_data if deflate fails. noexcept, no allocation.
  Status encode_frame(const FeedbackFrameInfo& info, std::span<const uint32_t> words,
                      std::span<const uint8_t>& out) noexcept {
    out = {};
    if (!stream_) return Status::invalid_argument;
    const uint64_t n = static_cast<uint64_t>(info.width) * info.height;
    if (n != words.size() || n == 0 || n > config_.max_frame_words) return Status::invalid_argument;
    if (info.decimation == 0 || info.decimation > kFeedbackTraceMaxDecimation || info.sample_dx >= info.decimation ||
        info.sample_dy >= info.decimation)
      return Status::invalid_argument;
    if (frames_ > 0 && info.frame_index <= last_frame_) return Status::invalid_argument;
    size_t written = 0;
    if (!detail::trace_deflate(stream_.get(), reinterpret_cast<const uint8_t*>(words.data()),
                               static_cast<size_t>(n) * 4, buffer_.data() + kFeedbackTraceFrameHeaderSize,
                               buffer_.size() - kFeedbackTraceFrameHeaderSize, written))
      return Status::bad_data;
    const uint32_t payload = static_cast<uint32_t>(written);
    const std::span<const uint8_t> payload_bytes(buffer_.data() + kFeedbackTraceFrameHeaderSize, payload);
    const uint32_t words_crc = crc32_of({reinterpret_cast<const uint8_t*>(words.data()), static_cast<size_t>(n) * 4});
    detail::trace_write_frame_header(buffer_.data(), info, words_crc, payload, crc32_of(payload_bytes));
    chain_crc_ = crc32_of({buffer_.data() + 100, 4}, chain_crc_);
    total_words_ += n;
    last_frame_ = info.frame_index;
    ++frames_;
    out = {buffer_.data(), kFeedbackTraceFrameHeaderSize + payload};
    return Status::success;
  }

  /// The 24-byte end record for the frames encoded so far (valid until the next call).
  /// noexcept, no allocation.
  std::span<const uint8_t> end_record() noexcept {
    uint8_t* p = end_;
    detail::trace_put_u32(p + 0, kFeedbackTraceEndTag);
    detail::trace_put_u32(p + 4, static_cast<uint32_t>(frames_));
    detail::trace_put_u32(p + 8, chain_crc_);
    detail::trace_put_u64(p + 12, total_words_);
    detail::trace_put_u32(p + 20, crc32_of({p, 20}));
    return {end_, kFeedbackTraceEndSize};
  }

  /// Frames encoded so far.
  uint64_t frame_count() const noexcept { return frames_; }
  const FeedbackTraceWriterConfig& config() const noexcept { return config_; }

 private:
  struct ZDeleter {
    void operator()(detail::TraceDeflater* d) const noexcept { detail::trace_deflater_destroy(d); }
  };
  FeedbackTraceWriterConfig config_;
  UniqueHandle<detail::TraceDeflater, ZDeleter> stream_;
  std::vector<uint8_t> buffer_;
  uint8_t header_[kFeedbackTraceHeaderSize] = {};
  uint8_t end_[kFeedbackTraceEndSize] = {};
  uint64_t frames_ = 0;
  uint64_t last_frame_ = 0;
  uint64_t total_words_ = 0;
  uint32_t chain_crc_ = 0;
};

/// Records a trace straight into a file (development builds: the engine calls record() once
/// per frame). open() allocates the writer and the stdio buffer; record() allocates nothing
/// and costs one deflate plus one buffered fwrite. close() (or the destructor) writes the end
/// record. Not thread-safe; movable.
class FeedbackTraceRecorder {
 public:
  /// Creates (replaces) `path` and writes the file header. io_error when the file cannot be
  /// created; the writer's errors for a bad config.
  static Result<FeedbackTraceRecorder> open(const std::string& path, const FeedbackTraceWriterConfig& config = {}) {
    auto writer = FeedbackTraceWriter::create(config);
    if (!writer) return writer.error();
    FeedbackTraceRecorder r;
    r.writer_ = std::move(*writer);
    r.path_ = path;
    r.file_.reset(std::fopen(path.c_str(), "wb"));
    if (!r.file_) return make_error(Status::io_error, "%s: cannot create: %s", path.c_str(), std::strerror(errno));
    const auto h = r.writer_.file_header();
    if (std::fwrite(h.data(), 1, h.size(), r.file_.get()) != h.size())
      return make_error(Status::io_error, "%s: cannot write the header", path.c_str());
    return r;
  }
  FeedbackTraceRecorder() = default;
  FeedbackTraceRecorder(FeedbackTraceRecorder&&) noexcept = default;
  FeedbackTraceRecorder& operator=(FeedbackTraceRecorder&&) noexcept = default;
  /// Writes the end record if close() was not called (errors are lost: call close()).
  ~FeedbackTraceRecorder() { (void)close(); }

  /// Appends one frame (FeedbackTraceWriter::encode_frame's preconditions and errors); io_error
  /// when the write fails or the recorder is closed. noexcept, no allocation.
  Status record(const FeedbackFrameInfo& info, std::span<const uint32_t> words) noexcept {
    if (!file_) return Status::io_error;
    std::span<const uint8_t> bytes;
    if (const Status s = writer_.encode_frame(info, words, bytes); s != Status::success) return s;
    if (std::fwrite(bytes.data(), 1, bytes.size(), file_.get()) != bytes.size()) return Status::io_error;
    return Status::success;
  }
  /// Writes the end record and closes the file. Returns io_error with the path on a failed
  /// write; success (and does nothing) when already closed.
  VoidResult close() {
    if (!file_) return {};
    const auto e = writer_.end_record();
    const bool wrote = std::fwrite(e.data(), 1, e.size(), file_.get()) == e.size();
    const bool closed = std::fclose(file_.release()) == 0;
    if (!wrote || !closed) return make_error(Status::io_error, "%s: cannot finish the trace", path_.c_str());
    return {};
  }
  /// Frames recorded so far.
  uint64_t frame_count() const noexcept { return writer_.frame_count(); }

 private:
  struct FileCloser {
    void operator()(std::FILE* f) const noexcept { std::fclose(f); }
  };
  FeedbackTraceWriter writer_;
  std::string path_;
  UniqueHandle<std::FILE, FileCloser> file_;
};

/// Caps on what read_feedback_trace() will allocate for untrusted input.
struct FeedbackTraceLimits {
  uint32_t max_frame_words = 1u << 24;  ///< per frame (4096×4096)
  uint64_t max_total_words = 1u << 27;  ///< over all frames (512 MiB of words)
  uint64_t max_frames = 1u << 20;
};

/// A trace read back: per-frame information and the decoded words of every frame.
struct FeedbackTrace {
  uint32_t max_frame_words = 0;           ///< from the file header
  std::vector<FeedbackFrameInfo> frames;  ///< in file order (frame_index strictly increasing)
  std::vector<uint64_t> offsets;          ///< frames.size() + 1 offsets into words
  std::vector<uint32_t> words;            ///< every frame's words, concatenated

  size_t frame_count() const noexcept { return frames.size(); }
  /// The words of frame i (row-major, width·height). Precondition: i < frame_count().
  std::span<const uint32_t> frame_words(size_t i) const noexcept {
    return {words.data() + offsets[i], static_cast<size_t>(offsets[i + 1] - offsets[i])};
  }
};

/// Parses and fully validates trace bytes: header signature, version (unsupported for another),
/// header/record/end CRCs, every record's sizes against the remaining bytes and the limits,
/// decimation and sample offsets, strictly increasing frame indices, each payload inflating to
/// exactly width·height words whose CRC matches, and the end record (frame count, chained CRC,
/// total words, nothing after it). Returns short_output for a truncated file, bad_data for
/// anything else malformed (the message says which frame, which field, expected vs found),
/// insufficient_space when a limit is exceeded. Safe on untrusted input; allocates; thread-safe.
inline Result<FeedbackTrace> read_feedback_trace(std::span<const uint8_t> bytes,
                                                 const FeedbackTraceLimits& limits = {}) {
  ByteReader r(bytes);
  if (bytes.size() < kFeedbackTraceHeaderSize)
    return make_error(Status::short_output, "feedback trace: %zu bytes, shorter than the %zu-byte header", bytes.size(),
                      kFeedbackTraceHeaderSize);
  if (!r.match(std::string_view(reinterpret_cast<const char*>(kFeedbackTraceMagic), 8)))
    return make_error(Status::bad_data, "feedback trace: wrong signature (expected \"BTFTRACE\")");
  const uint32_t version = r.u32();
  const uint32_t header_size = r.u32();
  const uint32_t flags = r.u32();
  FeedbackTrace t;
  t.max_frame_words = r.u32();
  r.skip(20);
  const uint32_t header_crc = r.u32();
  if (const uint32_t c = crc32_of(bytes.first(44)); c != header_crc)
    return make_error(Status::bad_data, "feedback trace: header CRC %08x, expected %08x", c, header_crc);
  if (version != kFeedbackTraceVersion)
    return make_error(Status::unsupported, "feedback trace: version %u, this reader reads version %u", version,
                      kFeedbackTraceVersion);
  if (header_size != kFeedbackTraceHeaderSize || flags != 0)
    return make_error(Status::bad_data, "feedback trace: header size %u / flags %u, expected %zu / 0", header_size,
                      flags, kFeedbackTraceHeaderSize);
  if (t.max_frame_words == 0 || t.max_frame_words > limits.max_frame_words)
    return make_error(t.max_frame_words == 0 ? Status::bad_data : Status::insufficient_space,
                      "feedback trace: max frame words %u not in 1 … %u", t.max_frame_words, limits.max_frame_words);

  // Pass 1: walk the records, check every size against the file and the limits (no inflating).
  struct Rec {
    size_t payload_offset;
    uint32_t payload_size, payload_crc, words_crc;
  };
  std::vector<Rec> recs;
  uint64_t total_words = 0;
  uint32_t chain = 0;
  for (;;) {
    const size_t at = r.offset();
    if (r.remaining() < 4)
      return make_error(Status::short_output, "feedback trace: truncated at byte %zu after %zu frames (no end record)",
                        at, t.frames.size());
    const uint32_t tag = r.u32();
    if (tag == kFeedbackTraceEndTag) {
      if (r.remaining() < kFeedbackTraceEndSize - 4)
        return make_error(Status::short_output, "feedback trace: end record at byte %zu truncated", at);
      const uint32_t count = r.u32(), chain_crc = r.u32();
      const uint64_t total = r.u64();
      const uint32_t end_crc = r.u32();
      if (const uint32_t c = crc32_of(bytes.subspan(at, 20)); c != end_crc)
        return make_error(Status::bad_data, "feedback trace: end record CRC %08x, expected %08x", c, end_crc);
      if (count != t.frames.size() || chain_crc != chain || total != total_words)
        return make_error(
            Status::bad_data,
            "feedback trace: end record says %u frames / %llu words / chain CRC %08x, file holds %zu / %llu / %08x",
            count, static_cast<unsigned long long>(total), chain_crc, t.frames.size(),
            static_cast<unsigned long long>(total_words), chain);
      if (r.remaining() != 0)
        return make_error(Status::bad_data, "feedback trace: %zu trailing bytes after the end record", r.remaining());
      break;
    }
    if (tag != kFeedbackTraceFrameTag)
      return make_error(Status::bad_data, "feedback trace: byte %zu: record tag %08x is neither FRME nor TEND", at,
                        tag);
    if (bytes.size() - at < kFeedbackTraceFrameHeaderSize)
      return make_error(Status::short_output, "feedback trace: frame %zu header at byte %zu truncated", t.frames.size(),
                        at);
    const uint8_t* p = bytes.data() + at;
    uint32_t stored_crc = 0;
    std::memcpy(&stored_crc, p + 100, 4);
    if (const uint32_t c = crc32_of({p, 100}); c != stored_crc)
      return make_error(Status::bad_data, "feedback trace: frame %zu header CRC %08x, expected %08x", t.frames.size(),
                        c, stored_crc);
    const uint32_t rec_header = r.u32();
    FeedbackFrameInfo f;
    f.frame_index = r.u64();
    f.width = r.u32();
    f.height = r.u32();
    f.decimation = r.u32();
    f.sample_dx = r.u32();
    f.sample_dy = r.u32();
    const uint32_t fflags = r.u32();
    float cam[12];
    for (float& c : cam) c = r.f32();
    Rec rec{};
    rec.words_crc = r.u32();
    rec.payload_size = r.u32();
    rec.payload_crc = r.u32();
    r.skip(4);
    const size_t i = t.frames.size();
    if (rec_header != kFeedbackTraceFrameHeaderSize || (fflags & ~kFeedbackTraceHasCamera) != 0)
      return make_error(Status::bad_data,
                        "feedback trace: frame %zu: record header size %u / flags %u, expected %zu / 0 or 1", i,
                        rec_header, fflags, kFeedbackTraceFrameHeaderSize);
    const uint64_t n = static_cast<uint64_t>(f.width) * f.height;
    if (n == 0 || n > t.max_frame_words)
      return make_error(Status::bad_data, "feedback trace: frame %zu is %ux%u words, expected 1 … %u (header)", i,
                        f.width, f.height, t.max_frame_words);
    if (f.decimation == 0 || f.decimation > kFeedbackTraceMaxDecimation || f.sample_dx >= f.decimation ||
        f.sample_dy >= f.decimation)
      return make_error(Status::bad_data,
                        "feedback trace: frame %zu: decimation %u with sample (%u, %u), expected 1 … %u and "
                        "the sample inside the block",
                        i, f.decimation, f.sample_dx, f.sample_dy, kFeedbackTraceMaxDecimation);
    if (i > 0 && f.frame_index <= t.frames.back().frame_index)
      return make_error(Status::bad_data, "feedback trace: frame %zu: index %llu does not follow %llu", i,
                        static_cast<unsigned long long>(f.frame_index),
                        static_cast<unsigned long long>(t.frames.back().frame_index));
    if (rec.payload_size > r.remaining())
      return make_error(Status::short_output, "feedback trace: frame %zu: payload of %u bytes, %zu left in the file", i,
                        rec.payload_size, r.remaining());
    if (i + 1 > limits.max_frames || total_words + n > limits.max_total_words)
      return make_error(Status::insufficient_space, "feedback trace: more than %llu frames or %llu words (limits)",
                        static_cast<unsigned long long>(limits.max_frames),
                        static_cast<unsigned long long>(limits.max_total_words));
    f.has_camera = (fflags & kFeedbackTraceHasCamera) != 0;
    if (f.has_camera) {
      FeedbackCamera& c = f.camera;
      std::memcpy(c.position, cam, 12);
      std::memcpy(c.forward, cam + 3, 12);
      std::memcpy(c.up, cam + 6, 12);
      c.fov_y = cam[9];
      c.near_plane = cam[10];
      c.far_plane = cam[11];
    }
    rec.payload_offset = r.offset();
    r.skip(rec.payload_size);
    chain = crc32_of({p + 100, 4}, chain);
    total_words += n;
    t.frames.push_back(f);
    recs.push_back(rec);
  }

  // Pass 2: inflate each payload into exactly width·height words (never more: bomb-proof).
  t.words.resize(static_cast<size_t>(total_words));
  t.offsets.assign(1, 0);
  for (size_t i = 0; i < recs.size(); ++i) {
    const Rec& rec = recs[i];
    const auto payload = bytes.subspan(rec.payload_offset, rec.payload_size);
    const uint64_t n = static_cast<uint64_t>(t.frames[i].width) * t.frames[i].height;
    uint32_t* dst = t.words.data() + t.offsets.back();
    auto fail = [&](const char* what) {
      return make_error(Status::bad_data, "feedback trace: frame %zu (index %llu): %s", i,
                        static_cast<unsigned long long>(t.frames[i].frame_index), what);
    };
    if (crc32_of(payload) != rec.payload_crc) return fail("payload CRC mismatch");
    if (const char* why = detail::trace_inflate_exact(payload.data(), payload.size(), reinterpret_cast<uint8_t*>(dst),
                                                      static_cast<size_t>(n) * 4))
      return fail(why);
    if (crc32_of({reinterpret_cast<const uint8_t*>(dst), static_cast<size_t>(n) * 4}) != rec.words_crc)
      return fail("CRC of the decoded words does not match");
    t.offsets.push_back(t.offsets.back() + n);
  }
  return t;
}

/// Reads and validates a trace file (read_feedback_trace on its bytes). io_error with the path
/// when the file cannot be read; messages are prefixed with the path.
inline Result<FeedbackTrace> read_feedback_trace_file(const std::string& path, const FeedbackTraceLimits& limits = {}) {
  auto bytes = read_file_bytes(path, uint64_t{limits.max_total_words} * 4 + (uint64_t{1} << 26));
  if (!bytes) return bytes.error();
  auto t = read_feedback_trace(*bytes, limits);
  if (!t) return Error{t.status(), path + ": " + t.message()};
  return t;
}

/// Encodes frames into one trace in memory (tests, tools). `words[i]` belongs to `frames[i]`.
/// Returns the writer's invalid_argument for a frame it refuses. Allocates.
inline Result<std::vector<uint8_t>> write_feedback_trace(std::span<const FeedbackFrameInfo> frames,
                                                         std::span<const std::span<const uint32_t>> words,
                                                         const FeedbackTraceWriterConfig& config = {}) {
  if (frames.size() != words.size())
    return make_error(Status::invalid_argument, "write_feedback_trace: %zu frames, %zu word spans", frames.size(),
                      words.size());
  auto w = FeedbackTraceWriter::create(config);
  if (!w) return w.error();
  std::vector<uint8_t> out(w->file_header().begin(), w->file_header().end());
  for (size_t i = 0; i < frames.size(); ++i) {
    std::span<const uint8_t> rec;
    if (const Status s = w->encode_frame(frames[i], words[i], rec); s != Status::success)
      return make_error(s, "write_feedback_trace: frame %zu (%ux%u, %zu words, decimation %u) refused", i,
                        frames[i].width, frames[i].height, words[i].size(), frames[i].decimation);
    out.insert(out.end(), rec.begin(), rec.end());
  }
  const auto e = w->end_record();
  out.insert(out.end(), e.begin(), e.end());
  return out;
}

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
#include <zlib.h>

namespace btflod::detail {

struct TraceDeflater {
  z_stream z{};
};

TraceDeflater* trace_deflater_create(int level) noexcept {
  auto* d = new (std::nothrow) TraceDeflater;
  if (d == nullptr) return nullptr;
  if (deflateInit2(&d->z, level, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    delete d;
    return nullptr;
  }
  return d;
}

void trace_deflater_destroy(TraceDeflater* d) noexcept {
  if (d == nullptr) return;
  deflateEnd(&d->z);
  delete d;
}

size_t trace_deflate_bound(TraceDeflater* d, size_t n) noexcept { return deflateBound(&d->z, static_cast<uLong>(n)); }

bool trace_deflate(TraceDeflater* d, const uint8_t* in, size_t n, uint8_t* out, size_t capacity,
                   size_t& written) noexcept {
  written = 0;
  z_stream& z = d->z;
  if (n > (1u << 30) || deflateReset(&z) != Z_OK) return false;
  z.next_in = const_cast<Bytef*>(in);
  z.avail_in = static_cast<uInt>(n);
  z.next_out = out;
  z.avail_out = static_cast<uInt>(capacity > (1u << 31) ? (1u << 31) : capacity);
  if (deflate(&z, Z_FINISH) != Z_STREAM_END) return false;
  written = static_cast<size_t>(z.total_out);
  return true;
}

const char* trace_inflate_exact(const uint8_t* in, size_t n, uint8_t* out, size_t out_size) noexcept {
  if (n > (1u << 31) || out_size > (1u << 31)) return "payload too large";
  z_stream z{};
  if (inflateInit2(&z, -15) != Z_OK) return "inflate set-up failed";
  z.next_in = const_cast<Bytef*>(in);
  z.avail_in = static_cast<uInt>(n);
  z.next_out = out;
  z.avail_out = static_cast<uInt>(out_size);
  const int ret = inflate(&z, Z_FINISH);  // never writes past out_size: a bomb stops here
  const char* why = nullptr;
  if (ret == Z_BUF_ERROR && z.avail_out == 0)
    why = "payload inflates to more than width x height words";
  else if (ret != Z_STREAM_END)
    why = z.avail_in == 0 ? "payload ends before its deflate stream does" : "payload is not a valid deflate stream";
  else if (z.avail_out != 0)
    why = "payload inflates to fewer than width x height words";
  else if (z.avail_in != 0)
    why = "bytes after the deflate stream inside the payload";
  inflateEnd(&z);
  return why;
}

}  // namespace btflod::detail
#endif  // BTFLOD_IMPLEMENTATION
