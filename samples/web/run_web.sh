#!/usr/bin/env bash
# btflod web client: build, serve, test.
#   run_web.sh serve --tool BTFLOD_WEB_TOOL --work DIR [--port P]
#       builds the wasm client (emscripten, Debian's zlib/libdeflate/libzstd sources), synthesises
#       the materials (zstd tiles; the last material deflate-coded, as earlier versions wrote
#       every tile, so both tile formats are served), stages the site and serves it with nginx on
#       127.0.0.1 until Ctrl-C.
#   run_web.sh test --tool BTFLOD_WEB_TOOL --work DIR [--reduced | --bench-only]
#       the same site, the engine runtime in wasm under Node (test/node_streamer.mjs), then the
#       browser driver (test/driver.mjs: chromium headless through
#       puppeteer-core) and the checks; exit 77 (skipped) when emcc, chromium, nginx or node are
#       missing. nginx runs with a private prefix and config; it is stopped on exit.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
mode=${1:-}
shift || true
TOOL="" WORK="" PORT=${BTFLOD_WEB_PORT:-0} REDUCED=0 BENCH_ONLY=
while [ $# -gt 0 ]; do
  case "$1" in
    --tool) TOOL=$2; shift 2 ;;
    --work) WORK=$2; shift 2 ;;
    --port) PORT=$2; shift 2 ;;
    --reduced) REDUCED=1; shift ;;
    --bench-only) BENCH_ONLY=--bench-only; shift ;;
    *) echo "run_web.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
[ -n "$TOOL" ] && [ -n "$WORK" ] || { echo "usage: run_web.sh serve|test --tool PATH --work DIR" >&2; exit 2; }
export NODE_PATH=${NODE_PATH:-/usr/share/nodejs}
CHROMIUM=${BTFLOD_CHROMIUM:-/usr/lib/chromium/chromium}
missing=()
command -v emcc >/dev/null || missing+=(emscripten)
command -v node >/dev/null || missing+=(nodejs)
[ -x /usr/sbin/nginx ] || missing+=(nginx-light)
[ "$mode" = test ] && { [ -x "$CHROMIUM" ] || missing+=(chromium); }
if [ ${#missing[@]} -gt 0 ]; then
  echo "btflod web: SKIPPED, missing ${missing[*]} (./run.sh installs them)"
  exit 77
fi
mkdir -p "$WORK"
WORK=$(cd "$WORK" && pwd)

# 1. The wasm client (its own emscripten build folder; zlib/libdeflate/libzstd from Debian sources).
WEB_BUILD=${BTFLOD_WEB_BUILD:-$WORK/wasm-build}
"$HERE/tools/debian_sources.sh" "$WEB_BUILD/third_party"
if [ ! -f "$WEB_BUILD/CMakeCache.txt" ]; then
  emcmake cmake -S "$HERE/client" -B "$WEB_BUILD" -DCMAKE_BUILD_TYPE=Release -DBTFLOD_WEB_THIRD_PARTY="$WEB_BUILD/third_party" \
    -DCMAKE_CROSSCOMPILING_EMULATOR="/usr/bin/node;--no-experimental-fetch" >/dev/null
fi
# The reduced (CI) run builds the page's module and the Streamer module; the full run adds the
# libdeflate twin.
if [ "$REDUCED" = 1 ]; then targets=(--target btflod_web btflod_web_streamer); else targets=(); fi
cmake --build "$WEB_BUILD" -j "${BTFLOD_JOBS:-2}" "${targets[@]}" >/dev/null

# 2. The site: page, client, wasm, materials (+ corrupted copies for the fault test).
SITE=$WORK/site
mkdir -p "$SITE/wasm" "$SITE/data"
cp "$HERE"/www/*.html "$HERE"/www/*.js "$SITE/"
cp "$WEB_BUILD"/btflod_web*.js "$WEB_BUILD"/btflod_web*.wasm "$SITE/wasm/"
count=3
[ "$REDUCED" = 1 ] && count=2
# (a materials.json without tile coders predates zstd tiles: built again)
grep -qs '"coder"' "$SITE/data/materials.json" ||
  "$TOOL" materials --out "$SITE/data" --count "$count" --deflate $((count - 1)) >/dev/null

# 3. nginx on loopback with a private prefix (static files; Range is nginx's default for them).
NGX=$WORK/nginx
mkdir -p "$NGX/logs" "$NGX/tmp"
if [ "$PORT" = 0 ]; then PORT=$(( 20000 + RANDOM % 20000 )); fi
cat > "$NGX/nginx.conf" <<CONF
daemon off;
worker_processes 1;
pid $NGX/nginx.pid;
error_log $NGX/logs/error.log warn;
$( [ "$(id -u)" = 0 ] && echo "user root;" )
events { worker_connections 256; }
http {
  include /etc/nginx/mime.types;
  default_type application/octet-stream;
  log_format ranges '\$request_method \$uri \$status \$body_bytes_sent "\$http_range" \$args';
  access_log $NGX/logs/access.log ranges;
  client_body_temp_path $NGX/tmp/body;
  proxy_temp_path $NGX/tmp/proxy;
  fastcgi_temp_path $NGX/tmp/fastcgi;
  uwsgi_temp_path $NGX/tmp/uwsgi;
  scgi_temp_path $NGX/tmp/scgi;
  sendfile on;
  keepalive_timeout 30;
  server {
    listen 127.0.0.1:$PORT;
    root $SITE;
    etag off;
    add_header Cache-Control no-store;
    # Fault test: a request carrying ?drop=1 is answered by closing the connection (444).
    location /data/ { if (\$arg_drop) { return 444; } }
  }
}
CONF
: > "$NGX/logs/access.log"
/usr/sbin/nginx -p "$NGX" -c "$NGX/nginx.conf" &
NGINX_PID=$!
trap 'kill $NGINX_PID 2>/dev/null || true; wait $NGINX_PID 2>/dev/null || true' EXIT
for _ in $(seq 50); do
  curl -s -o /dev/null "http://127.0.0.1:$PORT/index.html" 2>/dev/null && break
  sleep 0.1
done
URL="http://127.0.0.1:$PORT/index.html"

if [ "$mode" = serve ]; then
  echo "btflod web: open $URL   (nginx on 127.0.0.1:$PORT, Ctrl-C stops it)"
  wait $NGINX_PID
  exit 0
fi

# 4. The engine runtime in wasm under Node (no browser): every material in one Streamer with
#    JavaScript-owned, out-of-order, failing and damaged reads (test/node_streamer.mjs).
TEST=$HERE/test
if [ -z "$BENCH_ONLY" ]; then
  node --no-experimental-fetch "$TEST/node_streamer.mjs" "$WEB_BUILD/btflod_web_streamer.js" "$SITE"/data/*.bsvtf ||
    { echo "btflod web: the Streamer in WebAssembly FAILED"; exit 1; }
fi

# 5. Browser test.
if [ ! -d "$TEST/node_modules/puppeteer-core" ]; then
  (cd "$TEST" && PUPPETEER_SKIP_DOWNLOAD=1 npm install --no-audit --no-fund --silent >/dev/null 2>&1) || {
    echo "btflod web: SKIPPED, npm could not install puppeteer-core into $TEST/node_modules"
    exit 77
  }
fi
node --no-experimental-fetch "$TEST/driver.mjs" --url "$URL" --site "$SITE" --tool "$TOOL" --work "$WORK" \
  --access-log "$NGX/logs/access.log" --chromium "$CHROMIUM" --wasm "$WEB_BUILD" $( [ "$REDUCED" = 1 ] && echo --reduced ) $BENCH_ONLY
