// The golden cases of test_golden_scene.hpp and test_golden_representations.hpp that every set of
// generated programs must pass, declared as tests for one backend factory: test_golden_gl.cpp
// runs them on the GL programs, test_golden_vk.cpp on the Vulkan GLSL and HLSL programs.
#pragma once

#include <gtest/gtest.h>

#include "test_golden_representations.hpp"
#include "test_golden_scene.hpp"

/// Declares the tests Suite.<Prefix><case> (Prefix may be empty), each running one golden case
/// with the backend factory `make` (a btflod::golden::BackendFactory).
#define BTFLOD_GOLDEN_PROGRAM_TESTS(Suite, Prefix, make)                                                             \
  TEST(Suite, Prefix##FmfMatchesCpuReference) { btflod::golden::golden_fmf(make); }                                  \
  TEST(Suite, Prefix##FmfValueTransformsMatchCpuReference) { btflod::golden::golden_fmf_value_transforms(make); }    \
  TEST(Suite, Prefix##FmfMaterialsOfEveryRankUnderOneProgram) { btflod::golden::golden_fmf_component_counts(make); } \
  TEST(Suite, Prefix##BsvtfPartialCacheMatchesCpuReference) { btflod::golden::golden_bsvtf_partial(make); }          \
  TEST(Suite, Prefix##BsvtfRgba8PartialCacheMatchesCpuReference) {                                                   \
    btflod::golden::golden_bsvtf_partial(make, btflod::CacheFormat::rgba8_affine);                                   \
  }                                                                                                                  \
  TEST(Suite, Prefix##BsvtfBc5PartialCacheMatchesCpuReference) {                                                     \
    btflod::golden::golden_bsvtf_partial(make, btflod::CacheFormat::bc5_affine);                                     \
  }                                                                                                                  \
  TEST(Suite, Prefix##LaplacianLevelBlendMatchesCpuReference) { btflod::golden::golden_laplacian(make); }            \
  TEST(Suite, Prefix##LpcaClustersMatchCpuReference) { btflod::golden::golden_lpca(make); }                          \
  TEST(Suite, Prefix##PcaViewsGroupsMatchCpuReference) { btflod::golden::golden_pca_views(make); }                   \
  TEST(Suite, Prefix##SpmmMixturesAndResidualMatchCpuReference) { btflod::golden::golden_spmm(make); }
