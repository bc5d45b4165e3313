// Golden-image cases shared by test_golden_gl.cpp and test_golden_vk.cpp: the same scene (a
// tilted plane, perspective camera, directional light) rendered by a GPU backend and by the CPU
// reference of offline/render/cpu_reference.hpp (ray-cast Scene + Camera, CpuCacheTexture sampled
// through the vt/ TileCache page table, shade_fmf's 9-tap eq. 5) must agree: PSNR ≥ 40 dB at
// 256×256, for FMF and for BSVTF with a partially filled cache. The view magnifies the texture
// everywhere (with a negative LOD bias), so the GPU's desired level is the finest one and both
// renderers read the deepest resident tile — the CPU reference's rule.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "btflod/offline/build/tile_pyramid.hpp"
#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/runtime/backend/page_table_writes.hpp"
#include "btflod/runtime/vt/cache_bc5.hpp"
#include "btflod/runtime/vt/tile_cache.hpp"
#include "test_shader_backend_cases.hpp"
#include "test_shader_scene.hpp"

namespace btflod::golden {

using namespace btflod::test_scene;

inline constexpr int kTexture = 256;  // M = N; T = 64 → finest level 2

/// The backend cases' FMF configuration (parabolic map, barycentric lookup, T = 64, B = 4) with
/// C = 8 and a single-layer 6 × 6 cache sampled trilinearly.
inline ShaderConfig golden_config() {
  ShaderConfig c = backend_cases::default_fmf_config();
  c.components = 8;
  c.vt.slots_x = c.vt.slots_y = 6;
  c.vt.cache_layers = 1;
  c.vt.trilinear = true;
  return c;
}

/// The plane: origin corner, axes u (→ uv.x) and v (→ uv.y), 2 × 2 units, tilted towards the camera.
struct PlaneSetup {
  glm::vec3 origin{-1.0f, -1.0f, 0.0f};
  glm::vec3 axis_u{1.0f, 0.0f, 0.0f};
  glm::vec3 axis_v = glm::normalize(glm::vec3(0.0f, 0.94f, -0.34f));
  float size = 2.0f;
};

inline Camera golden_camera() {
  Camera cam;
  cam.position = glm::vec3(0.25f, -0.1f, 1.6f);
  cam.target = glm::vec3(0.05f, 0.05f, -0.2f);
  cam.up = glm::vec3(0.0f, 1.0f, 0.0f);
  cam.fov_y_degrees = 45.0f;
  cam.width = kSize;
  cam.height = kSize;
  return cam;
}

inline ShaderParams golden_params(const Camera& cam) {
  ShaderParams p;
  const glm::mat4 proj = glm::perspective(degrees_to_radians(cam.fov_y_degrees), 1.0f, 0.05f, 50.0f);
  p.model_view_proj = proj * glm::lookAt(cam.position, cam.target, cam.up);
  p.model = glm::mat4(1.0f);
  p.camera_pos = glm::vec4(cam.position, 1.0f);
  p.light = glm::vec4(glm::normalize(glm::vec3(-0.5f, 0.4f, 0.8f)), 0.0f);
  p.light_color = glm::vec4(1.6f, 1.2f, 1.0f, 1.0f);
  p.vt_extent = glm::vec4(kTexture, kTexture, 2, 0);
  p.lod.x = -1.5f;  // LOD bias: finer than the pixel footprint everywhere (λ clamps to L)
  return p;
}

/// The plane as a mesh with the frame the CPU reference uses (t = u axis, n = u × v, b = v).
inline void plane_mesh(const PlaneSetup& s, std::vector<MeshVertex>& v, std::vector<uint32_t>& idx) {
  const glm::vec3 n = glm::normalize(glm::cross(s.axis_u, s.axis_v));
  const float c[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  v.clear();
  for (const auto& k : c) {
    const glm::vec3 p = s.origin + k[0] * s.size * s.axis_u + k[1] * s.size * s.axis_v;
    v.push_back(MeshVertex{{p.x, p.y, p.z}, {n.x, n.y, n.z}, {s.axis_u.x, s.axis_u.y, s.axis_u.z, 1.0f}, {k[0], k[1]}});
  }
  idx = {0, 1, 2, 0, 2, 3};
}

/// The plane of PlaneSetup{} uploaded to a backend.
inline Result<MeshHandle> create_plane_mesh(Backend& be) {
  std::vector<MeshVertex> verts;
  std::vector<uint32_t> idx;
  plane_mesh(PlaneSetup{}, verts, idx);
  return be.create_mesh(MeshData{verts, idx});
}

/// The eigen-textures (V′, U′ and its shape) of an FMF material, in `transform`'s encoding.
inline EigenTextures eigen_textures_of(const Material& m, ValueTransform transform = {}) {
  EigenTextures e;
  e.textures = m.v;
  e.angular = m.u;
  e.light_count = m.lights;
  e.view_count = m.views;
  e.transform = transform;
  return e;
}

/// CPU reference image of the golden plane: shade(hit, wl, wv) → rgb, times the light colour.
template <class Shade>
Image<float> cpu_render_with(const ShaderParams& p, Shade&& shade) {
  const PlaneSetup s;
  Scene scene;
  scene.add(Shape::plane(0, s.origin, s.axis_u, s.axis_v, s.size, s.size));
  const Camera cam = golden_camera();
  Image<float> out(kSize, kSize, 4, 0.0f);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const SurfaceHit h = scene.intersect(cam.ray(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f));
      if (!h.hit) continue;
      const glm::vec3 wl = to_local(h, glm::normalize(glm::vec3(p.light)));
      const glm::vec3 wv = to_local(h, glm::normalize(glm::vec3(p.camera_pos) - h.position));
      const glm::vec3 rgb = shade(h, wl, wv) * glm::vec3(p.light_color);
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = rgb[c];
      out.at(x, y, 3) = 1.0f;
    }
  return out;
}

/// CPU reference image: ray-cast the plane, V' from `sample_v(hit, out[C])`, eq. 5 with the
/// shader's angular lookup (test_scene::lookup), times the light colour. Background 0.
/// `used` > 0: eq. 5 over the first `used` components only.
template <class SampleV>
Image<float> cpu_render(const Material& m, const ShaderParams& p, SampleV&& sample_v, ValueTransform transform = {},
                        uint32_t used = 0) {
  const EigenTextures e = eigen_textures_of(m, transform);
  std::vector<float> comps(m.config.components);
  return cpu_render_with(p, [&](const SurfaceHit& h, const glm::vec3& wl, const glm::vec3& wv) {
    sample_v(h, comps.data());
    AngularSample ls, vs;
    lookup(m, m.light_index, m.light_weight, wl, ls.index.data(), ls.weight.data());
    lookup(m, m.view_index, m.view_weight, wv, vs.index.data(), vs.weight.data());
    const std::span<const float> shaded(comps.data(), used > 0 ? std::min<size_t>(used, comps.size()) : comps.size());
    return shade_fmf(e, ls, vs, shaded);
  });
}

/// A kSize × kSize frame with 32 × 32 feedback.
inline FrameDesc backend_frame() { return backend_cases::frame_desc(); }

/// One frame of `program` drawing `material` on `mesh`; returns the colour target. Every step
/// must succeed.
inline Image<float> render_frame(Backend& be, ShaderProgram program, MeshHandle mesh, MaterialHandle material,
                                 const ShaderParams& params) {
  Image<float> img(kSize, kSize, 4);
  EXPECT_EQ(be.begin_frame(backend_frame()), Status::success);
  EXPECT_EQ(be.draw(program, mesh, material, params), Status::success);
  EXPECT_EQ(be.end_frame(), Status::success);
  EXPECT_EQ(be.read_color(img.view()), Status::success);
  return img;
}

/// As render_frame(), but every step is asserted: the image goes to `img`, and a failed step is a
/// fatal failure (callers return on HasFatalFailure()).
inline void assert_render_frame(Backend& be, ShaderProgram program, MeshHandle mesh, MaterialHandle material,
                                const ShaderParams& params, Image<float>& img) {
  ASSERT_EQ(be.begin_frame(backend_frame()), Status::success);
  ASSERT_EQ(be.draw(program, mesh, material, params), Status::success);
  ASSERT_EQ(be.end_frame(), Status::success);
  ASSERT_EQ(be.read_color(img.view()), Status::success);
}

/// What the golden cases are given: a GPU backend, or null with the reason in `why`.
using BackendFactory = std::unique_ptr<Backend> (*)(std::string& why);

/// A backend from `make`, initialised for `config` with `virtual_textures` page-table layers.
/// Null when the GPU API is not available (the test is then skipped with the reason) or init()
/// fails (a fatal failure); callers return on null.
inline std::unique_ptr<Backend> start_backend(BackendFactory make, const ShaderConfig& config,
                                              uint32_t virtual_textures) {
  std::string why;
  std::unique_ptr<Backend> be = make(why);
  if (!be) {
    [&] { GTEST_SKIP() << "GPU API unavailable: " << why; }();
    return nullptr;
  }
  if (const VoidResult r = be->init(config, virtual_textures); !r) {
    [&] { FAIL() << "init(config, " << virtual_textures << ") failed: " << r.message(); }();
    return nullptr;
  }
  return be;
}

/// The plane of PlaneSetup{} and an FMF material of `m` (U′ and V′, no mip chain) created on
/// `be`, each asserted; `prepare(d)` may change the material data (and try it on `be`) first.
template <class Prepare>
void create_fmf_plane(Backend& be, const Material& m, Result<MeshHandle>& mesh, Result<MaterialHandle>& mat,
                      Prepare&& prepare) {
  mesh = create_plane_mesh(be);
  ASSERT_TRUE(mesh.ok()) << mesh.message();
  FmfMaterialData d = m.data(true);
  d.mipmaps = false;
  prepare(d);
  mat = be.create_material(d);
  ASSERT_TRUE(mat.ok()) << mat.message();
}

/// V′ of an FMF material as the GPU samples it: bilinear with repeat at the finest level on
/// both sides (no mip chain on the GPU). For cpu_render(); `m` must outlive the sampler.
inline auto finest_v_sampler(const Material& m) {
  return [&m](const SurfaceHit& h, float* out) {
    bilinear(m.v, h.texcoord.x * kTexture, h.texcoord.y * kTexture, true, out);
  };
}

/// A blank or flat image must not pass: mean and spread of the rgb values.
inline void expect_content(const Image<float>& img) {
  double sum = 0, sq = 0;
  size_t n = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < 3; ++c, ++n) {
        sum += img.at(x, y, c);
        sq += static_cast<double>(img.at(x, y, c)) * img.at(x, y, c);
      }
  const double mean = sum / static_cast<double>(n);
  EXPECT_GT(mean, 0.05);
  EXPECT_GT(sq / static_cast<double>(n) - mean * mean, 1e-4);
}

