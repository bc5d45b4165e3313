// libFuzzer target for offline/btf/merl_brdf.hpp: parse_merl_binary must never crash, hang or read out
// of bounds on any input (inputs here are far below a full MERL file, so this exercises the
// header, size and truncation checks), and MerlTable::lookup / half_diff_from_directions must
// give finite, non-negative values for any angles or directions taken from the input,
// including NaN, infinities and huge values, over a table with not-measured holes.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <span>
#include <vector>

#include "btflod/offline/btf/merl_brdf.hpp"

namespace {
const btflod::MerlTable& holey_table() {
  static const btflod::MerlTable table = [] {
    std::vector<double> v(3 * btflod::kMerlPlaneSize);
    for (size_t i = 0; i < v.size(); ++i) v[i] = (i % 7 == 0 || (i / 180) % 90 > 80) ? -1.0 : 0.5 + double(i % 13);
    return btflod::MerlTable(std::move(v));
  }();
  return table;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  btflod::MerlReadOptions small;
  small.res_theta = 4;
  small.res_phi = 8;
  auto brdf = btflod::parse_merl_binary(std::span<const uint8_t>(data, size), "fuzz", small);
  if (!brdf.ok() && brdf.message().empty()) std::abort();  // every rejection explains itself
  if (size >= 6 * sizeof(double)) {
    double d[6];
    std::memcpy(d, data, sizeof d);
    const btflod::HalfDiffAngles a = btflod::half_diff_from_directions({d[0], d[1], d[2]}, {d[3], d[4], d[5]});
    bool measured = false;
    for (const btflod::HalfDiffAngles& q : {a, btflod::HalfDiffAngles{d[0], d[1], d[2]}}) {
      const glm::dvec3 r = holey_table().lookup(q, &measured);
      for (int c = 0; c < 3; ++c)
        if (!(r[c] >= 0.0) || !std::isfinite(r[c])) std::abort();
    }
  }
  return 0;
}
