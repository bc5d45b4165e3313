// btflod-web-tool — the native side of the browser client's tests and benchmarks:
//   materials --out DIR [--count N] [--size S] [--repeat R] [--deflate I[,J…]]
//       synthesises N materials (samples/demo's preparation: procedural BTF, FMF, .bsvtf) into
//       DIR and writes DIR/materials.json (the page's material list, with each file's tile coder).
//       Tiles are zstd-coded (tile format 3, the library's default); the materials listed in
//       --deflate are deflate-coded (format 2, what earlier versions wrote)
//   reference --out FILE.f32 --bsvtf A.bsvtf[,B.bsvtf…] --eye x,y,z --target x,y,z --fov deg
//             --light x,y,z --light-color r,g,b --size WxH
//       CPU reference frame of the page's scene (one 2×2 plane per material, side by side) with
//       every tile of every material resident: offline/render/cpu_reference.hpp's ray caster, the vt/
//       page table through CpuCacheTexture (half texels, like the GPU cache), eq. 5 with the
//       same angular tables as the client (web_material.hpp). Raw RGBA float32, row 0 = top.
//   compare --ref A.f32 --img B.f32 --size WxH
//       PSNR (rgb, peak = reference maximum, as the GPU golden tests) and mean SSIM.
//   pcak --out FILE.pcak --ref FILE.f32 [--index I] [--k 3] [--components 4] + the view options
//       synthesises material I (as `materials` does), factorises it with PCA over groups of k
//       views (paper 004, offline/factor/pca_views.hpp), writes the pca_rings GPU layout (L planes and R
//       columns one component per chunk, the ring search's uniform block) as one static file
//       for the page, and the CPU reference frame of one 2×2 plane at the origin
//       (reference_pca_rings)
//   decode --bsvtf FILE [--repeats N]
//       decodes every tile with zlib and libdeflate (deflate tiles; zstd tiles through zstd): hash (bit identity with
//       the wasm decoder), µs per tile. Prints JSON.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "btflod/core/file_io.hpp"
#include "btflod/core/half.hpp"
#include "btflod/offline/factor/pca_views.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"
#include "btflod/offline/packing/representation_packing.hpp"
#include "btflod/offline/packing/ring_search_block.hpp"
#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/vt/cache_bc5.hpp"
#include "btflod/runtime/vt/tile_cache.hpp"
#include "client/web_material.hpp"
#include "common/arguments.hpp"
#include "demo/materials.hpp"

