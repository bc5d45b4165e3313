// What the engine-style golden tests (GL and Vulkan) share: the uniform blocks of the engine
// (std140 mirrors of the blocks the engine's own shader declares, not btflod's ShaderParams), its
// fragment main(), the options that point the generated functions at its bindings, and the
// comparison of its images with the CPU reference.
#pragma once

#include <glm/glm.hpp>

#include <cstdio>

#include "btflod/runtime/shader/glsl_generator.hpp"
#include "test_golden_scene.hpp"

namespace btflod::golden {

struct EngineCamera {
  glm::mat4 view_proj;
  glm::vec4 eye;
};
struct EngineSurface {
  glm::vec4 sun_direction;
  glm::vec4 sun_radiance;
  glm::vec4 vt_extent;  // M, N, L
  glm::uvec4 layers;    // x: first page-table layer, y: 0 = fmf, 1 = bsvtf
  glm::vec4 lod;        // x: LOD bias
};

/// The engine's fragment main(): local directions from the engine's frame, then the generated
/// bsvtf or fmf function as the surface block's layers.y says, times the sun's radiance.
inline const char* const kEngineFragmentMain = R"(
void main() {
  vec3 wl; vec3 wv;
  mat_local_dirs(p_normal, p_tangent, normalize(surface.sun_direction.xyz), normalize(camera.eye.xyz - p_world), wl, wv);
  vec3 rho = surface.layers.y == 1u ? mat_bsvtf(p_uv, wl, wv) : mat_fmf(p_uv, wl, wv);
  frag_color = vec4(rho * surface.sun_radiance.rgb, 1.0);
}
)";

/// The engine's options for generate_functions(): prefix "mat_", the material samplers at
/// bindings first_binding… (eigen_abrdfs, angular_index, angular_weight, eigen_textures,
/// page_table) in descriptor set `set` (ignored by GL), the tile cache declared by the engine
/// as g_vt_cache at `cache_binding`, and the per-draw values read from its surface block.
inline GlslFunctionOptions engine_function_options(uint32_t first_binding, uint32_t set, uint32_t cache_binding) {
  GlslFunctionOptions o;
  o.prefix = "mat_";
  const ShaderBinding roles[] = {ShaderBinding::eigen_abrdfs, ShaderBinding::angular_index,
                                 ShaderBinding::angular_weight, ShaderBinding::eigen_textures,
                                 ShaderBinding::page_table};
  uint32_t binding = first_binding;
  for (ShaderBinding r : roles) {
    o.resource(r).binding = binding++;
    o.resource(r).set = set;
  }
  o.resource(ShaderBinding::tile_cache) = GlslResource{"g_vt_cache", cache_binding, set, false};
  o.uniforms.vt_extent = "surface.vt_extent";
  o.uniforms.lod_bias = "surface.lod.x";
  o.uniforms.first_layer = "surface.layers.x";
  o.uniforms.component_count = "surface.vt_extent.w";
  return o;
}

/// The golden FMF material of the engine tests, its partially filled tile cache (built in
/// place; a fatal failure when it cannot be) and U′ and V′ packed as RGBA texels for upload.
struct EngineMaterial {
  explicit EngineMaterial(const ShaderConfig& config) : m(make_material(config, kTexture, kTexture)) {
    build_partial_cache(config, m, vt);
  }
  Material m;
  PartialCacheScene vt;
  FmfMaterialData d = m.data(true);
  std::vector<float> u = pack_eigen_abrdfs_rgba(d);
  std::vector<float> v = pack_eigen_textures_rgba(d.eigen_textures);
};

/// The engine images drawn on `api` (fmf_img with the fmf function, bsvtf_img with the bsvtf
/// one through the partial cache `vt`) against the CPU reference of material `m` under
/// `params`: both have content and match at PSNR ≥ 40 dB, and the bsvtf image is at least
/// 3 dB further from a renderer that read the finest level everywhere.
inline void expect_engine_images_match(const char* api, const Material& m, const ShaderParams& params,
                                       const PartialCacheScene& vt, const Image<float>& fmf_img,
                                       const Image<float>& bsvtf_img) {
  const Image<float> fmf_ref = cpu_render(m, params, finest_v_sampler(m));
  const Image<float> bsvtf_ref = cpu_render(m, params, cache_v_sampler(vt));
  const Image<float> bsvtf_wrong = cpu_render(m, params, finest_only_v_sampler(vt));
  expect_content(fmf_img);
  expect_content(bsvtf_img);
  const double p_fmf = psnr_rgb(fmf_ref, fmf_img), p_bsvtf = psnr_rgb(bsvtf_ref, bsvtf_img);
  const double p_wrong = psnr_rgb(bsvtf_wrong, bsvtf_img);
  std::printf("[ engine-style %s shader ] fmf %.2f dB, bsvtf %.2f dB vs CPU reference (bsvtf vs finest-only %.2f dB)\n",
              api, p_fmf, p_bsvtf, p_wrong);
  EXPECT_GE(p_fmf, 40.0);
  EXPECT_GE(p_bsvtf, 40.0);
  EXPECT_LT(p_wrong, p_bsvtf - 3.0);
}

}  // namespace btflod::golden
