// btflod sample — OpenGL textures and programs of the laplacian, lpca and pca_views materials.
// See gl_representations.hpp; layouts in backend.hpp and docs/shaders.md.
#include "gl_representations.hpp"

#include <algorithm>
#include <string>
#include <vector>

#include "gl_util.hpp"

namespace btflod::samples {
namespace {

GLsizei sz(uint32_t v) { return static_cast<GLsizei>(v); }

/// RGBA32F 2D array (or 2D when layers == 0) with `mips` levels; data: all mips, finest first,
/// each layer-major. Nearest filtering.
GLuint float_array(uint32_t w, uint32_t h, uint32_t layers, uint32_t mips, const float* data) {
  GLuint t = 0;
  if (layers == 0) {
    glCreateTextures(GL_TEXTURE_2D, 1, &t);
    glTextureStorage2D(t, 1, GL_RGBA32F, sz(w), sz(h));
    glTextureSubImage2D(t, 0, 0, 0, sz(w), sz(h), GL_RGBA, GL_FLOAT, data);
  } else {
    glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &t);
    glTextureStorage3D(t, sz(mips), GL_RGBA32F, sz(w), sz(h), sz(layers));
    for (uint32_t k = 0; k < mips; ++k) {
      const uint32_t wk = std::max(1u, w >> k), hk = std::max(1u, h >> k);
      glTextureSubImage3D(t, sz(k), 0, 0, 0, sz(wk), sz(hk), sz(layers), GL_RGBA, GL_FLOAT, data);
      data += static_cast<size_t>(wk) * hk * layers * 4;
    }
  }
  set_gl_sampling(t, mips > 1 ? GL_NEAREST_MIPMAP_NEAREST : GL_NEAREST, GL_NEAREST, GL_CLAMP_TO_EDGE);
  return t;
}

void add_angular(GlRepresentation& r, const AngularTablesData& a) {
  const GlAngularTables t = create_gl_angular_tables(a);
  r.units[r.unit_count++] = {ShaderBinding::angular_index, t.index};
  r.units[r.unit_count++] = {ShaderBinding::angular_weight, t.weight};
}

Result<GlRepresentation> finish(GlRepresentation r, ShaderProgram program, const ShaderConfig& config) {
  r.program = program;
  Result<GlslProgramSource> src = generate_program(program, GlslTarget::gl450_core, config);
  if (!src) {
    destroy_gl_representation(r);
    return src.error();
  }
  Result<GLuint> prog = compile_gl_program(*src, shader_program_name(program));
  if (!prog) {
    destroy_gl_representation(r);
    return prog.error();
  }
  r.gl_program = *prog;
  if (GLenum e = glGetError(); e != GL_NO_ERROR) {
    destroy_gl_representation(r);
    return make_error(Status::unsupported, "GL: error 0x%04x while creating a %s material", e,
                      shader_program_name(program));
  }
  return r;
}

}  // namespace

Result<GlRepresentation> create_gl_representation(const ShaderConfig& base, const LaplacianMaterialData& m) {
  GlRepresentation r;
  const uint32_t groups = (m.components + 3) / 4;
  // Eigen Laplacian BRDFs: texel (light, view), layer k·C + j (paper 001 §3.3).
  r.units[r.unit_count++] = {
      ShaderBinding::laplacian_eigen,
      float_array(m.light_count, m.view_count, (m.max_level + 1) * m.components, 1, m.eigen.data())};
  // PCA weight maps: mip k = pyramid level k, read with texelFetch at the level-k texel.
  r.units[r.unit_count++] = {ShaderBinding::laplacian_weights,
                             float_array(m.width, m.height, groups, m.max_level + 1, m.weights.data())};
  r.units[r.unit_count++] = {ShaderBinding::laplacian_mean,
                             float_array(m.light_count, m.view_count, 0, 1, m.mean.data())};
  add_angular(r, m.angular);
  return finish(r, ShaderProgram::laplacian, representation_config(base, m));
}