namespace {

using namespace btflod;

// A command's options through the samples' parser: each command reads what it knows with get();
// main() then reports anything left over (unknown options, stray words) and exits with 2.
struct Args {
  std::string command;
  samples::Arguments* parser = nullptr;
  std::map<std::string, std::optional<std::string>, std::less<>> seen;  // options already read
  std::string get(const std::string& k, const std::string& fallback = "") {
    auto it = seen.find(k);
    if (it == seen.end()) it = seen.emplace(k, parser->value(k)).first;
    return it->second ? *it->second : fallback;
  }
};

std::vector<float> floats(const std::string& s) {
  std::vector<float> v;
  const char* p = s.c_str();
  while (*p) {
    char* end = nullptr;
    v.push_back(std::strtof(p, &end));
    if (end == p) break;
    p = *end == ',' ? end + 1 : end;
  }
  return v;
}

glm::vec3 vec3_arg(Args& a, const std::string& k, glm::vec3 fallback) {
  const auto v = floats(a.get(k));
  return v.size() == 3 ? glm::vec3(v[0], v[1], v[2]) : fallback;
}

bool size_arg(Args& a, int& w, int& h) {
  return std::sscanf(a.get("size", "512x512").c_str(), "%dx%d", &w, &h) == 2 && w > 0 && h > 0 && w <= 8192 &&
         h <= 8192;
}

// The reference camera of --eye, --target, --up and --fov at W × H pixels.
Camera camera_arg(Args& a, int W, int H) {
  Camera cam;
  cam.position = vec3_arg(a, "eye", glm::vec3(0, -2, 3));
  cam.target = vec3_arg(a, "target", glm::vec3(0));
  cam.up = vec3_arg(a, "up", glm::vec3(0, 0, 1));
  cam.fov_y_degrees = std::strtof(a.get("fov", "45").c_str(), nullptr);
  cam.width = static_cast<uint32_t>(W);
  cam.height = static_cast<uint32_t>(H);
  return cam;
}

int fail(const std::string& msg) {
  std::fprintf(stderr, "btflod-web-tool: %s\n", msg.c_str());
  return 1;
}

// The page's scene: material i on a 2 × 2 plane at x offset (i − (n − 1)/2) · 2.2, normal +z,
// u along +x, v along +y (www/btflod_client.js builds the same meshes).
glm::vec3 plane_origin(uint32_t i, uint32_t n) {
  return glm::vec3(-1.0f + 2.2f * (static_cast<float>(i) - 0.5f * static_cast<float>(n - 1)), -1.0f, 0.0f);
}

int cmd_materials(Args& a) {
  const std::string out = a.get("out");
  if (out.empty()) return fail("materials: --out DIR required");
  std::filesystem::create_directories(out);
  demo::MaterialSettings s;
  s.size = std::atoi(a.get("size", "32").c_str());
  s.repeat = static_cast<uint32_t>(std::atoi(a.get("repeat", "8").c_str()));
  const int count = std::atoi(a.get("count", "3").c_str());
  std::vector<bool> deflate(static_cast<size_t>(std::max(count, 0)), false);
  for (const float f : floats(a.get("deflate"))) {
    const int i = static_cast<int>(f);
    if (i < 0 || i >= count || static_cast<float>(i) != f) return fail("materials: --deflate lists material indices");
    deflate[static_cast<size_t>(i)] = true;
  }
  std::string json = "{\"materials\": [";
  for (int i = 0; i < count; ++i) {
    s.entropy_coder = deflate[static_cast<size_t>(i)] ? TileEntropyCoder::deflate : default_tile_entropy_coder();
    const char* coder = s.entropy_coder == TileEntropyCoder::zstd ? "zstd" : "deflate";
    auto m = demo::prepare_material(static_cast<uint32_t>(i), s, out);
    if (!m) return fail(m.message());
    json += (i ? ", " : "") + std::string("{\"name\": \"") + m->name + "\", \"file\": \"" + m->name +
            ".bsvtf\", \"bytes\": " + std::to_string(m->bsvtf.size()) + ", \"coder\": \"" + coder + "\"}";
    std::printf("%s: %zu bytes, %u levels, %s tiles\n", m->bsvtf_path.c_str(), m->bsvtf.size(), m->finest_level + 1,
                coder);
  }
  json += "]}\n";
  const std::string path = (std::filesystem::path(out) / "materials.json").string();
  if (auto w =
          write_file_bytes(path, std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(json.data()), json.size()));
      !w)
    return fail(w.message());
  return 0;
}

struct RefMaterial {
  std::vector<uint8_t> file;
  BsvtfDirectory dir;
  BsvtfAngularTables angular;
  std::vector<float> u_rgba, u;
  EigenTextures eigen;  // angular = u (E's layout), for shade_fmf
};

