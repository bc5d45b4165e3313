#!/usr/bin/env bash
# Runs `./run.sh demo` then `./run.sh test` on a copy of run.sh with cmake, ctest, dpkg-query and
# the demo replaced by recorders, and checks that the test command configures the release build
# with the tests on (a demo configuration cached in the same folder must not turn them off) and
# that every ctest call fails when it finds no tests.
set -euo pipefail
src=${1:?usage: run_sh_command_order.sh <source dir> <work dir>}
work=${2:?usage: run_sh_command_order.sh <source dir> <work dir>}
rm -rf "$work" && mkdir -p "$work/bin" "$work/tree"
cp "$src/run.sh" "$work/tree/run.sh" && chmod +x "$work/tree/run.sh"
log="$work/calls.log"
for tool in cmake ctest; do
  printf '#!/bin/sh\necho "%s $*" >> "%s"\n' "$tool" "$log" > "$work/bin/$tool"
done
printf '#!/bin/sh\necho "install ok installed"\n' > "$work/bin/dpkg-query"
chmod +x "$work/bin/"*
mkdir -p "$work/tree/b/samples/demo" "$work/tree/b-asan" "$work/tree/b-tsan" "$work/tree/b-fuzz"
printf '#!/bin/sh\nexit 0\n' > "$work/tree/b/samples/demo/btflod-demo"
chmod +x "$work/tree/b/samples/demo/btflod-demo"
(cd "$work/tree" && PATH="$work/bin:$PATH" BTFLOD_BUILD_DIR=b BTFLOD_JOBS=1 ./run.sh demo >/dev/null)
: > "$log.demo" && mv "$log" "$log.demo"
(cd "$work/tree" && PATH="$work/bin:$PATH" BTFLOD_BUILD_DIR=b BTFLOD_JOBS=1 ./run.sh test >/dev/null)
fail=0
release=$(grep -E '^cmake -S \. -B b ' "$log" || true)
if [ -z "$release" ]; then
  echo "FAIL: ./run.sh test never configures the release folder b"; fail=1
elif ! grep -q -- '-DBTFLOD_BUILD_TESTS=ON' <<<"$release"; then
  echo "FAIL: ./run.sh test configures b without -DBTFLOD_BUILD_TESTS=ON after ./run.sh demo:"
  echo "  $release"; fail=1
fi
n_ctest=$(grep -c '^ctest ' "$log" || true)
if [ "$n_ctest" -lt 3 ]; then
  echo "FAIL: expected the release, sanitizer and fuzz ctest calls, saw $n_ctest"; fail=1
fi
while IFS= read -r line; do
  if ! grep -q -- '--no-tests=error' <<<"$line"; then
    echo "FAIL: ctest call without --no-tests=error: $line"; fail=1
  fi
done < <(grep '^ctest ' "$log")
# Every configure call states whether tests are built, so no cached value decides it.
while IFS= read -r line; do
  if ! grep -q -- '-DBTFLOD_BUILD_TESTS=' <<<"$line"; then
    echo "FAIL: configure call leaves BTFLOD_BUILD_TESTS to the cache: $line"; fail=1
  fi
done < <(grep -E '^cmake -S ' "$log" "$log.demo" | sed 's/^[^:]*://')
[ "$fail" -eq 0 ] && echo "run.sh: demo then test configures tests on; every ctest call has --no-tests=error"
exit "$fail"
