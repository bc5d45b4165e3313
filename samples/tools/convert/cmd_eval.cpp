// btflod-convert eval — error table of a factor file against its source BTF; and
// btflod-convert factor-table — the comparison table of docs/factor.md (every representation
// at several sizes on synthesised materials and on the measured car-paint BRDF).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "btflod/offline/btf/btf_files.hpp"
#include "command.hpp"
#include "common/progress_bar.hpp"
#include "common/texel_direction_samples.hpp"
#include "store_commands.hpp"

#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/btf/measured_brdf.hpp"
#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/factor/any_factorization.hpp"
#include "btflod/offline/factor/fmf_store_metrics.hpp"
#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/metrics/btf_metrics.hpp"

// The shared data folder next to the repository (this file is samples/tools/convert/cmd_eval.cpp).
inline std::string default_shared_dir() {
  return (std::filesystem::path(__FILE__).parent_path() / ".." / ".." / ".." / "shared").lexically_normal().string();
}

namespace {

using namespace btflod;

void print_report_row(const char* name, const char* config, size_t bytes, double ratio, const BtfErrorReport& r,
                      double seconds) {
  std::printf("| %s | %s | %zu | %.1f | %.5f | %.2f | %.4f | %.3f | %.2f | %.4f | %.2e / %.2e / %.2e | %.2f |\n", name,
              config, bytes, ratio, r.rmse, r.psnr, r.mean_ssim, r.mae_cielab, r.delta_e_p99, r.relative_frobenius,
              r.mse_ycbcr[0], r.mse_ycbcr[1], r.mse_ycbcr[2], seconds);
}

const char* kHeader =
    "| material | representation | bytes | ratio | RMSE | PSNR dB | mean SSIM | CIELAB MAE | ΔE*ab p99 | "
    "rel. Frobenius | MSE Y / Cb / Cr | factorise s |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|";

struct StoreEvalArgs {
  double lambda = 0.0, range = 0.0;
  int pca = -1;
  bool no_residual = false;
  uint64_t memory = 0;
};

// eval against a BTF store: streamed within the budget (offline/factor/fmf_store_metrics.hpp).
int eval_against_store(const AnyFactorization& f, const std::string& path, const StoreEvalArgs& a) {
  auto store = BtfStore::open(path);
  if (!store) {
    std::fprintf(stderr, "btflod-convert eval: %s\n", store.message().c_str());
    return convert::kExitFailure;
  }
  const auto& shape = factorization_shape(f);
  const BtfStoreInfo& info = store->info();
  if (shape.width != info.width || shape.height != info.height || shape.view_count() != info.views.size() ||
      shape.light_count() != info.lights.size()) {
    std::fprintf(stderr, "btflod-convert eval: factor file is %dx%d x %zu x %zu, store is %dx%d x %zu x %zu\n",
                 shape.width, shape.height, shape.view_count(), shape.light_count(), info.width, info.height,
                 info.views.size(), info.lights.size());
    return convert::kExitFailure;
  }
  BtfStoreEvalOptions o;
  o.data_range = a.range;
  o.memory_budget = a.memory;
  const auto t0 = std::chrono::steady_clock::now();
  BtfStoreEvalStats st;
  Result<BtfErrorReport> report = make_error(Status::unsupported, "not evaluated");
  if (const auto* fmf = std::get_if<Fmf>(&f)) {
    report = compare_btf_store(
        *store, [fmf](size_t v, size_t l, std::span<float> out) { return fmf_reconstruct_image(*fmf, v, l, out); }, o,
        &st);
  } else {
    // Other kinds reconstruct the whole BTF: it must fit in the budget next to the streamed images.
    const uint64_t whole = shape.float_bytes();
    if (whole + btf_store_eval_min_budget(info) > a.memory) {
      std::fprintf(stderr,
                   "btflod-convert eval: a %s file is reconstructed whole (%.1f MiB), more than the --memory budget "
                   "%.1f MiB allows next to the streamed images; only fmf files are evaluated image by image\n",
                   factorization_name(f), static_cast<double>(whole) / 1048576.0,
                   static_cast<double>(a.memory) / 1048576.0);
      return convert::kExitFailure;
    }
    const auto* lp = std::get_if<LaplacianPca>(&f);
    const auto* sp = std::get_if<Spmm>(&f);
    const BtfFloat rec = lp   ? lp->reconstruct(static_cast<float>(a.lambda))
                         : sp ? sp->reconstruct({.residual = !a.no_residual, .pca_components = a.pca})
                              : reconstruct_factorization(f);
    o.memory_budget = a.memory - whole;
    report = compare_btf_store(
        *store,
        [&rec](size_t v, size_t l, std::span<float> out) -> VoidResult {
          const auto img = rec.image(v, l);
          for (int y = 0; y < img.height(); ++y)
            for (int x = 0; x < img.width(); ++x)
              for (int c = 0; c < 3; ++c)
                out[(static_cast<size_t>(y) * static_cast<size_t>(img.width()) + static_cast<size_t>(x)) * 3 +
                    static_cast<size_t>(c)] = img.at(x, y, c);
          return {};
        },
        o, &st);
  }
  if (!report) {
    std::fprintf(stderr, "btflod-convert eval: %s\n", report.message().c_str());
    return convert::kExitFailure;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::puts(kHeader);
  print_report_row(path.c_str(), factorization_name(f), factorization_size_bytes(f), factorization_compression_ratio(f),
                   *report, 0.0);
  std::printf(
      "\nstreamed from the store: %zu light groups of %zu images per view, %.1f MiB read, buffers %.1f MiB "
      "of the %.1f MiB budget, peak RSS %.1f MiB, %.1f s\n",
      st.groups, st.lights_per_group, static_cast<double>(st.bytes_read) / 1048576.0,
      static_cast<double>(st.buffer_bytes) / 1048576.0, static_cast<double>(a.memory) / 1048576.0,
      static_cast<double>(convert::peak_rss_bytes()) / 1048576.0, seconds);
  return convert::kExitOk;
}

int run_eval(convert::Options& opt) {
  const double lambda = opt.number("lambda", 0.0, 0.0, 64.0);
  const double range = opt.number("range", 0.0, 0.0, 1e30);
  const int pca = static_cast<int>(opt.integer("pca", -1, -1, 1 << 20));
  const bool no_residual = opt.flag("no-residual");
  const std::string memory_text = opt.string("memory", "1G");
  const auto memory = convert::parse_byte_size(memory_text);
  if (!memory) opt.error("--memory " + memory_text + ": expected a size such as 512M or 4G");
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
  if (convert::is_store_path(opt.positional()[1]))
    return eval_against_store(*f, opt.positional()[1], {lambda, range, pca, no_residual, *memory});
  auto src = load_btf(opt.positional()[1]);
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
  const auto* sp = std::get_if<Spmm>(&*f);
  const BtfFloat rec = lp   ? lp->reconstruct(static_cast<float>(lambda))
                       : sp ? sp->reconstruct({.residual = !no_residual, .pca_components = pca})
                            : reconstruct_factorization(*f);
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
  // SPMM (paper 003): #BF cap B, residual N_PCA; K = 8 clusters, 4 representatives, 2 lobes.
  for (auto [bf, npca] : {std::pair{2, 0}, std::pair{4, 0}, std::pair{4, 4}, std::pair{4, 8}})
    c.push_back(
        {"spmm K=8 #BF<=" + std::to_string(bf) + " N_PCA=" + std::to_string(npca), [bf, npca](const BtfFloat& b) {
           SpmmOptions o;
           o.clusters = 8;
           o.max_basis_per_texel = bf;
           o.residual_components = npca;
           return wrap(factorize_spmm(b, o));
         }});
  return c;
}

int run_factor_table(convert::Options& opt) {
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

// Paper 003 Table 4: one SPMM fit, then "no residual" and N_PCA = 0 … max, each against the
// full-residual evaluation: time per sample of evaluate() (analytic part at the exact
// directions plus the residual through the exact-grid interpolators), RMSE and mean SSIM.
int run_spmm_table(convert::Options& opt) {
  const int size = static_cast<int>(opt.integer("size", 32, 4, 1024));
  const std::string material = opt.string("material", "cloth");
  const int clusters = static_cast<int>(opt.integer("clusters", 8, 1, 65535));
  const int bf = static_cast<int>(opt.integer("bf", 4, 1, 64));
  const int npca = static_cast<int>(opt.integer("pca", 4, 0, 256));
  const int samples = static_cast<int>(opt.integer("samples", 200000, 1000, 100000000));
  if (!opt.finish()) return convert::kExitUsage;
  auto mat = material_from_name(material);
  if (!mat) {
    std::fprintf(stderr, "spmm_table: unknown material %s\n", material.c_str());
    return convert::kExitUsage;
  }
  auto btf = synthesize_material(*mat, size, size, 1, SynthesisOptions{});
  if (!btf) {
    std::fprintf(stderr, "spmm_table: %s\n", btf.message().c_str());
    return convert::kExitFailure;
  }
  SpmmOptions o;
  o.clusters = clusters;
  o.max_basis_per_texel = bf;
  o.residual_components = npca;
  const auto t0 = std::chrono::steady_clock::now();
  auto p = factorize_spmm(*btf, o);
  const double fit_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!p) {
    std::fprintf(stderr, "spmm_table: %s\n", p.message().c_str());
    return convert::kExitFailure;
  }
  auto li = ExactGridInterpolator<ParabolicMap>::build(p->shape.lights);
  auto vi = ExactGridInterpolator<ParabolicMap>::build(p->shape.views);
  if (!li || !vi) {
    std::fprintf(stderr, "spmm_table: interpolator: %s\n", (li ? vi.message() : li.message()).c_str());
    return convert::kExitFailure;
  }
  // Random texels and upper-hemisphere directions (fixed seed), shared by every row.
  const auto pts =
      btflod::samples::random_texel_direction_samples(size, static_cast<size_t>(samples), 0x9e3779b97f4a7c15ull);
  const BtfFloat full = p->reconstruct();
  const double peak = btf_peak(full);
  std::printf(
      "Command: btflod-convert spmm_table --size %d --material %s --clusters %d --bf %d --pca %d --samples %d\n", size,
      material.c_str(), clusters, bf, npca, samples);
  std::printf("fit %.2f s, #BF %.2f per texel, %.1f:1; RMSE of the full evaluation vs the source %.5f\n\n", fit_s,
              p->mean_basis_per_texel(), p->compression_ratio(), compare_btfs(*btf, full, btf_peak(*btf)).rmse);
  std::puts("| N_PCA | eval ns/sample | MSSIM vs full | RMSE vs full |\n|---|---:|---:|---:|");
  for (int row = -1; row <= npca; ++row) {
    const SpmmEvalOptions eo{.residual = row >= 0, .pca_components = row < 0 ? 0 : row};
    float sink = 0.0f;
    const auto e0 = std::chrono::steady_clock::now();
    for (size_t i = 0; i < pts.x.size(); ++i)
      sink += p->evaluate(pts.x[i], pts.y[i], pts.l[i], pts.v[i], *li, *vi, eo).g;
    const double ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - e0).count() /
                      static_cast<double>(pts.x.size());
    const auto rep = compare_btfs(full, p->reconstruct(eo), peak);
    std::printf("| %s | %.1f | %.4f | %.5f |%s\n", row < 0 ? "no-RES" : std::to_string(row).c_str(), ns, rep.mean_ssim,
                rep.rmse, sink == -1.0f ? " " : "");
  }
  return convert::kExitOk;
}

constexpr char kEvalUsage[] =
    "usage: btflod-convert eval FACTOR_FILE SOURCE_BTF [--lambda L] [--range R] [--pca N] [--no-residual]\n"
    "                           [--memory SIZE]\n"
    "  Reconstructs the factorised BTF (at LOD lambda for laplacian files, default 0 = finest)\n"
    "  and prints RMSE, PSNR, mean SSIM (Wang 2004), CIELAB MAE and YCbCr MSE against the source.\n"
    "  R is the data range for PSNR/SSIM (default: the source's largest value).\n"
    "  spmm files: --pca N evaluates N residual components (default all), --no-residual only the\n"
    "  analytic part (paper 003 Table 4).\n"
    "  A SOURCE_BTF ending in .btfstore (btflod-convert synth --out X.btfstore) is streamed from disk\n"
    "  view by view, never loaded whole: the images held at once stay within --memory (default 1G;\n"
    "  offline/factor/fmf_store_metrics.hpp), and the figures equal those of the in-memory evaluation.\n"
    "  fmf files are reconstructed image by image; other kinds are reconstructed whole, which must\n"
    "  fit in the budget too.";

constexpr char kFactorTableUsage[] =
    "usage: btflod-convert factor-table [--size N] [--dirs ubo2003|small] [--materials LIST]\n"
    "                                   [--brdf FILE.mbsdf] [--rows SUBSTRING]\n"
    "  Synthesises materials (offline/btf/synthesizer.hpp; 'carpaint' = leather mesostructure with the\n"
    "  measured car-paint BRDF as base reflectance), factorises each with every representation\n"
    "  at three sizes and prints a markdown table of error vs compression ratio (docs/factor.md).\n"
    "  --rows runs only the representations whose label contains SUBSTRING (e.g. 'lpca').\n"
    "  defaults: --size 32 --dirs ubo2003 --materials cloth,stone,carpaint\n"
    "            --brdf <shared>/data/measured/carpaint_red.mbsdf";

constexpr char kSpmmTableUsage[] =
    "usage: btflod-convert spmm_table [--size N] [--material NAME] [--clusters K] [--bf B] [--pca N]\n"
    "                                 [--samples S]\n"
    "  Fits one SPMM (paper 003) to a synthesised material (default cloth, 32x32, UBO2003 directions)\n"
    "  and prints the analogue of paper 003 Table 4: eval ns per sample, RMSE and mean SSIM of the\n"
    "  no-residual and N_PCA = 0..N evaluations against the full residual (N = --pca, default 4).";

}  // namespace

BTFLOD_CONVERT_COMMAND(spmm_table, "paper 003 Table 4 analogue: SPMM residual N_PCA vs eval time, MSSIM, RMSE",
                       kSpmmTableUsage, run_spmm_table);
BTFLOD_CONVERT_COMMAND(eval, "error table (RMSE, PSNR, SSIM, CIELAB MAE, YCbCr MSE) of a factor file vs its BTF",
                       kEvalUsage, run_eval);
BTFLOD_CONVERT_COMMAND(factor_table, "docs/factor.md comparison table: every representation on synthesised materials",
                       kFactorTableUsage, run_factor_table);
