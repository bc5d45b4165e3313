// btflod-convert synth — write a procedurally synthesised BTF material (offline/btf/synthesizer.hpp).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include "btflod/offline/btf/btf_files.hpp"
#include "command.hpp"
#include "common/progress_bar.hpp"
#include "store_commands.hpp"

#include "btflod/offline/btf/merl_brdf.hpp"
#include "btflod/offline/btf/synthesizer.hpp"

namespace {

using namespace btflod;

int run_synth(convert::Options& opt) {
  const std::string material_text = opt.string("material", "cloth");
  const bool paper = convert::paper_profile(opt);
  const int size = static_cast<int>(opt.integer("size", paper ? 512 : 64, 1, 4096));
  const std::string dirs = opt.string("dirs", paper ? "ubo2014" : "ubo2003");
  const std::string store_type = opt.string("store-type", "half");
  if (store_type != "half" && store_type != "float")
    opt.error("--store-type " + store_type + ": expected half or float");
  const auto block_texels = static_cast<uint32_t>(opt.integer("block-texels", 256, 1, 1 << 20));
  const unsigned long long seed = opt.unsigned_integer("seed", 1);
  const auto brdf_path = opt.value("brdf");
  const bool interreflection = opt.flag("interreflection");
  const double depth = opt.number("depth", 1.0, 0.0, 100.0);
  const int components = static_cast<int>(opt.integer("components", 16, 1, 4096));
  const bool quiet = opt.flag("quiet", 'q');
  const auto out = opt.value("output", 'o');
  const auto material = material_from_name(material_text);
  if (!material) opt.error("--material " + material_text + ": expected cloth, stone, leather or tiles");
  if (dirs != "ubo2003" && dirs != "ubo2014") opt.error("--dirs " + dirs + ": expected ubo2003 or ubo2014");
  if (!out) opt.error("no output given (-o OUT)");
  if (!opt.finish()) return convert::kExitUsage;
  if (!opt.positional().empty()) {
    std::fprintf(stderr, "btflod-convert synth: unexpected argument %s\n", opt.positional().front().c_str());
    return convert::kExitUsage;
  }

  SynthesisOptions so;
  so.views = dirs == "ubo2014" ? DirectionSet::ubo2014() : DirectionSet::ubo2003();
  so.lights = so.views;
  so.interreflection = interreflection;
  MeasuredBrdf brdf;
  if (brdf_path) {
    const bool merl = std::filesystem::path(*brdf_path).extension() == ".binary";
    if (merl) {
      auto b = read_merl_binary(*brdf_path);
      if (!b) {
        std::fprintf(stderr, "btflod-convert synth: %s\n", b.message().c_str());
        return convert::kExitFailure;
      }
      if (!quiet && b->report.not_measured)
        std::fprintf(stderr,
                     "synth: %s: %zu of %zu samples not measured (interpolated from measured neighbours; "
                     "%zu resampled cells without any set to 0)\n",
                     brdf_path->c_str(), b->report.not_measured, 3 * b->report.plane_samples, b->report.unfilled_cells);
      brdf = std::move(b->brdf);
    } else {
      auto b = read_mbsdf(*brdf_path);
      if (!b) {
        std::fprintf(stderr, "btflod-convert synth: %s\n", b.message().c_str());
        return convert::kExitFailure;
      }
      brdf = std::move(*b);
    }
    so.measured_brdf = &brdf;
  }
  auto meso = make_mesostructure(*material, size, size, seed, static_cast<float>(depth));
  if (!meso) {
    std::fprintf(stderr, "btflod-convert synth: %s\n", meso.message().c_str());
    return convert::kExitFailure;
  }
  if (convert::is_store_path(*out))
    return convert::synthesize_to_store(*meso, so, *out,
                                        store_type == "float" ? BtfStoreValueType::float32 : BtfStoreValueType::float16,
                                        block_texels, quiet);
  samples::ProgressBar bar("synth", stderr, !quiet);
  so.progress = bar.callback();
  const auto t0 = std::chrono::steady_clock::now();
  auto btf = synthesize_btf(*meso, so);
  bar.finish();
  if (!btf) {
    std::fprintf(stderr, "btflod-convert synth: %s\n", btf.message().c_str());
    return convert::kExitFailure;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!quiet)
    std::fprintf(stderr, "synth: %s %dx%d, %zu views x %zu lights in %.2f s (%u threads)\n", material_text.c_str(),
                 size, size, btf->view_count(), btf->light_count(), seconds, default_thread_pool().thread_count());
  samples::ProgressBar write_bar("write", stderr, !quiet);
  BtfSaveOptions save;
  save.components = components;
  save.progress = write_bar.callback();
  auto saved = save_btf(*btf, *out, save);
  write_bar.finish();
  if (!saved) {
    std::fprintf(stderr, "btflod-convert synth: %s\n", saved.message().c_str());
    return convert::kExitFailure;
  }
  if (!quiet) std::fprintf(stderr, "synth: wrote %s\n", out->c_str());
  return convert::kExitOk;
}

constexpr char kSynthUsage[] =
    "usage: btflod-convert synth -o OUT [--material cloth|stone|leather|tiles] [--size N]\n"
    "                            [--dirs ubo2003|ubo2014] [--seed N] [--brdf FILE.mbsdf|FILE.binary]\n"
    "                            [--interreflection] [--depth X] [--components K] [--quiet]\n"
    "                            [--profile paper] [--store-type half|float] [--block-texels B]\n"
    "  Synthesises a tileable BTF: a height-field mesostructure rendered for every (view, light)\n"
    "  pair with ray-marched masking and self-shadowing, Lambert+GGX base reflectance (or the\n"
    "  measured BRDF given with --brdf: NVIDIA MBSDF, or MERL .binary resampled to 90 x 90 x 180).\n"
    "  Values are rho*cos(theta_light), linear RGB; a .btf output says so in its cosine flag.\n"
    "  OUT ending in .btf is written as a Bonn DFMF file (K components per channel, default 16);\n"
    "  any other OUT as a UBO2003-style PNG image folder.\n"
    "  OUT ending in .btfstore is a BTF store for out-of-core factorisation (offline/btf/btf_store.hpp),\n"
    "  written view by view (the BTF is never held whole): halves by default, B texels per block\n"
    "  (default 256). --profile paper: paper 000's configuration, 151 x 151 directions (ubo2014)\n"
    "  and 512 x 512 texels unless --dirs/--size say otherwise.\n"
    "  defaults: --material cloth --size 64 --dirs ubo2003 --seed 1 --depth 1";

}  // namespace

BTFLOD_CONVERT_COMMAND(synth, "write a synthesised material (cloth, stone, leather, tiles)", kSynthUsage, run_synth);