int cmd_reference(Args& a) {
  int W, H;
  if (!size_arg(a, W, H)) return fail("reference: bad --size");
  std::vector<std::string> paths;
  {
    std::string list = a.get("bsvtf");
    size_t p = 0;
    while (p < list.size()) {
      size_t q = list.find(',', p);
      if (q == std::string::npos) q = list.size();
      paths.push_back(list.substr(p, q - p));
      p = q + 1;
    }
  }
  if (paths.empty()) return fail("reference: --bsvtf required");
  const uint32_t res = static_cast<uint32_t>(std::atoi(a.get("angular-resolution", "32").c_str()));
  std::vector<RefMaterial> mats(paths.size());
  VtSet set;
  for (size_t i = 0; i < paths.size(); ++i) {
    auto bytes = read_file_bytes(paths[i]);
    if (!bytes) return fail(bytes.message());
    mats[i].file = std::move(*bytes);
    auto d = read_bsvtf(mats[i].file);
    if (!d) return fail(paths[i] + ": " + d.message());
    mats[i].dir = std::move(*d);
    const BsvtfMetadata& md = mats[i].dir.metadata;
    auto ang = web::build_angular_textures(md, res);
    if (!ang) return fail(ang.message());
    mats[i].angular = std::move(*ang);
    const size_t lights = md.light_directions.size() / 3, views = md.view_directions.size() / 3;
    mats[i].u_rgba.assign(lights * views * md.component_count * 4, 0.0f);
    mats[i].u.assign(static_cast<size_t>(md.u_rows) * md.component_count, 0.0f);
    std::vector<float> packet(static_cast<size_t>(md.u_rows) * 4);
    for (const BsvtfPacketEntry& p : mats[i].dir.packets) {
      unpack_bsvtf_packet(std::span<const uint8_t>(mats[i].file).subspan(p.offset, p.size), packet);
      web::scatter_u_packet(md, p.index, packet, mats[i].u_rgba, mats[i].u, md.u_row_order);
    }
    mats[i].eigen.angular = mats[i].u;
    mats[i].eigen.light_count = static_cast<uint32_t>(lights);
    mats[i].eigen.view_count = static_cast<uint32_t>(views);
    mats[i].eigen.textures = Image<float>(1, 1, static_cast<int>(md.component_count));  // C for shade_fmf
    set.add_material(VtGeometry::make(md.width, md.height, md.tile_size, md.border), md.texture_count());
  }
  auto cache_r = TileCache::create(set, TileCacheConfig{64, 64, 1u << 16});
  if (!cache_r) return fail(cache_r.message());
  TileCache& cache = *cache_r;
  // --cache-format rgba8: the compact cache (each tile quantised to unorm8 with its slot's affine
  // map from the decoded values, as the Streamer's decode jobs do); bc5: those unorm8 texels
  // BC5-encoded as the decode jobs do and decoded by the reference decoder; rgba16f otherwise.
  const std::string format_name = a.get("cache-format", "rgba16f");
  if (format_name != "rgba16f" && format_name != "rgba8" && format_name != "bc5")
    return fail("reference: --cache-format rgba16f, rgba8 or bc5");
  const CacheFormat format = format_name == "rgba8" ? CacheFormat::rgba8_affine
                             : format_name == "bc5" ? CacheFormat::bc5_affine
                                                    : CacheFormat::rgba16f;
  CpuCacheTexture texture(cache, format);
  // Every tile, coarse to fine, decoded against its parent (like the client) and inserted.
  std::vector<uint16_t> halves;
  std::vector<uint8_t> unorm8;
  std::vector<uint8_t> bc5;
  for (size_t i = 0; i < mats.size(); ++i) {
    const BsvtfDirectory& dir = mats[i].dir;
    const TileLayout layout = dir.metadata.layout();
    TileDecoder decoder(layout);
    std::vector<float> decoded(dir.tiles.size() * layout.sample_count());
    halves.resize(layout.sample_count());
    const uint32_t first = set.material(static_cast<uint32_t>(i)).first_texture;
    for (size_t t = 0; t < dir.tiles.size(); ++t) {
      const BsvtfTileEntry& e = dir.tiles[t];
      std::span<const float> parent;
      if (e.id.level > 0) {
        const BsvtfTileEntry* p = dir.find(e.id.parent());
        parent = std::span<const float>(
            decoded.data() + static_cast<size_t>(p - dir.tiles.data()) * layout.sample_count(), layout.sample_count());
      }
      std::span<float> out(decoded.data() + t * layout.sample_count(), layout.sample_count());
      if (decoder.decode(std::span<const uint8_t>(mats[i].file).subspan(e.offset, e.size), parent, e.id.x & 1,
                         e.id.y & 1, out) != Status::success)
        return fail(std::string("decode: ") + decoder.message());
      CacheSlotMap map;
      if (format == CacheFormat::rgba8_affine) {
        unorm8.resize(out.size());
        map = encode_cache_tile_unorm8(out, unorm8);
      } else if (format == CacheFormat::bc5_affine) {
        const uint32_t side = layout.stored_size();
        unorm8.resize(out.size());
        bc5.resize(cache_bc5_tile_bytes(side));
        map = encode_cache_tile_bc5(out, side, unorm8, bc5);
      } else {
        float_to_half(out, halves);
      }
      const TileId g{first + e.id.texture, e.id.level, e.id.x, e.id.y};
      uint32_t slot = cache.slot_of(g);  // roots are pinned by the cache itself
      if (slot == kNoSlot) {
        slot = cache.reserve_slot();
        if (slot == kNoSlot) return fail("reference cache too small");
        if (cache.insert(g, slot, 0) != Status::success) return fail("insert failed");
      }
      if (!texture.upload(cache, slot, halves, unorm8, map, bc5)) return fail("upload failed");
    }
  }
  Scene scene;
  const uint32_t n = static_cast<uint32_t>(mats.size());
  for (uint32_t i = 0; i < n; ++i)
    scene.add(Shape::plane(i, plane_origin(i, n), glm::vec3(1, 0, 0), glm::vec3(0, 1, 0), 2.0f, 2.0f));
  const Camera cam = camera_arg(a, W, H);
  const glm::vec3 light = glm::normalize(vec3_arg(a, "light", glm::vec3(-0.5f, 0.4f, 0.8f)));
  const glm::vec3 light_color = vec3_arg(a, "light-color", glm::vec3(1.0f));
  std::vector<float> img(static_cast<size_t>(W) * H * 4, 0.0f);
  std::vector<float> comps(64);
  for_each_pixel_hit(scene, cam, [&](uint32_t x, uint32_t y, float, float, const SurfaceHit& h) {
    if (!h.hit) return;
    const RefMaterial& m = mats[h.material];
    const uint32_t C = m.dir.metadata.component_count;
    const VtMaterial& vm = set.material(h.material);
    for (uint32_t k = 0; k < vm.texture_count; ++k) {
      float v4[4];
      texture.sample(cache, vm.first_texture + k, h.texcoord.x, h.texcoord.y, v4);
      for (uint32_t c = 0; c < 4 && 4 * k + c < C; ++c) comps[4 * k + c] = v4[c];
    }
    const AngularTablesData tables = m.angular.data();
    const AngularSample ls =
        angular_table_sample(tables, 0, DirectionParameterisation::parabolic, false, to_local(h, light));
    const AngularSample vs = angular_table_sample(tables, 1, DirectionParameterisation::parabolic, false,
                                                  to_local(h, glm::normalize(cam.position - h.position)));
    const glm::vec3 rgb = shade_fmf(m.eigen, ls, vs, std::span<const float>(comps.data(), C)) * light_color;
    float* p = img.data() + (static_cast<size_t>(y) * W + x) * 4;
    p[0] = rgb.r, p[1] = rgb.g, p[2] = rgb.b, p[3] = 1.0f;
  });
  const std::string out = a.get("out");
  if (out.empty()) return fail("reference: --out required");
  if (auto w =
          write_file_bytes(out, std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(img.data()), img.size() * 4));
      !w)
    return fail(w.message());
  std::printf("reference %dx%d written to %s\n", W, H, out.c_str());
  return 0;
}