/// The check of a golden image `img` against its CPU reference `ref` and a `wrong` reference (what
/// a renderer with a known mistake draws): both images have content, `img` matches `ref` at
/// PSNR ≥ 40 dB and is at least 3 dB further from `wrong`. Returns the two PSNRs (ref, wrong).
struct GoldenPsnr {
  double ref, wrong;
};
inline GoldenPsnr expect_golden_match(const Image<float>& ref, const Image<float>& img, const Image<float>& wrong) {
  expect_content(ref);
  expect_content(img);
  const GoldenPsnr p{psnr_rgb(ref, img), psnr_rgb(wrong, img)};
  EXPECT_GE(p.ref, 40.0);
  EXPECT_LT(p.wrong, p.ref - 3.0);
  return p;
}

/// FMF: V' bilinear with repeat at the finest level on both sides (no mip chain on the GPU).
inline void golden_fmf(BackendFactory make) {
  const ShaderConfig config = golden_config();
  const std::unique_ptr<Backend> be = start_backend(make, config, 2);
  if (!be) return;
  const Material m = make_material(config, kTexture, kTexture);
  Result<MeshHandle> mesh = MeshHandle{};
  Result<MaterialHandle> mat = MaterialHandle{};
  create_fmf_plane(*be, m, mesh, mat, [](const FmfMaterialData&) {});
  if (::testing::Test::HasFatalFailure()) return;
  const ShaderParams params = golden_params(golden_camera());
  Image<float> img(kSize, kSize, 4);
  assert_render_frame(*be, ShaderProgram::fmf, *mesh, *mat, params, img);
  if (::testing::Test::HasFatalFailure()) return;
  const Image<float> ref = cpu_render(m, params, finest_v_sampler(m));
  expect_content(ref);
  expect_content(img);
  const double psnr = psnr_rgb(ref, img);
  std::printf("[ %s ] golden FMF vs CPU reference: PSNR %.2f dB\n", be->name(), psnr);
  EXPECT_GE(psnr, 40.0);
}

