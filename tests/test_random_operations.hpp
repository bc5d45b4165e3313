// Length of the random-operation tests (tile cache, scheduler): a short default keeps the unit
// stage fast; `./run.sh fuzz` sets BTFLOD_RANDOM_OPS (e.g. 1000000) for a long run with the
// invariants still checked after every operation.
#pragma once

#include <cstdint>
#include <cstdlib>

namespace btflod::test {

/// BTFLOD_RANDOM_OPS when it holds a positive decimal number, else `default_count`.
inline uint64_t random_operation_count(uint64_t default_count) {
  const char* env = std::getenv("BTFLOD_RANDOM_OPS");
  if (env == nullptr || *env == '\0') return default_count;
  char* end = nullptr;
  const unsigned long long n = std::strtoull(env, &end, 10);
  return (end != nullptr && *end == '\0' && n > 0) ? static_cast<uint64_t>(n) : default_count;
}

}  // namespace btflod::test
