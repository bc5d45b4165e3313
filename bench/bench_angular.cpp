// Benchmarks for the angular interpolators: ns per query for each interpolator and for the
// 9-tap light × view combination, on UBO2003 and UBO2014. In-run baseline: the O(n)
// brute-force nearest direction (DirectionSet::nearest) on the same queries.
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/angular/nine_tap.hpp"
#include "btflod/offline/angular/regular_grid.hpp"
#include "btflod/offline/angular/ring_search.hpp"

namespace {

using namespace btflod;

std::vector<glm::vec3> queries(uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<glm::vec3> out;
  for (int i = 0; i < 4096; ++i) {
    const float z = u(rng), phi = kTwoPi * u(rng), r = std::sqrt(1.0f - z * z);
    out.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return out;
}

template <class I>
void register_set(const std::string& set_name, const std::string& name, std::shared_ptr<const I> interp, size_t count) {
  auto q = std::make_shared<std::vector<glm::vec3>>(queries(1));
  auto q2 = std::make_shared<std::vector<glm::vec3>>(queries(2));
  benchmark::RegisterBenchmark((set_name + "/query/" + name).c_str(), [interp, q](benchmark::State& st) {
    size_t i = 0;
    for (auto _ : st) {
      benchmark::DoNotOptimize(interp->query((*q)[i]));
      i = (i + 1) & 4095;
    }
    st.SetItemsProcessed(st.iterations());
  });
  auto table = std::make_shared<std::vector<float>>(count * count, 0.5f);
  benchmark::RegisterBenchmark((set_name + "/nine_tap/" + name).c_str(), [interp, q, q2, table,
                                                                          count](benchmark::State& st) {
    size_t i = 0;
    for (auto _ : st) {
      const float v = interpolate_light_view(*interp, *interp, (*q)[i], (*q2)[i],
                                             [&](uint32_t a, uint32_t b) noexcept { return (*table)[a * count + b]; });
      benchmark::DoNotOptimize(v);
      i = (i + 1) & 4095;
    }
    st.SetItemsProcessed(st.iterations());
  });
}

template <class R>
std::shared_ptr<const typename std::decay_t<decltype(std::declval<R>().value())>> must(R r) {
  if (!r) std::abort();
  return std::make_shared<const typename std::decay_t<decltype(r.value())>>(std::move(r.value()));
}

void register_all() {
  for (const DirectionSet& set : {DirectionSet::ubo2003(), DirectionSet::ubo2014()}) {
    const std::string s = set.name();
    const size_t n = set.size();
    auto dirs = std::make_shared<DirectionSet>(set);
    auto q = std::make_shared<std::vector<glm::vec3>>(queries(1));
    benchmark::RegisterBenchmark((s + "/query/baseline_bruteforce_nearest").c_str(), [dirs, q](benchmark::State& st) {
      size_t i = 0;
      for (auto _ : st) {
        benchmark::DoNotOptimize(dirs->nearest((*q)[i]));
        i = (i + 1) & 4095;
      }
      st.SetItemsProcessed(st.iterations());
    });
    register_set(s, "exact_grid_parabolic", must(ExactGridInterpolator<ParabolicMap>::build(set)), n);
    register_set(s, "exact_grid_concentric", must(ExactGridInterpolator<ElevatedConcentricMap>::build(set)), n);
    register_set(s, "exact_grid_orthographic", must(ExactGridInterpolator<OrthographicMap>::build(set)), n);
    register_set(s, "lookup_table_parabolic_256", must(LookupTableInterpolator<ParabolicMap>::build(set, 256)), n);
    register_set(s, "lookup_table_concentric_256",
                 must(LookupTableInterpolator<ElevatedConcentricMap>::build(set, 256)), n);
    register_set(s, "nearest_table_concentric_256",
                 must(NearestLookupInterpolator<ElevatedConcentricMap>::build(set, 256)), n);
    register_set(s, "ring_search", must(RingSearchInterpolator::build(set)), n);
  }
  // Paper 002 §6.2: one 4D evaluation = two trilinear fetches + one lerp (the 9-tap's rival).
  auto grid = must(RegularAngularGrid<ElevatedConcentricMap>::resample(
      16, 16, 1, [](glm::vec3 l, glm::vec3 v, float* out) { out[0] = l.z * v.z; }));
  auto q = std::make_shared<std::vector<glm::vec3>>(queries(1));
  auto q2 = std::make_shared<std::vector<glm::vec3>>(queries(2));
  benchmark::RegisterBenchmark("grid16/regular_grid_evaluate_concentric", [grid, q, q2](benchmark::State& st) {
    size_t i = 0;
    for (auto _ : st) {
      float v;
      grid->evaluate((*q)[i], (*q2)[i], &v);
      benchmark::DoNotOptimize(v);
      i = (i + 1) & 4095;
    }
    st.SetItemsProcessed(st.iterations());
  });
}

}  // namespace

int main(int argc, char** argv) {
  register_all();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
