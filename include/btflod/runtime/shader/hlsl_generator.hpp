// btflod — HLSL generator (Shader Model 5.1 / 6.0 style) of the same functions and programs as
// runtime/shader/glsl_generator.hpp, for engines that author HLSL.
//
// Same pieces, same dependency graph (GlslPiece, glsl_pieces()), same options type
// (GlslFunctionOptions: prefix, names, registers, uniform sources), same equations and the same
// function names; only the spelling is HLSL:
//
//   GLSL                                   HLSL
//   vec4 / ivec2 / uvec4                   float4 / int2 / uint4
//   sampler2DArray (binding b, set s)      Texture2DArray<float4> : register(t<b>, space<s>)
//   usampler2DArray (page table)           Texture2DArray<uint>   (angular index, SPMM: <uint4>)
//   texelFetch(t, ivec3(xy, layer), mip)   t.Load(int4(xy, layer, mip))
//   texture / textureLod (filtered)        t.Sample / t.SampleLevel with SamplerState
//                                          <prefix><role>_sampler : register(s<b>, space<s>)
//   textureSize(t, mip)                    t.GetDimensions(mip, w, h, layers, levels)
//   mix, fract, dFdx, atan(y, x)           lerp, frac, ddx, atan2(y, x)
//   uintBitsToFloat                        asfloat
//   const (global)                         static const
//   uniform block BtflodParams {..} btflod cbuffer BtflodParams { btflod_<member> } (register b0)
//   mat * v                                mul(mat, v) (column_major, the std140 bytes as they are)
//
// generate_hlsl_functions() emits the functions to paste into an engine's HLSL; the uniform
// sources default to the members of the whole programs' cbuffer (HlslFunctionOptions).
// generate_hlsl_program() assembles whole programs: a vertex shader and a pixel shader, each
// with entry point `main`. Why separate templates rather than a macro prelude: docs/shaders.md,
// "HLSL".
//
// Both are set-up code defined in the implementation TU (BTFLOD_IMPLEMENTATION).
#pragma once

#include <cstdint>
#include <string>

#include "btflod/core/result.hpp"
#include "btflod/runtime/shader/glsl_generator.hpp"
#include "btflod/runtime/shader/shader_config.hpp"

namespace btflod {

/// Generated HLSL of one program: `vertex` and `fragment` (pixel shader), entry point `main`.
using HlslProgramSource = GlslProgramSource;
/// Output of generate_hlsl_functions(): the code and every texture it reads (GlslSamplerUse:
/// binding = t register, set = register space).
using HlslFunctionSource = GlslFunctionSource;

/// Uniform sources naming the members of the whole HLSL programs' cbuffer BtflodParams
/// (globals `btflod_vt_extent`, `btflod_lod`, `btflod_ids`, ...). Allocates.
inline GlslUniformSources hlsl_default_uniform_sources() {
  GlslUniformSources u;
  u.vt_extent = "btflod_vt_extent";
  u.lod_bias = "btflod_lod.x";
  u.feedback_lod_offset = "btflod_lod.y";
  u.range_lod_scale = "btflod_lod.z";
  u.first_layer = "btflod_ids.x";
  u.texture_id = "btflod_ids.y";
  u.spmm_mode = "btflod_ids.w";
  u.component_count = "btflod_vt_extent.w";
  return u;
}

/// GlslFunctionOptions with the HLSL defaults: uniforms from hlsl_default_uniform_sources().
/// For HLSL a resource's `binding` is its register number (t for textures, s for the sampler
/// state of a filtered texture, b for the DirectionRings cbuffer) and `set` its register space.
/// A filtered texture (eigen_textures, tile_cache, lpca_volume) is sampled with the SamplerState
/// `<prefix><role>_sampler` (e.g. btflod_tile_cache_sampler), declared with its texture.
struct HlslFunctionOptions : GlslFunctionOptions {
  /// Default names and registers (register = ShaderBinding value, space 0), cbuffer uniforms.
  HlslFunctionOptions() { uniforms = hlsl_default_uniform_sources(); }
};

/// Generates the HLSL functions of `pieces` (a glsl_pieces() set; the pieces they call are
/// added), to paste into an engine's HLSL source. Same functions, names and arithmetic as
/// generate_functions(); textures are declared with `register(t<binding>, space<set>)` unless
/// the host declares them (GlslResource::declare = false; then it also declares the sampler
/// state `<prefix><role>_sampler` of a filtered texture). Functions using derivatives (the
/// page_table λ, bsvtf, feedback) and the filtered fetches of fmf and lpca (Sample) are for pixel
/// shaders in uniform control flow. Returns invalid_argument like generate_functions() (config,
/// piece set, prefix, names, uniform sources, two declared textures on one register and space).
/// Deterministic. Allocates (set-up time). Thread-safe.
Result<HlslFunctionSource> generate_hlsl_functions(uint32_t pieces, const ShaderConfig& config,
                                                   const GlslFunctionOptions& options = HlslFunctionOptions{});

/// Generates the vertex and pixel shader of `program` in HLSL: cbuffer BtflodParams
/// (ShaderParams byte for byte, register b0 space0), inputs POSITION/NORMAL/TANGENT/TEXCOORD0
/// (in attribute order, so SPIR-V locations follow VertexAttribute), varyings TEXCOORD0..3, the
/// functions of generate_hlsl_functions() with the default options, and SV_Target0 (bsvtf_feedback:
/// SV_Target1 = the uint feedback word; feedback: SV_Target0 is the word). Clip z is remapped
/// to [0, w] as for Vulkan GLSL (Direct3D and Vulkan depth range). Returns invalid_argument when
/// the config fails validate_shader_config(). Deterministic. Allocates. Thread-safe.
Result<HlslProgramSource> generate_hlsl_program(ShaderProgram program, const ShaderConfig& config);

}  // namespace btflod

#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)
#include "btflod/runtime/shader/hlsl_pieces.hpp"
#endif  // BTFLOD_IMPLEMENTATION