/// The first `components` of a material: U′ columns and V′ channels c < components (the
/// material a factorisation of that rank truncated, offline/factor/fmf.hpp truncate_fmf()).
inline Material truncated_material(const Material& m, uint32_t components) {
  Material t = m;
  const uint32_t C = m.config.components;
  t.config.components = components;
  t.u.clear();
  for (size_t row = 0; row < m.u.size() / C; ++row)
    for (uint32_t c = 0; c < components; ++c) t.u.push_back(m.u[row * C + c]);
  t.v = Image<float>(m.v.width(), m.v.height(), static_cast<int>(components));
  for (int y = 0; y < m.v.height(); ++y)
    for (int x = 0; x < m.v.width(); ++x)
      for (int c = 0; c < static_cast<int>(components); ++c) t.v.at(x, y, c) = m.v.at(x, y, c);
  return t;
}

/// One program of C = 8 draws materials of every rank C_m ≤ 8 (ShaderParams::vt_extent.w, set
/// by the backend from the material): a C_m = 3 material matches the CPU reference at C = 3,
/// and so does the C = 8 material drawn with vt_extent.w = 3 (its first three components), an
/// image far from its full one; a material of C_m = 9 is refused.
inline void golden_fmf_component_counts(BackendFactory make) {
  const ShaderConfig config = golden_config();
  ASSERT_EQ(config.components, 8u);
  const std::unique_ptr<Backend> be = start_backend(make, config, 2);
  if (!be) return;
  const Material m8 = make_material(config, kTexture, kTexture);
  const Material m3 = truncated_material(m8, 3);
  auto mesh = create_plane_mesh(*be);
  ASSERT_TRUE(mesh.ok()) << mesh.message();
  FmfMaterialData d8 = m8.data(true), d3 = m3.data(true);
  d8.mipmaps = d3.mipmaps = false;
  FmfMaterialData d9 = d8;
  d9.components = 9;
  EXPECT_EQ(be->create_material(d9).status(), Status::invalid_argument) << "C_m above the programs' C";
  auto mat8 = be->create_material(d8);
  auto mat3 = be->create_material(d3);
  ASSERT_TRUE(mat8.ok()) << mat8.message();
  ASSERT_TRUE(mat3.ok()) << mat3.message();
  const ShaderParams params = golden_params(golden_camera());
  ShaderParams first3 = params;
  first3.vt_extent.w = 3.0f;
  const Image<float> img3 = render_frame(*be, ShaderProgram::fmf, *mesh, *mat3, params);
  const Image<float> img8 = render_frame(*be, ShaderProgram::fmf, *mesh, *mat8, params);
  const Image<float> img8_first3 = render_frame(*be, ShaderProgram::fmf, *mesh, *mat8, first3);
  const Image<float> ref3 = cpu_render(m3, params, finest_v_sampler(m3));
  const Image<float> ref8 = cpu_render(m8, params, finest_v_sampler(m8));
  expect_content(ref3);
  expect_content(img3);
  const double psnr3 = psnr_rgb(ref3, img3), psnr8 = psnr_rgb(ref8, img8), psnr_first3 = psnr_rgb(ref3, img8_first3),
               apart = psnr_rgb(ref8, ref3);
  std::printf(
      "[ %s ] golden FMF, C_m = 3 under a C = 8 program vs CPU reference: PSNR %.2f dB; C = 8 %.2f dB; "
      "C = 8 drawn with w = 3 vs C = 3 %.2f dB (C = 3 vs 8 references %.2f dB)\n",
      be->name(), psnr3, psnr8, psnr_first3, apart);
  EXPECT_GE(psnr3, 40.0);
  EXPECT_GE(psnr8, 40.0);
  EXPECT_GE(psnr_first3, 40.0);
  EXPECT_LT(apart, psnr3 - 10.0) << "the scene must tell three components from eight";
}

