// libFuzzer target for runtime/lod/feedback_trace.hpp: read a whole trace from the input with small
// limits; when it is accepted, every frame's words must have width x height entries, and
// writing the frames again must give a trace that reads back to the same words (round trip).
// Nothing may crash, hang, read outside the input or allocate beyond the limits.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "btflod/runtime/lod/feedback_trace.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace btflod;
  FeedbackTraceLimits limits;
  limits.max_frame_words = 1u << 16;
  limits.max_total_words = 1u << 20;
  limits.max_frames = 4096;
  auto t = read_feedback_trace({data, size}, limits);
  if (!t) return 0;
  std::vector<std::span<const uint32_t>> spans;
  for (size_t i = 0; i < t->frame_count(); ++i) {
    const FeedbackFrameInfo& f = t->frames[i];
    if (t->frame_words(i).size() != size_t{f.width} * f.height) std::abort();
    spans.push_back(t->frame_words(i));
  }
  auto again = write_feedback_trace(t->frames, spans, {t->max_frame_words, 1});
  if (!again) std::abort();  // whatever the reader accepts, the writer must accept
  auto back = read_feedback_trace(*again, limits);
  if (!back || back->words != t->words || back->frame_count() != t->frame_count()) std::abort();
  return 0;
}
