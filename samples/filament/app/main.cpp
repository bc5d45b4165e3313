// btflod-filament — btflod's streamed BTF materials inside Google's Filament engine (OpenGL
// backend, headless). Everything an engine does to adopt btflod is in this file:
//
//   1. at build time, btflod's Filament target writes the material sources (matgen.cpp, with
//      runtime/shader/filament_material.hpp) and Filament's matc compiles them (CMakeLists.txt);
//   2. at load time, one btflod::Streamer serves every .bsvtf material of the world; its
//      gpu_layout() gives the shapes of the textures the materials read (tile cache, page
//      table, U′) and each container's directions give its angular lookup tables;
//   3. per frame: Streamer::update(last frame's feedback words) → tiles, U′ packets and
//      page-table texels copied with Texture::setImage (sub-rectangles; tiles before U′ before
//      page table, forward_streamer_outputs' order); decode jobs run on worker threads;
//      Filament draws the colour view and a small feedback view whose material packs each
//      pixel's feedback word into RGBA8; its readback lands in a polled ring (never waited on)
//      and the newest words go into the next update().
//
// Filament boilerplate (engine, views, meshes, readback) is in filament_host.cpp; the comparison
// with btflod's CPU reference (--check) in reference_check.cpp. --check also draws the floor once
// with the fmf material (a resident material: V′ from an ordinary texture) and checks it.
//
// usage: btflod-filament FLOOR.bsvtf SPHERE.bsvtf WALL.bsvtf [--out DIR] [--frames N] [--check]
//                        [--cache-format rgba16f|rgba8|bc5]
// (one material per shape of the scene: the floor, the sphere, the wall)
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <math/vec4.h>

#include "btflod/core/file_io.hpp"
#include "btflod/offline/btf/image_io.hpp"
#include "btflod/offline/render/primitives.hpp"
#include "btflod/runtime/angular/bsvtf_angular_tables.hpp"
#include "btflod/runtime/backend/streamer_outputs.hpp"
#include "btflod/runtime/shader/filament_material.hpp"
#include "btflod/runtime/stream/file_source.hpp"
#include "btflod/runtime/stream/thread_executor.hpp"
#include "btflod/runtime/streamer.hpp"
#include "common/arguments.hpp"
#include "filament_host.hpp"
#include "procedural_materials.hpp"
#include "reference_check.hpp"
#include "sample_config.hpp"

using namespace btflod;
using filament::Texture;
using filament::TextureSampler;
namespace fm = filament::math;

