// btflod sample — GL helpers shared by gl_backend.cpp and gl_representations.cpp: program
// compilation, sampler state and the angular lookup tables. Internal to btflod_gl_backend
// (includes glad); every function needs a current GL 4.5 context.
#pragma once

#include <glad/gl.h>

#include <algorithm>
#include <string>
#include <vector>

#include "btflod/core/result.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/shader/glsl_generator.hpp"

namespace btflod::samples {

/// The info log of a shader (`program` false) or program object.
inline std::string gl_info_log(GLuint obj, bool program) {
  GLint len = 0;
  if (program)
    glGetProgramiv(obj, GL_INFO_LOG_LENGTH, &len);
  else
    glGetShaderiv(obj, GL_INFO_LOG_LENGTH, &len);
  std::string log(static_cast<size_t>(std::max(len, 1)), '\0');
  if (program)
    glGetProgramInfoLog(obj, len, nullptr, log.data());
  else
    glGetShaderInfoLog(obj, len, nullptr, log.data());
  return log;
}

/// Compiles and links `src`. Returns the program, or unsupported with the compiler/linker log
/// (`what` names the program in the message); no shader or program object leaks on failure.
inline Result<GLuint> compile_gl_program(const GlslProgramSource& src, const char* what) {
  GLuint stages[2] = {glCreateShader(GL_VERTEX_SHADER), glCreateShader(GL_FRAGMENT_SHADER)};
  const char* texts[2] = {src.vertex.c_str(), src.fragment.c_str()};
  for (int i = 0; i < 2; ++i) {
    glShaderSource(stages[i], 1, &texts[i], nullptr);
    glCompileShader(stages[i]);
    GLint ok = 0;
    glGetShaderiv(stages[i], GL_COMPILE_STATUS, &ok);
    if (!ok) {
      std::string log = gl_info_log(stages[i], false);
      glDeleteShader(stages[0]);
      glDeleteShader(stages[1]);
      return make_error(Status::unsupported, "GL: %s %s shader does not compile: %s", what, i ? "fragment" : "vertex",
                        log.c_str());
    }
  }
  const GLuint prog = glCreateProgram();
  glAttachShader(prog, stages[0]);
  glAttachShader(prog, stages[1]);
  glLinkProgram(prog);
  glDeleteShader(stages[0]);
  glDeleteShader(stages[1]);
  GLint ok = 0;
  glGetProgramiv(prog, GL_LINK_STATUS, &ok);
  if (!ok) {
    std::string log = gl_info_log(prog, true);
    glDeleteProgram(prog);
    return make_error(Status::unsupported, "GL: %s program does not link: %s", what, log.c_str());
  }
  return prog;
}

/// Filters and wrap mode (S, T and R) of a texture.
inline void set_gl_sampling(GLuint tex, GLenum min_filter, GLenum mag_filter, GLenum wrap) {
  glTextureParameteri(tex, GL_TEXTURE_MIN_FILTER, static_cast<GLint>(min_filter));
  glTextureParameteri(tex, GL_TEXTURE_MAG_FILTER, static_cast<GLint>(mag_filter));
  glTextureParameteri(tex, GL_TEXTURE_WRAP_S, static_cast<GLint>(wrap));
  glTextureParameteri(tex, GL_TEXTURE_WRAP_T, static_cast<GLint>(wrap));
  glTextureParameteri(tex, GL_TEXTURE_WRAP_R, static_cast<GLint>(wrap));
}

/// The angular lookup tables of a material (docs/shaders.md): layer 0 lights, layer 1 views.
struct GlAngularTables {
  GLuint index = 0;   ///< RGBA32UI 2D array: the three direction indices per table texel
  GLuint weight = 0;  ///< RGBA32F 2D array: their barycentric weights
};

/// Creates both table textures from `a` (pack_angular_tables_rgba), nearest filtering, clamped.
inline GlAngularTables create_gl_angular_tables(const AngularTablesData& a) {
  std::vector<uint32_t> index;
  std::vector<float> weight;
  pack_angular_tables_rgba(a, index, weight);
  const GLsizei res = static_cast<GLsizei>(a.resolution);
  GlAngularTables t;
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &t.index);
  glTextureStorage3D(t.index, 1, GL_RGBA32UI, res, res, 2);
  glTextureSubImage3D(t.index, 0, 0, 0, 0, res, res, 2, GL_RGBA_INTEGER, GL_UNSIGNED_INT, index.data());
  set_gl_sampling(t.index, GL_NEAREST, GL_NEAREST, GL_CLAMP_TO_EDGE);
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &t.weight);
  glTextureStorage3D(t.weight, 1, GL_RGBA32F, res, res, 2);
  glTextureSubImage3D(t.weight, 0, 0, 0, 0, res, res, 2, GL_RGBA, GL_FLOAT, weight.data());
  set_gl_sampling(t.weight, GL_NEAREST, GL_NEAREST, GL_CLAMP_TO_EDGE);
  return t;
}

}  // namespace btflod::samples