Result<GlRepresentation> create_gl_representation(const ShaderConfig& base, const LpcaMaterialData& m) {
  GlRepresentation r;
  GLuint cluster = 0;
  glCreateTextures(GL_TEXTURE_2D, 1, &cluster);
  glTextureStorage2D(cluster, 1, GL_R32UI, sz(m.width), sz(m.height));
  glTextureSubImage2D(cluster, 0, 0, 0, sz(m.width), sz(m.height), GL_RED_INTEGER, GL_UNSIGNED_INT, m.cluster.data());
  set_gl_sampling(cluster, GL_NEAREST, GL_NEAREST, GL_CLAMP_TO_EDGE);
  r.units[r.unit_count++] = {ShaderBinding::lpca_cluster, cluster};
  // Weights α'_j of the mean (j = 0) and the C eigen-BRDFs, 8-bit scales folded in (§6.3).
  r.units[r.unit_count++] = {ShaderBinding::lpca_weights,
                             float_array(m.width, m.height, (m.components + 4) / 4, 1, m.weights.data())};
  // Eigen-BRDF volume (paper 002 §6.2), 8-bit as in §6.3: RGBA8_SNORM returns q/127 (a
  // texture-filterable format in GL 4.5 core); linear filtering does s_v, t_v and s_l.
  const uint32_t R = m.grid_resolution;
  GLuint volume = 0;
  glCreateTextures(GL_TEXTURE_3D, 1, &volume);
  glTextureStorage3D(volume, 1, GL_RGBA8_SNORM, sz((m.components + 1) * R), sz(m.clusters * R), sz(R * R));
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);  // 4-byte texels: rows are always 4-aligned
  glTextureSubImage3D(volume, 0, 0, 0, 0, sz((m.components + 1) * R), sz(m.clusters * R), sz(R * R), GL_RGBA, GL_BYTE,
                      m.volume.data());
  set_gl_sampling(volume, GL_LINEAR, GL_LINEAR, GL_CLAMP_TO_EDGE);
  r.units[r.unit_count++] = {ShaderBinding::lpca_volume, volume};
  return finish(r, ShaderProgram::lpca, representation_config(base, m));
}

Result<GlRepresentation> create_gl_representation(const ShaderConfig& base, const PcaViewsMaterialData& m) {
  GlRepresentation r;
  const uint32_t groups = (m.view_count + m.views_per_group - 1) / m.views_per_group;
  r.units[r.unit_count++] = {ShaderBinding::pca_l,
                             float_array(m.width, m.height, groups * ((m.components + 4) / 4), 1, m.l.data())};
  r.units[r.unit_count++] = {ShaderBinding::pca_r,
                             float_array(m.components, m.light_count * m.view_count, 0, 1, m.r.data())};
  add_angular(r, m.angular);
  return finish(r, ShaderProgram::pca_views, representation_config(base, m));
}

Result<GlRepresentation> create_gl_representation(const ShaderConfig& base, const SpmmMaterialData& m) {
  GlRepresentation r;
  // Per texel: S slot layers (basis index, α as float bits) and the cluster id + residual
  // coefficients (paper 003 eq. 1, 3), RGBA32UI, read with texelFetch.
  const uint32_t layers = m.slots + spmm_residual_layers(m.residual_components);
  GLuint texels = 0;
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &texels);
  glTextureStorage3D(texels, 1, GL_RGBA32UI, sz(m.width), sz(m.height), sz(layers));
  glTextureSubImage3D(texels, 0, 0, 0, 0, sz(m.width), sz(m.height), sz(layers), GL_RGBA_INTEGER, GL_UNSIGNED_INT,
                      m.texels.data());
  set_gl_sampling(texels, GL_NEAREST, GL_NEAREST, GL_CLAMP_TO_EDGE);
  r.units[r.unit_count++] = {ShaderBinding::spmm_texels, texels};
  // Dictionary (paper 003 eq. 2): 2 texels per basis function.
  const uint32_t rows = (m.bases + kSpmmBasesPerRow - 1) / kSpmmBasesPerRow;
  r.units[r.unit_count++] = {ShaderBinding::spmm_dictionary,
                             float_array(2 * kSpmmBasesPerRow, rows, 0, 1, m.dictionary.data())};
  // Residual mean and components per cluster over the measured directions (eq. 3).
  r.units[r.unit_count++] = {
      ShaderBinding::spmm_residual,
      float_array(m.light_count, m.view_count, m.clusters * (m.residual_components + 1), 1, m.residual.data())};
  add_angular(r, m.angular);
  return finish(r, ShaderProgram::spmm, representation_config(base, m));
}

void bind_gl_representation(const GlRepresentation& r) noexcept {
  glUseProgram(r.gl_program);
  for (int i = 0; i < r.unit_count; ++i) glBindTextureUnit(static_cast<GLuint>(r.units[i].binding), r.units[i].texture);
}

void destroy_gl_representation(GlRepresentation& r) noexcept {
  if (r.gl_program) glDeleteProgram(r.gl_program);
  for (int i = 0; i < r.unit_count; ++i) glDeleteTextures(1, &r.units[i].texture);
  r = GlRepresentation{};
}

}  // namespace btflod::samples
