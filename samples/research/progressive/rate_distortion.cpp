// btflod-rate-distortion — what a material costs against what a viewer sees, end to end: total
// bits per BTF sample of the streamed representation (U′ packets, V′ tiles after the tile codec,
// headers, weights and directory: the whole .bsvtf) against the screen error of its rendering
// measured against the RAW tabulated BTF, per material, over the FMF rank C, the value encoding
// (core/value_transform.hpp) and the codec quality.
//
// Every image is the demo's last view ray-cast on the CPU through the same rays (samples/demo/
// raw_reference.hpp: `rays`² rays per pixel, box filter, finest level, the shaders' 3 × 3
// angular taps): the raw image from each material's store, read once; the factorised images by
// RawReferenceBuilder::replace_fmf, from
//   FMF      the rank-C factorisation as computed (V′ uncompressed; its size as halves of U and
//            V′ over the virtual texture, paper 000 Table 1's "FMF" column), and
//   q<Q>     V′ decoded from the .bsvtf built at quality Q, coarse to fine against the decoded
//            parent (closed loop, paper 000 §6), finest level — what a client holds once every
//            tile arrived.
// The rank-C factorisations are truncations of one rank-C_max factorisation per encoding
// (offline/factor/fmf_rank.hpp truncate_fmf: the SVD's leading components, paper 000 eq. 4).
//
// A BTF sample is one RGB value ρ(x, l, v) of the virtual texture (M × N texels × lights × views;
// raw halves: 48 bits). Screen figures per material over the pixels whose centre ray hits it:
// SSIM of the sRGB images and ΔE*ab (CIE76, D65) p99 and mean of what the PNGs show
// (raw_reference.hpp image_error). Visually faithful: ΔE*ab p99 ≤ 2.3 (one JND after Sharma 2003).
//
// Output: DIR/rate_distortion.csv (one row per material, encoding, C and quality), a gnuplot
// data file and script, and with --svg PATH the plot rendered by gnuplot (ΔE*ab p99 and SSIM
// against bits per sample, one panel per material, one line per encoding and C through the
// qualities); --doc FILE rewrites the doc block "rate-distortion-<profile>" with the tables.
//
// Usage: btflod-rate-distortion --out DIR [--profile default|paper] [--materials N] [--size N]
//            [--components 4,8,16,32] [--qualities 25,50,75,90] [--encodings linear,log]
//            [--width W] [--height H] [--rays R] [--svg PATH] [--doc FILE] [--check]
//   --profile paper  paper 000's configuration (151 × 151 directions, T = 64, C up to 100,
//                    out-of-core factorisation; default 2 materials of 64² texels repeated to a
//                    512² virtual texture, C = 8,16,32,64,100, 3 × 3 rays)
//   --check          exit 1 unless, for every material, encoding and C, the bits grow with the
//                    quality, the highest quality's decoded V′ is within 30 dB PSNR of the FMF's
//                    (the decoded tiles land where the FMF's texels are, in the right channels)
//                    and its SSIM against raw within 0.02 of the uncompressed FMF's
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "btflod/offline/factor/fmf_rank.hpp"
#include "common/arguments.hpp"
#include "common/doc_block.hpp"
#include "raw_reference.hpp"
#include "scene_render.hpp"

using namespace btflod;

