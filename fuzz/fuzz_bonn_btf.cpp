// libFuzzer target for btf/bonn_btf.hpp: parses arbitrary bytes as a Bonn .btf file. Accepted
// files are reconstructed when small, and re-encoded: encode(read(encode(read(x)))) must equal
// encode(read(x)) byte for byte (a round-trip check that traps on mismatch).
#include <cstddef>
#include <cstdint>
#include <span>

#include "btflod/btf/bonn_btf.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace btflod;
  static ThreadPool pool(1);  // one worker: keep the fuzzer's own threads predictable
  auto f = read_bonn_btf(std::span<const uint8_t>(data, size));
  if (!f) {
    if (f.message().empty()) __builtin_trap();  // every failure explains itself
    return 0;
  }
  BonnReconstructOptions ro;
  ro.max_samples = uint64_t{1} << 16;  // keep each run fast and small
  ro.pool = &pool;
  auto btf = reconstruct_bonn_btf(*f, ro);
  (void)btf;
  auto a = encode_bonn_btf(*f);
  if (!a) return 0;  // e.g. a meta block version > 4 that the writer does not produce
  auto again = read_bonn_btf(std::span<const uint8_t>(*a));
  if (!again) __builtin_trap();
  auto b = encode_bonn_btf(*again);
  if (!b || *a != *b) __builtin_trap();
  return 0;
}