// .pcak: the page's PCA-k file, laid out for streaming component by component (paper 004 §5:
// the first components render first, quality grows as the others arrive).
//   header, 16 uint32 (little-endian): magic 'PCAK', version 2, C, k, lights, views, W, H,
//     groups, chunk count (C + 1), ring block bytes, 3 reserved, CRC-32 of the chunk table, 0
//   chunk table at byte 64: one entry per chunk, 4 uint32: offset, size, CRC-32 of the chunk, 0
//   chunk 0: the ring search's uniform block (RingSearchBlock, std140) and the mean plane
//     m (groups × H × W float32); chunk c ≥ 1: component c's plane of L = [m | UΣ]
//     (groups × H × W float32) and column c − 1 of R = [1; Vᵀ] (lights · views RGBA32F texels)
// Every chunk is one Range request; the page verifies its CRC before it touches a texture.
int cmd_pcak(Args& a) {
  int W, H;
  if (!size_arg(a, W, H)) return fail("pcak: bad --size");
  const uint32_t index = static_cast<uint32_t>(std::atoi(a.get("index", "0").c_str()));
  const SynthMaterial kinds[] = {SynthMaterial::cloth, SynthMaterial::stone, SynthMaterial::leather,
                                 SynthMaterial::tiles};
  SynthesisOptions so;
  so.views = demo::demo_directions();
  so.lights = demo::demo_directions();
  const int texels = std::atoi(a.get("texels", "32").c_str());
  auto btf = synthesize_material(kinds[index % 4], texels, texels, 1 + index, so);
  if (!btf) return fail(btf.message());
  PcaViewsOptions opt;
  opt.views_per_group = std::atoi(a.get("k", "3").c_str());
  opt.components = std::atoi(a.get("components", "4").c_str());
  auto pca = factorize_pca_views(*btf, opt);
  if (!pca) return fail(pca.message());
  auto packed = pack_pca_views_material(*pca);
  if (!packed) return fail(packed.message());
  // Paper 004 §4.4: the ring search over the measured directions, held in a uniform block.
  auto light_rings = RingSearchInterpolator::build(btf->lights());
  auto view_rings = RingSearchInterpolator::build(btf->views());
  if (!light_rings) return fail(light_rings.message());
  if (!view_rings) return fail(view_rings.message());
  auto block = pack_ring_search_block(*light_rings, *view_rings);
  if (!block) return fail(block.message());
  const PcaViewsMaterialData& info = packed->info;
  const uint32_t C = info.components, groups = static_cast<uint32_t>(pca->groups.size());
  const uint32_t layers = (C + 4) / 4;  // L layers per group: components 0..C in RGBA texels
  const size_t n = static_cast<size_t>(info.width) * info.height,
               rows = static_cast<size_t>(info.light_count) * info.view_count;
  std::vector<std::vector<uint8_t>> chunks(C + 1);
  const auto append = [](std::vector<uint8_t>& to, const void* p, size_t bytes) {
    const auto* b = static_cast<const uint8_t*>(p);
    to.insert(to.end(), b, b + bytes);
  };
  append(chunks[0], &*block, sizeof(RingSearchBlock));
  std::vector<float> plane(groups * n), column(rows * 4);
  for (uint32_t c = 0; c <= C; ++c) {
    for (uint32_t b = 0; b < groups; ++b)
      for (size_t t = 0; t < n; ++t) plane[b * n + t] = packed->l[((b * layers + c / 4) * n + t) * 4 + c % 4];
    append(chunks[c], plane.data(), plane.size() * 4);
    if (c == 0) continue;
    for (size_t r = 0; r < rows; ++r)
      for (int k = 0; k < 4; ++k) column[r * 4 + k] = packed->r[(r * C + (c - 1)) * 4 + k];
    append(chunks[c], column.data(), column.size() * 4);
  }
  std::vector<uint32_t> table(4 * (C + 1));
  uint32_t cursor = 64 + static_cast<uint32_t>(table.size() * 4);
  for (uint32_t c = 0; c <= C; ++c) {
    table[4 * c] = cursor;
    table[4 * c + 1] = static_cast<uint32_t>(chunks[c].size());
    table[4 * c + 2] = crc32_of(chunks[c]);
    cursor += table[4 * c + 1];
  }
  const uint32_t table_crc =
      crc32_of(std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(table.data()), table.size() * 4));
  const uint32_t header[16] = {0x4b414350u,
                               2,
                               C,
                               info.views_per_group,
                               info.light_count,
                               info.view_count,
                               info.width,
                               info.height,
                               groups,
                               C + 1,
                               static_cast<uint32_t>(sizeof(RingSearchBlock)),
                               0,
                               0,
                               0,
                               table_crc,
                               0};
  std::vector<uint8_t> file;
  append(file, header, sizeof header);
  append(file, table.data(), table.size() * 4);
  for (const auto& ch : chunks) append(file, ch.data(), ch.size());
  if (auto w = write_file_bytes(a.get("out"), file); !w) return fail(w.message());
  // Reference frame: one plane at the origin, the program's arithmetic on the CPU.
  Scene scene;
  scene.add(Shape::plane(0, plane_origin(0, 1), glm::vec3(1, 0, 0), glm::vec3(0, 1, 0), 2.0f, 2.0f));
  const Camera cam = camera_arg(a, W, H);
  const glm::vec3 light = glm::normalize(vec3_arg(a, "light", glm::vec3(-0.5f, 0.4f, 0.8f)));
  const glm::vec3 light_color = vec3_arg(a, "light-color", glm::vec3(1.0f));
  std::vector<float> img(static_cast<size_t>(W) * H * 4, 0.0f);
  for_each_pixel_hit(scene, cam, [&](uint32_t x, uint32_t y, float, float, const SurfaceHit& h) {
    if (!h.hit) return;
    const glm::vec3 rgb = reference_pca_rings(*pca, *light_rings, *view_rings, h.texcoord, to_local(h, light),
                                              to_local(h, glm::normalize(cam.position - h.position))) *
                          light_color;
    float* p = img.data() + (static_cast<size_t>(y) * W + x) * 4;
    p[0] = rgb.r, p[1] = rgb.g, p[2] = rgb.b, p[3] = 1.0f;
  });
  if (auto w = write_file_bytes(a.get("ref"),
                                std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(img.data()), img.size() * 4));
      !w)
    return fail(w.message());
  std::printf("%s: C = %u, k = %u, %u groups, %u + %u rings, %zu bytes; reference %dx%d\n", a.get("out").c_str(),
              info.components, info.views_per_group, groups, static_cast<unsigned>(light_rings->rings().size()),
              static_cast<unsigned>(view_rings->rings().size()), file.size(), W, H);
  return 0;
}

