// Golden image of an ENGINE-STYLE shader on OpenGL (EGL headless, llvmpipe): the engine writes
// its own vertex shader (its own attribute locations), its own fragment main(), its own uniform
// blocks at its own bindings, declares one sampler itself, and calls the functions of
// generate_functions() (prefix "mat_", samplers moved to bindings 8–13, uniform sources pointing
// at the engine's blocks). One shader holds the fmf and bsvtf pieces (their shared eq. 5 and
// angular lookup emitted once) and picks one per draw from its material block. The scene,
// material and partial tile cache are those of test_golden_scene.hpp; the image must match the
// CPU reference (offline/render/cpu_reference.hpp) at PSNR >= 40 dB, and a wrong variant (BSVTF read at
// the finest level everywhere) must not.
// Skips with the reason when no EGL / GL 4.5 context is available.
// btflod-link: btflod_gl_backend btflod_glad
// btflod-label: gpu
#include <glad/gl.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "btflod/runtime/shader/glsl_generator.hpp"
#include "gl_backend.hpp"
#include "gl_util.hpp"
#include "test_golden_engine_blocks.hpp"
#include "test_golden_scene.hpp"

namespace {

using namespace btflod;
using namespace btflod::golden;

constexpr GLuint kCameraBinding = 3, kSurfaceBinding = 5, kEngineCacheBinding = 15;

const char* kEngineVertex = R"(#version 450 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec2 a_uv;
layout(location = 2) in vec3 a_normal;
layout(location = 3) in vec4 a_tangent;
layout(std140, binding = 3) uniform EngineCamera { mat4 view_proj; vec4 eye; } camera;
out vec3 p_world; out vec3 p_normal; out vec4 p_tangent; out vec2 p_uv;
void main() {
  p_world = a_position; p_normal = a_normal; p_tangent = a_tangent; p_uv = a_uv;
  gl_Position = camera.view_proj * vec4(a_position, 1.0);
}
)";

// Everything above the generated functions: the engine's own declarations.
const char* kEngineFragmentHead = R"(#version 450 core
layout(std140, binding = 3) uniform EngineCamera { mat4 view_proj; vec4 eye; } camera;
layout(std140, binding = 5) uniform EngineSurface {
  vec4 sun_direction; vec4 sun_radiance; vec4 vt_extent; uvec4 layers; vec4 lod;
} surface;
layout(binding = 15) uniform sampler2DArray g_vt_cache;  // declared by the engine, read by mat_bsvtf
in vec3 p_world; in vec3 p_normal; in vec4 p_tangent; in vec2 p_uv;
layout(location = 0) out vec4 frag_color;
)";

GLuint texture_of(const GlslFunctionSource& fn, ShaderBinding role) {
  for (const GlslSamplerUse& s : fn.samplers)
    if (s.role == role) return s.binding;
  ADD_FAILURE() << "no sampler for " << shader_binding_name(role);
  return 0;
}

// Renders the plane with the engine program; returns the image top row first.
Image<float> render(GLuint program, GLuint vao, GLuint fbo, GLuint ubo_camera, GLuint ubo_surface) {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  glViewport(0, 0, kSize, kSize);
  const float clear[4] = {0, 0, 0, 0};
  glClearNamedFramebufferfv(fbo, GL_COLOR, 0, clear);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glUseProgram(program);
  glBindBufferBase(GL_UNIFORM_BUFFER, kCameraBinding, ubo_camera);
  glBindBufferBase(GL_UNIFORM_BUFFER, kSurfaceBinding, ubo_surface);
  glBindVertexArray(vao);
  glDrawElements(GL_TRIANGLES, 6, GL_UNSIGNED_INT, nullptr);
  std::vector<float> px(static_cast<size_t>(kSize) * kSize * 4);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(0, 0, kSize, kSize, GL_RGBA, GL_FLOAT, px.data());
  Image<float> img(kSize, kSize, 4);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x)
      for (int c = 0; c < 4; ++c) img.at(x, y, c) = px[(static_cast<size_t>(kSize - 1 - y) * kSize + x) * 4 + c];
  return img;
}

}  // namespace

