// btflod-convert factor — factorise a BTF into one of the representations of factor/ and
// write it in the factor file format (offline/factor/factor_file.hpp).
#include <chrono>
#include <cstdio>
#include <string>

#include "btflod/offline/btf/btf_files.hpp"
#include "command.hpp"
#include "common/progress_bar.hpp"
#include "store_commands.hpp"

#include "btflod/offline/factor/any_factorization.hpp"
#include "btflod/offline/factor/fmf_rank.hpp"

namespace {

using namespace btflod;

int run_factor(convert::Options& opt) {
  const std::string method = opt.string("method", "fmf");
  const bool paper = convert::paper_profile(opt);
  const std::string memory_text = opt.string("memory", "4G");
  const auto memory = convert::parse_byte_size(memory_text);
  if (!memory) opt.error("--memory " + memory_text + ": expected a size such as 4G, 512M or 1500000000");
  const std::string checkpoint = opt.string("checkpoint", "");
  const int stop_after = static_cast<int>(opt.integer("stop-after-passes", 0, 0, 100));
  const auto block_columns = static_cast<size_t>(opt.integer("block-columns", 256, 1, 1 << 20));
  const auto components_text = opt.value("components");
  const std::string encoding_text = opt.string("value-encoding", "linear");
  const auto target_text = opt.value("target-ssim");
  const auto exposure_text = opt.value("exposure");
  double target_ssim = 0.0, exposure = 1.0;
  if (target_text) {
    char* end = nullptr;
    target_ssim = std::strtod(target_text->c_str(), &end);
    if (end == target_text->c_str() || *end != '\0' || !(target_ssim > 0.0 && target_ssim <= 1.0))
      opt.error("--target-ssim " + *target_text + ": expected a number in (0, 1]");
  }
  if (exposure_text) {
    char* end = nullptr;
    exposure = std::strtod(exposure_text->c_str(), &end);
    if (end == exposure_text->c_str() || *end != '\0' || !(exposure > 0.0 && exposure < 1e6))
      opt.error("--exposure " + *exposure_text + ": expected a positive number");
  }
  ValueTransform transform;
  if (!parse_value_encoding(encoding_text, transform.encoding))
    opt.error("--value-encoding " + encoding_text + ": expected linear, sqrt, log or log_ycbcr");
  const int k = static_cast<int>(opt.integer("k", 3, 0, 1 << 16));
  const int clusters = static_cast<int>(opt.integer("clusters", method == "spmm" ? 4 : 8, 1, 65535));
  const int iterations = static_cast<int>(opt.integer("iterations", 20, 0, 1000));
  const int mips = static_cast<int>(opt.integer("mips", 0, 0, 16));
  const int cbcr = static_cast<int>(opt.integer("components-cbcr", 2, 0, 4096));
  const std::string svd = opt.string("svd", "auto");
  const SvdOptions svd_defaults{};
  const int power = static_cast<int>(opt.integer("power-iterations", svd_defaults.power_iterations, 0, 20));
  const int max_power = static_cast<int>(opt.integer("max-power-iterations", svd_defaults.max_power_iterations, 0, 20));
  const auto tolerance_text = opt.value("power-tolerance");
  const int oversampling = static_cast<int>(opt.integer("oversampling", svd_defaults.oversampling, 0, 1000));
  const int sketch_nonzeros = static_cast<int>(opt.integer("sketch-nonzeros", svd_defaults.sketch_nonzeros, 0, 1000));
  const bool use_float = opt.flag("float");
  const int basis_per_texel = static_cast<int>(opt.integer("basis-per-texel", 4, 1, 64));
  const int representatives = static_cast<int>(opt.integer("representatives", 4, 1, 1024));
  const int lobes = static_cast<int>(opt.integer("lobes", 2, 0, 64));
  const bool quiet = opt.flag("quiet", 'q');
  if (method != "fmf" && method != "pca-k" && method != "laplacian" && method != "lpca" && method != "spmm")
    opt.error("--method " + method + ": expected fmf, pca-k, laplacian, lpca or spmm");
  if (!transform.is_linear() && method != "fmf")
    opt.error("--value-encoding " + encoding_text + ": only the fmf method has value encodings");
  if (target_text && method != "fmf") opt.error("--target-ssim: only the fmf method chooses its rank");
  if (svd != "auto" && svd != "exact" && svd != "randomized")
    opt.error("--svd " + svd + ": expected auto, exact or randomized");
  int components = method == "fmf" ? (paper ? 100 : 16) : (method == "lpca" || method == "spmm") ? 4 : 8;
  if (components_text) {
    char* end = nullptr;
    const long c = std::strtol(components_text->c_str(), &end, 10);
    if (end == components_text->c_str() || *end != '\0' || c < 1 || c > 100000)
      opt.error("--components " + *components_text + ": expected an integer in [1, 100000]");
    else
      components = static_cast<int>(c);
  }
  double tolerance = svd_defaults.power_tolerance;
  if (tolerance_text) {
    char* end = nullptr;
    tolerance = std::strtod(tolerance_text->c_str(), &end);
    if (end == tolerance_text->c_str() || *end != '\0' || !(tolerance >= 0.0 && tolerance <= 1.0))
      opt.error("--power-tolerance " + *tolerance_text + ": expected a number in [0, 1]");
  }
  if (!opt.finish()) return convert::kExitUsage;
  if (opt.positional().size() != 2) {
    std::fprintf(stderr, "btflod-convert factor: expected IN and OUT (got %zu arguments)\n", opt.positional().size());
    return convert::kExitUsage;
  }
  const std::string in = opt.positional()[0], out = opt.positional()[1];
  if (convert::is_store_path(in)) {
    if (method != "fmf") {
      std::fprintf(stderr, "btflod-convert factor: a .btfstore is factorised with --method fmf only\n");
      return convert::kExitUsage;
    }
    convert::StoreFactorArgs a;
    a.in = in;
    a.out = out;
    a.components = components;
    a.transform = transform;
    a.svd.power_iterations = power;
    a.svd.max_power_iterations = max_power;
    a.svd.power_tolerance = tolerance;
    a.svd.oversampling = oversampling;
    a.svd.sketch_nonzeros = sketch_nonzeros;
    a.svd.block_columns = block_columns;
    a.memory_budget = *memory;
    a.checkpoint = checkpoint;
    a.stop_after_passes = stop_after;
    a.quiet = quiet;
    return convert::run_factor_store(a);
  }

  auto btf = load_btf(in);
  if (!btf) {
    std::fprintf(stderr, "btflod-convert factor: %s\n", btf.message().c_str());
    return convert::kExitFailure;
  }
  SvdOptions so;
  so.method = svd == "exact" ? SvdMethod::exact : svd == "randomized" ? SvdMethod::randomized : SvdMethod::automatic;
  so.power_iterations = power;
  so.max_power_iterations = max_power;
  so.power_tolerance = tolerance;
  so.oversampling = oversampling;
  so.sketch_nonzeros = sketch_nonzeros;
  samples::ProgressBar bar("factor", stderr, !quiet);
  const auto t0 = std::chrono::steady_clock::now();
  Result<AnyFactorization> result = make_error(Status::invalid_argument, "no method");
  auto wrap = [](auto r) -> Result<AnyFactorization> {
    if (!r) return r.error();
    return AnyFactorization(std::move(*r));
  };
  if (method == "fmf" && target_text) {
    FmfRankOptions o;
    o.fmf.svd = so;
    o.fmf.transform = transform;
    o.min_ssim = target_ssim;
    o.exposure = static_cast<float>(exposure);
    o.candidates.clear();
    for (int c : {4, 8, 12, 16, 24, 32, 48, 64, 100})
      if (c < components) o.candidates.push_back(c);
    o.candidates.push_back(components);
    auto choice = choose_fmf_rank(*btf, o, bar.callback());
    if (choice) {
      for (const FmfRankPoint& p : choice->curve)
        std::printf("  rank %3d: displayed SSIM %.4f on the training views, %.4f on the held-out views\n", p.components,
                    p.training_ssim, p.held_out_ssim);
      std::printf("  chose C = %d (%s target %.4f)\n", choice->components,
                  choice->target_met ? "meets the" : "the largest candidate: below the", target_ssim);
      result = AnyFactorization(std::move(choice->fmf));
    } else {
      result = choice.error();
    }
  } else if (method == "fmf") {
    FmfOptions o;
    o.components = components;
    o.svd = so;
    o.transform = transform;
    result = wrap(factorize_fmf(*btf, o, bar.callback()));
  } else if (method == "pca-k") {
    PcaViewsOptions o;
    o.views_per_group = k;
    o.components = components;
    o.svd = so;
    result = wrap(factorize_pca_views(*btf, o, bar.callback()));
  } else if (method == "laplacian") {
    LaplacianPcaOptions o;
    o.mip_count = mips;
    o.components = {components, cbcr, cbcr};
    o.svd = so;
    result = wrap(factorize_laplacian_pca(*btf, o, bar.callback()));
  } else if (method == "spmm") {
    SpmmOptions o;
    o.clusters = clusters;
    o.max_basis_per_texel = basis_per_texel;
    o.representatives = representatives;
    o.lobes_per_representative = lobes;
    o.residual_components = components;
    o.svd = so;
    result = wrap(factorize_spmm(*btf, o, bar.callback()));
  } else {
    LocalPcaOptions o;
    o.clusters = clusters;
    o.components = components;
    o.max_iterations = iterations;
    o.quantize_8bit = !use_float;
    o.svd = so;
    result = wrap(factorize_local_pca(*btf, o, bar.callback()));
  }
  bar.finish();
  if (!result) {
    std::fprintf(stderr, "btflod-convert factor: %s\n", result.message().c_str());
    return convert::kExitFailure;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (auto s = save_factorization(*result, out); !s) {
    std::fprintf(stderr, "btflod-convert factor: %s\n", s.message().c_str());
    return convert::kExitFailure;
  }
  std::printf("%s: %dx%d, %zu views x %zu lights -> %s %s: %zu bytes, ratio %.1f:1 (vs float32), %.2f s\n", in.c_str(),
              btf->width(), btf->height(), btf->view_count(), btf->light_count(), factorization_name(*result),
              out.c_str(), factorization_size_bytes(*result), factorization_compression_ratio(*result), seconds);
  if (const auto* f = std::get_if<Fmf>(&*result)) {
    const SvdReport& r = f->svd_report;
    if (r.exact)
      std::printf("  SVD: exact (BDCSVD), error %.6g (Eckart-Young optimum), |A| %.6g\n", r.error_estimate,
                  r.frobenius_norm);
    else
      std::printf(
          "  SVD: randomised, %d power iterations, error estimate %.6g, predicted %.5fx the optimum, |A| %.6g\n",
          r.power_iterations, r.error_estimate, r.predicted_ratio, r.frobenius_norm);
  }
  if (const auto* sp = std::get_if<Spmm>(&*result)) {
    size_t bases = 0;
    for (const auto& d : sp->dictionaries) bases += d.size();
    std::printf("  SPMM: %d clusters, %zu basis functions, #BF %.2f per texel (cap %d), N_PCA %d\n", sp->clusters(),
                bases, sp->mean_basis_per_texel(), sp->slots, sp->residual_components);
  }
  if (const auto* lp = std::get_if<LaplacianPca>(&*result))
    std::printf("  paper 001 3.3 packing: eigen Laplacian BRDF map %zu bytes, PCA weight map %zu bytes\n",
                lp->packed_eigen_map_bytes(), lp->packed_weight_map_bytes());
  return convert::kExitOk;
}

constexpr char kFactorUsage[] =
    "usage: btflod-convert factor IN OUT --method fmf|pca-k|laplacian|lpca|spmm [--components C]\n"
    "                             [--k K] [--clusters K] [--iterations N] [--mips N]\n"
    "                             [--components-cbcr C] [--svd auto|exact|randomized]\n"
    "                             [--power-iterations Q] [--max-power-iterations QMAX]\n"
    "                             [--power-tolerance T] [--oversampling P] [--sketch-nonzeros Z]\n"
    "                             [--float] [--basis-per-texel B] [--representatives R]\n"
    "                             [--lobes L] [--value-encoding linear|sqrt|log|log_ycbcr]\n"
    "                             [--target-ssim S [--exposure E]] [--quiet]\n"
    "                             [--profile paper] [--memory SIZE] [--checkpoint FILE]\n"
    "                             [--block-columns N] [--stop-after-passes K]\n"
    "  fmf        paper 000 SVD, rank C (default 16), plus the ambient basis\n"
    "  pca-k      paper 004 PCA over K neighbouring views (default K 3, C 8; K 0 = all views)\n"
    "  laplacian  paper 001 Laplacian-pyramid PCA, C for Y (default 8), --components-cbcr for\n"
    "             Cb/Cr (default 2), --mips pyramid bands (default automatic)\n"
    "  lpca       paper 002 local PCA, --clusters K (default 8), C per cluster (default 4),\n"
    "             8-bit eigen-BRDFs unless --float\n"
    "  spmm       paper 003 sparse parametric mixture: --clusters K (default 4), at most B analytic\n"
    "             basis functions per texel (default 4), R representatives per cluster (default 4),\n"
    "             L lobes fitted per representative (default 2), C residual PCA components (default 4)\n"
    "  randomised SVD: at least Q power iterations (default 2), more while the estimated error\n"
    "             is still improving (up to QMAX, default 6; QMAX <= Q: exactly Q), stopping when the\n"
    "             predicted excess over the optimum of the squared error is <= T (default 0.005), P oversampling\n"
    "             (default 50), Z nonzeros per row of the sparse sketch (default 8, 0 = Gaussian)\n"
    "  IN is any BTF btflod reads (Bonn .btf, image folder, .mbsdf); OUT is a factor file.\n"
    "  IN ending in .btfstore (btflod-convert synth -o X.btfstore) is factorised out of core (fmf only):\n"
    "             read in column blocks with peak memory under --memory (default 4G; e.g. 512M, 1.5G),\n"
    "             a progress line per pass, a checkpoint after every pass (default OUT.checkpoint) that\n"
    "             the same command resumes; --stop-after-passes K stops after K passes (e.g. to fit a\n"
    "             scheduler's time limit). --profile paper: paper 000's rank, C = 100.\n"
    "  --value-encoding  fmf: factorise the values (linear, the default), their square root or\n"
    "             ln(x + 0.05), a dynamic-range reduction for glossy materials, or log_ycbcr:\n"
    "             ln(Y + 0.05) with chroma over Y + 0.05 (decorrelated colour); stored in the\n"
    "             file and decoded by every renderer (core/value_transform.hpp).\n"
    "  --target-ssim  fmf: choose the smallest rank among 4, 8, 12, 16, 24, 32, 48, 64, 100 up to\n"
    "             --components whose displayed images (x exposure --exposure, default 1, clamped,\n"
    "             sRGB) of the even views reach this mean SSIM against the BTF; the odd views are\n"
    "             held out and reported (offline/factor/fmf_rank.hpp, docs/fidelity.md).";

}  // namespace

BTFLOD_CONVERT_COMMAND(factor, "factorise a BTF (fmf, pca-k, laplacian, lpca, spmm) into a factor file", kFactorUsage,
                       run_factor);
