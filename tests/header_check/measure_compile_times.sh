#!/bin/sh
# Compile cost of btflod's headers, measured in one run next to a baseline TU that includes only
# <vector> (README "Compile cost"). CPU seconds (user + sys) and peak RSS from /usr/bin/time -v,
# g++ -std=c++20 -O2 -c, each TU compiled once. Usage: tests/header_check/measure_compile_times.sh [g++]
set -eu
CXX=${1:-g++}
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
DIR=$(mktemp -d)
trap 'rm -rf "$DIR"' EXIT
INC="-I$ROOT/include -isystem /usr/include/eigen3 -isystem /usr/include/stb"

printf '#include <vector>\nint main() { std::vector<int> v(3); return static_cast<int>(v.size()) - 3; }\n' > "$DIR/baseline.cpp"
{
  for d in lod vt stream runtime shader; do
    for h in "$ROOT"/include/btflod/$d/*.hpp; do
      [ -e "$h" ] || continue
      case "$h" in */stream/http_source.hpp) continue ;; esac  # libcurl: not a per-frame header
      echo "#include \"btflod/$d/$(basename "$h")\""
    done
  done
  for h in codec/tile_codec.hpp codec/container.hpp backend/backend.hpp backend/page_table_writes.hpp core/half.hpp; do
    echo "#include \"btflod/$h\""
  done
  echo 'int main() { return 0; }'
} > "$DIR/runtime.cpp"
printf '#include "btflod/btflod.hpp"\nint main() { return 0; }\n' > "$DIR/umbrella.cpp"
printf '#include "btflod/factor/truncated_svd.hpp"\nint main() { return 0; }\n' > "$DIR/truncated_svd.cpp"
printf '#define BTFLOD_IMPLEMENTATION\n#include "btflod/btflod.hpp"\n' > "$DIR/implementation.cpp"

measure() {
  /usr/bin/time -v "$CXX" -std=c++20 -O2 $INC -c "$DIR/$1.cpp" -o "$DIR/$1.o" 2> "$DIR/$1.time"
  user=$(sed -n 's/.*User time (seconds): //p' "$DIR/$1.time")
  sys=$(sed -n 's/.*System time (seconds): //p' "$DIR/$1.time")
  rss=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$DIR/$1.time")
  lines=$("$CXX" -std=c++20 $INC -E "$DIR/$1.cpp" | wc -l)
  awk -v n="$1" -v u="$user" -v s="$sys" -v r="$rss" -v l="$lines" \
    'BEGIN { printf "%-16s %7.2f s CPU %7.0f MB RSS %8d preprocessed lines\n", n, u + s, r / 1024, l }'
}
echo "$CXX -std=c++20 -O2 -c, $(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)"
for tu in baseline runtime truncated_svd umbrella ${BTFLOD_MEASURE_IMPLEMENTATION:+implementation}; do measure $tu; done
