// Tests for offline/btf/merl_brdf.hpp: a known analytic BRDF written in MERL's .binary layout by the
// test (real MERL files are not on this machine) and read back (half/difference mapping,
// square-root θ_h indexing, colour scales, resampling onto MeasuredBrdf's grid), not-measured
// samples (handled and counted), the synthesiser using a MERL base, and the failure classes:
// truncated header and planes, wrong dimensions, NaN/Inf, no measured sample, trailing bytes,
// missing file.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "btflod/core/file_io.hpp"
#include "btflod/offline/btf/merl_brdf.hpp"
#include "btflod/offline/btf/synthesizer.hpp"

namespace {

using namespace btflod;

// Lambert + a normalised Blinn–Phong lobe, per channel: ρ = kd/π + ks·(n + 2)/(2π)·(n·h)^n.
// Evaluated from the directions themselves (not from MERL's angles), so a mistake in the
// reader's half/difference mapping shows up as a mismatch.
glm::dvec3 analytic(const glm::dvec3& l, const glm::dvec3& v) {
  const glm::dvec3 h = glm::normalize(l + v);
  const double lobe = (20.0 + 2.0) / (2.0 * 3.14159265358979323846) * std::pow(std::max(h.z, 0.0), 20.0);
  const glm::dvec3 kd(0.5, 0.3, 0.1), ks(0.04, 0.05, 0.06);
  return kd / 3.14159265358979323846 + ks * lobe;
}

const std::vector<double>& analytic_table() {
  static const std::vector<double> t = merl_table_from_function(analytic);
  return t;
}

std::vector<uint8_t> analytic_file() {
  auto bytes = encode_merl_binary(analytic_table());
  EXPECT_TRUE(bytes.ok());
  return bytes.ok() ? *bytes : std::vector<uint8_t>{};
}

glm::dvec3 random_upper(std::mt19937& rng, double max_theta) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double t = max_theta * u(rng), p = 2.0 * 3.14159265358979323846 * u(rng);
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

TEST(MerlBrdf, HalfDiffRoundTripsThroughDirections) {
  std::mt19937 rng(3);
  for (int n = 0; n < 500; ++n) {
    const glm::dvec3 l = random_upper(rng, 1.5), v = random_upper(rng, 1.5);
    const HalfDiffAngles a = half_diff_from_directions(l, v);
    glm::dvec3 l2, v2;
    directions_from_half_diff(a, l2, v2);
    // Same angles between the pair and the normal (the frame is rotated by φ_h about z).
    EXPECT_NEAR(l2.z, l.z, 1e-9);
    EXPECT_NEAR(v2.z, v.z, 1e-9);
    EXPECT_NEAR(glm::dot(l2, v2), glm::dot(l, v), 1e-9);
  }
  // Mirror configuration: θ_h = 0, θ_d = θ.
  const HalfDiffAngles m =
      half_diff_from_directions({std::sin(0.4), 0, std::cos(0.4)}, {-std::sin(0.4), 0, std::cos(0.4)});
  EXPECT_NEAR(m.theta_half, 0.0, 1e-9);
  EXPECT_NEAR(m.theta_diff, 0.4, 1e-9);
}

TEST(MerlBrdf, FileLayoutIndexesAndScalesAsDocumented) {
  const auto& t = analytic_table();
  ASSERT_EQ(t.size(), 3 * kMerlPlaneSize);
  // Sample (i_h, i_d, i_p) at θ_h = (i_h/90)²·π/2, θ_d = i_d·π/180, φ_d = i_p·π/180, plane c
  // stores ρ_c / scale_c at index c·N + (i_h·90 + i_d)·180 + i_p.
  const int ih = 30, id = 20, ip = 45;
  const double th = (ih / 90.0) * (ih / 90.0) * 0.5 * 3.14159265358979323846;
  const double td = id * 0.5 * 3.14159265358979323846 / 90.0, pd = ip * 3.14159265358979323846 / 180.0;
  // Directions built independently: the half vector tilted by θ_h in the xz plane, the light
  // at θ_d, φ_d around it.
  const glm::dvec3 n_h(std::sin(th), 0.0, std::cos(th)), b(0, 1, 0), tng = glm::cross(b, n_h);
  const glm::dvec3 l = std::cos(td) * n_h + std::sin(td) * (std::cos(pd) * tng + std::sin(pd) * b);
  const glm::dvec3 v = 2.0 * glm::dot(l, n_h) * n_h - l;
  const glm::dvec3 rho = analytic(l, v);
  const size_t i = (size_t{ih} * 90 + id) * 180 + ip;
  EXPECT_NEAR(t[i] * 1.0 / 1500.0, rho.x, 1e-9);
  EXPECT_NEAR(t[kMerlPlaneSize + i] * 1.15 / 1500.0, rho.y, 1e-9);
  EXPECT_NEAR(t[2 * kMerlPlaneSize + i] * 1.66 / 1500.0, rho.z, 1e-9);
}

// Found by fuzz_merl_binary: a NaN angle went through std::clamp unchanged and was converted to
// an int index (undefined behaviour, then a read far outside the table).
TEST(MerlBrdf, NanAnglesInALookupAreNotMeasuredNeverAnOutOfBoundsRead) {
  const MerlTable table{std::vector<double>(analytic_table())};
  const double nan = std::nan(""), inf = std::numeric_limits<double>::infinity();
  for (const HalfDiffAngles& a : {HalfDiffAngles{nan, 0.3, 0.2}, HalfDiffAngles{0.3, nan, 0.2},
                                  HalfDiffAngles{nan, nan, nan}, HalfDiffAngles{0.3, 0.2, nan}}) {
    bool measured = true;
    const glm::dvec3 r = table.lookup(a, &measured);
    for (int c = 0; c < 3; ++c) EXPECT_TRUE(std::isfinite(r[c]) && r[c] >= 0.0);
    if (std::isnan(a.theta_half) || std::isnan(a.theta_diff)) {
      EXPECT_FALSE(measured);
      EXPECT_EQ(r, glm::dvec3(0.0));
    }
  }
  // Infinite angles clamp to the table's range.
  const glm::dvec3 r = table.lookup(HalfDiffAngles{inf, -inf, inf});
  for (int c = 0; c < 3; ++c) EXPECT_TRUE(std::isfinite(r[c]) && r[c] >= 0.0);
}

TEST(MerlBrdf, AnalyticBrdfReadBackMatchesTheFunction) {
  const std::string path = std::string(BTFLOD_TEST_TMP_DIR) + "/analytic.binary";
  ASSERT_TRUE(write_file_bytes(path, analytic_file()).ok());
  auto m = read_merl_binary(path);
  ASSERT_TRUE(m.ok()) << m.message();
  EXPECT_EQ(m->brdf.res_theta(), 90u);
  EXPECT_EQ(m->brdf.res_phi(), 180u);
  EXPECT_EQ(m->brdf.channels(), 3);
  // Exact table lookups and the resampled MeasuredBrdf both follow the function.
  std::mt19937 rng(11);
  double worst_table = 0, worst_brdf = 0;
  for (int n = 0; n < 2000; ++n) {
    const glm::dvec3 l = random_upper(rng, 1.3), v = random_upper(rng, 1.3);  // θ ≤ 74.5°
    const glm::dvec3 ref = analytic(l, v);
    const glm::dvec3 a = m->table.lookup(half_diff_from_directions(l, v));
    const glm::vec3 b = m->brdf.evaluate(glm::vec3(l), glm::vec3(v));
    for (int c = 0; c < 3; ++c) {
      worst_table = std::max(worst_table, std::abs(a[c] - ref[c]) / ref[c]);
      worst_brdf = std::max(worst_brdf, std::abs(double(b[c]) - ref[c]) / ref[c]);
    }
  }
  // The lobe (exponent 20) is smooth at MERL's resolution: linear interpolation error of a
  // few percent at most; a wrong index mapping or scale gives errors of order 1.
  EXPECT_LT(worst_table, 0.03);
  EXPECT_LT(worst_brdf, 0.05);
  // Only below-horizon samples are marked not measured by the writer.
  EXPECT_GT(m->report.not_measured, 0u);
  EXPECT_EQ(m->report.unfilled_cells, 0u);
}

TEST(MerlBrdf, NotMeasuredSamplesAreSkippedAndReported) {
  std::vector<double> t = analytic_table();
  const size_t before = [&] {
    size_t n = 0;
    for (double v : t) n += v < 0.0;
    return n;
  }();
  // Punch a hole: every θ_d index ≥ 80 (grazing difference angles) not measured, all planes.
  size_t punched = 0;
  for (int c = 0; c < 3; ++c)
    for (int ih = 0; ih < 90; ++ih)
      for (int id = 80; id < 90; ++id)
        for (int ip = 0; ip < 180; ++ip) {
          double& v = t[c * kMerlPlaneSize + (size_t{90} * ih + id) * 180 + ip];
          if (v >= 0.0) ++punched;
          v = -1.0;
        }
  auto bytes = encode_merl_binary(t);
  ASSERT_TRUE(bytes.ok());
  MerlReadOptions small;
  small.res_theta = 30;
  small.res_phi = 60;
  auto m = parse_merl_binary(*bytes, "holes", small);
  ASSERT_TRUE(m.ok()) << m.message();
  EXPECT_EQ(m->report.not_measured, before + punched);
  EXPECT_EQ(m->brdf.negative_count(), 0u);
  // Inside the hole the value comes from the measured neighbours (θ_d index 79): finite, > 0.
  const HalfDiffAngles deep{0.2, 88.0 / 90.0 * 0.5 * 3.14159265358979323846, 1.0};
  bool measured = true;
  const glm::dvec3 v = m->table.lookup(deep, &measured);
  EXPECT_FALSE(measured);
  EXPECT_EQ(v, glm::dvec3(0.0));
  const HalfDiffAngles edge{0.2, 79.5 / 90.0 * 0.5 * 3.14159265358979323846, 1.0};
  const glm::dvec3 e = m->table.lookup(edge, &measured);
  EXPECT_TRUE(measured);
  EXPECT_GT(e.x, 0.0);
  // Resampled cells that fall entirely inside the hole are counted and hold 0.
  EXPECT_GT(m->report.unfilled_cells, 0u);
  for (float x : m->brdf.values()) ASSERT_TRUE(std::isfinite(x) && x >= 0.0f);
}

TEST(MerlBrdf, IsABaseReflectanceForTheSynthesiser) {
  MerlReadOptions small;
  small.res_theta = 30;
  small.res_phi = 60;
  auto m = parse_merl_binary(analytic_file(), "analytic", small);
  ASSERT_TRUE(m.ok()) << m.message();
  const Mesostructure flat = make_flat_mesostructure(2, 2, glm::vec3(0.5f), 0.5f, 0.0f);
  SynthesisOptions opts;
  opts.measured_brdf = &m->brdf;
  opts.convention = BtfValueConvention::brdf;
  auto btf = synthesize_btf(flat, opts);
  ASSERT_TRUE(btf.ok()) << btf.message();
  // A flat texel shows the base BRDF (tinted by the albedo map relative to its mean, here 1).
  double worst = 0;
  for (size_t v = 0; v < btf->view_count(); v += 7)
    for (size_t l = 0; l < btf->light_count(); l += 5) {
      const glm::vec3 ref = m->brdf.evaluate(btf->lights()[l].vector, btf->views()[v].vector);
      for (int c = 0; c < 3; ++c)
        worst = std::max(worst, double(std::abs(btf->value(0, 0, v, l, c) - ref[c])) / std::max(1e-3, double(ref[c])));
    }
  EXPECT_LT(worst, 1e-3);
}

// ---- failure classes ---------------------------------------------------------------------------

std::vector<uint8_t> small_header_file(int32_t a, int32_t b, int32_t c, size_t doubles) {
  std::vector<uint8_t> out(12 + doubles * 8, 0);
  const int32_t dims[3] = {a, b, c};
  std::memcpy(out.data(), dims, 12);
  return out;
}

TEST(MerlBrdf, TruncatedInputIsShortOutput) {
  const auto good = analytic_file();
  for (size_t n : {size_t{0}, size_t{5}, size_t{11}, size_t{12}, size_t{20}, good.size() / 2, good.size() - 1}) {
    auto m = parse_merl_binary(std::span<const uint8_t>(good.data(), n));
    ASSERT_FALSE(m.ok()) << n;
    EXPECT_EQ(m.status(), Status::short_output) << n << ": " << m.message();
    EXPECT_NE(m.message().find("truncated"), std::string::npos) << m.message();
  }
}

TEST(MerlBrdf, WrongDimensionsAreBadData) {
  for (auto dims : {std::array<int32_t, 3>{90, 90, 360}, std::array<int32_t, 3>{180, 90, 90},
                    std::array<int32_t, 3>{-90, 90, 180}, std::array<int32_t, 3>{0x7fffffff, 90, 180}}) {
    auto m = parse_merl_binary(small_header_file(dims[0], dims[1], dims[2], 4));
    ASSERT_FALSE(m.ok());
    EXPECT_EQ(m.status(), Status::bad_data) << m.message();
    EXPECT_NE(m.message().find("expected 90 x 90 x 180"), std::string::npos) << m.message();
  }
}

TEST(MerlBrdf, NaNAndInfinityAreBadDataNamingTheSample) {
  auto bytes = analytic_file();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const size_t sample = kMerlPlaneSize + (size_t{90} * 3 + 4) * 180 + 5;  // green, θ_h 3, θ_d 4, φ_d 5
  std::memcpy(bytes.data() + 12 + sample * 8, &nan, 8);
  auto m = parse_merl_binary(bytes);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status(), Status::bad_data);
  EXPECT_NE(m.message().find("green plane sample"), std::string::npos) << m.message();
  EXPECT_NE(m.message().find("theta_h 3, theta_d 4, phi_d 5"), std::string::npos) << m.message();
  const double inf = std::numeric_limits<double>::infinity();
  bytes = analytic_file();
  std::memcpy(bytes.data() + 12, &inf, 8);
  m = parse_merl_binary(bytes);
  EXPECT_EQ(m.status(), Status::bad_data);
  EXPECT_NE(m.message().find("infinite"), std::string::npos) << m.message();
}

