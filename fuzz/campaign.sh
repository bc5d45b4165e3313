#!/usr/bin/env bash
# A fuzzing campaign over every libFuzzer target of a build (run through `./run.sh fuzz`):
#   fuzz/campaign.sh BUILD_DIR MINUTES JOBS
# Each target runs MINUTES on a scratch corpus seeded from fuzz/corpus/<target>/, JOBS targets
# at a time. Afterwards the inputs that add coverage are merged into fuzz/corpus/<target>/
# (libFuzzer -merge=1, so the kept corpus stays minimal), crashing inputs are kept under
# BUILD_DIR/fuzz/campaign/<target>/findings/, and a table prints executions, executions per
# second, coverage (edges, features), inputs added and findings per target. Exit status 1 when
# any target found something. BTFLOD_FUZZ_TARGETS (an extended regex on the target names, e.g.
# 'container|tile_') limits the campaign to the targets it matches.
set -euo pipefail
build=$1 minutes=$2 jobs=$3
src=$(cd "$(dirname "$0")" && pwd)
out="$build/fuzz/campaign"
mkdir -p "$out"
secs=$((minutes * 60))

run_target() {  # binary
  local bin=$1 name
  name=$(basename "$bin")
  local dir="$out/$name"
  rm -rf "$dir" && mkdir -p "$dir/corpus" "$dir/findings"
  local before
  before=$(find "$src/corpus/$name" -type f | wc -l)
  # -max_len as in the CI smoke runs; -timeout 10 s per input reports hangs as findings.
  "$bin" -max_total_time="$secs" -max_len=65536 -timeout=10 -print_final_stats=1 \
    -artifact_prefix="$dir/findings/" "$dir/corpus" "$src/corpus/$name" >"$dir/log" 2>&1 || true
  "$bin" -merge=1 -max_len=65536 "$src/corpus/$name" "$dir/corpus" >"$dir/merge.log" 2>&1 || true
  local after
  after=$(find "$src/corpus/$name" -type f | wc -l)
  echo $((after - before)) >"$dir/added"
}
export -f run_target
export out src secs

targets=()
for bin in "$build"/fuzz/fuzz_*; do
  [ -x "$bin" ] && [ -f "$bin" ] || continue
  if [ -n "${BTFLOD_FUZZ_TARGETS:-}" ] && ! basename "$bin" | grep -Eq -- "$BTFLOD_FUZZ_TARGETS"; then continue; fi
  targets+=("$bin")
done
[ ${#targets[@]} -gt 0 ] || { echo "campaign: no fuzz targets in $build/fuzz" >&2; exit 2; }
echo "campaign: ${#targets[@]} targets × ${minutes} min, ${jobs} at a time"
printf '%s\n' "${targets[@]}" | xargs -P "$jobs" -I{} bash -c 'run_target "$@"' _ {}

found=0
printf '\n| target | executions | exec/s | edges | features | inputs added | findings |\n'
printf '|---|---:|---:|---:|---:|---:|---:|\n'
for bin in "${targets[@]}"; do
  name=$(basename "$bin")
  log="$out/$name/log"
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  n=$(find "$out/$name/findings" -type f | wc -l)
  [ "$n" -gt 0 ] && found=1
  printf '| %s | %s | %s | %s | %s | %s | %s |\n' "$name" "${execs:-?}" "${rate:-?}" "${cov:-?}" "${ft:-?}" \
    "$(cat "$out/$name/added" 2>/dev/null || echo ?)" "$n"
done
if [ "$found" -ne 0 ]; then
  echo "campaign: findings kept under $out/<target>/findings/ (reproduce: BUILD/fuzz/<target> <file>)" >&2
  exit 1
fi
