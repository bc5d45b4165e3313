#!/usr/bin/env bash
# btflod's one entry point for a fresh Debian 12 machine.
#   ./run.sh demo [demo args...]  install what is missing, build, run the demo on built-in data
#   ./run.sh test                 install what is missing, build and run every test
#                                 (release with -Werror, then ASan+UBSan, then TSan on the tests
#                                 that start threads, then fuzz smoke runs)
#   ./run.sh bench [filter]       build and run the benchmarks, JSON into build/bench-results/ (no
#                                 filter: also the demo's frames to converge after a camera cut)
#   ./run.sh web [--port P]       build the WebAssembly client and the materials, serve them with
#                                 nginx on 127.0.0.1 and print the URL to open (samples/web/)
#   ./run.sh raytrace [args...]   Embree ray tracer with BTF materials on built-in data, into
#                                 out/raytrace/ (docs/raytrace.md)
#   ./run.sh soak [minutes]       stream a world through faulty I/O for the given minutes
#                                 (default 10), then as long over HTTP from an nginx restarted
#                                 every 10 s (when installed), checking the engine's invariants
#                                 every frame (docs/reliability.md); reports in out/soak*.json
#   ./run.sh fuzz [minutes]       fuzzing campaign: every libFuzzer target for the given minutes
#                                 (default 10), corpus merged into fuzz/corpus/, a table per
#                                 target; then the random-operation tests with 10^6 operations
# Environment: BTFLOD_JOBS (parallel build jobs, default nproc), BTFLOD_BUILD_DIR (default build).
# Every command passes each build option it depends on, so commands can run in any order on the
# same build folder (a cached option from an earlier command never changes what a later one does),
# and every ctest call fails when it finds no tests (--no-tests=error).
set -euo pipefail
cd "$(dirname "$0")"

# The Debian packages btflod needs; DEVELOPERS.md explains each one.
PACKAGES=(g++ cmake make ninja-build pkgconf libglm-dev libstb-dev python3-glad libeigen3-dev libgtest-dev
  libbenchmark-dev zlib1g-dev libdeflate-dev libturbojpeg0-dev libjpeg62-turbo-dev libegl-dev libopengl-dev
  libgl1-mesa-dri mesa-vulkan-drivers libvulkan-dev glslc glslang-tools vulkan-tools
  libzstd-dev libcurl4-openssl-dev nginx-light clang libclang-rt-14-dev libx11-dev xvfb libopenexr-dev libembree-dev emscripten
  chromium nodejs npm libopenmpi-dev openmpi-bin libopenblas-dev libfilament-dev libfilament-tools
  gnuplot-nox clang-format libsquish-dev)

install_packages() {
  local missing=()
  for p in "${PACKAGES[@]}"; do
    # A Node.js installed from elsewhere (e.g. NodeSource, which bundles npm) conflicts with
    # Debian's nodejs/npm packages: a working node and npm on PATH satisfy them.
    case "$p" in
      nodejs) command -v node >/dev/null 2>&1 && continue ;;
      npm) command -v npm >/dev/null 2>&1 && continue ;;
    esac
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  local line="apt-get install -y --no-install-recommends ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then
    echo "btflod: missing Debian packages. Run as root:" >&2
    echo "  apt-get update && $line" >&2
    exit 1
  fi
  echo "btflod: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  # shellcheck disable=SC2086
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

JOBS=${BTFLOD_JOBS:-$(nproc)}
# The sanitizer stage covers the code that reads untrusted bytes or runs per frame: core, file
# readers, codec, streaming, LOD/feedback, the virtual-texture cache and scheduler, the factor
# file readers and the Delaunay triangulation (hostile point sets). The numeric factorisation and
# shading tests run in the release stage only, to keep CI within its time budget.
ASAN_TESTS='^test_(core|btf|codec|stream|lod|vt|runtime|factor_any|factor_spmm|backend_spmm|angular_delaunay|angular_interpolators|render_sampling|render_surface)'

BUILD=${BTFLOD_BUILD_DIR:-build}

configure_and_build() {  # dir, extra cmake args... (BTFLOD_TARGET: build only that target)
  local dir=$1; shift
  # Ninja for new folders: its targets compile while the libraries they link are still being
  # built (make waits for the whole implementation TU first, leaving one of 2 cores idle for
  # minutes). A folder configured before keeps its generator.
  local generator=()
  [ -f "$dir/CMakeCache.txt" ] || generator=(-G Ninja)
  # Release at -O2 (CMake's default is -O3): the same code paths and floating-point results
  # (no -ffast-math), about a third less compile time for the ~290 targets on 2 cores.
  cmake -S . -B "$dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O2 -DNDEBUG" "$@" >/dev/null
  cmake --build "$dir" -j "$JOBS" ${BTFLOD_TARGET:+--target "$BTFLOD_TARGET"}
}

