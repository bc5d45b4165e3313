// A container of one smooth synthetic material, for tests that need a real file but no
// GoogleTest (runtime_no_exceptions_data.cpp) as well as for the unit tests.
#pragma once

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "btflod/offline/build/bsvtf_build.hpp"

namespace btflod_test {

// Builds a container (T = 32, B = 4) of one size × size material with `components` components
// of 0.5 + 0.3 sin(fx · x · (c + 1) + fy · y), 2 lights × the views given (3 floats a view) and a
// constant U′ of 0.25. Returns the file, or the builder's error.
inline btflod::Result<std::vector<uint8_t>> build_wave_container(int size, int components, float fx, float fy,
                                                                 std::vector<float> view_directions) {
  using namespace btflod;
  EigenTextures e;
  e.textures.resize(size, size, components);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      for (int c = 0; c < components; ++c) e.textures.at(x, y, c) = 0.5f + 0.3f * std::sin(fx * x * (c + 1) + fy * y);
  e.light_count = 2;
  e.view_count = static_cast<uint32_t>(view_directions.size() / 3);
  e.angular.assign(size_t{2} * e.view_count * 3 * static_cast<size_t>(components), 0.25f);
  BsvtfFromEigenOptions o;
  o.tile_size = 32;
  o.border = 4;
  o.light_directions = {0, 0, 1, 0.6f, 0, 0.8f};
  o.view_directions = std::move(view_directions);
  return build_bsvtf_from_eigen_textures(e, o);
}

}  // namespace btflod_test
