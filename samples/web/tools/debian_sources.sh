#!/usr/bin/env bash
# Unpacks the Debian source packages the WebAssembly client compiles with emcc (zlib, libdeflate,
# libzstd — the client compiles only zstd's decompressor, lib/common + lib/decompress) into DEST
# (default build-web/third_party). Debian's emscripten cannot fetch its own ports
# (-sUSE_ZLIB downloads from the internet), so the decompression libraries come from Debian's archive
# through apt-get source, with a private apt configuration (a deb-src line for the archive the
# machine already uses): the system's apt state is not changed. Nothing is downloaded twice.
set -euo pipefail
DEST=${1:-build-web/third_party}
mkdir -p "$DEST"
DEST=$(cd "$DEST" && pwd)
have() { [ -f "$DEST/zlib/inflate.c" ] && [ -f "$DEST/libdeflate/lib/deflate_decompress.c" ] &&
  [ -f "$DEST/libzstd/lib/decompress/zstd_decompress.c" ]; }
if have; then exit 0; fi
APT="$DEST/apt"
mkdir -p "$APT/lists/partial" "$APT/download"
suite=$(. /etc/os-release && echo "${VERSION_CODENAME:-bookworm}")
echo "deb-src [signed-by=/usr/share/keyrings/debian-archive-keyring.gpg] http://deb.debian.org/debian $suite main" \
  > "$APT/sources.list"
opts=(-o Dir::Etc::SourceList="$APT/sources.list" -o Dir::Etc::SourceParts=/dev/null -o Dir::State::Lists="$APT/lists"
  -o APT::Get::List-Cleanup=0 -o Debug::NoLocking=1)
apt-get "${opts[@]}" -qq update
(cd "$APT/download" && apt-get "${opts[@]}" -qq source --download-only zlib libdeflate libzstd 2>&1 | grep -v "unsandboxed" || true)
for pkg in zlib libdeflate libzstd; do
  [ "$pkg" = zlib ] && [ -f "$DEST/zlib/inflate.c" ] && continue
  [ "$pkg" = libdeflate ] && [ -f "$DEST/libdeflate/lib/deflate_decompress.c" ] && continue
  [ "$pkg" = libzstd ] && [ -f "$DEST/libzstd/lib/decompress/zstd_decompress.c" ] && continue
  orig=$(ls "$APT/download/${pkg}_"*.orig.tar.* | head -n 1)
  rm -rf "$DEST/$pkg" "$DEST/$pkg.tmp"
  mkdir -p "$DEST/$pkg.tmp"
  tar -xf "$orig" -C "$DEST/$pkg.tmp"
  mv "$DEST/$pkg.tmp"/* "$DEST/$pkg"
  rmdir "$DEST/$pkg.tmp"
  echo "btflod web: $(basename "$orig") unpacked into $DEST/$pkg"
done