namespace {

constexpr uint32_t kWidth = 256, kHeight = 192, kDecimation = 4;  // small: llvmpipe draws every pixel
constexpr double kMinPsnr = 60.0;                                 // --check bound: 95 dB measured (docs/filament.md)
constexpr float kLodBias = -1.0f;  // finer than the pixel footprint (the check view magnifies)
const glm::vec3 kToLight = glm::normalize(glm::vec3(-0.5f, 0.8f, 0.4f)), kLightColor(1.6f, 1.3f, 1.1f);
const glm::vec3 kCheckEye(0.3f, 1.1f, 2.6f), kCheckTarget(0.45f, 0.0f, 1.9f);  // sees only the floor

// The world: the demo scene's floor, sphere and wall, each with one material (index = Streamer
// material). The same shapes, ray-cast, are the CPU reference's scene (reference_check.cpp).
struct WorldShape {
  TriangleMeshData mesh;
  btflod::Shape cpu;
};
std::vector<WorldShape> world_shapes() {
  const glm::vec3 corner(-4, 0, 4), x(1, 0, 0), back(0, 0, -1), up(0, 1, 0), wall(-2, 0, -2.5f);
  return {{make_quad(corner, 8.0f * x, 8.0f * back, {4, 4}, 8), btflod::Shape::plane(0, corner, x, back, 8, 8, {4, 4})},
          {make_uv_sphere({0, 0.8f, -1}, 0.8f, 48, 24, {4, 2}), btflod::Shape::sphere(1, {0, 0.8f, -1}, 0.8f, {4, 2})},
          {make_quad(wall, 4.0f * x, 2.0f * up, {2, 1}, 4), btflod::Shape::plane(2, wall, x, up, 4, 2, {2, 1})}};
}

// The camera flies from above the scene down to the check view over the first 3/4 of the frames.
void camera_at(uint32_t frame, uint32_t frames, glm::vec3& eye, glm::vec3& target) {
  const float t = std::min(1.0f, static_cast<float>(frame) / (0.75f * static_cast<float>(frames)));
  const float s = t * t * (3.0f - 2.0f * t);
  eye = glm::mix(glm::vec3(-2.5f, 2.4f, 4.5f), kCheckEye, s) + glm::vec3(0.8f * std::sin(s * 3.14159f), 0, 0);
  target = glm::mix(glm::vec3(0.0f, 0.6f, -1.0f), kCheckTarget, s);
}

// The CPU reference's twins of the scene and the camera (--check).
btflod::Scene cpu_scene(const std::vector<WorldShape>& shapes) {
  btflod::Scene scene;
  for (const WorldShape& s : shapes) scene.add(s.cpu);
  return scene;
}
btflod::Camera check_camera(glm::vec3 eye, glm::vec3 target) {
  btflod::Camera cam;
  cam.position = eye;
  cam.target = target;
  cam.fov_y_degrees = 45.0f;
  cam.width = kWidth;
  cam.height = kHeight;
  return cam;
}

// One btflod material on the GPU: U′ (eigen-ABRDFs, filled by the Streamer's packets), angular
// tables, and the two Filament material instances that draw it.
struct GpuMaterial {
  BsvtfAngularTables angular;
  Texture* eigen_abrdfs = nullptr;  // RGBA32F 2D array: texel (light, view), layer = component
  Texture* angular_index = nullptr;
  Texture* angular_weight = nullptr;
  filament::MaterialInstance* color = nullptr;
  filament::MaterialInstance* feedback = nullptr;
};

bool write_frame(const std::string& path, const std::vector<float>& rgba) {
  Image<float> img(kWidth, kHeight, 4);
  std::copy(rgba.begin(), rgba.end(), img.view().data());
  return write_png_srgb(path, img.view()).ok();
}

}  // namespace