/// FMF in the sqrt, log and log_ycbcr encodings (core/value_transform.hpp): the programs generated for
/// ShaderConfig::value_transform decode the sum of eq. 5 as the CPU reference does (≥ 40 dB),
/// and the image differs from the linear one; a material of another encoding is refused.
inline void golden_fmf_value_transforms(BackendFactory make) {
  const Material m = make_material(golden_config(), kTexture, kTexture);
  const ShaderParams params = golden_params(golden_camera());
  const auto sample = finest_v_sampler(m);
  const Image<float> linear = cpu_render(m, params, sample);
  for (const ValueTransform t : {ValueTransform{ValueEncoding::sqrt}, ValueTransform{ValueEncoding::log, 0.05f},
                                 ValueTransform{ValueEncoding::log_ycbcr, 0.05f}}) {
    ShaderConfig config = golden_config();
    config.value_transform = t;
    const std::unique_ptr<Backend> be = start_backend(make, config, 2);
    if (!be) return;
    Result<MeshHandle> mesh = MeshHandle{};
    Result<MaterialHandle> mat = MaterialHandle{};
    create_fmf_plane(*be, m, mesh, mat, [&](FmfMaterialData& d) {
      EXPECT_EQ(be->create_material(d).status(), Status::invalid_argument)
          << "a linear material under a " << value_encoding_name(t.encoding) << " program";
      d.transform = t;
    });
    if (::testing::Test::HasFatalFailure()) return;
    Image<float> img(kSize, kSize, 4);
    assert_render_frame(*be, ShaderProgram::fmf, *mesh, *mat, params, img);
    if (::testing::Test::HasFatalFailure()) return;
    const Image<float> ref = cpu_render(m, params, sample, t);
    expect_content(ref);
    expect_content(img);
    const double psnr = psnr_rgb(ref, img), vs_linear = psnr_rgb(linear, img);
    std::printf("[ %s ] golden FMF, %s encoding, vs CPU reference: PSNR %.2f dB (vs the linear image %.2f dB)\n",
                be->name(), value_encoding_name(t.encoding), psnr, vs_linear);
    EXPECT_GE(psnr, 40.0);
    EXPECT_LT(vs_linear, psnr - 10.0);
  }
}

