// A tiny engine-side consumer: proves the installed package is usable with find_package.
#include <btflod/btflod.hpp>

#include <cstdio>

int main() {
  const btflod::DirectionSet set = btflod::DirectionSet::ubo2003();
  const btflod::Half h(0.5f);
  std::printf("btflod consumer: %zu directions, half(0.5) = %g\n", set.size(), static_cast<double>(h.to_float()));
  return set.size() == 81 && h.to_float() == 0.5f ? 0 : 1;
}