TEST(GoldenEngineGl, EngineShaderCallingGeneratedFunctionsMatchesCpuReference) {
  auto backend = samples::create_gl_backend();  // makes an EGL GL 4.5 context current on this thread
  if (!backend) GTEST_SKIP() << "GPU API unavailable: " << backend.message();

  const ShaderConfig config = golden_config();
  const GlslFunctionOptions options = engine_function_options(8, 0, kEngineCacheBinding);
  Result<GlslFunctionSource> fn = generate_functions(
      glsl_pieces({GlslPiece::fmf, GlslPiece::bsvtf, GlslPiece::local_frame}), GlslTarget::gl450_core, config, options);
  ASSERT_TRUE(fn.ok()) << fn.message();
  // The shared pieces are emitted once although fmf and bsvtf both call them.
  EXPECT_EQ(fn->code.find("vec3 mat_fmf_brdf("), fn->code.rfind("vec3 mat_fmf_brdf("));
  EXPECT_EQ(fn->code.find("void mat_angular("), fn->code.rfind("void mat_angular("));
  EXPECT_EQ(fn->code.find("g_vt_cache;"), std::string::npos) << "the engine declares the cache itself";
  EXPECT_EQ(fn->code.find("btflod"), std::string::npos) << "no default name may leak into the engine's shader";
  GlslProgramSource src{kEngineVertex, std::string(kEngineFragmentHead) + fn->code + kEngineFragmentMain};
  Result<GLuint> program = samples::compile_gl_program(src, "engine");
  ASSERT_TRUE(program.ok()) << program.message() << "\n" << src.fragment;

  // Material (FMF textures and U') and the partially filled tile cache of the golden scene.
  const EngineMaterial mat(config);
  if (HasFatalFailure()) return;
  const Material& m = mat.m;
  const PartialCacheScene& vt = mat.vt;
  GLuint tex[4] = {};
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 4, tex);
  glTextureStorage3D(tex[0], 1, GL_RGBA32F, static_cast<GLsizei>(m.lights), static_cast<GLsizei>(m.views),
                     static_cast<GLsizei>(config.components));
  glTextureSubImage3D(tex[0], 0, 0, 0, 0, static_cast<GLsizei>(m.lights), static_cast<GLsizei>(m.views),
                      static_cast<GLsizei>(config.components), GL_RGBA, GL_FLOAT, mat.u.data());
  samples::set_gl_sampling(tex[0], GL_NEAREST, GL_NEAREST, GL_CLAMP_TO_EDGE);
  const GLsizei groups = static_cast<GLsizei>(config.component_groups());
  glTextureStorage3D(tex[1], 1, GL_RGBA32F, kTexture, kTexture, groups);
  glTextureSubImage3D(tex[1], 0, 0, 0, 0, kTexture, kTexture, groups, GL_RGBA, GL_FLOAT, mat.v.data());
  samples::set_gl_sampling(tex[1], GL_LINEAR, GL_LINEAR, GL_REPEAT);
  const VirtualTextureConfig& vc = config.vt;
  glTextureStorage3D(tex[2], 1, GL_RGBA16F, static_cast<GLsizei>(vc.cache_width()),
                     static_cast<GLsizei>(vc.cache_height()), static_cast<GLsizei>(vc.cache_layers));
  samples::set_gl_sampling(tex[2], GL_LINEAR, GL_LINEAR, GL_CLAMP_TO_EDGE);
  const GLsizei padded = static_cast<GLsizei>(vc.padded_tile_size());
  for (const TileUpload& t : vt.uploads) {
    const SlotPlacement p = slot_placement(vc, t.slot);
    glTextureSubImage3D(tex[2], 0, static_cast<GLint>(p.x), static_cast<GLint>(p.y), static_cast<GLint>(p.layer),
                        padded, padded, 1, GL_RGBA, GL_HALF_FLOAT, t.texels.data());
  }
  const GLsizei side = 1 << vc.finest_level;
  glTextureStorage3D(tex[3], static_cast<GLsizei>(vc.finest_level + 1), GL_R32UI, side, side,
                     static_cast<GLsizei>(vt.set.texture_count()));
  samples::set_gl_sampling(tex[3], GL_NEAREST_MIPMAP_NEAREST, GL_NEAREST, GL_CLAMP_TO_EDGE);
  for (const PageTableWrite& w : vt.writes)
    glTextureSubImage3D(tex[3], static_cast<GLint>(w.page_mip), static_cast<GLint>(w.tile.x),
                        static_cast<GLint>(w.tile.y), static_cast<GLint>(w.tile.texture), 1, 1, 1, GL_RED_INTEGER,
                        GL_UNSIGNED_INT, &w.entry);
  const samples::GlAngularTables tables = samples::create_gl_angular_tables(mat.d.angular);
  // Bind each texture where the options put it (the engine's own table).
  glBindTextureUnit(texture_of(*fn, ShaderBinding::eigen_abrdfs), tex[0]);
  glBindTextureUnit(texture_of(*fn, ShaderBinding::eigen_textures), tex[1]);
  glBindTextureUnit(kEngineCacheBinding, tex[2]);
  glBindTextureUnit(texture_of(*fn, ShaderBinding::page_table), tex[3]);
  glBindTextureUnit(texture_of(*fn, ShaderBinding::angular_index), tables.index);
  glBindTextureUnit(texture_of(*fn, ShaderBinding::angular_weight), tables.weight);

  // Engine mesh: its own attribute locations (position 0, uv 1, normal 2, tangent 3).
  std::vector<MeshVertex> verts;
  std::vector<uint32_t> idx;
  plane_mesh(PlaneSetup{}, verts, idx);
  GLuint vbo = 0, ibo = 0, vao = 0;
  glCreateBuffers(1, &vbo);
  glNamedBufferStorage(vbo, static_cast<GLsizeiptr>(verts.size() * sizeof(MeshVertex)), verts.data(), 0);
  glCreateBuffers(1, &ibo);
  glNamedBufferStorage(ibo, static_cast<GLsizeiptr>(idx.size() * sizeof(uint32_t)), idx.data(), 0);
  glCreateVertexArrays(1, &vao);
  glVertexArrayVertexBuffer(vao, 0, vbo, 0, sizeof(MeshVertex));
  glVertexArrayElementBuffer(vao, ibo);
  const struct {
    GLuint loc;
    GLint n;
    GLuint off;
  } attrs[4] = {{0, 3, offsetof(MeshVertex, position)},
                {1, 2, offsetof(MeshVertex, uv)},
                {2, 3, offsetof(MeshVertex, normal)},
                {3, 4, offsetof(MeshVertex, tangent)}};
  for (const auto& a : attrs) {
    glEnableVertexArrayAttrib(vao, a.loc);
    glVertexArrayAttribFormat(vao, a.loc, a.n, GL_FLOAT, GL_FALSE, a.off);
    glVertexArrayAttribBinding(vao, a.loc, 0);
  }
  GLuint color = 0, fbo = 0;
  glCreateTextures(GL_TEXTURE_2D, 1, &color);
  glTextureStorage2D(color, 1, GL_RGBA32F, kSize, kSize);
  glCreateFramebuffers(1, &fbo);
  glNamedFramebufferTexture(fbo, GL_COLOR_ATTACHMENT0, color, 0);
  ASSERT_EQ(glCheckNamedFramebufferStatus(fbo, GL_FRAMEBUFFER), static_cast<GLenum>(GL_FRAMEBUFFER_COMPLETE));

  // The engine's uniforms, from the golden scene's parameters.
  const ShaderParams params = golden_params(golden_camera());
  EngineCamera cam{params.model_view_proj, params.camera_pos};
  EngineSurface surf{params.light, params.light_color, params.vt_extent, glm::uvec4(0, 0, 0, 0), params.lod};
  GLuint ubo[2] = {};
  glCreateBuffers(2, ubo);
  glNamedBufferStorage(ubo[0], sizeof(cam), &cam, 0);
  glNamedBufferStorage(ubo[1], sizeof(surf), nullptr, GL_DYNAMIC_STORAGE_BIT);

  glNamedBufferSubData(ubo[1], 0, sizeof(surf), &surf);
  const Image<float> fmf_img = render(*program, vao, fbo, ubo[0], ubo[1]);
  surf.layers.y = 1;
  glNamedBufferSubData(ubo[1], 0, sizeof(surf), &surf);
  const Image<float> bsvtf_img = render(*program, vao, fbo, ubo[0], ubo[1]);
  ASSERT_EQ(glGetError(), static_cast<GLenum>(GL_NO_ERROR));

  expect_engine_images_match("GL", m, params, vt, fmf_img, bsvtf_img);

  glDeleteFramebuffers(1, &fbo);
  glDeleteTextures(1, &color);
  glDeleteBuffers(2, ubo);
  glDeleteVertexArrays(1, &vao);
  glDeleteBuffers(1, &vbo);
  glDeleteBuffers(1, &ibo);
  glDeleteTextures(4, tex);
  GLuint t2[2] = {tables.index, tables.weight};
  glDeleteTextures(2, t2);
  glDeleteProgram(*program);
}