/// U′ packets (Backend::upload_u_packets): a material created with U′ = 0 and then given its
/// U′ packet by packet (light-major rows of four halves, as the runtime hands them out) renders
/// exactly like a material created with the same (half-rounded) U′; after packet 0 only, like a
/// material whose components 4…7 are zero. An out-of-range packet is refused.
inline void golden_fmf_u_packets(BackendFactory make) {
  const ShaderConfig config = golden_config();
  const std::unique_ptr<Backend> be = start_backend(make, config, 2);
  if (!be) return;
  const Material m = make_material(config, kTexture, kTexture);
  const uint32_t C = config.components, rows = m.lights * m.views * 3;
  ASSERT_EQ(C, 8u);
  auto mesh = create_plane_mesh(*be);
  ASSERT_TRUE(mesh.ok()) << mesh.message();
  // The packets, and U′ as they carry it (rounded to half) in full and with packet 0 only.
  std::vector<std::vector<uint16_t>> packets(2, std::vector<uint16_t>(size_t{rows} * 4));
  std::vector<float> u_half(m.u.size()), u_first(m.u.size(), 0.0f), zeros(m.u.size(), 0.0f);
  for (uint32_t r = 0; r < rows; ++r)
    for (uint32_t c = 0; c < C; ++c) {
      const uint16_t h = float_to_half_bits(m.u[size_t{r} * C + c]);
      packets[c / 4][size_t{r} * 4 + c % 4] = h;
      u_half[size_t{r} * C + c] = half_bits_to_float(h);
      if (c < 4) u_first[size_t{r} * C + c] = half_bits_to_float(h);
    }
  const auto render = [&](std::span<const float> u, std::span<const std::vector<uint16_t>> upload) {
    FmfMaterialData d = m.data(true);
    d.mipmaps = false;
    d.eigen_abrdfs = u;
    auto mat = be->create_material(d);
    EXPECT_TRUE(mat.ok()) << mat.message();
    for (uint32_t g = 0; g < upload.size(); ++g) {
      const UPacketUpload p{g, rows, upload[g]};
      EXPECT_EQ(be->upload_u_packets(*mat, std::span<const UPacketUpload>(&p, 1)), Status::success);
    }
    const Image<float> img = render_frame(*be, ShaderProgram::fmf, *mesh, *mat, golden_params(golden_camera()));
    // Refused: packet 2 of a C = 8 material, a short packet, an empty handle.
    const UPacketUpload bad[3] = {{2, rows, packets[0]}, {0, rows, std::span<const uint16_t>(packets[0]).first(8)}};
    EXPECT_EQ(be->upload_u_packets(*mat, std::span<const UPacketUpload>(bad, 1)), Status::invalid_argument);
    EXPECT_EQ(be->upload_u_packets(*mat, std::span<const UPacketUpload>(bad + 1, 1)), Status::invalid_argument);
    EXPECT_EQ(be->upload_u_packets(MaterialHandle{}, std::span<const UPacketUpload>(bad + 2, 0)),
              Status::invalid_argument);
    return img;
  };
  const auto max_diff = [](const Image<float>& a, const Image<float>& b) {
    float d = 0.0f;
    for (int y = 0; y < a.height(); ++y)
      for (int x = 0; x < a.width(); ++x)
        for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(a.at(x, y, c) - b.at(x, y, c)));
    return d;
  };
  const Image<float> ref = render(u_half, {});
  const Image<float> ref_first = render(u_first, {});
  const Image<float> blank = render(zeros, {});
  const Image<float> streamed = render(zeros, packets);
  const Image<float> streamed_first = render(zeros, std::span<const std::vector<uint16_t>>(packets).first(1));
  expect_content(ref);
  EXPECT_GT(max_diff(ref, blank), 0.01f);       // U′ matters in this scene
  EXPECT_GT(max_diff(ref, ref_first), 0.001f);  // so does packet 1
  EXPECT_EQ(max_diff(ref, streamed), 0.0f);
  EXPECT_EQ(max_diff(ref_first, streamed_first), 0.0f);
  std::printf("[ %s ] U' packets: streamed vs created max diff %g (blank %g, packet 0 only %g)\n", be->name(),
              static_cast<double>(max_diff(ref, streamed)), static_cast<double>(max_diff(ref, blank)),
              static_cast<double>(max_diff(ref, streamed_first)));
}