int main(int argc, char** argv) {
  btflod::samples::Arguments args("btflod-filament", argc, argv);
  const std::string out_dir = args.string("out", ".");
  const uint32_t frames = args.integer_as<uint32_t>("frames", 48, 4, 100000);
  const bool check = args.flag("check");
  // --cache-format rgba8: the compact tile cache (RGBA8 texels, each slot's affine map in an
  // RGBA32UI slot-map texture; its own bsvtf material). bc5 asks for the block-compressed cache
  // (runtime/vt/cache_bc5.hpp), which Filament 1.9 cannot hold: its Texture::InternalFormat and
  // CompressedPixelDataType list EAC/ETC2, DXT1–5 (S3TC) and ASTC but no RGTC (BC4/BC5), so a
  // bc5 request keeps the rgba8 cache (the same slot maps at twice the bytes) and says so.
  const size_t format_choice = args.choice("cache-format", {"rgba16f", "rgba8", "bc5"}).value_or(0);
  const bool compact = format_choice != 0;
  if (format_choice == 2)
    std::printf(
        "btflod-filament: cache format bc5 falls back to rgba8: Filament 1.9 has no RGTC (BC5) texture format\n");
  const bool parsed = args.finish(3);
  const std::vector<std::string>& paths = args.positional();
  if (!parsed || paths.size() != 3)
    return std::fprintf(
               stderr,
               "usage: btflod-filament FLOOR.bsvtf SPHERE.bsvtf WALL.bsvtf [--out DIR] [--frames N ≥ 4] [--check]\n"
               "                       [--cache-format rgba16f|rgba8|bc5]\n"),
           2;

  std::filesystem::create_directories(out_dir);

  // --- Filament, and the materials matc compiled from btflod's generated sources ---------------
  host::Host h;
  if (!host::create(h, kWidth, kHeight, kWidth / kDecimation, kHeight / kDecimation)) return 77;  // test: skipped
  filament::Engine& engine = *h.engine;
  filament::Material* bsvtf_material = host::load_material(
      h, compact ? BTFLOD_FILAMATS_DIR "/btflod_bsvtf_rgba8.filamat" : BTFLOD_FILAMATS_DIR "/btflod_bsvtf.filamat");
  filament::Material* feedback_material = host::load_material(h, BTFLOD_FILAMATS_DIR "/btflod_feedback.filamat");
  if (!bsvtf_material || !feedback_material) return 1;
  // (The feedback target is cleared to 0; the feedback material writes word ^ empty word, so a
  // pixel no material covers reads back as the empty word.)

  // --- one Streamer for the world's .bsvtf files ----------------------------------------------
  // What the .filamat files were generated for.
  const ShaderConfig shader = sample::shader_config(compact ? CacheFormat::rgba8_affine : CacheFormat::rgba16f);
  std::vector<BsvtfDirectory> directories;
  std::vector<std::unique_ptr<FileSource>> sources;
  for (const std::string& p : paths) {
    auto bytes = read_file_bytes(p);  // the directory: the file's first bytes (small files: all of it)
    auto dir = bytes ? read_bsvtf(*bytes) : Result<BsvtfDirectory>(bytes.error());
    auto src = FileSource::open(p);
    if (!dir || !src)
      return std::fprintf(stderr, "%s: %s\n", p.c_str(), (dir ? src.message() : dir.message()).c_str()), 1;
    if (dir->metadata.component_count != shader.components)  // C is compiled into the material
      return std::fprintf(stderr, "%s: C = %u, the material was generated for C = %u\n", p.c_str(),
                          dir->metadata.component_count, shader.components),
             1;
    directories.push_back(std::move(*dir));
    sources.push_back(std::move(*src));
  }
  std::vector<StreamerMaterial> world;
  for (size_t i = 0; i < paths.size(); ++i) world.push_back({&directories[i], sources[i].get(), nullptr});
  StreamerConfig config;
  config.cache = shader.vt;  // the shaders' cache shape is the Streamer's
  config.scheduler.budgets.uploads_per_frame = 32;
  config.vote_window_frames = 2;
  config.decode_workers = 2;
  auto created = Streamer::create(world, config);
  if (!created) return std::fprintf(stderr, "streamer: %s\n", created.message().c_str()), 1;
  Streamer streamer = std::move(*created);

  // --- the textures the generated shaders read, shaped by gpu_layout() -------------------------
  const StreamerGpuLayout layout = streamer.gpu_layout();
  Texture* cache =
      host::create_array_texture(engine, layout.cache_width, layout.cache_height, layout.cache_layers,
                                 compact ? Texture::InternalFormat::RGBA8 : Texture::InternalFormat::RGBA16F);
  // The compact cache's per-slot affine maps: one RGBA32UI texel per slot (cache_slot_map_texel).
  Texture* slot_map = nullptr;
  if (compact) {
    slot_map = Texture::Builder()
                   .width(cache_slot_map_width(shader.vt))
                   .height(cache_slot_map_height(shader.vt))
                   .sampler(Texture::Sampler::SAMPLER_2D)
                   .format(Texture::InternalFormat::RGBA32UI)
                   .build(engine);
  }
  Texture* page_table = Texture::Builder()
                            .width(layout.page_table_width)
                            .height(layout.page_table_height)
                            .depth(layout.page_table_layers)
                            .levels(static_cast<uint8_t>(layout.page_table_levels))
                            .sampler(Texture::Sampler::SAMPLER_2D_ARRAY)
                            .format(Texture::InternalFormat::R32UI)
                            .build(engine);
  for (uint32_t mip = 0; mip < layout.page_table_levels; ++mip) {  // entry 0 until the Streamer writes one
    const uint32_t w = std::max(1u, layout.page_table_width >> mip), hh = std::max(1u, layout.page_table_height >> mip);
    const std::vector<uint32_t> zeros(size_t{w} * hh * layout.page_table_layers, 0u);
    host::set_image(h, page_table, mip, 0, 0, 0, w, hh, layout.page_table_layers, zeros.data(), zeros.size() * 4,
                    Texture::Format::R_INTEGER, Texture::Type::UINT);
  }
  const TextureSampler nearest(TextureSampler::MinFilter::NEAREST, TextureSampler::MagFilter::NEAREST);
  const TextureSampler bilinear(TextureSampler::MinFilter::LINEAR, TextureSampler::MagFilter::LINEAR);
  const auto param = [](ShaderBinding role) { return filament_sampler_parameter(role); };

  std::vector<GpuMaterial> gpu(paths.size());
  for (uint32_t m = 0; m < gpu.size(); ++m) {
    GpuMaterial& g = gpu[m];
    auto tables = build_bsvtf_angular_tables(directories[m].metadata, shader.angular);
    if (!tables) return std::fprintf(stderr, "%s: %s\n", paths[m].c_str(), tables.message().c_str()), 1;
    g.angular = std::move(*tables);
    const uint32_t res = shader.angular.resolution;
    g.angular_index = host::create_array_texture(engine, res, res, 2, Texture::InternalFormat::RGBA32UI);
    g.angular_weight = host::create_array_texture(engine, res, res, 2, Texture::InternalFormat::RGBA32F);
    host::set_image(h, g.angular_index, 0, 0, 0, 0, res, res, 2, g.angular.index_rgba.data(),
                    g.angular.index_rgba.size() * 4, Texture::Format::RGBA_INTEGER, Texture::Type::UINT);
    host::set_image(h, g.angular_weight, 0, 0, 0, 0, res, res, 2, g.angular.weight_rgba.data(),
                    g.angular.weight_rgba.size() * 4, Texture::Format::RGBA, Texture::Type::FLOAT);
    g.eigen_abrdfs = host::create_array_texture(engine, g.angular.light_count, g.angular.view_count, shader.components,
                                                Texture::InternalFormat::RGBA32F);
    // Per instance (= per btflod material), ShaderParams' values: vt_extent = (M, N, L_m),
    // lod = (bias, log2(screen / feedback size)), ids = (first page-table layer, feedback id).
    const BsvtfMetadata& md = directories[m].metadata;
    g.color = bsvtf_material->createInstance();
    g.feedback = feedback_material->createInstance();
    for (filament::MaterialInstance* mi : {g.color, g.feedback}) {
      mi->setParameter(kFilamentParamVtExtent, fm::float4(md.width, md.height, md.level_count - 1, 0));
      mi->setParameter(kFilamentParamLod, fm::float4(kLodBias, std::log2(float(kDecimation)), 1, 0));
      mi->setParameter(kFilamentParamIds, fm::uint4(streamer.first_texture(m), m, 0, 0));
      mi->setParameter(param(ShaderBinding::page_table).c_str(), page_table, nearest);
    }
    g.color->setParameter(kFilamentParamLight, fm::float4(kToLight.x, kToLight.y, kToLight.z, 0));  // w = 0: direction
    g.color->setParameter(kFilamentParamLightColor, fm::float4(kLightColor.x, kLightColor.y, kLightColor.z, 1));
    g.color->setParameter(param(ShaderBinding::tile_cache).c_str(), cache, bilinear);
    if (slot_map != nullptr) g.color->setParameter(param(ShaderBinding::slot_map).c_str(), slot_map, nearest);
    g.color->setParameter(param(ShaderBinding::eigen_abrdfs).c_str(), g.eigen_abrdfs, nearest);
    g.color->setParameter(param(ShaderBinding::angular_index).c_str(), g.angular_index, nearest);
    g.color->setParameter(param(ShaderBinding::angular_weight).c_str(), g.angular_weight, nearest);
  }
  const std::vector<WorldShape> shapes = world_shapes();
  for (const WorldShape& s : shapes) host::add_mesh(h, s.mesh, gpu[s.cpu.material].color, gpu[s.cpu.material].feedback);

  // --- caller-owned outputs, sized once ---------------------------------------------------------
  std::vector<StreamerTileUpload> tiles(streamer.tile_uploads_bound());
  std::vector<StreamerPacketUpload> packets(streamer.packet_uploads_bound());
  std::vector<PageTableWrite> writes(4096);
  std::vector<ResidencyEvent> events(64);
  std::vector<float> u_layers;  // one U′ packet as RGBA layers
  std::vector<uint8_t> feedback_rgba;
  std::vector<uint32_t> words;  // last frame's feedback, the next update()'s input
  std::vector<float> color;
  std::vector<const BsvtfAngularTables*> tables;
  for (const GpuMaterial& g : gpu) tables.push_back(&g.angular);
  sample::ReferenceCheck reference(streamer, tables);

  // --- the frame loop -----------------------------------------------------------------------------
  // Decode jobs on two threads (an engine hands them to its own workers: StreamerOutputs::runnable_jobs).
  auto workers = std::make_unique<ThreadExecutor>(streamer.jobs(), 2);
  uint64_t uploads = 0, quiet_frames = 0, feedback_images = 0;
  bool ok = true;
  uint32_t frame = 0;
  const uint32_t max_frames = frames + 400;  // the camera stops at `frames`; then wait for convergence
  for (; frame < max_frames; ++frame) {
    StreamerOutputs out{tiles, packets, writes, events};
    if (streamer.update(words, out) != Status::success) return std::fprintf(stderr, "update failed\n"), 1;
    const Status applied = forward_streamer_outputs(
        out,
        [&](std::span<const TileUpload> batch) noexcept {  // each tile into its slot of the cache
          for (const TileUpload& t : batch) {
            const SlotPlacement at = slot_placement(shader.vt, t.slot);
            const uint32_t n = shader.vt.padded_tile_size();  // T + 2B, border included
            if (compact) {
              host::set_image(h, cache, 0, at.x, at.y, at.layer, n, n, 1, t.unorm8.data(), t.unorm8.size_bytes(),
                              Texture::Format::RGBA, Texture::Type::UBYTE);
              const std::array<uint32_t, 4> map = pack_cache_slot_map(t.map);
              const CacheSlotMapTexel m = cache_slot_map_texel(shader.vt, t.slot);
              host::set_image_2d(h, slot_map, m.x, m.y, 1, 1, map.data(), sizeof(map), Texture::Format::RGBA_INTEGER,
                                 Texture::Type::UINT);
            } else {
              host::set_image(h, cache, 0, at.x, at.y, at.layer, n, n, 1, t.texels.data(), t.texels.size_bytes(),
                              Texture::Format::RGBA, Texture::Type::HALF);
            }
          }
          return Status::success;
        },
        [&](std::span<const PageTableWrite> texels) noexcept {  // one R32UI texel each
          for (const PageTableWrite& w : texels)
            host::set_image(h, page_table, w.page_mip, w.tile.x, w.tile.y, w.tile.texture, 1, 1, 1, &w.entry, 4,
                            Texture::Format::R_INTEGER, Texture::Type::UINT);
          return Status::success;
        },
        [&](const StreamerPacketUpload& p) noexcept {  // U′ components 4g … 4g+3 as texture layers
          GpuMaterial& g = gpu[p.material];
          u_layers.resize(size_t{g.angular.light_count} * g.angular.view_count * 4 * 4);
          const uint32_t n = u_packet_to_rgba_layers(to_u_packet_upload(p), g.angular.light_count, g.angular.view_count,
                                                     shader.components, u_layers);
          if (n == 0) return Status::invalid_argument;
          host::set_image(h, g.eigen_abrdfs, 0, 0, 0, 4 * p.packet, g.angular.light_count, g.angular.view_count, n,
                          u_layers.data(), size_t{g.angular.light_count} * g.angular.view_count * n * 16,
                          Texture::Format::RGBA, Texture::Type::FLOAT);
          return Status::success;
        });
    if (applied != Status::success) return std::fprintf(stderr, "upload failed: %s\n", status_name(applied)), 1;
    if (check) reference.mirror(out);  // the CPU reference sees what the GPU got
    for (size_t i = 0; i < out.event_count; ++i)
      if (events[i].kind == ResidencyEventKind::material_failed)
        return std::fprintf(stderr, "material %u failed: %s\n", events[i].material, status_name(events[i].status)), 1;
    uploads += out.tile_upload_count;

    // Draw: both views with this frame's camera; the feedback image comes back as words.
    glm::vec3 eye, target;
    camera_at(frame, frames, eye, target);
    host::set_camera(h, eye, target, {0, 1, 0}, 45.0f);
    const bool keep = frame % 16 == 0 || (check && frame == frames / 3);  // frames to write or check
    words.clear();                                                        // no feedback landed this frame: no new votes
    if (host::render(h, feedback_rgba, keep ? &color : nullptr)) {        // the readback ring, polled
      ++feedback_images;
      words.resize(size_t{h.feedback_width} * h.feedback_height);
      feedback_words_from_rgba8(feedback_rgba, h.feedback_width, h.feedback_height, false, words,
                                shader.vt.feedback.empty_word);
    }
    if (keep) write_frame(out_dir + "/frame_" + std::to_string(frame) + ".png", color);
    if (check && frame == frames / 3)  // mid-flight: many levels, three shapes, silhouettes
      ok = reference.compare_feedback("mid-flight", cpu_scene(shapes), check_camera(eye, target), kLodBias, words,
                                      kDecimation, 0.95, 0.005) &&
           ok;

    // Converged: the camera stopped, nothing was uploaded or written for 4 frames and no job runs.
    const bool quiet = out.tile_upload_count == 0 && out.page_table_write_count == 0 && streamer.idle();
    quiet_frames = quiet ? quiet_frames + 1 : 0;
    if (frame >= frames && quiet_frames >= 4) break;
  }
  workers.reset();  // joins the threads; no job runs after this
  const StreamerStats st = streamer.stats();
  std::printf(
      "btflod-filament: %u frames, %llu feedback images landed, %llu tile uploads, %u of %u slots used, "
      "%llu bytes read, converged: %s\n",
      frame + 1, static_cast<unsigned long long>(feedback_images), static_cast<unsigned long long>(uploads),
      st.slots_used, st.slots, static_cast<unsigned long long>(st.bytes_read), frame < max_frames ? "yes" : "no");
  ok = frame < max_frames && ok;

  // The converged frame at the check view, and (--check) the CPU reference of the same view.
  host::render(h, feedback_rgba, &color);  // waits: this frame's colour and feedback
  words.resize(size_t{h.feedback_width} * h.feedback_height);
  feedback_words_from_rgba8(feedback_rgba, h.feedback_width, h.feedback_height, false, words,
                            shader.vt.feedback.empty_word);
  write_frame(out_dir + "/converged.png", color);
  if (check)
    ok = reference.run(cpu_scene(shapes), check_camera(kCheckEye, kCheckTarget), kToLight, kLightColor, kLodBias, color,
                       words, kDecimation, kMinPsnr, out_dir) &&
         ok;

  // A resident (not streamed) material uses the fmf material: the same U′ and angular tables, V′
  // from an ordinary filtered texture (⌈C/4⌉ RGBA layers, repeat). Shown (and checked) on the
  // floor with its own eigen-textures, which the offline step made the .bsvtf from.
  filament::Material* fmf_material = nullptr;
  filament::MaterialInstance* fmf = nullptr;
  Texture* eigen_textures = nullptr;
  if (check) {
    std::vector<float> directions;
    const EigenTextures floor = sample::make_eigen(0, directions);
    const std::vector<float> v = pack_eigen_textures_rgba(floor.textures.view());
    const uint32_t groups = shader.component_groups();
    eigen_textures =
        host::create_array_texture(engine, sample::kTexels, sample::kTexels, groups, Texture::InternalFormat::RGBA32F);
    host::set_image(h, eigen_textures, 0, 0, 0, 0, sample::kTexels, sample::kTexels, groups, v.data(), v.size() * 4,
                    Texture::Format::RGBA, Texture::Type::FLOAT);
    fmf_material = host::load_material(h, BTFLOD_FILAMATS_DIR "/btflod_fmf.filamat");
    if (!fmf_material) return 1;
    fmf = fmf_material->createInstance();
    const BsvtfMetadata& md = directories[0].metadata;
    fmf->setParameter(kFilamentParamVtExtent, fm::float4(md.width, md.height, md.level_count - 1, 0));
    fmf->setParameter(kFilamentParamLod, fm::float4(kLodBias, 0, 1, 0));
    fmf->setParameter(kFilamentParamIds, fm::uint4(0, 0, 0, 0));
    fmf->setParameter(kFilamentParamLight, fm::float4(kToLight.x, kToLight.y, kToLight.z, 0));
    fmf->setParameter(kFilamentParamLightColor, fm::float4(kLightColor.x, kLightColor.y, kLightColor.z, 1));
    fmf->setParameter(param(ShaderBinding::eigen_abrdfs).c_str(), gpu[0].eigen_abrdfs, nearest);
    fmf->setParameter(param(ShaderBinding::angular_index).c_str(), gpu[0].angular_index, nearest);
    fmf->setParameter(param(ShaderBinding::angular_weight).c_str(), gpu[0].angular_weight, nearest);
    const TextureSampler repeat(TextureSampler::MinFilter::LINEAR, TextureSampler::MagFilter::LINEAR,
                                TextureSampler::WrapMode::REPEAT);
    fmf->setParameter(param(ShaderBinding::eigen_textures).c_str(), eigen_textures, repeat);
    host::set_color_material(h, 0, fmf);
    host::render(h, feedback_rgba, &color);
    write_frame(out_dir + "/fmf.png", color);
    ok = reference.run_fmf(cpu_scene(shapes), check_camera(kCheckEye, kCheckTarget), kToLight, kLightColor, 0,
                           floor.textures, color, kMinPsnr, out_dir) &&
         ok;
  }
  host::destroy_meshes(h);  // the renderables use the instances, the instances the textures
  for (GpuMaterial& g : gpu) {
    engine.destroy(g.color);
    engine.destroy(g.feedback);
    for (Texture* t : {g.eigen_abrdfs, g.angular_index, g.angular_weight}) engine.destroy(t);
  }
  if (fmf) engine.destroy(fmf);
  if (fmf_material) engine.destroy(fmf_material);
  if (eigen_textures) engine.destroy(eigen_textures);
  engine.destroy(cache);
  engine.destroy(page_table);
  if (slot_map != nullptr) engine.destroy(slot_map);
  engine.destroy(bsvtf_material);
  engine.destroy(feedback_material);
  host::destroy(h);
  std::printf("btflod-filament: %s\n", ok ? "ok" : "FAILED");
  return ok ? 0 : 1;
}
