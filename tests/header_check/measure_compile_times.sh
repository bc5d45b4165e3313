#!/bin/sh
# Compile cost of btflod's headers, measured in one run next to a baseline TU that includes only
# <vector> (README "Compile cost"). CPU seconds (user + sys) and peak RSS from /usr/bin/time -v,
# g++ -std=c++20 -O2 -c. Each TU is compiled REPEAT times (default 5, interleaved with the others
# so that load changes hit every TU alike) and the median is printed, with its difference to and
# ratio over the baseline. Usage: [REPEAT=n] [TUS="baseline runtime ..."] measure_compile_times.sh [g++]
# COMPARE_INCLUDE=<dir> (another revision's include/ folder, e.g. from `git archive`) adds the TU
# "runtime_before": the same per-frame TU built against those headers, in the same interleaved
# loop, so that before/after figures come from one run.
set -eu
CXX=${1:-g++}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
DIR=$(mktemp -d)
trap 'rm -rf "$DIR"' EXIT
INC="-I$ROOT/include -isystem /usr/include/eigen3 -isystem /usr/include/stb"

printf '#include <vector>\nint main() { std::vector<int> v(3); return static_cast<int>(v.size()) - 3; }\n' > "$DIR/baseline.cpp"
# The per-frame headers: what check_runtime_headers.cmake checks (every header under
# btflod/runtime/ and btflod/core/), without the thread-owning conveniences (measured on their
# own), the libcurl source, and the implementation-only headers (runtime/impl/, the x86 kernels).
# $1: the include folder.
per_frame_tu() {
  (cd "$1" && find btflod/runtime btflod/core -name '*.hpp' | sort) | while read -r h; do
    case "$h" in
      */stream/http_source.hpp | */stream/thread_executor.hpp | */stream/file_source.hpp | */core/thread_pool.hpp | */core/simd_kernels.hpp | */runtime/impl/*) continue ;;
    esac
    echo "#include \"$h\""
  done
  echo 'int main() { return 0; }'
}
per_frame_tu "$ROOT/include" > "$DIR/runtime.cpp"
if [ -n "${COMPARE_INCLUDE:-}" ]; then
  per_frame_tu "$COMPARE_INCLUDE" > "$DIR/runtime_before.cpp"
fi
printf '#include "btflod/runtime/stream/thread_executor.hpp"\n#include "btflod/runtime/stream/file_source.hpp"\nint main() { return 0; }\n' > "$DIR/conveniences.cpp"
for h in runtime/streamer runtime/stream/payload_cache runtime/codec/container runtime/shader/glsl_generator runtime/backend/backend runtime/vt/scheduler; do
  printf '#include "btflod/%s.hpp"\nint main() { return 0; }\n' "$h" > "$DIR/$(basename "$h").cpp"
done
# An engine's frame: a TU that calls the per-frame API (update, the decode jobs, the outputs),
# not one that only includes it.
cat > "$DIR/frame.cpp" <<'FRAME'
#include "btflod/runtime/streamer.hpp"
int frame(btflod::Streamer& streamer, std::span<const uint32_t> feedback, btflod::StreamerOutputs& out) {
  if (streamer.update(feedback, out) != btflod::Status::success) return -1;
  int uploads = 0;
  for (uint32_t job = streamer.acquire_job(); job != btflod::Streamer::kNoJob; job = streamer.acquire_job()) {
    streamer.run_job(job);
  }
  for (size_t i = 0; i < out.tile_upload_count; ++i) uploads += static_cast<int>(out.tile_uploads[i].texels.size() > 0);
  return uploads + static_cast<int>(out.page_table_write_count);
}
int main() { return 0; }
FRAME
printf '#include "btflod/btflod.hpp"\nint main() { return 0; }\n' > "$DIR/umbrella.cpp"
printf '#include "btflod/offline/factor/truncated_svd.hpp"\nint main() { return 0; }\n' > "$DIR/truncated_svd.cpp"
printf '#define BTFLOD_IMPLEMENTATION\n#include "btflod/btflod.hpp"\n' > "$DIR/implementation.cpp"

# One compile: appends "cpu_seconds rss_kb" to $DIR/<tu>.runs.
inc_for() {  # include flags of a TU
  case "$1" in *_before) echo "-I$COMPARE_INCLUDE -isystem /usr/include/eigen3 -isystem /usr/include/stb" ;; *) echo "$INC" ;; esac
}
compile_once() {
  /usr/bin/time -v "$CXX" -std=c++20 -O2 $(inc_for "$1") -c "$DIR/$1.cpp" -o "$DIR/$1.o" 2> "$DIR/$1.time"
  user=$(sed -n 's/.*User time (seconds): //p' "$DIR/$1.time")
  sys=$(sed -n 's/.*System time (seconds): //p' "$DIR/$1.time")
  rss=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$DIR/$1.time")
  awk -v u="$user" -v s="$sys" -v r="$rss" 'BEGIN { printf "%.3f %d\n", u + s, r }' >> "$DIR/$1.runs"
}
# Median CPU seconds of $DIR/<tu>.runs.
median() { sort -n "$DIR/$1.runs" | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
REPEAT=${REPEAT:-5}
TUS=${TUS:-"baseline runtime ${COMPARE_INCLUDE:+runtime_before} frame conveniences streamer payload_cache container glsl_generator backend scheduler truncated_svd umbrella ${BTFLOD_MEASURE_IMPLEMENTATION:+implementation}"}
echo "$CXX -std=c++20 -O2 -c, median of $REPEAT, $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)"
i=0
while [ "$i" -lt "$REPEAT" ]; do
  for tu in $TUS; do compile_once "$tu"; done
  i=$((i + 1))
done
base=$(median baseline)
for tu in $TUS; do
  m=$(median "$tu")
  rss=$(sort -n -k2 "$DIR/$tu.runs" | tail -n 1 | cut -d' ' -f2)
  lines=$("$CXX" -std=c++20 $(inc_for "$tu") -E "$DIR/$tu.cpp" | wc -l)
  runs=$(cut -d' ' -f1 "$DIR/$tu.runs" | tr '\n' ' ')
  awk -v n="$tu" -v m="$m" -v b="$base" -v r="$rss" -v l="$lines" -v runs="$runs" \
    'BEGIN { printf "%-15s %6.2f s CPU  %+6.2f s  x%5.1f  %5.0f MB RSS  %7d lines  (runs: %s)\n", n, m, m - b, m / b, r / 1024, l, runs }'
done
