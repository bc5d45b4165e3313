// Offline half of runtime_no_exceptions: builds the container with the normal (exception-
// enabled) flags, so only the runtime translation unit is compiled with -fno-exceptions.
#include <cstdint>
#include <vector>

#include "test_wave_container.hpp"

std::vector<uint8_t> btflod_no_exceptions_container() {
  auto r = btflod_test::build_wave_container(96, 5, 0.07f, 0.05f, {0, 0, 1, 0, 0.6f, 0.8f, 0.6f, 0, 0.8f});
  return r ? std::move(r.value()) : std::vector<uint8_t>{};
}
