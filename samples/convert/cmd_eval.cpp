// btflod-convert eval — error table of a factor file against its source BTF; and
// btflod-convert factor-table — the comparison table of docs/factor.md (every representation
// at several sizes on synthesised materials and on the measured car-paint BRDF).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "command.hpp"
#include "common/btf_files.hpp"
#include "common/progress_bar.hpp"

#include "btflod/btf/measured_brdf.hpp"
#include "btflod/btf/synthesizer.hpp"
#include "btflod/factor/any_factorization.hpp"
#include "btflod/factor/low_rank_btf.hpp"
#include "btflod/metrics/btf_metrics.hpp"

// The shared data folder next to the repository (this file is samples/convert/cmd_eval.cpp).
inline std::string default_shared_dir() {
  return (std::filesystem::path(__FILE__).parent_path() / ".." / ".." / ".." / "shared").lexically_normal().string();
}

namespace {

using namespace btflod;

void print_report_row(const char* name, const char* config, size_t bytes, double ratio, const BtfErrorReport& r,
                      double seconds) {
  std::printf("| %s | %s | %zu | %.1f | %.5f | %.2f | %.4f | %.3f | %.2e / %.2e / %.2e | %.2f |\n", name, config, bytes,
              ratio, r.rmse, r.psnr, r.mean_ssim, r.mae_cielab, r.mse_ycbcr[0], r.mse_ycbcr[1], r.mse_ycbcr[2],
              seconds);
}

const char* kHeader =
    "| material | representation | bytes | ratio | RMSE | PSNR dB | mean SSIM | CIELAB MAE | MSE Y / Cb / Cr | "
    "factorise s |\n|---|---|---:|---:|---:|---:|---:|---:|---|---:|";

int run_eval(int argc, char** argv) {
  convert::Options opt(argc, argv);
  if (opt.wants_help()) {
    std::puts(
        "usage: btflod-convert eval FACTOR_FILE SOURCE_BTF [--lambda L] [--range R]\n"
        "  Reconstructs the factorised BTF (at LOD lambda for laplacian files, default 0 = finest)\n"
        "  and prints RMSE, PSNR, mean SSIM (Wang 2004), CIELAB MAE and YCbCr MSE against the source.\n"
        "  R is the data range for PSNR/SSIM (default: the source's largest value).");
    return convert::kExitOk;
  }
  const double lambda = opt.number("lambda", 0.0, 0.0, 64.0);
  const double range = opt.number("range", 0.0, 0.0, 1e30);
  if (!opt.finish()) return convert::kExitUsage;
  if (opt.positional().size() != 2) {
    std::fprintf(stderr, "btflod-convert eval: expected FACTOR_FILE and SOURCE_BTF\n");
    return convert::kExitUsage;
  }
  auto f = load_factorization(opt.positional()[0]);
  if (!f) {
    std::fprintf(stderr, "btflod-convert eval: %s\n", f.message().c_str());
    return convert::kExitFailure;
  }
  auto src = samples::load_btf(opt.positional()[1]);
  if (!src) {
    std::fprintf(stderr, "btflod-convert eval: %s\n", src.message().c_str());
    return convert::kExitFailure;
  }
  const auto& shape = factorization_shape(*f);
  if (shape.width != src->width() || shape.height != src->height() || shape.view_count() != src->view_count() ||
      shape.light_count() != src->light_count()) {
    std::fprintf(stderr, "btflod-convert eval: factor file is %dx%d x %zu x %zu, source is %dx%d x %zu x %zu\n",
                 shape.width, shape.height, shape.view_count(), shape.light_count(), src->width(), src->height(),
                 src->view_count(), src->light_count());
    return convert::kExitFailure;
  }
  const auto* lp = std::get_if<LaplacianPca>(&*f);
  const BtfFloat rec = lp ? lp->reconstruct(static_cast<float>(lambda)) : reconstruct_factorization(*f);
  const auto report = compare_btfs(*src, rec, range > 0.0 ? range : btf_peak(*src));
  std::puts(kHeader);
  print_report_row(opt.positional()[1].c_str(), factorization_name(*f), factorization_size_bytes(*f),
                   factorization_compression_ratio(*f), report, 0.0);
  return convert::kExitOk;
}

struct Config {
  std::string label;
  std::function<Result<AnyFactorization>(const BtfFloat&)> run;
};

template <class R>
Result<AnyFactorization> wrap(R r) {
  if (!r) return r.error();
  return AnyFactorization(std::move(*r));
}

std::vector<Config> table_configs(size_t n_view) {
  std::vector<Config> c;
  for (int comps : {4, 16, 64})
    c.push_back({"fmf C=" + std::to_string(comps), [comps](const BtfFloat& b) {
                   FmfOptions o;
                   o.components = comps;
                   return wrap(factorize_fmf(b, o));
                 }});
  for (auto [k, comps] : {std::pair{1, 4}, std::pair{3, 8}, std::pair{0, 32}})
    c.push_back(
        {"pca-k k=" + (k == 0 ? std::to_string(n_view) + " (all)" : std::to_string(k)) + " C=" + std::to_string(comps),
         [k, comps](const BtfFloat& b) {
           PcaViewsOptions o;
           o.views_per_group = k;
           o.components = comps;
           return wrap(factorize_pca_views(b, o));
         }});
  for (auto [y, cc] : {std::pair{4, 1}, std::pair{8, 2}, std::pair{16, 4}})
    c.push_back({"laplacian " + std::to_string(y) + "/" + std::to_string(cc) + "/" + std::to_string(cc),
                 [y, cc](const BtfFloat& b) {
                   LaplacianPcaOptions o;
                   o.components = {y, cc, cc};
                   return wrap(factorize_laplacian_pca(b, o));
                 }});
  for (auto [k, comps] : {std::pair{8, 4}, std::pair{16, 8}, std::pair{32, 8}})
    c.push_back(
        {"lpca K=" + std::to_string(k) + " C=" + std::to_string(comps) + " 8-bit", [k, comps](const BtfFloat& b) {
           LocalPcaOptions o;
           o.clusters = k;
           o.components = comps;
           return wrap(factorize_local_pca(b, o));
         }});
  return c;
}

int run_factor_table(int argc, char** argv) {
  convert::Options opt(argc, argv);
  if (opt.wants_help()) {
    std::puts(
        "usage: btflod-convert factor-table [--size N] [--dirs ubo2003|small] [--materials LIST]\n"
        "                                   [--brdf FILE.mbsdf] [--rows SUBSTRING]\n"
        "  Synthesises materials (btf/synthesizer.hpp; 'carpaint' = leather mesostructure with the\n"
        "  measured car-paint BRDF as base reflectance), factorises each with every representation\n"
        "  at three sizes and prints a markdown table of error vs compression ratio (docs/factor.md).\n"
        "  --rows runs only the representations whose label contains SUBSTRING (e.g. 'lpca').\n"
        "  defaults: --size 32 --dirs ubo2003 --materials cloth,stone,carpaint\n"
        "            --brdf <shared>/data/measured/carpaint_red.mbsdf");
    return convert::kExitOk;
  }
  const int size = static_cast<int>(opt.integer("size", 32, 4, 1024));
  const std::string dirs = opt.string("dirs", "ubo2003");
  const std::string materials = opt.string("materials", "cloth,stone,carpaint");
  const std::string brdf_path = opt.string("brdf", default_shared_dir() + "/data/measured/carpaint_red.mbsdf");
  const std::string rows = opt.string("rows", "");
  if (!opt.finish()) return convert::kExitUsage;
  std::printf("Command: btflod-convert factor_table --size %d --dirs %s --materials %s%s%s\n\n", size, dirs.c_str(),
              materials.c_str(), rows.empty() ? "" : " --rows ", rows.c_str());
  std::puts(kHeader);
  size_t start = 0;
  while (start <= materials.size()) {
    const size_t comma = materials.find(',', start);
    const std::string name = materials.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    start = comma == std::string::npos ? materials.size() + 1 : comma + 1;
    SynthesisOptions so;
    if (dirs == "small") {
      so.views = small_direction_set(3, 6, "views");
      so.lights = small_direction_set(4, 8, "lights");
    }
    MeasuredBrdf brdf;
    SynthMaterial mat = SynthMaterial::cloth;
    if (name == "carpaint") {
      auto b = read_mbsdf(brdf_path);
      if (!b) {
        std::fprintf(stderr, "factor-table: %s\n", b.message().c_str());
        return convert::kExitFailure;
      }
      brdf = std::move(*b);
      so.measured_brdf = &brdf;
      mat = SynthMaterial::leather;
    } else if (auto m = material_from_name(name)) {
      mat = *m;
    } else {
      std::fprintf(stderr, "factor-table: unknown material %s\n", name.c_str());
      return convert::kExitUsage;
    }
    auto btf = synthesize_material(mat, size, size, 1, so);
    if (!btf) {
      std::fprintf(stderr, "factor-table: %s\n", btf.message().c_str());
      return convert::kExitFailure;
    }
    const double peak = btf_peak(*btf);
    for (const auto& cfg : table_configs(btf->view_count())) {
      if (!rows.empty() && cfg.label.find(rows) == std::string::npos) continue;
      const auto t0 = std::chrono::steady_clock::now();
      auto f = cfg.run(*btf);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (!f) {
        std::fprintf(stderr, "factor-table: %s %s: %s\n", name.c_str(), cfg.label.c_str(), f.message().c_str());
        continue;
      }
      const auto report = compare_btfs(*btf, reconstruct_factorization(*f), peak);
      print_report_row(name.c_str(), cfg.label.c_str(), factorization_size_bytes(*f),
                       factorization_compression_ratio(*f), report, seconds);
      std::fflush(stdout);
    }
  }
  return convert::kExitOk;
}

}  // namespace

BTFLOD_CONVERT_COMMAND(eval, "error table (RMSE, PSNR, SSIM, CIELAB MAE, YCbCr MSE) of a factor file vs its BTF",
                       run_eval);
BTFLOD_CONVERT_COMMAND(factor_table, "docs/factor.md comparison table: every representation on synthesised materials",
                       run_factor_table);