/// The BSVTF scene's virtual texture: a vt/ TileCache holding every tile of levels 0–1 and the
/// left half of level 2, its tiles as GPU uploads and in a CpuCacheTexture (both in the cache
/// format of config.vt.format: rgba8_affine and bc5_affine tiles are encoded once and the same
/// bytes go to both), and the page-table writes of the whole cache. Filled in place (the cache refers to
/// nothing outside it).
struct PartialCacheScene {
  std::optional<TilePyramid> pyr;
  VtSet set;
  std::optional<TileCache> cache;
  std::optional<CpuCacheTexture> cpu;
  std::vector<std::vector<uint8_t>> unorm8;  // rgba8_affine: each upload's bytes
  std::vector<std::vector<uint8_t>> bc5;     // bc5_affine: each upload's blocks
  std::vector<TileUpload> uploads;
  std::vector<PageTableWrite> writes;
};

inline void build_partial_cache(const ShaderConfig& config, const Material& m, PartialCacheScene& out) {
  auto pyr = TilePyramid::build(eigen_textures_of(m), 64, 4);
  ASSERT_TRUE(pyr.ok()) << pyr.message();
  out.pyr.emplace(std::move(*pyr));
  out.set.add_material(out.pyr->geometry(), out.pyr->texture_count());
  TileCacheConfig cache_config{config.vt.slots_x, config.vt.slots_y, 1024};
  cache_config.format = config.vt.format;
  auto cache_r = TileCache::create(out.set, cache_config);
  ASSERT_TRUE(cache_r.ok()) << cache_r.message();
  out.cache.emplace(std::move(*cache_r));
  TileCache& cache = *out.cache;
  const VtLevelTable& lv = out.set.levels_of(0);
  for (uint32_t k = 0; k < out.set.texture_count(); ++k)
    for (uint32_t l = 1; l <= 2; ++l)
      for (uint32_t y = 0; y < lv.tiles_y[l]; ++y)
        for (uint32_t x = 0; x < lv.tiles_x[l]; ++x) {
          if (l == 2 && x >= lv.tiles_x[l] / 2) continue;
          const uint32_t s = cache.reserve_slot();
          ASSERT_NE(s, kNoSlot);
          ASSERT_EQ(cache.insert(TileId{k, l, x, y}, s, 0), Status::success);
        }
  out.cpu.emplace(cache);
  out.unorm8.reserve(cache.slot_count());  // the uploads' spans point into these
  out.bc5.reserve(cache.slot_count());
  for (uint32_t s = 0; s < cache.slot_count(); ++s) {
    const SlotInfo& info = cache.slot(s);
    if (info.state != SlotInfo::State::used) continue;
    const auto texels = out.pyr->tile_texels(info.tile.texture, info.flat_index);
    if (config.vt.format == CacheFormat::rgba8_affine) {
      std::vector<float> scratch(texels.size());
      std::vector<uint8_t>& bytes = out.unorm8.emplace_back(texels.size());
      const CacheSlotMap map = encode_cache_tile_unorm8(texels, scratch, bytes);
      ASSERT_TRUE(out.cpu->upload(cache, s, bytes, map));
      out.uploads.push_back(TileUpload{s, {}, bytes, map});
    } else if (config.vt.format == CacheFormat::bc5_affine) {
      const uint32_t side = config.vt.padded_tile_size();
      std::vector<float> values(texels.size());
      half_to_float(texels, values);
      std::vector<uint8_t> scratch(texels.size());
      std::vector<uint8_t>& blocks = out.bc5.emplace_back(cache_bc5_tile_bytes(side));
      const CacheSlotMap map = encode_cache_tile_bc5(values, side, scratch, blocks);
      ASSERT_TRUE(out.cpu->upload_bc5(cache, s, blocks, map));
      out.uploads.push_back(TileUpload{s, {}, {}, map, blocks});
    } else {
      ASSERT_TRUE(out.cpu->upload(cache, s, texels));
      out.uploads.push_back(TileUpload{s, texels, {}, {}});
    }
  }
  ASSERT_EQ(out.uploads.size(), 2u * (1 + 4 + 8));
  for (uint32_t t = 0; t < out.set.texture_count(); ++t) append_full_page_table_writes(cache, t, out.writes);
}

