// Differential libFuzzer target for the two raw-inflate backends behind RawInflater
// (runtime/codec/tile_codec.hpp): zlib and libdeflate must give the same Status and, on success, the
// same bytes for every input. Bytes 0–1 (little endian) give the expected output size
// (0..65535), the rest is the raw deflate stream. Without libdeflate in the build the target
// only checks that zlib never crashes. State is created once: no per-input allocation.
//
// Known differences are allowed, where libdeflate (Debian 12 ships 1.14) is deliberately more
// accepting than zlib in a safe way (libdeflate issue #288): code-length repeats that run past
// the declared number of lengths are ignored (zlib: "invalid bit length repeat", libdeflate
// rejects them from 1.16 on), and a dynamic header may declare up to 288 literal/length and 32
// distance codes, the field widths' maximum (zlib: "too many length or distance symbols", RFC
// 1951 allows 286 and 30). A deflate encoder never writes such a stream, and tile payloads and
// sections are CRC-checked before inflating. When libdeflate accepts and the wrapper's zlib
// rejects, the target asks zlib itself for its reason and aborts on any reason not listed.
// btflod-link: ZLIB::ZLIB
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <span>

#include <zlib.h>

#include "btflod/runtime/codec/tile_codec.hpp"

namespace {
using btflod::InflateBackend;
using btflod::RawInflater;
using btflod::Status;

// zlib's own message for a raw stream, or nullptr when zlib inflates it without error.
const char* zlib_reason(std::span<const uint8_t> in, uint8_t* out, size_t out_size) {
  static z_stream* z = [] {
    auto* s = new z_stream{};
    if (inflateInit2(s, -15) != Z_OK) std::abort();
    return s;
  }();
  inflateReset(z);
  z->next_in = const_cast<Bytef*>(in.data());
  z->avail_in = static_cast<uInt>(in.size());
  z->next_out = out;
  z->avail_out = static_cast<uInt>(out_size);
  const int r = inflate(z, Z_FINISH);
  return (r == Z_DATA_ERROR && z->msg) ? z->msg : nullptr;
}

struct Backends {
  RawInflater zlib, libdeflate;
  bool have_libdeflate = false;
  uint8_t out_zlib[65536], out_libdeflate[65536];
  Backends() {
    if (!zlib.create(InflateBackend::zlib)) std::abort();
    have_libdeflate = btflod::inflate_backend_available(InflateBackend::libdeflate) &&
                      libdeflate.create(InflateBackend::libdeflate) &&
                      libdeflate.backend() == InflateBackend::libdeflate;
  }
};
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Backends* b = new Backends();  // never freed: lives for the process
  if (size < 2) return 0;
  const size_t out_size = static_cast<size_t>(data[0]) | static_cast<size_t>(data[1]) << 8;
  const std::span<const uint8_t> in(data + 2, size - 2);
  const char* why_zlib = nullptr;
  const Status s_zlib = b->zlib.inflate(in, {b->out_zlib, out_size}, &why_zlib);
  if (!b->have_libdeflate) return 0;
  const char* why_libdeflate = nullptr;
  const Status s_libdeflate = b->libdeflate.inflate(in, {b->out_libdeflate, out_size}, &why_libdeflate);
  if (s_zlib == Status::bad_data && s_libdeflate == Status::success) {
    const char* reason = zlib_reason(in, b->out_zlib, sizeof b->out_zlib);
    for (const char* known : {"invalid bit length repeat", "too many length or distance symbols"})
      if (reason != nullptr && std::strcmp(reason, known) == 0) return 0;  // the known differences above
  }
  if (s_zlib != s_libdeflate) {
    const char* reason = zlib_reason(in, b->out_zlib, sizeof b->out_zlib);
    std::fprintf(stderr, "status differs: zlib %d (%s; zlib: %s), libdeflate %d (%s), %zu output bytes\n",
                 static_cast<int>(s_zlib), why_zlib ? why_zlib : "", reason ? reason : "-",
                 static_cast<int>(s_libdeflate), why_libdeflate ? why_libdeflate : "", out_size);
    std::abort();
  }
  if (s_zlib == Status::success && std::memcmp(b->out_zlib, b->out_libdeflate, out_size) != 0) {
    std::fprintf(stderr, "output differs on a stream both backends accept (%zu bytes)\n", out_size);
    std::abort();
  }
  return 0;
}
