// Golden images: the Vulkan backend (samples/vulkan, headless on lavapipe) vs the CPU reference
// of backend/cpu_reference.hpp on the same scene:
// PSNR >= 40 dB at 256x256 for FMF and for BSVTF through a partially filled vt/ TileCache, and for
// the laplacian (eq. 7 level blending), lpca (3 clusters), pca_views (k = 3 of 9 views) and spmm
// (paper 003, three residual switches) programs against the representations' CPU evaluators
// (test_golden_representations.hpp).
// Skips with the reason when the GPU API is not available at run time.
// btflod-link: btflod_vk_backend
// btflod-label: gpu
#include <gtest/gtest.h>

#include "vk_backend.hpp"
#include "test_golden_representations.hpp"
#include "test_golden_scene.hpp"

namespace {

std::unique_ptr<btflod::Backend> make_backend(std::string& why) {
  auto r = btflod::samples::create_vk_backend();
  if (!r) {
    why = r.message();
    return nullptr;
  }
  return std::move(r.value());
}

}  // namespace

TEST(GoldenVk, FmfMatchesCpuReference) { btflod::golden::golden_fmf(make_backend); }
TEST(GoldenVk, UPacketUploadsMatchAMaterialCreatedWithThem) {
  btflod::golden::golden_fmf_u_packets(make_backend);
}
TEST(GoldenVk, BsvtfPartialCacheMatchesCpuReference) { btflod::golden::golden_bsvtf_partial(make_backend); }
TEST(GoldenVk, LaplacianLevelBlendMatchesCpuReference) { btflod::golden::golden_laplacian(make_backend); }
TEST(GoldenVk, LpcaClustersMatchCpuReference) { btflod::golden::golden_lpca(make_backend); }
TEST(GoldenVk, PcaViewsGroupsMatchCpuReference) { btflod::golden::golden_pca_views(make_backend); }
TEST(GoldenVk, SpmmMixturesAndResidualMatchCpuReference) { btflod::golden::golden_spmm(make_backend); }
