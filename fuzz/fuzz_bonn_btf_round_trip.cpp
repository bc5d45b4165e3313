// libFuzzer target for offline/btf/bonn_btf.hpp's writer: every file the reader accepts is re-encoded,
// and encode(read(encode(read(x)))) must equal encode(read(x)) byte for byte (traps on
// mismatch). Reading alone (and reconstruction) is fuzz_bonn_btf.
#include <cstddef>
#include <cstdint>
#include <span>

#include "btflod/offline/btf/bonn_btf.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace btflod;
  auto f = read_bonn_btf(std::span<const uint8_t>(data, size));
  if (!f) return 0;
  auto a = encode_bonn_btf(*f);
  if (!a) return 0;  // e.g. a meta block version > 4 that the writer does not produce
  auto again = read_bonn_btf(std::span<const uint8_t>(*a));
  if (!again) __builtin_trap();
  auto b = encode_bonn_btf(*again);
  if (!b || *a != *b) __builtin_trap();
  return 0;
}
