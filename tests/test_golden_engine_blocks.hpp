// The uniform blocks of the engine in the engine-style golden tests (GL and Vulkan): std140
// mirrors of the blocks the engine's own shader declares, not btflod's ShaderParams.
#pragma once

#include <glm/glm.hpp>

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

}  // namespace btflod::golden
