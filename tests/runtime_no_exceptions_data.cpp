// Offline half of runtime_no_exceptions: builds the container with the normal (exception-
// enabled) flags, so only the runtime translation unit is compiled with -fno-exceptions.
#include <cmath>
#include <cstdint>
#include <vector>

#include "btflod/offline/build/bsvtf_build.hpp"

std::vector<uint8_t> btflod_no_exceptions_container() {
  using namespace btflod;
  EigenTextures e;
  e.textures.resize(96, 96, 5);
  for (int y = 0; y < 96; ++y)
    for (int x = 0; x < 96; ++x)
      for (int c = 0; c < 5; ++c) e.textures.at(x, y, c) = 0.5f + 0.3f * std::sin(0.07f * x * (c + 1) + 0.05f * y);
  e.light_count = 2;
  e.view_count = 3;
  e.angular.assign(2 * 3 * 3 * 5, 0.25f);
  BsvtfFromEigenOptions o;
  o.tile_size = 32;
  o.border = 4;
  o.light_directions = {0, 0, 1, 0.6f, 0, 0.8f};
  o.view_directions = {0, 0, 1, 0, 0.6f, 0.8f, 0.6f, 0, 0.8f};
  auto r = build_bsvtf_from_eigen_textures(e, o);
  return r ? std::move(r.value()) : std::vector<uint8_t>{};
}