Result<Image<float>> read_f32(const std::string& path, int w, int h) {
  auto b = read_file_bytes(path);
  if (!b) return b.error();
  if (b->size() != static_cast<size_t>(w) * h * 16)
    return make_error(Status::bad_data, "%s: %zu bytes, expected %d×%d RGBA float32", path.c_str(), b->size(), w, h);
  Image<float> img(w, h, 4);
  std::memcpy(img.elements().data(), b->data(), b->size());
  return img;
}

int cmd_compare(Args& a) {
  int W, H;
  if (!size_arg(a, W, H)) return fail("compare: bad --size");
  auto ref = read_f32(a.get("ref"), W, H);
  if (!ref) return fail(ref.message());
  auto img = read_f32(a.get("img"), W, H);
  if (!img) return fail(img.message());
  double se = 0, peak = 1e-12, sum = 0;
  size_t n = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < 3; ++c) {
        const double d = static_cast<double>(ref->at(x, y, c)) - img->at(x, y, c);
        se += d * d;
        peak = std::max(peak, static_cast<double>(ref->at(x, y, c)));
        sum += ref->at(x, y, c);
        ++n;
      }
  const double mse = se / static_cast<double>(n);
  const double psnr = mse <= 0 ? 200.0 : 10.0 * std::log10(peak * peak / mse);
  const double ssim = mean_ssim(ref->view(), img->view());
  std::printf("{\"psnr_db\": %.3f, \"ssim\": %.6f, \"ref_mean\": %.5f}\n", psnr, ssim, sum / static_cast<double>(n));
  return 0;
}

