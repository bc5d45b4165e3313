// btflod-angular-eval — accuracy of the angular interpolators against real measurements.
//
// For each measured car-paint BRDF (../shared/data/measured/*.mbsdf) and each direction set
// (UBO2003, UBO2014): tabulate ρ(l, v) at every light × view pair of the set, then interpolate
// at held-out random (light, view) pairs with each interpolator × parameterisation (9 taps:
// light sample × view sample) and compare with the measurement itself. Also the regular-grid
// resampling of paper 002 §6.2 (concentric 4D grid built from the exact interpolator, then
// "3D linear + one manual lerp"). Prints a Markdown table; with --doc FILE it replaces the
// block between "<!-- angular-eval:begin -->" and "<!-- angular-eval:end -->" in FILE.
//
// --merl: the materials are MERL .binary BRDFs instead (offline/btf/merl_brdf.hpp) — analytic BRDFs
// written in MERL's layout by this tool (real MERL files are not needed), read back by the MERL
// reader and resampled to MeasuredBrdf's grid; the table goes into the
// "<!-- angular-eval-merl:begin -->" … "<!-- angular-eval-merl:end -->" block.
//
// Usage: btflod-angular-eval [--shared DIR] [--samples N] [--grid N] [--seed S] [--merl] [--doc FILE]
// Exit code 0 on success or when the data folder is absent (prints "skipped"), 1 on errors.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "btflod/core/file_io.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/angular/nine_tap.hpp"
#include "btflod/offline/angular/regular_grid.hpp"
#include "btflod/offline/angular/ring_search.hpp"
#include "btflod/offline/btf/measured_brdf.hpp"
#include "btflod/offline/btf/merl_brdf.hpp"
#include "common/arguments.hpp"

