// Golden images: the Vulkan backend (samples/vulkan, headless on lavapipe) vs the CPU reference
// of offline/render/cpu_reference.hpp on the same scene:
// PSNR >= 40 dB at 256x256 for FMF and for BSVTF through a partially filled vt/ TileCache, and for
// the laplacian (eq. 7 level blending), lpca (3 clusters), pca_views (k = 3 of 9 views) and spmm
// (paper 003, three residual switches) programs against the representations' CPU evaluators
// (test_golden_representations.hpp); a live Streamer's materials removed and added on the backend
// render like a fresh Streamer's, and two materials in two cache pools of different tile sizes
// match their CPU references (test_golden_streamer.hpp).
// The HLSL programs (VkBackendOptions::hlsl_programs, SPIR-V from glslang's HLSL front end)
// render the FMF and the partial-cache BSVTF scenes like the Vulkan GLSL programs (>= 60 dB), and
// pass every golden test above against the same CPU references.
// Skips with the reason when the GPU API is not available at run time.
// btflod-link: btflod_vk_backend
// btflod-label: gpu
#include <gtest/gtest.h>

#define BTFLOD_TEST_VK_FACTORY 1
#include "test_backend_factory.hpp"
#include "test_golden_cases.hpp"
#include "test_golden_streamer.hpp"
#include "vk_backend.hpp"

namespace {

std::unique_ptr<btflod::Backend> make_backend(std::string& why) { return btflod::test::make_vk_backend(why, false); }
std::unique_ptr<btflod::Backend> make_hlsl_backend(std::string& why) {
  return btflod::test::make_vk_backend(why, true);
}

// The image of `program` on the golden scene (the partial cache for bsvtf) drawn by `be`.
void render_golden(btflod::Backend& be, btflod::ShaderProgram program, btflod::Image<float>& img) {
  using namespace btflod;
  using namespace btflod::golden;
  const ShaderConfig config = golden_config();
  const Material m = make_material(config, kTexture, kTexture);
  PartialCacheScene vt;
  const bool bsvtf = program == ShaderProgram::bsvtf;
  if (bsvtf) build_partial_cache(config, m, vt);
  if (::testing::Test::HasFatalFailure()) return;
  ASSERT_TRUE(be.init(config, bsvtf ? vt.set.texture_count() : 2).ok());
  if (bsvtf) {
    ASSERT_EQ(be.upload_tiles(vt.uploads), Status::success);
    ASSERT_EQ(be.apply_page_table_writes(vt.writes), Status::success);
  }
  auto mesh = create_plane_mesh(be);
  ASSERT_TRUE(mesh.ok()) << mesh.message();
  FmfMaterialData d = m.data(!bsvtf);
  d.mipmaps = false;
  auto mat = be.create_material(d);
  ASSERT_TRUE(mat.ok()) << mat.message();
  assert_render_frame(be, program, *mesh, *mat, golden_params(golden_camera()), img);
}

void hlsl_matches_glsl(btflod::ShaderProgram program) {
  std::string why;
  std::unique_ptr<btflod::Backend> glsl = btflod::test::make_vk_backend(why, false);
  if (!glsl) GTEST_SKIP() << "GPU API unavailable: " << why;
  std::unique_ptr<btflod::Backend> hlsl = btflod::test::make_vk_backend(why, true);
  ASSERT_TRUE(hlsl) << why;
  btflod::Image<float> a(btflod::golden::kSize, btflod::golden::kSize, 4);
  btflod::Image<float> b(btflod::golden::kSize, btflod::golden::kSize, 4);
  render_golden(*glsl, program, a);
  render_golden(*hlsl, program, b);
  if (::testing::Test::HasFatalFailure()) return;
  btflod::golden::expect_content(b);
  const double psnr = btflod::test_scene::psnr_rgb(a, b);
  std::printf("[ %s ] golden %s, HLSL vs GLSL programs: PSNR %.2f dB\n", hlsl->name(),
              btflod::shader_program_name(program), psnr);
  EXPECT_GE(psnr, 60.0);
}

}  // namespace

BTFLOD_GOLDEN_PROGRAM_TESTS(GoldenVk, , make_backend)
BTFLOD_GOLDEN_PROGRAM_TESTS(GoldenVk, Hlsl, make_hlsl_backend)
TEST(GoldenVk, UPacketUploadsMatchAMaterialCreatedWithThem) { btflod::golden::golden_fmf_u_packets(make_backend); }
TEST(GoldenVk, StreamerMaterialsComeAndGoOnTheGpu) {
  btflod::golden::golden_streamer_materials_come_and_go(make_backend);
}
TEST(GoldenVk, TwoCachePoolsOfDifferentTileSizesMatchCpuReference) {
  btflod::golden::golden_streamer_pools(make_backend);
}
TEST(GoldenVk, HlslTwoCachePoolsOfDifferentTileSizesMatchCpuReference) {
  btflod::golden::golden_streamer_pools(make_hlsl_backend);
}
TEST(GoldenVk, HlslFmfRendersLikeGlsl) { hlsl_matches_glsl(btflod::ShaderProgram::fmf); }
TEST(GoldenVk, HlslBsvtfPartialCacheRendersLikeGlsl) { hlsl_matches_glsl(btflod::ShaderProgram::bsvtf); }
