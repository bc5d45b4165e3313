// Shared by the factorisation tests (test_factor_*.cpp): the option sets they use written in one
// call, the squared error between two BTFs, the 3 × 3 angular blend of measured images that an
// exact factorisation must reproduce, and the read-back and truncation checks every factor file
// format passes.
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/laplacian_pca.hpp"
#include "btflod/offline/factor/local_pca.hpp"
#include "btflod/offline/factor/pca_views.hpp"

namespace btflod_test {

using namespace btflod;

inline FmfOptions fmf_options(int components, SvdMethod method = SvdMethod::automatic) {
  FmfOptions o;
  o.components = components;
  o.svd.method = method;
  return o;
}

inline PcaViewsOptions pca_views_options(int views_per_group, int components) {
  PcaViewsOptions o;
  o.views_per_group = views_per_group;
  o.components = components;
  return o;
}

inline LaplacianPcaOptions laplacian_options(int mip_count, std::array<int, 3> components) {
  LaplacianPcaOptions o;
  o.mip_count = mip_count;
  o.components = components;
  return o;
}

inline LocalPcaOptions local_pca_options(int clusters, int components, bool quantize_8bit = true) {
  LocalPcaOptions o;
  o.clusters = clusters;
  o.components = components;
  o.quantize_8bit = quantize_8bit;
  return o;
}

// Σ (a − b)² over every sample; a and b have the same shape.
inline double squared_error(const BtfFloat& a, const BtfFloat& b) {
  double s = 0.0;
  for (size_t i = 0; i < a.samples().size(); ++i) {
    const double d = static_cast<double>(a.samples()[i]) - b.samples()[i];
    s += d * d;
  }
  return s;
}

// Expects got (an evaluation at texel x, y) to be the light- and view-weighted sum of the nine
// measured images the two samples name, within 1e-4 per channel.
inline void expect_nine_tap_blend(const BtfFloat& btf, int x, int y, const AngularSample& light,
                                  const AngularSample& view, const glm::vec3& got) {
  for (int c = 0; c < 3; ++c) {
    double want = 0.0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        want += view.weight[i] * light.weight[j] * btf.value(x, y, view.index[i], light.index[j], c);
    EXPECT_NEAR(got[c], want, 1e-4);
  }
}

// Serialises rep, reads the bytes back and expects them to serialise to the same bytes.
// Returns the representation read, or nothing (after a failed expectation) when the bytes do
// not read.
template <class T>
std::optional<T> expect_reads_back(const T& rep) {
  const std::vector<uint8_t> bytes = rep.serialize();
  auto back = T::deserialize(bytes);
  EXPECT_TRUE(back.ok()) << back.message();
  if (!back.ok()) return std::nullopt;
  EXPECT_EQ(back->serialize(), bytes);
  return std::move(*back);
}

// Expects T's reader to refuse every prefix of bytes whose length is a multiple of step.
template <class T>
void expect_prefixes_refused(std::span<const uint8_t> bytes, size_t step) {
  for (size_t cut = 0; cut < bytes.size(); cut += step) EXPECT_FALSE(T::deserialize(bytes.first(cut)).ok()) << cut;
}

}  // namespace btflod_test