build_sample() {  # target: the one sample target, in a release build without tests, benchmarks or fuzzers
  BTFLOD_TARGET=$1 configure_and_build "$BUILD" -DBTFLOD_BUILD_SAMPLES=ON -DBTFLOD_BUILD_TESTS=OFF \
    -DBTFLOD_BUILD_BENCH=OFF -DBTFLOD_BUILD_FUZZ=OFF -DBTFLOD_SANITIZE=OFF
}

cmd=${1:-}
shift || true
case "$cmd" in
  demo)
    install_packages
    build_sample btflod-demo
    mkdir -p out
    "$BUILD"/samples/demo/btflod-demo --out out/demo "$@"
    ;;
  test)
    install_packages
    start=$(date +%s)
    echo "== release build (-Werror) =="
    configure_and_build "$BUILD" -DBTFLOD_BUILD_TESTS=ON -DBTFLOD_BUILD_SAMPLES=ON -DBTFLOD_BUILD_BENCH=OFF \
      -DBTFLOD_BUILD_FUZZ=OFF -DBTFLOD_SANITIZE=OFF -DBTFLOD_WERROR=ON -DBTFLOD_TEST_FILTER= -DBTFLOD_TEST_LABEL=
    (cd "$BUILD" && ctest --no-tests=error --output-on-failure -j "$JOBS" --timeout 900)
    echo "== ASan+UBSan build: unit tests =="
    # clang at -O0 with asserts on and line tables only: the sanitizers need no more, clang's UBSan
    # also checks pointer-offset overflow (GCC's does not), and the build takes a third of g++ -O1's
    # time for 2-3x longer test runs (277 s + 141 s instead of about 1,000 s + 41 s on 2 cores).
    CC=clang CXX=clang++ configure_and_build "$BUILD-asan" -DBTFLOD_SANITIZE=ON -DBTFLOD_BUILD_TESTS=ON -DBTFLOD_BUILD_BENCH=OFF \
      -DBTFLOD_BUILD_FUZZ=OFF -DBTFLOD_INSTALL=OFF -DBTFLOD_WERROR=ON \
      -DBTFLOD_BUILD_SAMPLES=OFF -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O0 -g1" \
      -DBTFLOD_TEST_FILTER="$ASAN_TESTS" -DBTFLOD_TEST_LABEL=
    (cd "$BUILD-asan" && ASAN_OPTIONS=detect_leaks=1 ctest --no-tests=error --output-on-failure -j "$JOBS" -L unit --timeout 900)
    echo "== ThreadSanitizer build: tests that start threads =="
    # The test files labelled `threads` (their `// btflod-label:` lines; tests/README.md lists
    # them), built alone with clang -O1 -g1, asserts on. Suppressions: tests/tsan.supp.
    tsan_start=$(date +%s)
    tsan_options="halt_on_error=1 second_deadlock_stack=1 suppressions=$PWD/tests/tsan.supp"
    CC=clang CXX=clang++ configure_and_build "$BUILD-tsan" -DBTFLOD_SANITIZE=thread -DBTFLOD_BUILD_TESTS=ON \
      -DBTFLOD_BUILD_BENCH=OFF -DBTFLOD_BUILD_FUZZ=OFF -DBTFLOD_INSTALL=OFF -DBTFLOD_WERROR=ON -DBTFLOD_BUILD_SAMPLES=OFF \
      -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" -DBTFLOD_TEST_FILTER= -DBTFLOD_TEST_LABEL=threads
    (cd "$BUILD-tsan" && TSAN_OPTIONS="$tsan_options" ctest --no-tests=error --output-on-failure -j "$JOBS" -L threads --timeout 900)
    echo "btflod: ThreadSanitizer stage took $(( $(date +%s) - tsan_start )) s"
    echo "== libFuzzer smoke runs (clang) =="
    CC=clang CXX=clang++ configure_and_build "$BUILD-fuzz" -DBTFLOD_BUILD_FUZZ=ON -DBTFLOD_BUILD_TESTS=OFF \
      -DBTFLOD_BUILD_SAMPLES=OFF -DBTFLOD_BUILD_BENCH=OFF -DBTFLOD_INSTALL=OFF -DBTFLOD_WERROR=OFF \
      -DBTFLOD_SANITIZE=OFF
    (cd "$BUILD-fuzz" && ctest --no-tests=error --output-on-failure -j "$JOBS" -L fuzz --timeout 900)
    echo "btflod: all test stages passed in $(( $(date +%s) - start )) s"
    ;;
  fuzz)
    install_packages
    minutes=${1:-10}
    case "$minutes" in '' | *[!0-9]*) echo "usage: ./run.sh fuzz [minutes]" >&2; exit 2 ;; esac
    CC=clang CXX=clang++ configure_and_build "$BUILD-fuzz" -DBTFLOD_BUILD_FUZZ=ON -DBTFLOD_BUILD_TESTS=OFF \
      -DBTFLOD_BUILD_SAMPLES=OFF -DBTFLOD_BUILD_BENCH=OFF -DBTFLOD_INSTALL=OFF -DBTFLOD_WERROR=OFF \
      -DBTFLOD_SANITIZE=OFF
    status=0
    fuzz/campaign.sh "$BUILD-fuzz" "$minutes" "$JOBS" || status=$?
    echo "== random-operation tests, 10^6 operations each (invariants checked after every one) =="
    configure_and_build "$BUILD" -DBTFLOD_BUILD_TESTS=ON -DBTFLOD_BUILD_BENCH=OFF -DBTFLOD_BUILD_FUZZ=OFF \
      -DBTFLOD_SANITIZE=OFF -DBTFLOD_BUILD_SAMPLES=OFF -DBTFLOD_TEST_FILTER='^test_vt_(cache|scheduler)$' -DBTFLOD_TEST_LABEL=
    BTFLOD_RANDOM_OPS=1000000 "$BUILD/tests/test_vt_cache" --gtest_filter='*Random*' || status=1
    BTFLOD_RANDOM_OPS=1000000 "$BUILD/tests/test_vt_scheduler" --gtest_filter='*Random*' || status=1
    exit $status
    ;;
  bench)
    install_packages
    configure_and_build "$BUILD" -DBTFLOD_BUILD_BENCH=ON -DBTFLOD_BUILD_SAMPLES=ON -DBTFLOD_BUILD_FUZZ=OFF -DBTFLOD_SANITIZE=OFF
    mkdir -p "$BUILD/bench-results"
    for b in "$BUILD"/bench/bench_*; do
      [ -x "$b" ] || continue
      name=$(basename "$b")
      "$b" --benchmark_filter="${1:-.}" --benchmark_out="$BUILD/bench-results/$name.json" --benchmark_out_format=json
    done
    # Frames to converge after a camera cut: the demo scene at its default link budget (about
    # 3 minutes; docs/benchmarking.md). Skipped when a filter is given.
    if [ -z "${1:-}" ]; then
      "$BUILD"/samples/demo/btflod-demo --out "$BUILD/bench-results/demo_cut" --cut --quiet | grep -E "^  (cut|settle|renderer)|btflod demo: renderer"
    fi
    ;;
  web)
    install_packages
    build_sample btflod-web-tool
    samples/web/run_web.sh serve --tool "$BUILD"/samples/web/btflod-web-tool --work "$BUILD"/web "$@"
    ;;
  svd-compare)
    # btflod's randomised SVD (in memory, out of core) vs SLEPc's on the same matrix: opt-in, so
    # CI does not install SLEPc. Arguments go to btflod-svd-compare (--material, --size, --rank).
    PACKAGES+=(libslepc-real-dev libbenchmark-dev)
    install_packages
    BTFLOD_TARGET=btflod-svd-compare configure_and_build "$BUILD" -DBTFLOD_BUILD_BENCH=ON -DBTFLOD_BUILD_TESTS=OFF \
      -DBTFLOD_BUILD_SAMPLES=OFF -DBTFLOD_BUILD_FUZZ=OFF -DBTFLOD_SANITIZE=OFF -DBTFLOD_WITH_MPI=ON
    mkdir -p out
    "$BUILD"/bench/btflod-svd-compare --dir out "$@"
    ;;
  raytrace)
    install_packages
    build_sample btflod-raytrace
    mkdir -p out
    "$BUILD"/samples/raytrace/btflod-raytrace --out out/raytrace "$@"
    ;;
  soak)
    install_packages
    minutes=${1:-10}
    case "$minutes" in '' | *[!0-9]*) echo "usage: ./run.sh soak [minutes]" >&2; exit 2 ;; esac
    build_sample btflod-soak
    mkdir -p out
    status=0
    "$BUILD"/samples/tools/soak/btflod-soak --minutes "$minutes" --json out/soak.json || status=1
    # The same world over HTTP from a private nginx restarted every 10 s (skipped with a message
    # when nginx is not installed).
    if [ -x /usr/sbin/nginx ]; then
      "$BUILD"/samples/tools/soak/btflod-soak --http --minutes "$minutes" --json out/soak_http.json || status=1
    else
      echo "btflod: no /usr/sbin/nginx (Debian: nginx-light): skipping the HTTP soak"
    fi
    exit $status
    ;;
  *)
    echo "usage: ./run.sh demo|test|bench|web|raytrace|fuzz|soak|svd-compare" >&2
    exit 2
    ;;
esac
