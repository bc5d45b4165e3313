// libFuzzer target: the factor file reader (offline/factor/any_factorization.hpp) on hostile bytes.
// Every accepted file must be evaluable at its first and last texel and direction without
// reading out of range (ASan checks), and must serialise again.
//
// Mutation: structure-aware (structure_mutators.hpp: mutate_factor_file, cross_over_factor_file),
// so mutated section payloads keep valid lengths and CRCs and reach the representation readers;
// with BTFLOD_FUZZ_BYTES=1 in the environment libFuzzer's plain byte-level mutation and a plain
// splice cross-over are used.
#include <cstddef>
#include <cstdint>
#include <span>

#include "btflod/offline/factor/any_factorization.hpp"
#include "structure_mutators.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto f = btflod::parse_factorization(std::span<const uint8_t>(data, size));
  if (!f) return 0;
  const auto& shape = btflod::factorization_shape(*f);
  const int x1 = shape.width - 1, y1 = shape.height - 1;
  const auto v1 = static_cast<uint32_t>(shape.view_count() - 1), l1 = static_cast<uint32_t>(shape.light_count() - 1);
  float sink = 0.0f;
  std::visit(
      [&](const auto& rep) {
        using T = std::decay_t<decltype(rep)>;
        if constexpr (std::is_same_v<T, btflod::LaplacianPca>) {
          sink += rep.evaluate_measured(0, 0, 0, 0, 0.0f).x + rep.evaluate_measured(x1, y1, v1, l1, 0.5f).y;
        } else {
          sink += rep.evaluate_measured(0, 0, 0, 0).x + rep.evaluate_measured(x1, y1, v1, l1).y;
        }
      },
      *f);
  (void)btflod::serialize_factorization(*f);
  volatile float keep = sink;
  (void)keep;
  return 0;
}

BTFLOD_FUZZ_STRUCTURE_AWARE(btflod_fuzz::mutate_factor_file, btflod_fuzz::cross_over_factor_file)