/// BSVTF: the partial cache above, uploaded to the GPU and to a CpuCacheTexture; page table from
/// the cache. In cache format `format`: the CPU reference reads the same bytes as the GPU.
/// V′ of every virtual texture of `vt` through its CpuCacheTexture (the deepest resident tile,
/// as the GPU reads it), for cpu_render(); `on_level(level)` sees the level read for texture 0.
/// `vt` must outlive the sampler.
template <class OnLevel>
auto cache_v_sampler(const PartialCacheScene& vt, OnLevel on_level) {
  return [&vt, on_level](const SurfaceHit& h, float* out) mutable {
    for (uint32_t k = 0; k < vt.set.texture_count(); ++k) {
      float v4[4];
      const uint32_t level = vt.cpu->sample(*vt.cache, k, h.texcoord.x, h.texcoord.y, v4);
      if (k == 0) on_level(level);
      for (int c = 0; c < 4; ++c) out[4 * k + c] = v4[c];
    }
  };
}
inline auto cache_v_sampler(const PartialCacheScene& vt) {
  return cache_v_sampler(vt, [](uint32_t) {});
}

/// V′ of every virtual texture of `vt` at the finest level everywhere: what a renderer that
/// ignored the page table would read. `vt` must outlive the sampler.
inline auto finest_only_v_sampler(const PartialCacheScene& vt) {
  return [&vt](const SurfaceHit& h, float* out) {
    for (uint32_t k = 0; k < vt.set.texture_count(); ++k) vt.pyr->sample(k, 2, h.texcoord.x, h.texcoord.y, out + 4 * k);
  };
}