TEST(MerlBrdf, PlaneWithoutMeasuredSamplesIsBadData) {
  std::vector<double> t = analytic_table();
  for (size_t i = 0; i < kMerlPlaneSize; ++i) t[2 * kMerlPlaneSize + i] = -1.0;
  auto m = parse_merl_binary(*encode_merl_binary(t));
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status(), Status::bad_data);
  EXPECT_NE(m.message().find("blue plane has no measured sample"), std::string::npos) << m.message();
}

TEST(MerlBrdf, TrailingBytesAndBadOptionsAreRejected) {
  auto bytes = analytic_file();
  bytes.push_back(0);
  auto m = parse_merl_binary(bytes);
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status(), Status::bad_data);
  EXPECT_NE(m.message().find("trailing bytes: 1 bytes"), std::string::npos) << m.message();
  MerlReadOptions bad;
  bad.res_theta = 0;
  EXPECT_EQ(parse_merl_binary(analytic_file(), "x", bad).status(), Status::invalid_argument);
  EXPECT_EQ(read_merl_binary(std::string(BTFLOD_TEST_TMP_DIR) + "/no_such.binary").status(), Status::io_error);
  EXPECT_EQ(encode_merl_binary(std::vector<double>(5)).status(), Status::invalid_argument);
}

}  // namespace
