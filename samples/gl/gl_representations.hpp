// btflod sample — the OpenGL side of the laplacian, lpca, pca_views and spmm programs (paper 001
// eq. 7, paper 002 §6.2, paper 004 §6.3, paper 003 eq. 1–3): textures in the layouts of backend.hpp's *MaterialData and
// the program generated for each material. Internal to btflod_gl_backend (includes glad).
#pragma once

#include <glad/gl.h>

#include "btflod/core/result.hpp"
#include "btflod/runtime/backend/backend.hpp"

namespace btflod::samples {

/// A material of one of the three representations: its program and the textures it binds.
struct GlRepresentation {
  struct Unit {
    ShaderBinding binding = ShaderBinding::params;
    GLuint texture = 0;
  };
  ShaderProgram program = ShaderProgram::fmf;
  GLuint gl_program = 0;
  Unit units[6];
  int unit_count = 0;
};

/// Creates the textures and compiles the program (generate_program for gl450_core with
/// representation_config(base, m)). Preconditions: a current GL 4.5 context, validate_material
/// passed. Returns unsupported with the compiler log or GL error; nothing leaks on failure.
Result<GlRepresentation> create_gl_representation(const ShaderConfig& base, const LaplacianMaterialData& m);
Result<GlRepresentation> create_gl_representation(const ShaderConfig& base, const LpcaMaterialData& m);
Result<GlRepresentation> create_gl_representation(const ShaderConfig& base, const PcaViewsMaterialData& m);
Result<GlRepresentation> create_gl_representation(const ShaderConfig& base, const SpmmMaterialData& m);

/// glUseProgram + binds every texture to its unit. No allocation.
void bind_gl_representation(const GlRepresentation& r) noexcept;

/// Deletes the program and textures (zeroes `r`).
void destroy_gl_representation(GlRepresentation& r) noexcept;

}  // namespace btflod::samples