namespace {

struct Options {
  std::string out, svg, doc;
  bool paper = false, check = false;
  uint32_t materials = 4, size = 32, width = 480, height = 270, rays = 4;
  std::vector<uint32_t> components{4, 8, 16, 32};
  std::vector<float> qualities{25, 50, 75, 90};
  std::vector<ValueEncoding> encodings{ValueEncoding::linear, ValueEncoding::log};
};

bool parse(int argc, char** argv, Options& o) {
  samples::Arguments args("btflod-rate-distortion", argc, argv);
  o.out = args.string("out", o.out);
  o.svg = args.string("svg", o.svg);
  o.doc = args.string("doc", o.doc);
  o.check = args.flag("check");
  if (const auto p = args.choice("profile", {"default", "paper"})) o.paper = *p == 1;
  const auto materials = args.optional_integer("materials", 1, 4);
  const auto size = args.optional_integer("size", 8, 256);
  const auto rays = args.optional_integer("rays", 1, 8);
  o.width = args.integer_as("width", o.width, 16, 1920);
  o.height = args.integer_as("height", o.height, 16, 1080);
  const auto components = args.list("components");
  if (components) {
    o.components.clear();
    for (const std::string& s : *components) {
      char* end = nullptr;
      const unsigned long x = std::strtoul(s.c_str(), &end, 10);
      if (*end != '\0' || x < 1 || x > 128) args.error("--components " + s + ": expected integers in [1, 128]");
      o.components.push_back(static_cast<uint32_t>(x));
    }
  }
  if (const auto qualities = args.list("qualities")) {
    o.qualities.clear();
    for (const std::string& s : *qualities) {
      char* end = nullptr;
      const float q = std::strtof(s.c_str(), &end);
      if (*end != '\0' || !(q >= 1.0f && q <= 100.0f))
        args.error("--qualities " + s + ": expected numbers in [1, 100]");
      o.qualities.push_back(q);
    }
  }
  if (const auto encodings = args.list("encodings")) {
    o.encodings.clear();
    for (const std::string& s : *encodings) {
      ValueEncoding e = ValueEncoding::linear;
      if (!parse_value_encoding(s, e)) args.error("--encodings " + s + ": expected linear, sqrt, log or log_ycbcr");
      o.encodings.push_back(e);
    }
  }
  if (!args.finish(0)) return false;
  if (materials) o.materials = static_cast<uint32_t>(*materials);
  if (size) o.size = static_cast<uint32_t>(*size);
  if (rays) o.rays = static_cast<uint32_t>(*rays);
  const bool materials_set = materials.has_value(), size_set = size.has_value(), rays_set = rays.has_value();
  const bool components_set = components.has_value();
  if (o.out.empty()) {
    std::fprintf(stderr, "btflod-rate-distortion: --out DIR is required\n");
    return false;
  }
  if (o.paper) {
    if (!materials_set) o.materials = 2;
    if (!size_set) o.size = 64;
    if (!components_set) o.components = {8, 16, 32, 64, 100};
    if (!rays_set) o.rays = 3;
  }
  std::sort(o.components.begin(), o.components.end());
  o.components.erase(std::unique(o.components.begin(), o.components.end()), o.components.end());
  std::sort(o.qualities.begin(), o.qualities.end());
  o.qualities.erase(std::unique(o.qualities.begin(), o.qualities.end()), o.qualities.end());
  return true;
}

/// One measured point.
struct Point {
  std::string material;
  ValueEncoding encoding = ValueEncoding::linear;
  uint32_t components = 0;
  float quality = 0;  ///< 0: the uncompressed FMF (halves)
  uint64_t bytes = 0, u_bytes = 0, tile_bytes = 0;
  double bits_per_sample = 0;
  double v_psnr = INFINITY;  ///< decoded V′ against the FMF's over the virtual texture (range: V′'s)
  demo::ImageError error;
};

/// V′ of the finest level decoded from `file` (closed loop over the levels) into m.decoded, as
/// the virtual texture (M × N × C) the ray-caster samples. `m` holds the material's name and
/// its tile pyramid (the level table the containers of every quality share).
Result<Image<float>> decoded_eigen_textures(progressive::Material& m, std::span<const uint8_t> file, uint64_t* u_bytes,
                                            uint64_t* tile_bytes) {
  auto dir = read_bsvtf(file);
  if (!dir) return dir.error();
  const BsvtfMetadata& md = dir->metadata;
  if (auto d = progressive::decode_tiles(m, file, *dir); !d) return d.error();
  *u_bytes = 0, *tile_bytes = 0;
  for (const BsvtfPacketEntry& p : dir->packets) *u_bytes += p.size;
  for (const BsvtfTileEntry& t : dir->tiles) *tile_bytes += t.size;
  const VtGeometry& g = m.pyramid.geometry();
  const VtLevelTable& lv = m.pyramid.levels();
  const uint32_t fl = g.finest_level, T = g.tile_size, B = g.border, S = g.stored_size();
  const int C = static_cast<int>(md.component_count);
  Image<float> out(static_cast<int>(g.width), static_cast<int>(g.height), C);
  for (uint32_t k = 0; k < md.texture_count(); ++k)
    for (uint32_t ty = 0; ty < lv.tiles_y[fl]; ++ty)
      for (uint32_t tx = 0; tx < lv.tiles_x[fl]; ++tx) {
        const std::vector<float>& tile = m.decoded[k][lv.index(fl, tx, ty)];
        for (uint32_t y = 0; y < T; ++y)
          for (uint32_t x = 0; x < T; ++x) {
            const int ox = static_cast<int>(tx * T + x), oy = static_cast<int>(ty * T + y);
            if (ox >= out.width() || oy >= out.height()) continue;
            for (uint32_t c = 0; c < 4; ++c) {
              const int ch = static_cast<int>(4 * k + c);
              if (ch < C) out.at(ox, oy, ch) = tile[((y + B) * S + x + B) * 4 + c];
            }
          }
      }
  return out;
}

/// PSNR of `decoded` against `reference` (same shape), peak = the reference's range.
double eigen_texture_psnr(const Image<float>& reference, const Image<float>& decoded) {
  double se = 0, lo = INFINITY, hi = -INFINITY;
  size_t n = 0;
  for (int y = 0; y < reference.height(); ++y)
    for (int x = 0; x < reference.width(); ++x)
      for (int c = 0; c < reference.channels(); ++c) {
        const double a = reference.at(x, y, c), d = a - decoded.at(x, y, c);
        se += d * d, lo = std::min(lo, a), hi = std::max(hi, a), ++n;
      }
  return se > 0 ? 20.0 * std::log10((hi - lo) / std::sqrt(se / static_cast<double>(n))) : INFINITY;
}

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

std::string quality_name(float q) { return q == 0.0f ? std::string("FMF") : "q" + fmt("%.0f", q); }

/// The gnuplot data (one block per material, encoding and C, points ordered by bits) and script.
std::string gnuplot_script(const std::vector<Point>& pts, const std::vector<std::string>& materials,
                           const std::string& data_path, const std::string& svg_path, const std::string& title,
                           std::string& data) {
  std::ostringstream d, s;
  std::map<std::string, int> index;  // "material|encoding|C" → gnuplot index
  std::vector<std::string> keys;
  for (const Point& p : pts) {
    const std::string key = p.material + "|" + value_encoding_name(p.encoding) + "|" + std::to_string(p.components);
    if (!index.count(key)) index[key] = static_cast<int>(keys.size()), keys.push_back(key);
  }
  for (const std::string& key : keys) {
    std::vector<const Point*> series;
    for (const Point& p : pts)
      if (p.material + "|" + value_encoding_name(p.encoding) + "|" + std::to_string(p.components) == key)
        series.push_back(&p);
    std::sort(series.begin(), series.end(),
              [](const Point* a, const Point* b) { return a->bits_per_sample < b->bits_per_sample; });
    // Block 2i: the codec's qualities (a line); block 2i + 1: the uncompressed FMF (a point).
    for (int fmf = 0; fmf < 2; ++fmf) {
      d << "# " << key << (fmf ? " FMF (halves)" : " codec qualities") << "\n";
      for (const Point* p : series)
        if ((p->quality == 0.0f) == (fmf == 1))
          d << fmt("%.6g", p->bits_per_sample) << " " << fmt("%.4f", p->error.de_p99) << " "
            << fmt("%.5f", p->error.ssim) << " " << quality_name(p->quality) << "\n";
      d << "\n\n";
    }
  }
  std::vector<std::string> ranks;  // one colour per C
  for (const Point& p : pts)
    if (std::find(ranks.begin(), ranks.end(), std::to_string(p.components)) == ranks.end())
      ranks.push_back(std::to_string(p.components));
  data = d.str();
  const int cols = static_cast<int>(materials.size());
  s << "# Generated by btflod-rate-distortion; render with: gnuplot <this file>\n"
    << "set encoding utf8\nset terminal svg size " << 360 * cols << ",720 dynamic font 'sans,11'\n"
    << "set output '" << svg_path << "'\n"
    << "set multiplot layout 2," << cols << " title \"" << title
    << "\\nlines: the codec's qualities; open marks: the FMF as halves; dotted: ΔE*ab p99 = 2.3\"\n"
    << "set logscale x\nset grid\nset key top right font ',9'\n"
    << "set xlabel 'bits per BTF sample'\n";
  for (int row = 0; row < 2; ++row)
    for (const std::string& mat : materials) {
      // One key per row (the first panel's), where the curves rarely are.
      s << "set title '" << mat << "'\n"
        << (&mat == &materials.front() ? (row == 0 ? "set key top right\n" : "set key bottom right\n") : "unset key\n");
      if (row == 0)
        s << "set ylabel 'screen ΔE*ab p99 vs raw'\nset logscale y\nset yrange [1:*]\n"
          << "set arrow 1 from graph 0, first 2.3 to graph 1, first 2.3 nohead dt 3 lc rgb '#888888'\n";
      else
        s << "set ylabel 'SSIM vs raw'\nunset logscale y\nunset arrow 1\nset yrange [*:1]\n";
      s << "plot ";
      bool first = true;
      for (const std::string& key : keys) {
        if (key.rfind(mat + "|", 0) != 0) continue;
        const std::string rest = key.substr(mat.size() + 1);
        const std::string enc = rest.substr(0, rest.find('|')), C = rest.substr(rest.find('|') + 1);
        const int colour = static_cast<int>(std::find(ranks.begin(), ranks.end(), C) - ranks.begin()) + 1;
        const int point = enc == "log" ? 7 : enc == "sqrt" ? 5 : 9;
        s << (first ? "" : ", \\\n     ") << "'" << data_path << "' index " << 2 * index[key]
          << " using 1:" << (row == 0 ? 2 : 3) << " with linespoints lc " << colour << " pt " << point << " dt "
          << (enc == "log"    ? 1
              : enc == "sqrt" ? 4
                              : 2)
          << " title '" << enc << " C=" << C << "', \\\n     '" << data_path << "' index " << 2 * index[key] + 1
          << " using 1:" << (row == 0 ? 2 : 3) << " with points lc " << colour << " pt " << point - 1
          << " ps 1.4 notitle";
        first = false;
      }
      s << "\n";
    }
  s << "unset multiplot\n";
  return s.str();
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, o)) return 2;
  const samples::MeasuredRun run("btflod-rate-distortion", argc, argv, o.out);
  const auto fail = [](const std::string& what, const std::string& msg) {
    std::fprintf(stderr, "btflod-rate-distortion: %s: %s\n", what.c_str(), msg.c_str());
    return 1;
  };

  const uint32_t c_max = o.components.back();
  demo::MaterialSettings base =
      o.paper ? demo::paper_material_settings(static_cast<int>(o.size)) : demo::MaterialSettings{};
  base.size = static_cast<int>(o.size);
  base.quality = o.qualities.front();
  const DirectionSet directions = o.paper ? DirectionSet::ubo2014() : demo::demo_directions();
  const scene::View view = scene::camera_path(1, 2, o.width, o.height);  // the demo's last view
  auto builder = demo::RawReferenceBuilder::cast(o.materials, view, o.rays, false);
  if (!builder) return fail("raw reference", builder.message());

  std::vector<Point> points;
  std::vector<std::string> names;
  bool check_ok = true;
  std::ostringstream check_log;
  std::printf("btflod rate-distortion (%s profile): %u materials of %u² texels, C =", o.paper ? "paper" : "default",
              o.materials, o.size);
  for (uint32_t c : o.components) std::printf(" %u", c);
  std::printf("; view %ux%u, %u×%u rays per pixel\n", o.width, o.height, o.rays, o.rays);
  std::printf("%-10s %-6s %4s %5s %12s %10s %8s %9s %9s %8s\n", "material", "enc", "C", "q", "bits/sample", "ratio",
              "SSIM", "dE p99", "dE mean", "V' PSNR");
  for (size_t ei = 0; ei < o.encodings.size(); ++ei) {
    demo::MaterialSettings s = base;
    s.components = c_max;
    s.transform.encoding = o.encodings[ei];
    // The paper profile synthesises each store once: later encodings read it back.
    if (o.paper && ei > 0) s.inputs_dir = o.out;
    // Every material first: finish() needs them all added (the raw image is read from the first
    // encoding's stores, which the later encodings synthesise identically).
    std::vector<demo::DemoMaterial> prepared;
    std::vector<Fmf> fulls(o.materials);
    for (uint32_t i = 0; i < o.materials; ++i) {
      auto m = demo::prepare_material(i, s, o.out, &fulls[i]);
      if (!m) return fail("material", m.message());
      if (ei == 0) {
        names.push_back(m->name);
        if (auto r = builder->add_material(i, *m); !r) return fail("raw reference", r.message());
      }
      if (!o.paper) {
        std::error_code ec;  // a store left behind is only disk space
        std::filesystem::remove(m->store_path, ec);
      }
      prepared.push_back(std::move(*m));
    }
    for (uint32_t i = 0; i < o.materials; ++i) {
      const demo::DemoMaterial* m = &prepared[i];
      const Fmf& full = fulls[i];
      const double samples =
          static_cast<double>(m->eigen_textures.width()) * m->eigen_textures.height() * m->light_count * m->view_count;
      for (uint32_t C : o.components) {
        demo::MaterialSettings sc = s;
        sc.components = C;
        auto mc = demo::finish_material(*m, truncate_fmf(full, static_cast<int>(C)), directions, directions, sc, o.out);
        if (!mc) return fail("material", mc.message());
        auto md = read_bsvtf(mc->bsvtf);
        if (!md) return fail(mc->bsvtf_path, md.message());
        auto pyramid = TilePyramid::build(mc->eigen, md->metadata.tile_size, md->metadata.border, TileEdge::wrap);
        if (!pyramid) return fail("tile pyramid", pyramid.message());
        const samples::BsvtfTileInputs inputs = samples::bsvtf_tiles_from_pyramid(
            *pyramid, md->metadata.level_count, md->metadata.tile_size, md->metadata.border);
        progressive::Material decoded;  // the decode target of every quality (the inputs own their samples)
        decoded.demo.name = mc->name;
        decoded.pyramid = std::move(*pyramid);
        demo::DemoMaterial shown = *mc;  // the FMF with V′ replaced by each quality's decoded V′
        std::vector<Point> series;
        for (size_t qi = 0; qi <= o.qualities.size(); ++qi) {
          Point p;
          p.material = mc->name;
          p.encoding = o.encodings[ei];
          p.components = C;
          if (qi == 0) {  // the FMF itself: U and V′ over the virtual texture as halves
            p.bytes = 2 * (mc->u.size() +
                           static_cast<uint64_t>(mc->eigen_textures.width()) * mc->eigen_textures.height() * C);
          } else {
            p.quality = o.qualities[qi - 1];
            std::vector<uint8_t> built;  // the container finish_material built is at sc.quality
            if (p.quality != sc.quality) {
              BsvtfBuildOptions bo;
              bo.quality = p.quality;
              bo.entropy_coder = sc.entropy_coder;
              auto f = build_bsvtf(md->metadata, mc->u, inputs.tiles, bo);
              if (!f) return fail("build", f.message());
              built = std::move(*f);
            }
            const std::span<const uint8_t> file =
                p.quality == sc.quality ? std::span<const uint8_t>(mc->bsvtf) : std::span<const uint8_t>(built);
            p.bytes = file.size();
            auto v = decoded_eigen_textures(decoded, file, &p.u_bytes, &p.tile_bytes);
            if (!v) return fail(mc->name + " decode", v.message());
            p.v_psnr = eigen_texture_psnr(mc->eigen_textures, *v);
            shown.eigen_textures = std::move(*v);
          }
          if (auto r = builder->replace_fmf(i, qi == 0 ? *mc : shown); !r) return fail("render", r.message());
          auto ref = builder->finish();
          if (!ref) return fail("render", ref.message());
          p.error = demo::image_error(ref->raw, ref->fmf_cpu, &ref->pixel_material, i);
          p.bits_per_sample = 8.0 * static_cast<double>(p.bytes) / samples;
          std::printf("%-10s %-6s %4u %5s %12.4f %9.1f:1 %8.4f %9.3f %9.3f %8.1f\n", p.material.c_str(),
                      value_encoding_name(p.encoding), C, quality_name(p.quality).c_str(), p.bits_per_sample,
                      48.0 / p.bits_per_sample, p.error.ssim, p.error.de_p99, p.error.de_mean, p.v_psnr);
          series.push_back(p);
        }
        // --check: bits grow with quality; the best quality renders like the FMF.
        for (size_t k = 2; k < series.size(); ++k)
          if (series[k].bytes <= series[k - 1].bytes) {
            check_ok = false;
            check_log << "  " << series[k].material << " " << value_encoding_name(series[k].encoding) << " C=" << C
                      << ": " << quality_name(series[k].quality) << " is not larger than "
                      << quality_name(series[k - 1].quality) << "\n";
          }
        if (series.size() > 1 && !(series.back().v_psnr >= 30.0)) {
          check_ok = false;
          check_log << "  " << series.back().material << " " << value_encoding_name(series.back().encoding)
                    << " C=" << C << ": decoded V′ at " << quality_name(series.back().quality) << " only "
                    << fmt("%.1f dB", series.back().v_psnr) << " from the FMF's\n";
        }
        if (series.size() > 1 && std::fabs(series.back().error.ssim - series.front().error.ssim) > 0.02) {
          check_ok = false;
          check_log << "  " << series.back().material << " " << value_encoding_name(series.back().encoding)
                    << " C=" << C << ": SSIM at " << quality_name(series.back().quality) << " "
                    << fmt("%.4f", series.back().error.ssim) << " vs FMF " << fmt("%.4f", series.front().error.ssim)
                    << "\n";
        }
        points.insert(points.end(), series.begin(), series.end());
      }
    }
  }

  // CSV, gnuplot data and script, and the plot.
  const std::filesystem::path out(o.out);
  {
    std::ofstream csv(out / "rate_distortion.csv");
    csv << "profile,material,encoding,components,quality,bytes,u_bytes,tile_bytes,bits_per_sample,ratio_to_halves,"
           "ssim,de_p99,de_mean,psnr,pixels,v_psnr\n";
    for (const Point& p : points)
      csv << (o.paper ? "paper" : "default") << "," << p.material << "," << value_encoding_name(p.encoding) << ","
          << p.components << "," << (p.quality == 0.0f ? std::string("fmf") : fmt("%.0f", p.quality)) << "," << p.bytes
          << "," << p.u_bytes << "," << p.tile_bytes << "," << fmt("%.6g", p.bits_per_sample) << ","
          << fmt("%.2f", 48.0 / p.bits_per_sample) << "," << fmt("%.5f", p.error.ssim) << ","
          << fmt("%.4f", p.error.de_p99) << "," << fmt("%.4f", p.error.de_mean) << "," << fmt("%.3f", p.error.psnr)
          << "," << p.error.pixels << "," << fmt("%.2f", p.v_psnr) << "\n";
    if (!csv) return fail("write", (out / "rate_distortion.csv").string());
  }
  const std::string data_path = (out / "rate_distortion.dat").string();
  const std::string svg_path = o.svg.empty() ? (out / "rate_distortion.svg").string() : o.svg;
  std::string data;
  const std::string title = std::string("btflod rate–distortion against the raw BTF (") +
                            (o.paper ? "paper" : "default") + " profile, " + std::to_string(o.size) + "² materials)";
  const std::string script = gnuplot_script(points, names, data_path, svg_path, title, data);
  {
    std::ofstream(data_path) << data;
    std::ofstream(out / "rate_distortion.gp") << script;
  }
  if (!o.svg.empty()) {
    const std::string cmd = "gnuplot '" + (out / "rate_distortion.gp").string() + "'";
    if (std::system(cmd.c_str()) != 0)
      return fail("plot", "gnuplot failed or is missing (Debian: gnuplot-nox): " + cmd);
    std::printf("  wrote %s\n", svg_path.c_str());
  }

  // Summary: per material, the fewest bits meeting ΔE*ab p99 ≤ 2.3, and the lowest p99 reached.
  std::ostringstream summary;
  for (const std::string& n : names) {
    const Point* best = nullptr;
    const Point* faithful = nullptr;
    for (const Point& p : points) {
      if (p.material != n) continue;
      if (!best || p.error.de_p99 < best->error.de_p99) best = &p;
      if (p.error.de_p99 <= 2.3 && (!faithful || p.bits_per_sample < faithful->bits_per_sample)) faithful = &p;
    }
    summary << "- " << n << ": lowest ΔE*ab p99 " << fmt("%.2f", best->error.de_p99) << " ("
            << value_encoding_name(best->encoding) << ", C = " << best->components << ", "
            << quality_name(best->quality) << ", " << fmt("%.3g", best->bits_per_sample) << " bits per sample); "
            << (faithful ? "ΔE*ab p99 ≤ 2.3 from " + fmt("%.3g", faithful->bits_per_sample) + " bits per sample (" +
                               value_encoding_name(faithful->encoding) + ", C = " +
                               std::to_string(faithful->components) + ", " + quality_name(faithful->quality) + ")"
                         : std::string("ΔE*ab p99 ≤ 2.3 not reached"))
            << "\n";
  }
  std::printf("%s(%.1f s)\n", summary.str().c_str(), run.seconds());

  if (!o.doc.empty()) {
    std::ostringstream doc;
    doc << "Command: `" << run.command() << "` (" << fmt("%.0f", run.seconds()) << " s on the 2-core machine). "
        << o.materials << " materials of " << o.size << "² texels × " << directions.size() << " × " << directions.size()
        << " directions, repeated to a "
        << (points.empty() ? 0 : o.size * (o.paper ? demo::paper_repeat(static_cast<int>(o.size)) : base.repeat))
        << "² virtual texture; T = " << base.tile_size << ", B = " << base.border << "; the demo's last view at "
        << o.width << " × " << o.height << ", " << o.rays << " × " << o.rays
        << " rays per pixel through the same rays as the raw image. Each cell: bits per BTF sample · ΔE*ab p99 · "
           "SSIM, against the raw BTF, over the material's pixels.\n\n| material | encoding | C | FMF (halves) |";
    for (float q : o.qualities) doc << " " << quality_name(q) << " |";
    doc << "\n|---|---|---:|---:|";
    for (size_t q = 0; q < o.qualities.size(); ++q) doc << "---:|";
    doc << "\n";
    for (size_t k = 0; k < points.size(); k += o.qualities.size() + 1) {
      const Point& h = points[k];
      doc << "| " << h.material << " | " << value_encoding_name(h.encoding) << " | " << h.components << " |";
      for (size_t q = 0; q <= o.qualities.size(); ++q) {
        const Point& p = points[k + q];
        const bool ok = p.error.de_p99 <= 2.3;
        doc << " " << (ok ? "**" : "") << fmt("%.3g", p.bits_per_sample) << " · " << fmt("%.1f", p.error.de_p99)
            << " · " << fmt("%.3f", p.error.ssim) << (ok ? "**" : "") << " |";
      }
      doc << "\n";
    }
    doc << "\n" << summary.str();
    if (!samples::replace_doc_block(o.doc, std::string("rate-distortion-") + (o.paper ? "paper" : "default"),
                                    doc.str()))
      return fail("doc", "cannot write " + o.doc);
  }
  if (o.check) {
    std::printf("%scheck: %s\n", check_log.str().c_str(), check_ok ? "passed" : "FAILED");
    return check_ok ? 0 : 1;
  }
  return 0;
}