namespace {

using namespace btflod;

// Platform-independent uniform floats (std distributions differ between standard libraries).
struct Rng {
  uint64_t s;
  float next() {
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    return static_cast<float>(s >> 40) * (1.0f / 16777216.0f);
  }
};

// Uniform on the spherical cap θ ≤ max_theta.
glm::vec3 random_direction(Rng& rng, float max_theta) {
  const float zmin = std::cos(max_theta);
  const float z = zmin + (1.0f - zmin) * rng.next();
  const float phi = kTwoPi * rng.next();
  const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

struct Stats {
  double sum_sq = 0.0;
  double truth_sq = 0.0;
  double max_abs = 0.0;
  double sum_abs = 0.0;
  size_t n = 0;
  void add(glm::vec3 got, glm::vec3 truth) {
    for (int c = 0; c < 3; ++c) {
      const double e = static_cast<double>(got[c]) - truth[c];
      sum_sq += e * e;
      truth_sq += static_cast<double>(truth[c]) * truth[c];
      max_abs = std::max(max_abs, std::abs(e));
      sum_abs += std::abs(e);
      ++n;
    }
  }
  double rmse() const { return n ? std::sqrt(sum_sq / n) : 0.0; }
  double mae() const { return n ? sum_abs / n : 0.0; }
  double relative() const { return truth_sq > 0 ? std::sqrt(sum_sq / truth_sq) : 0.0; }
};

// One interpolation method: name + a function (light, view) → value from the set's table.
struct Method {
  std::string name;
  std::function<glm::vec3(glm::vec3, glm::vec3)> eval;
};

template <class I>
Method nine_tap_method(std::string name, std::shared_ptr<const I> interp, const std::vector<glm::vec3>* table,
                       size_t count) {
  return {std::move(name), [interp, table, count](glm::vec3 l, glm::vec3 v) {
            return interpolate_light_view(*interp, *interp, l, v,
                                          [&](uint32_t a, uint32_t b) noexcept { return (*table)[a * count + b]; });
          }};
}

template <class I>
std::shared_ptr<const I> must(Result<I> r, const char* what) {
  if (!r) {
    std::fprintf(stderr, "btflod-angular-eval: %s: %s\n", what, r.message().c_str());
    std::exit(1);
  }
  return std::make_shared<const I>(std::move(r.value()));
}

// Interpolators depend only on the direction set: build each once and share it between the
// three paints.
std::map<std::string, std::shared_ptr<const void>>& interpolator_cache() {
  static std::map<std::string, std::shared_ptr<const void>> cache;
  return cache;
}

template <class I, class Build>
std::shared_ptr<const I> cached(const std::string& key, Build&& build, const char* what) {
  auto& c = interpolator_cache();
  auto it = c.find(key);
  if (it != c.end()) return std::static_pointer_cast<const I>(it->second);
  auto made = must(build(), what);
  c[key] = made;
  return made;
}

template <class P>
void add_plane_methods(std::vector<Method>& out, const DirectionSet& set, const std::vector<glm::vec3>* table) {
  const size_t n = set.size();
  const std::string p = P::kName;
  out.push_back(
      nine_tap_method("exact grid (paper 003) / " + p,
                      cached<ExactGridInterpolator<P>>(
                          set.name() + "exact" + p, [&] { return ExactGridInterpolator<P>::build(set); }, "exact"),
                      table, n));
  out.push_back(
      nine_tap_method("lookup table 256² (paper 000) / " + p,
                      cached<LookupTableInterpolator<P>>(
                          set.name() + "lut" + p, [&] { return LookupTableInterpolator<P>::build(set, 256); }, "lut"),
                      table, n));
  out.push_back(nine_tap_method(
      "nearest table 256² (paper 001) / " + p,
      cached<NearestLookupInterpolator<P>>(
          set.name() + "nearest" + p, [&] { return NearestLookupInterpolator<P>::build(set, 256); }, "nearest"),
      table, n));
}

// Analytic BRDFs written in MERL's layout: Lambert + normalised Blinn–Phong lobe of exponent
// n, per-channel albedo kd and specular ks; samples with θ_d index ≥ 85 marked not measured
// (as MERL's grazing holes).
struct MerlAnalytic {
  const char* name;
  glm::dvec3 kd, ks;
  double n;
};

Result<MerlBrdf> make_merl_material(const MerlAnalytic& m) {
  std::vector<double> table = merl_table_from_function([&](const glm::dvec3& l, const glm::dvec3& v) {
    const glm::dvec3 h = glm::normalize(l + v);
    const double lobe = (m.n + 2.0) / (2.0 * 3.14159265358979323846) * std::pow(std::max(h.z, 0.0), m.n);
    return m.kd / 3.14159265358979323846 + m.ks * lobe;
  });
  for (int c = 0; c < 3; ++c)
    for (size_t i = 0; i < kMerlPlaneSize; ++i)
      if ((i / kMerlPhiDiffCount) % kMerlThetaDiffCount >= 85) table[c * kMerlPlaneSize + i] = -1.0;
  auto bytes = encode_merl_binary(table);
  if (!bytes) return bytes.error();
  return parse_merl_binary(*bytes, m.name);
}

}  // namespace

int main(int argc, char** argv) {
  std::string shared = BTFLOD_SHARED_DIR;
  std::string doc;
  int samples = 20000;
  int grid = 32;
  uint64_t seed = 20260101;
  bool merl = false;
  btflod::samples::Arguments args("btflod-angular-eval", argc, argv);
  if (args.wants_help()) {
    std::puts("usage: btflod-angular-eval [--shared DIR] [--samples N] [--grid N] [--seed S] [--merl] [--doc FILE]");
    return 0;
  }
  shared = args.string("shared", shared);
  doc = args.string("doc", doc);
  samples = args.integer_as("samples", samples, 1, 100000000);
  grid = args.integer_as("grid", grid, 2, 64);
  seed = args.unsigned_integer("seed", seed);
  merl = args.flag("merl");
  if (!args.finish(0)) return 2;
  const char* names[] = {"carpaint_red", "carpaint_green", "carpaint_blue"};
  std::vector<MeasuredBrdf> brdfs;
  const MerlAnalytic merl_materials[] = {
      {"merl-layout Lambert + Blinn-Phong n=20", {0.5, 0.3, 0.1}, {0.04, 0.05, 0.06}, 20.0},
      {"merl-layout Lambert + Blinn-Phong n=200", {0.1, 0.2, 0.4}, {0.2, 0.2, 0.2}, 200.0}};
  std::string merl_note;
  if (merl) {
    for (const MerlAnalytic& m : merl_materials) {
      auto b = make_merl_material(m);
      if (!b) {
        std::fprintf(stderr, "btflod-angular-eval: %s\n", b.message().c_str());
        return 1;
      }
      char line[256];
      std::snprintf(line, sizeof line, "%s%s: %zu of %zu samples not measured", merl_note.empty() ? "" : "; ", m.name,
                    b->report.not_measured, 3 * b->report.plane_samples);
      merl_note += line;
      brdfs.push_back(std::move(b->brdf));
    }
  }
  for (const char* nm : names) {
    if (merl) break;
    const std::string path = shared + "/data/measured/" + nm + ".mbsdf";
    auto b = read_mbsdf(path);
    if (!b) {
      if (b.status() == Status::io_error) {
        std::printf("skipped: %s\n", b.message().c_str());
        return 0;
      }
      std::fprintf(stderr, "btflod-angular-eval: %s\n", b.message().c_str());
      return 1;
    }
    brdfs.push_back(std::move(b.value()));
  }
  const float max_theta = degrees_to_radians(75.0f);  // held-out pairs inside the last ring

  std::ostringstream md;
  if (merl) {
    md << "Materials: two analytic BRDFs written in MERL's .binary layout by the tool (90 × 90 × 180 half/"
       << "difference samples, colour scales 1/1500, 1.15/1500, 1.66/1500; θ_d samples ≥ 85 of 90 marked not"
       << " measured), read back by read_merl_binary's parser and resampled to 90 × 90 × 180 (θ_in, θ_out, φ_d)"
       << " cells (" << merl_note << "). Command: `btflod-angular-eval --merl --samples " << samples << " --grid "
       << grid << " --seed " << seed << "`.\n\n";
  }
  md << "Held-out pairs: " << samples << " random (light, view) pairs per BRDF, uniform on the cap θ ≤ 75°"
     << " (inside the last measured ring), seed " << seed << "; errors pooled over the "
     << (merl ? "two MERL-layout materials" : "three car paints") << " and"
     << " the RGB channels; ρ in 1/sr. MAE = mean |e|; relative RMSE = √(Σe²/Σρ²). Regular grid: " << grid
     << "⁴ nodes.\n\n";
  md << "| set | interpolator / parameterisation | RMSE | MAE | max error | relative RMSE |\n";
  md << "|---|---|---:|---:|---:|---:|\n";
  for (const DirectionSet& set : {DirectionSet::ubo2003(), DirectionSet::ubo2014()}) {
    const size_t n = set.size();
    std::vector<std::vector<glm::vec3>> tables(brdfs.size(), std::vector<glm::vec3>(n * n));
    for (size_t b = 0; b < brdfs.size(); ++b)
      for (size_t l = 0; l < n; ++l)
        for (size_t v = 0; v < n; ++v) tables[b][l * n + v] = brdfs[b].evaluate(set[l].vector, set[v].vector);
    std::vector<std::vector<Method>> methods(brdfs.size());
    for (size_t b = 0; b < brdfs.size(); ++b) {
      auto& m = methods[b];
      add_plane_methods<ParabolicMap>(m, set, &tables[b]);
      add_plane_methods<ElevatedConcentricMap>(m, set, &tables[b]);
      add_plane_methods<OrthographicMap>(m, set, &tables[b]);
      m.push_back(nine_tap_method("UBO ring search (paper 004)",
                                  cached<RingSearchInterpolator>(
                                      set.name() + "ring", [&] { return RingSearchInterpolator::build(set); }, "ring"),
                                  &tables[b], n));
      // Paper 002 §6.2: resample (via the exact concentric interpolator) onto the regular grid.
      auto exact = cached<ExactGridInterpolator<ElevatedConcentricMap>>(
          set.name() + "exact" + ElevatedConcentricMap::kName,
          [&] { return ExactGridInterpolator<ElevatedConcentricMap>::build(set); }, "exact");
      const auto* table = &tables[b];
      auto g =
          must(RegularAngularGrid<ElevatedConcentricMap>::resample(
                   grid, grid, 3,
                   [&](glm::vec3 l, glm::vec3 v, float* out) {
                     const glm::vec3 r = interpolate_light_view(
                         *exact, *exact, l, v, [&](uint32_t a, uint32_t bb) noexcept { return (*table)[a * n + bb]; });
                     out[0] = r.x;
                     out[1] = r.y;
                     out[2] = r.z;
                   }),
               "grid");
      m.push_back(
          {"regular grid " + std::to_string(grid) + "⁴ + lerp (paper 002) / concentric", [g](glm::vec3 l, glm::vec3 v) {
             glm::vec3 r;
             g->evaluate(l, v, &r.x);
             return r;
           }});
    }
    std::vector<Stats> stats(methods[0].size());
    for (size_t b = 0; b < brdfs.size(); ++b) {
      Rng rng{seed * 2654435761u + b + 1};
      for (int s = 0; s < samples; ++s) {
        const glm::vec3 l = random_direction(rng, max_theta), v = random_direction(rng, max_theta);
        const glm::vec3 truth = brdfs[b].evaluate(l, v);
        for (size_t k = 0; k < methods[b].size(); ++k) stats[k].add(methods[b][k].eval(l, v), truth);
      }
    }
    for (size_t k = 0; k < stats.size(); ++k) {
      char line[512];
      std::snprintf(line, sizeof line, "| %s | %s | %.4f | %.4f | %.3f | %.3f |\n", set.name().c_str(),
                    methods[0][k].name.c_str(), stats[k].rmse(), stats[k].mae(), stats[k].max_abs, stats[k].relative());
      md << line;
    }
  }
  const std::string table = md.str();
  std::fputs(table.c_str(), stdout);
  if (!doc.empty()) {
    std::ifstream in(doc);
    if (!in) {
      std::fprintf(stderr, "btflod-angular-eval: cannot read %s\n", doc.c_str());
      return 1;
    }
    std::stringstream ss;
    ss << in.rdbuf();
    std::string text = ss.str();
    const std::string begin = merl ? "<!-- angular-eval-merl:begin -->" : "<!-- angular-eval:begin -->";
    const std::string end = merl ? "<!-- angular-eval-merl:end -->" : "<!-- angular-eval:end -->";
    const size_t b = text.find(begin), e = text.find(end);
    if (b == std::string::npos || e == std::string::npos || e < b) {
      std::fprintf(stderr, "btflod-angular-eval: %s has no %s … %s block\n", doc.c_str(), begin.c_str(), end.c_str());
      return 1;
    }
    text = text.substr(0, b + begin.size()) + "\n" + table + text.substr(e);
    std::ofstream out(doc, std::ios::trunc);
    out << text;
    if (!out) {
      std::fprintf(stderr, "btflod-angular-eval: cannot write %s\n", doc.c_str());
      return 1;
    }
  }
  return 0;
}
