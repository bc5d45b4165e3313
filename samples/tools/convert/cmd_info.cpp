// btflod-convert info FILE... — what a material file holds: format, sizes, directions, values;
// for a .bsvtf streaming container: header, metadata, U packets, tiles and bytes per level.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "btflod/runtime/codec/container.hpp"

#include "btflod/offline/btf/btf_files.hpp"
#include "command.hpp"

namespace {

using namespace btflod;
using btflod::BtfFileKind;

void print_directions(const char* what, const DirectionSet& d) {
  float max_theta = 0.0f;
  for (const auto& dir : d) max_theta = std::max(max_theta, dir.theta);
  std::printf("  %-7s %zu directions (%s), theta up to %.1f deg\n", what, d.size(),
              d.name().empty() ? "custom" : d.name().c_str(), static_cast<double>(radians_to_degrees(max_theta)));
}

void print_value_range(const BtfFloat& btf) {
  float lo = INFINITY, hi = -INFINITY;
  double sum = 0.0;
  size_t non_finite = 0;
  for (float v : btf.samples()) {
    if (!std::isfinite(v)) {
      ++non_finite;
      continue;
    }
    lo = std::min(lo, v);
    hi = std::max(hi, v);
    sum += v;
  }
  std::printf("  values  min %.6g, max %.6g, mean %.6g", static_cast<double>(lo), static_cast<double>(hi),
              sum / static_cast<double>(std::max<size_t>(btf.samples().size(), 1)));
  if (non_finite) std::printf(", %zu non-finite", non_finite);
  std::printf("\n");
}

int info_mbsdf(const std::string& path) {
  auto brdf = read_mbsdf(path);
  if (!brdf) {
    std::fprintf(stderr, "btflod-convert info: %s\n", brdf.message().c_str());
    return convert::kExitFailure;
  }
  std::printf("%s: NVIDIA ARC MBSDF V1 measured isotropic BRDF\n", path.c_str());
  std::printf("  grid    %u x %u x %u (theta_in x theta_out x phi_diff), %s, cell centres at (i+0.5)*90/%u deg\n",
              brdf->res_theta(), brdf->res_theta(), brdf->res_phi(), brdf->channels() == 3 ? "RGB" : "scalar",
              brdf->res_theta());
  std::printf("  values  max %.6g, %zu negative (measurement noise, clamped to 0 on evaluation)\n",
              static_cast<double>(brdf->max_value()), brdf->negative_count());
  std::printf("  parts   reflection%s\n", brdf->had_transmission() ? " + transmission (ignored)" : "");
  const glm::vec3 normal = brdf->evaluate(glm::vec3(0, 0, 1), glm::vec3(0, 0, 1));
  const glm::vec3 l45 = direction_from_spherical(degrees_to_radians(45.0f), 0.0f);
  const glm::vec3 mirror45 = brdf->evaluate(l45, direction_from_spherical(degrees_to_radians(45.0f), kPi));
  std::printf("  rho     normal incidence (%.4g, %.4g, %.4g) /sr; 45 deg mirror (%.4g, %.4g, %.4g) /sr\n",
              static_cast<double>(normal.r), static_cast<double>(normal.g), static_cast<double>(normal.b),
              static_cast<double>(mirror45.r), static_cast<double>(mirror45.g), static_cast<double>(mirror45.b));
  return convert::kExitOk;
}

// True when the file starts with the .bsvtf signature.
bool is_bsvtf(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  char magic[8] = {};
  return f.read(magic, 8) && std::memcmp(magic, kBsvtfMagic, 8) == 0;
}

const char* color_mode_name(ColorMode m) {
  switch (m) {
    case ColorMode::linear_rgb:
      return "linear RGB";
    case ColorMode::ycbcr:
      return "YCbCr";
    case ColorMode::luminance:
      return "luminance";
  }
  return "unknown";
}

// Describes a .bsvtf container (runtime/codec/container.hpp, docs/bsvtf_format.md). `values`: also
// check every payload's CRC-32 and decode every tile down the hierarchy.
int info_bsvtf(const std::string& path, bool values) {
  auto bytes = read_file_bytes(path);
  if (!bytes) {
    std::fprintf(stderr, "btflod-convert info: %s\n", bytes.message().c_str());
    return convert::kExitFailure;
  }
  auto dir = read_bsvtf(*bytes);
  if (!dir) {
    std::fprintf(stderr, "btflod-convert info: %s: %s\n", path.c_str(), dir.message().c_str());
    return convert::kExitFailure;
  }
  const BsvtfHeader& h = dir->header;
  const BsvtfMetadata& m = dir->metadata;
  std::printf("%s: btflod .bsvtf streaming container, version %u\n", path.c_str(), h.version);
  std::printf("  file    %llu bytes: directory %llu (metadata %u, %u packet entries, %u tile entries), payloads %llu\n",
              static_cast<unsigned long long>(h.file_size), static_cast<unsigned long long>(h.directory_size),
              h.metadata_size, h.packet_count, h.tile_count, static_cast<unsigned long long>(h.payload_size));
  std::printf("  material \"%s\", %u x %u texels, %u levels of %u+2*%u tiles, %u components in %u RGBA textures\n",
              m.material_name.c_str(), m.width, m.height, m.level_count, m.tile_size, m.border, m.component_count,
              m.texture_count());
  std::printf("  colour  %u channels, %s; U %u rows x %u components; quality %.1f; values %s", m.color_channels,
              color_mode_name(m.color_mode), m.u_rows, m.component_count, static_cast<double>(m.quality),
              value_encoding_name(m.value_transform.encoding));
  if (m.value_transform.uses_log_offset())
    std::printf(" (offset %g)", static_cast<double>(m.value_transform.log_offset));
  std::printf("\n");
  std::printf("  lights  %zu directions (%s)\n  views   %zu directions (%s)\n", m.light_directions.size() / 3,
              m.light_set.c_str(), m.view_directions.size() / 3, m.view_set.c_str());
  uint64_t packet_bytes = 0;
  for (const auto& p : dir->packets) packet_bytes += p.size;
  std::printf("  packets %zu U packets, %llu bytes\n", dir->packets.size(),
              static_cast<unsigned long long>(packet_bytes));
  const size_t raw_tile = m.layout().sample_count() * 2;  // raw half floats
  uint64_t all = 0;
  for (uint32_t l = 0; l < m.level_count; ++l) {
    uint64_t count = 0, sum = 0;
    for (const auto& t : dir->tiles)
      if (t.id.level == l) {
        ++count;
        sum += t.size;
      }
    all += sum;
    std::printf(
        "  level %-2u %6llu tiles, %10llu bytes, %8.0f bytes/tile, %5.2f:1 vs raw halves; prefix to here %llu bytes\n",
        l, static_cast<unsigned long long>(count), static_cast<unsigned long long>(sum),
        count ? static_cast<double>(sum) / static_cast<double>(count) : 0.0,
        sum ? static_cast<double>(count * raw_tile) / static_cast<double>(sum) : 0.0,
        static_cast<unsigned long long>(dir->prefix_size(l)));
  }
  std::printf("  tiles   %zu, %llu bytes, %.2f:1 vs raw halves\n", dir->tiles.size(),
              static_cast<unsigned long long>(all),
              all ? static_cast<double>(dir->tiles.size() * raw_tile) / static_cast<double>(all) : 0.0);
  if (!values) return convert::kExitOk;
  const std::span<const uint8_t> file(*bytes);
  size_t bad_crc = 0, bad_decode = 0, decoded = 0;
  for (size_t i = 0; i < dir->packets.size(); ++i) {
    const auto& p = dir->packets[i];
    const auto payload = file.subspan(p.offset, p.size);
    if (verify_bsvtf_payload(p.size, p.crc, payload) != Status::success) {
      std::fprintf(stderr, "  U packet %zu: %u bytes at %llu: bad CRC-32 %08x, index says %08x\n", i, p.size,
                   static_cast<unsigned long long>(p.offset), static_cast<unsigned>(crc32_of(payload)), p.crc);
      ++bad_crc;
    }
  }
  TileDecoder decoder(m.layout());
  std::vector<std::vector<float>> out(dir->tiles.size());
  for (uint32_t l = 0; l < m.level_count; ++l)  // parents first: the index is sorted by key, level in the key
    for (size_t i = 0; i < dir->tiles.size(); ++i) {
      const auto& t = dir->tiles[i];
      if (t.id.level != l) continue;
      const auto payload = file.subspan(t.offset, t.size);
      if (verify_bsvtf_payload(t.size, t.crc, payload) != Status::success) {
        std::fprintf(stderr, "  tile %u/%u/%u/%u: %u bytes at %llu: bad CRC-32 %08x, index says %08x\n", t.id.texture,
                     t.id.level, t.id.x, t.id.y, t.size, static_cast<unsigned long long>(t.offset),
                     static_cast<unsigned>(crc32_of(payload)), t.crc);
        ++bad_crc;
        continue;
      }
      std::span<const float> parent;
      if (l > 0) {
        const BsvtfTileEntry* pe = dir->find(t.id.parent());
        const size_t pi = pe ? static_cast<size_t>(pe - dir->tiles.data()) : 0;
        if (!pe || out[pi].empty()) {
          ++bad_decode;
          continue;
        }
        parent = out[pi];
      }
      out[i].resize(m.layout().sample_count());
      if (decoder.decode(payload, parent, t.id.x & 1, t.id.y & 1, out[i]) != Status::success) {
        std::fprintf(stderr, "  tile %u/%u/%u/%u: %s\n", t.id.texture, t.id.level, t.id.x, t.id.y, decoder.message());
        out[i].clear();
        ++bad_decode;
        continue;
      }
      ++decoded;
      if (l + 1 < m.level_count) continue;
      std::vector<float>().swap(out[i]);  // finest level: nothing decodes against it
    }
  std::printf("  check   %zu payload checksum failures, %zu tiles decoded, %zu failed\n", bad_crc, decoded, bad_decode);
  return (bad_crc || bad_decode) ? convert::kExitFailure : convert::kExitOk;
}

int info_bonn(const std::string& path, bool values) {
  auto file = read_bonn_btf(path);
  if (!file) {
    std::fprintf(stderr, "btflod-convert info: %s\n", file.message().c_str());
    return convert::kExitFailure;
  }
  const auto& f = *file;
  std::printf("%s: Bonn binary BTF, %s\n", path.c_str(),
              f.format == BonnFormat::dfmf ? "DFMF (per-channel factor matrices)" : "FMF (one factor matrix)");
  std::printf("  texels  %d x %d\n", f.width, f.height);
  print_directions("views", f.views);
  print_directions("lights", f.lights);
  std::printf("  meta    version %u, setup \"%s\", sensor \"%s\", light \"%s\", %.3g px/mm\n", f.meta_version,
              f.measurement_setup.c_str(), f.image_sensor.c_str(), f.light_source.c_str(), static_cast<double>(f.ppmm));
  std::printf("  colour  %zu channels, model %d, cosine in data: %s\n", f.channel_count(),
              static_cast<int>(f.color_model), f.cosine_in_data ? "yes" : "no");
  for (size_t c = 0; c < f.factors.size(); ++c)
    std::printf("  factors [%zu] %lld components, U %lld x %lld, SxV %lld x %lld, %u-byte scalars\n", c,
                static_cast<long long>(f.factors[c].u.cols()), static_cast<long long>(f.factors[c].u.rows()),
                static_cast<long long>(f.factors[c].u.cols()), static_cast<long long>(f.factors[c].sxv.rows()),
                static_cast<long long>(f.factors[c].sxv.cols()), f.factors[c].scalar_size);
  for (const auto& w : f.warnings) std::printf("  warning %s\n", w.c_str());
  if (values) {
    auto btf = reconstruct_bonn_btf(f);
    if (!btf) {
      std::fprintf(stderr, "btflod-convert info: %s: %s\n", path.c_str(), btf.message().c_str());
      return convert::kExitFailure;
    }
    print_value_range(*btf);
  }
  return convert::kExitOk;
}

int info_folder(const std::string& path) {
  auto folder = read_ubo2003_folder(path);
  if (!folder) {
    std::fprintf(stderr, "btflod-convert info: %s\n", folder.message().c_str());
    return convert::kExitFailure;
  }
  const BtfFloat& btf = folder->btf;
  std::printf("%s: UBO2003-style image folder, %zu images (8-bit sRGB, linearised)\n", path.c_str(),
              folder->image_paths.size());
  std::printf("  texels  %d x %d\n", btf.width(), btf.height());
  print_directions("views", btf.views());
  print_directions("lights", btf.lights());
  if (!folder->image_paths.empty()) std::printf("  first   %s\n", folder->image_paths.front().c_str());
  print_value_range(btf);
  for (const auto& w : folder->warnings) std::printf("  warning %s\n", w.c_str());
  return convert::kExitOk;
}

[[maybe_unused]] int info_generic(const std::string& path) {
  auto btf = load_btf(path);
  if (!btf) {
    std::fprintf(stderr, "btflod-convert info: %s\n", btf.message().c_str());
    return convert::kExitFailure;
  }
  std::printf("%s: %s\n", path.c_str(), btf_file_kind_name(detect_btf_file(path)));
  std::printf("  texels  %d x %d\n", btf->width(), btf->height());
  print_directions("views", btf->views());
  print_directions("lights", btf->lights());
  print_value_range(*btf);
  return convert::kExitOk;
}

int run_info(convert::Options& opt) {
  const bool values = opt.flag("values");
  if (!opt.finish()) return convert::kExitUsage;
  if (opt.positional().empty()) {
    std::fprintf(stderr, "btflod-convert info: no FILE given (see --help)\n");
    return convert::kExitUsage;
  }
  int result = convert::kExitOk;
  for (const auto& path : opt.positional()) {
    int r = convert::kExitFailure;
    if (is_bsvtf(path)) {
      r = info_bsvtf(path, values);
      if (r != convert::kExitOk) result = r;
      continue;
    }
    switch (detect_btf_file(path)) {
      case BtfFileKind::missing:
        std::fprintf(stderr, "btflod-convert info: %s: cannot open (missing or unreadable)\n", path.c_str());
        break;
      case BtfFileKind::unknown:
        std::fprintf(stderr, "btflod-convert info: %s: not a format btflod reads\n", path.c_str());
        break;
      case BtfFileKind::mbsdf:
        r = info_mbsdf(path);
        break;
      case BtfFileKind::bonn:
        r = info_bonn(path, values);
        break;
      case BtfFileKind::image_folder:
        r = info_folder(path);
        break;
    }
    if (r != convert::kExitOk) result = r;
  }
  return result;
}

constexpr char kInfoUsage[] =
    "usage: btflod-convert info FILE... [--values]\n"
    "  Prints what each file holds: format, texel size, view and light directions, and for\n"
    "  measured BRDFs the grid and a few values. Reads NVIDIA ARC .mbsdf files, Bonn .btf files\n"
    "  (!DFMF08FCR, !FMF12FCER), UBO2003-style image folders (when compiled in) and .bsvtf\n"
    "  streaming containers (header, metadata, U packets, tiles and bytes per level).\n"
    "  --values   also reconstruct the data and print its value range (may be slow); for .bsvtf:\n"
    "             check every payload checksum and decode every tile";

}  // namespace

BTFLOD_CONVERT_COMMAND(info, "what a material file holds (.mbsdf, Bonn .btf, UBO2003 folder, .bsvtf)", kInfoUsage,
                       run_info);
