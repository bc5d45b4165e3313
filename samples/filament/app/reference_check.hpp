// --check: the converged Filament frame and feedback against btflod's CPU reference
// (offline/render/cpu_reference.hpp) at the same view. Not part of an integration: a test of one.
//
// The CPU side mirrors what the GPU received (every tile upload into a CpuCacheTexture, every U′
// packet into U), ray-casts the same shapes with the same camera, samples V′ through the tile
// cache's own page table (deepest resident tile, bilinear in the bordered tile) and shades eq. 5
// with the same angular tables. The check view magnifies the texture everywhere (λ ≥ L), so the
// GPU also reads the deepest resident tile and both must agree up to half-float and rasteriser
// rounding. Feedback words are computed by the CPU at the feedback view's pixel centres (ray
// differentials instead of the GPU's finite differences).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "btflod/core/image.hpp"
#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/runtime/angular/bsvtf_angular_tables.hpp"
#include "btflod/runtime/backend/streamer_outputs.hpp"
#include "btflod/runtime/streamer.hpp"

namespace sample {

class ReferenceCheck {
 public:
  ReferenceCheck(const btflod::Streamer& s, std::vector<const btflod::BsvtfAngularTables*> tables);
  /// Mirrors one frame's uploads (call with the same outputs the GPU got).
  void mirror(const btflod::StreamerOutputs& out);
  /// Feedback words of the Filament feedback view (top row first, a view with `decimation`×
  /// fewer pixels per side than `cam`) against the CPU's at the same pixel centres. Prints the
  /// counts under `label`; returns true when ≥ min_equal of them are equal and at most
  /// max_other differ by more than one level (or in material or tile at the same level).
  bool compare_feedback(const char* label, const btflod::Scene& scene, const btflod::Camera& cam, float lod_bias,
                        std::span<const uint32_t> words, uint32_t decimation, double min_equal, double max_other) const;
  /// Compares; prints the numbers; returns true when every bound holds. rgba: the Filament frame
  /// (cam.width × cam.height × 4 floats, top row first); words: the feedback view's words
  /// (top row first) of a view with `decimation`× fewer pixels per side.
  bool run(const btflod::Scene& scene, const btflod::Camera& cam, glm::vec3 to_light, glm::vec3 light_color,
           float lod_bias, std::span<const float> rgba, std::span<const uint32_t> words, uint32_t decimation,
           double min_psnr, const std::string& out_dir);
  /// The fmf material's frame (resident V′ = `v` on material `material`'s shapes, bilinear with
  /// repeat at the finest level, the GPU's sampling when the view magnifies) against the CPU's.
  bool run_fmf(const btflod::Scene& scene, const btflod::Camera& cam, glm::vec3 to_light, glm::vec3 light_color,
               uint32_t material, const btflod::Image<float>& v, std::span<const float> rgba, double min_psnr,
               const std::string& out_dir);

 private:
  // Shades one pixel with eq. 5 from components `v` (C values); black where nothing is hit.
  glm::vec3 shade(const btflod::SurfaceHit& hit, const btflod::Camera& cam, glm::vec3 to_light, glm::vec3 light_color,
                  std::span<const float> v) const;
  // PSNR of `rgba` against `ref` (rgb, peak = the reference's maximum); writes ref as PNG.
  static double psnr(const btflod::Image<float>& ref, std::span<const float> rgba, const std::string& png);

  const btflod::Streamer& streamer_;
  std::vector<const btflod::BsvtfAngularTables*> tables_;
  btflod::CpuCacheTexture cache_;
  std::vector<btflod::EigenTextures> u_;  // U′ per material (light-major rows), V unused
};

}  // namespace sample
