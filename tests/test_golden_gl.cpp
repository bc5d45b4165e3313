// Golden images: the OpenGL backend (samples/gl, EGL headless on llvmpipe) vs the CPU reference
// of offline/render/cpu_reference.hpp on the same scene:
// PSNR >= 40 dB at 256x256 for FMF and for BSVTF through a partially filled vt/ TileCache, and for
// the laplacian (eq. 7 level blending), lpca (3 clusters), pca_views (k = 3 of 9 views) and spmm
// (paper 003, three residual switches) programs against the representations' CPU evaluators
// (test_golden_representations.hpp); a live Streamer's materials removed and added on the backend
// render like a fresh Streamer's, and two materials in two cache pools of different tile sizes
// match their CPU references (test_golden_streamer.hpp).
// Skips with the reason when the GPU API is not available at run time.
// btflod-link: btflod_gl_backend
// btflod-label: gpu
#include <gtest/gtest.h>

#include "gl_backend.hpp"
#include "test_backend_factory.hpp"
#include "test_golden_cases.hpp"
#include "test_golden_streamer.hpp"

namespace {

std::unique_ptr<btflod::Backend> make_backend(std::string& why) {
  return btflod::test::backend_or_why(btflod::samples::create_gl_backend(), why);
}

}  // namespace

BTFLOD_GOLDEN_PROGRAM_TESTS(GoldenGl, , make_backend)
TEST(GoldenGl, UPacketUploadsMatchAMaterialCreatedWithThem) { btflod::golden::golden_fmf_u_packets(make_backend); }
TEST(GoldenGl, StreamerMaterialsComeAndGoOnTheGpu) {
  btflod::golden::golden_streamer_materials_come_and_go(make_backend);
}
TEST(GoldenGl, TwoCachePoolsOfDifferentTileSizesMatchCpuReference) {
  btflod::golden::golden_streamer_pools(make_backend);
}
