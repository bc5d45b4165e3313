// libFuzzer target for offline/btf/bonn_btf.hpp: parses arbitrary bytes as a Bonn .btf file; every
// rejection explains itself, and accepted files are reconstructed (at most 2^16 samples). The
// encode → read → encode round trip is its own target (fuzz_bonn_btf_round_trip). Mutation is
// structure-aware (bonn_mutator.hpp: one field of the parsed file changed, the file written
// again with consistent counts); BTFLOD_FUZZ_BYTES=1 keeps plain byte-level mutation.
#include <cstddef>
#include <cstdint>
#include <span>

#include "bonn_mutator.hpp"
#include "btflod/offline/btf/bonn_btf.hpp"

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
  return 0;
}

extern "C" size_t LLVMFuzzerCustomMutator(uint8_t* data, size_t size, size_t max_size, unsigned seed) {
  return btflod_fuzz::mutate_bonn_btf(data, size, max_size, seed);
}
