// libFuzzer target for offline/btf/measured_brdf.hpp: parse_mbsdf must never crash, hang or read out
// of bounds on any input; a BRDF it accepts must evaluate to finite, non-negative values.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "btflod/offline/btf/measured_brdf.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto brdf = btflod::parse_mbsdf(std::span<const uint8_t>(data, size), "fuzz");
  if (!brdf.ok()) {
    if (brdf.message().empty()) std::abort();  // every rejection explains itself
    return 0;
  }
  const glm::vec3 dirs[] = {{0, 0, 1}, {0.5f, 0.1f, 0.8f}, {-0.7f, 0.2f, 0.1f}, {0.0f, -1.0f, 0.01f}};
  for (const auto& l : dirs)
    for (const auto& v : dirs) {
      const glm::vec3 r = brdf->evaluate(l, v);
      for (int c = 0; c < 3; ++c)
        if (!(r[c] >= 0.0f) || !std::isfinite(r[c])) std::abort();
    }
  return 0;
}