inline void golden_bsvtf_partial(BackendFactory make, CacheFormat format = CacheFormat::rgba16f) {
  ShaderConfig config = golden_config();
  config.vt.format = format;
  const Material m = make_material(config, kTexture, kTexture);
  PartialCacheScene vt;
  build_partial_cache(config, m, vt);
  if (::testing::Test::HasFatalFailure()) return;
  const VtSet& set = vt.set;
  TileCache& cache = *vt.cache;
  const std::unique_ptr<Backend> be = start_backend(make, config, set.texture_count());
  if (!be) return;
  ASSERT_EQ(be->upload_tiles(vt.uploads), Status::success);
  ASSERT_EQ(be->apply_page_table_writes(vt.writes), Status::success);
  auto mesh = create_plane_mesh(*be);
  ASSERT_TRUE(mesh.ok()) << mesh.message();
  auto mat = be->create_material(m.data(false));
  ASSERT_TRUE(mat.ok()) << mat.message();
  const ShaderParams params = golden_params(golden_camera());
  Image<float> img(kSize, kSize, 4);
  assert_render_frame(*be, ShaderProgram::bsvtf, *mesh, *mat, params, img);
  if (::testing::Test::HasFatalFailure()) return;
  uint64_t finest = 0, coarser = 0;
  const Image<float> ref =
      cpu_render(m, params, cache_v_sampler(vt, [&](uint32_t level) { ++(level == 2 ? finest : coarser); }));
  // A renderer that ignored the page table (finest level everywhere) must not pass.
  const Image<float> wrong = cpu_render(m, params, finest_only_v_sampler(vt));
  const GoldenPsnr psnr = expect_golden_match(ref, img, wrong);
  EXPECT_GT(finest, 1000u);
  EXPECT_GT(coarser, 1000u) << "the view must show both resident and missing finest tiles";
  std::printf("[ %s ] golden BSVTF (partial cache, %s) vs CPU reference: PSNR %.2f dB (vs finest-only %.2f dB)\n",
              be->name(), cache_format_name(format), psnr.ref, psnr.wrong);
  {
    // The first three components only (vt_extent.w = 3): page-table layer 1 is not read and
    // eq. 5 stops at c = 3, as the CPU reference truncated to three components.
    ShaderParams first3 = params;
    first3.vt_extent.w = 3.0f;
    const Image<float> img3 = render_frame(*be, ShaderProgram::bsvtf, *mesh, *mat, first3);
    const Image<float> ref3 = cpu_render(m, params, cache_v_sampler(vt), {}, 3);
    const double psnr3 = psnr_rgb(ref3, img3), apart = psnr_rgb(ref, ref3);
    std::printf(
        "[ %s ] golden BSVTF drawn with its first 3 components vs CPU reference: PSNR %.2f dB (vs all "
        "%.2f dB)\n",
        be->name(), psnr3, apart);
    EXPECT_GE(psnr3, 40.0);
    EXPECT_LT(apart, psnr3 - 10.0);
  }
  if (cache_format_has_slot_map(format)) {
    // The same cache at rgba16f on the CPU: the 8-bit (or BC5) cache stays close to it (the
    // tiles' own ranges keep the step small), and a renderer that skipped the slot maps would not.
    PartialCacheScene wide;
    ShaderConfig wide_config = config;
    wide_config.vt.format = CacheFormat::rgba16f;
    build_partial_cache(wide_config, m, wide);
    if (::testing::Test::HasFatalFailure()) return;
    const Image<float> ref16 = cpu_render(m, params, [&](const SurfaceHit& h, float* out) {
      for (uint32_t k = 0; k < set.texture_count(); ++k)
        wide.cpu->sample(*wide.cache, k, h.texcoord.x, h.texcoord.y, out + 4 * k);
    });
    CpuCacheTexture raw(cache);  // the same bytes read as plain unorm (identity maps)
    CacheSlotMap identity;
    for (int c = 0; c < 4; ++c) identity.scale[c] = 1.0f;
    for (const TileUpload& u : vt.uploads) ASSERT_TRUE(raw.upload(cache, u.slot, {}, u.unorm8, identity, u.bc5));
    const Image<float> unmapped = cpu_render(m, params, [&](const SurfaceHit& h, float* out) {
      for (uint32_t k = 0; k < set.texture_count(); ++k) raw.sample(cache, k, h.texcoord.x, h.texcoord.y, out + 4 * k);
    });
    const double psnr16 = psnr_rgb(ref16, img), psnr_unmapped = psnr_rgb(unmapped, img);
    std::printf("[ %s ] %s GPU image vs the rgba16f CPU reference: PSNR %.2f dB\n", be->name(),
                cache_format_name(format), psnr16);
    EXPECT_GE(psnr16, format == CacheFormat::bc5_affine ? 35.0 : 40.0);
    EXPECT_LT(psnr_unmapped, psnr16 - 3.0);
  }
}

}  // namespace btflod::golden