int cmd_decode(Args& a) {
  auto bytes = read_file_bytes(a.get("bsvtf"));
  if (!bytes) return fail(bytes.message());
  const int repeats = std::max(1, std::atoi(a.get("repeats", "3").c_str()));
  // The scalar twin is what wasm runs (bit identity); the default (AVX2/FMA when the CPU has
  // it) is the native speed a desktop engine gets.
  const auto z = web::decode_container_tiles(*bytes, InflateBackend::zlib, repeats, false);
  const auto d = web::decode_container_tiles(*bytes, InflateBackend::libdeflate, repeats, false);
  const auto v = web::decode_container_tiles(*bytes, InflateBackend::libdeflate, repeats, true);
  if (z.status != Status::success || d.status != Status::success || v.status != Status::success)
    return fail("decode failed");
  std::printf(
      "{\"hash_lo\": %u, \"hash_hi\": %u, \"tiles\": %u, \"zlib_decode_us\": %.3f, \"zlib_inflate_us\": %.3f, "
      "\"libdeflate_hash_equal\": %s, \"libdeflate_decode_us\": %.3f, \"libdeflate_inflate_us\": %.3f, "
      "\"simd_decode_us\": %.3f, \"simd_hash_equal\": %s}\n",
      static_cast<unsigned>(z.hash & 0xffffffffu), static_cast<unsigned>(z.hash >> 32), z.tiles / repeats,
      z.decode_us / z.tiles, z.inflate_us / z.tiles, z.hash == d.hash ? "true" : "false", d.decode_us / d.tiles,
      d.inflate_us / d.tiles, v.decode_us / v.tiles, v.hash == z.hash ? "true" : "false");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  if (argc < 2) {
    std::fprintf(stderr, "usage: btflod-web-tool materials|reference|compare|decode [--option value]...\n");
    return 2;
  }
  a.command = argv[1];
  samples::Arguments parser("btflod-web-tool " + a.command, argc - 1, argv + 1);
  a.parser = &parser;
  int status = 0;
  if (a.command == "materials")
    status = cmd_materials(a);
  else if (a.command == "reference")
    status = cmd_reference(a);
  else if (a.command == "compare")
    status = cmd_compare(a);
  else if (a.command == "decode")
    status = cmd_decode(a);
  else if (a.command == "pcak")
    status = cmd_pcak(a);
  else
    return fail("unknown command " + a.command);
  return parser.finish(0) ? status : 2;
}
