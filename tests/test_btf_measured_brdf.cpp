// Tests for offline/btf/measured_brdf.hpp: the real MDL SDK car paints (when the shared folder is
// present), the cell-centre trilinear lookup, the φ mirror, the horizon, sampling into a BTF,
// and the failure classes of the reader (truncated, wrong first line, wrong part line, NaN,
// absurd resolutions, trailing bytes, unknown type).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "btflod/offline/btf/measured_brdf.hpp"

namespace {

using namespace btflod;

const std::string kMeasuredDir = std::string(BTFLOD_SHARED_DIR) + "/data/measured";

// Builds MBSDF bytes by hand (an independent writer, not the reader's inverse).
std::vector<uint8_t> make_mbsdf(uint32_t type, uint32_t res_theta, uint32_t res_phi, const std::vector<float>& values,
                                const char* part = "MBSDF_DATA_REFLECTION=\n") {
  ByteWriter w;
  w.text("NVIDIA ARC MBSDF V1\n");
  w.text(part);
  w.u32(type);
  w.u32(res_theta);
  w.u32(res_phi);
  for (float v : values) w.f32(v);
  return w.take();
}

// A small RGB table whose value encodes its indices: v = 100 i + 10 j + k + c / 10.
std::vector<float> index_table(uint32_t rt, uint32_t rp) {
  std::vector<float> v;
  for (uint32_t i = 0; i < rt; ++i)
    for (uint32_t j = 0; j < rt; ++j)
      for (uint32_t k = 0; k < rp; ++k)
        for (int c = 0; c < 3; ++c) v.push_back(100.0f * i + 10.0f * j + static_cast<float>(k) + 0.1f * c);
  return v;
}

TEST(MeasuredBrdfFile, RealCarPaintsParseWithTheDocumentedShape) {
  if (!std::filesystem::exists(kMeasuredDir))
    GTEST_SKIP() << "shared data folder " << kMeasuredDir << " is absent (set BTFLOD_SHARED_DIR)";
  for (const char* name : {"carpaint_red.mbsdf", "carpaint_green.mbsdf", "carpaint_blue.mbsdf"}) {
    auto brdf = read_mbsdf(kMeasuredDir + "/" + name);
    ASSERT_TRUE(brdf.ok()) << brdf.message();
    EXPECT_EQ(brdf->res_theta(), 45u);
    EXPECT_EQ(brdf->res_phi(), 90u);
    EXPECT_EQ(brdf->channels(), 3);
    EXPECT_EQ(brdf->values().size(), 45u * 45u * 90u * 3u);
    EXPECT_FALSE(brdf->had_transmission());
    EXPECT_GT(brdf->max_value(), 1.0f);  // a glossy peak
  }
}

TEST(MeasuredBrdfFile, RealCarPaintValuesSitAtTheDocumentedOffsets) {
  if (!std::filesystem::exists(kMeasuredDir)) GTEST_SKIP() << "shared data folder " << kMeasuredDir << " is absent";
  const std::string path = kMeasuredDir + "/carpaint_red.mbsdf";
  auto brdf = read_mbsdf(path);
  ASSERT_TRUE(brdf.ok()) << brdf.message();
  auto bytes = read_file_bytes(path);
  ASSERT_TRUE(bytes.ok());
  // Independent decoding of one value straight from the bytes: header is 20 + 23 + 12 bytes.
  const size_t i = 10, j = 10, k = 89, c = 1;
  const size_t off = 55 + 4 * (3 * (i * 90 * 45 + j * 90 + k) + c);
  float expected;
  std::memcpy(&expected, bytes->data() + off, 4);
  EXPECT_EQ(brdf->raw(10, 10, 89, 1), expected);
  // The specular configuration (θ_in = θ_out, φ_diff = π) is far brighter than the back-scatter one.
  const float t = brdf->theta_center(10);
  const glm::vec3 spec = brdf->evaluate_angles(t, t, kPi);
  const glm::vec3 back = brdf->evaluate_angles(t, t, 0.0f);
  EXPECT_GT(spec.g, 20.0f * back.g);
  // Through the direction API: light at φ = 0, view mirrored at φ = π.
  const glm::vec3 via_dirs = brdf->evaluate(direction_from_spherical(t, 0.0f), direction_from_spherical(t, kPi));
  EXPECT_NEAR(via_dirs.g, spec.g, 1e-3f * spec.g);
}

TEST(MeasuredBrdfEval, CellCentresReturnTheTableExactly) {
  auto brdf = MeasuredBrdf::from_table(4, 6, 3, index_table(4, 6));
  ASSERT_TRUE(brdf.ok()) << brdf.message();
  for (uint32_t i = 0; i < 4; ++i)
    for (uint32_t j = 0; j < 4; ++j)
      for (uint32_t k = 0; k < 6; ++k) {
        const glm::vec3 v = brdf->evaluate_angles(brdf->theta_center(i), brdf->theta_center(j), brdf->phi_center(k));
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(v[c], brdf->raw(i, j, k, c), 1e-3f) << i << j << k << c;
      }
}

TEST(MeasuredBrdfEval, TrilinearBetweenCentresAndClampedAtTheEnds) {
  auto brdf = MeasuredBrdf::from_table(4, 6, 3, index_table(4, 6));
  ASSERT_TRUE(brdf.ok());
  // The table is affine in (i, j, k), so trilinear interpolation reproduces it exactly:
  // halfway between centres i = 1 and 2 along θ_in.
  const float ti = 0.5f * (brdf->theta_center(1) + brdf->theta_center(2));
  const float tj = 0.25f * brdf->theta_center(2) + 0.75f * brdf->theta_center(3);  // j = 2.75
  const float pk = 0.5f * (brdf->phi_center(3) + brdf->phi_center(4));             // k = 3.5
  const glm::vec3 v = brdf->evaluate_angles(ti, tj, pk);
  EXPECT_NEAR(v.r, 150.0f + 27.5f + 3.5f, 1e-3f);
  EXPECT_NEAR(v.b, 150.0f + 27.5f + 3.5f + 0.2f, 1e-3f);
  // Below the first centre and above the last centre the value is clamped (not extrapolated).
  EXPECT_NEAR(brdf->evaluate_angles(0.0f, 0.0f, 0.0f).r, 0.0f, 1e-4f);
  EXPECT_NEAR(brdf->evaluate_angles(0.5f * kPi, 0.5f * kPi, kPi).r, 300.0f + 30.0f + 5.0f, 1e-3f);
}

TEST(MeasuredBrdfEval, PhiMirrorAndPeriodicity) {
  auto brdf = MeasuredBrdf::from_table(4, 6, 3, index_table(4, 6));
  ASSERT_TRUE(brdf.ok());
  const float t = 0.4f;
  for (float phi : {0.1f, 0.7f, 1.9f, 3.0f}) {
    const glm::vec3 a = brdf->evaluate_angles(t, t, phi);
    const glm::vec3 mirrored = brdf->evaluate_angles(t, t, kTwoPi - phi);
    const glm::vec3 negative = brdf->evaluate_angles(t, t, -phi);
    const glm::vec3 shifted = brdf->evaluate_angles(t, t, phi + 2.0f * kTwoPi);
    EXPECT_NEAR(a.r, mirrored.r, 1e-3f);
    EXPECT_NEAR(a.r, negative.r, 1e-3f);
    EXPECT_NEAR(a.r, shifted.r, 1e-3f);
  }
  // The mirror really matters: φ = 1.0 and φ = 2.0 differ in this table.
  EXPECT_GT(std::abs(brdf->evaluate_angles(t, t, 1.0f).r - brdf->evaluate_angles(t, t, 2.0f).r), 0.5f);
}

TEST(MeasuredBrdfEval, RotationAboutTheNormalDoesNotChangeTheValue) {
  auto brdf = MeasuredBrdf::from_table(4, 6, 3, index_table(4, 6));
  ASSERT_TRUE(brdf.ok());
  const glm::vec3 base = brdf->evaluate(direction_from_spherical(0.5f, 0.3f), direction_from_spherical(1.0f, 2.2f));
  for (float rot : {0.5f, 2.0f, -1.3f, 3.1f}) {
    const glm::vec3 v =
        brdf->evaluate(direction_from_spherical(0.5f, 0.3f + rot), direction_from_spherical(1.0f, 2.2f + rot));
    EXPECT_NEAR(v.r, base.r, 1e-2f) << rot;
  }
}

TEST(MeasuredBrdfEval, BelowTheHorizonIsZeroAndNegativeNoiseIsClamped) {
  std::vector<float> values(2 * 2 * 2 * 3, -0.5f);
  auto brdf = MeasuredBrdf::from_table(2, 2, 3, values);
  ASSERT_TRUE(brdf.ok());
  EXPECT_EQ(brdf->negative_count(), values.size());
  EXPECT_EQ(brdf->evaluate(glm::vec3(0, 0, 1), glm::vec3(0, 0, 1)), glm::vec3(0.0f));
  auto pos = MeasuredBrdf::from_table(4, 6, 3, index_table(4, 6));
  ASSERT_TRUE(pos.ok());
  EXPECT_GT(pos->evaluate(glm::vec3(0.3f, 0, 1), glm::vec3(0, 0.2f, 1)).r, 0.0f);
  EXPECT_EQ(pos->evaluate(glm::vec3(0.3f, 0, -0.1f), glm::vec3(0, 0, 1)), glm::vec3(0.0f));
  EXPECT_EQ(pos->evaluate(glm::vec3(0, 0, 1), glm::vec3(1, 0, 0)), glm::vec3(0.0f));
  EXPECT_EQ(pos->evaluate(glm::vec3(NAN, 0, 1), glm::vec3(0, 0, 1)), glm::vec3(0.0f));
  EXPECT_EQ(MeasuredBrdf().evaluate(glm::vec3(0, 0, 1), glm::vec3(0, 0, 1)), glm::vec3(0.0f));
}

TEST(MeasuredBrdfEval, ScalarTablesAnswerEveryChannel) {
  std::vector<float> values(3 * 3 * 4, 0.25f);
  auto bytes = make_mbsdf(0, 3, 4, values);
  auto brdf = parse_mbsdf(bytes);
  ASSERT_TRUE(brdf.ok()) << brdf.message();
  EXPECT_EQ(brdf->channels(), 1);
  EXPECT_EQ(brdf->evaluate(glm::vec3(0.1f, 0, 1), glm::vec3(0, 0.1f, 1)), glm::vec3(0.25f));
}

TEST(MeasuredBrdfSample, BtfHoldsAbrdfTimesCosLight) {
  std::vector<float> values(3 * 3 * 4 * 3, 0.5f);
  auto brdf = MeasuredBrdf::from_table(3, 4, 3, values);
  ASSERT_TRUE(brdf.ok());
  const DirectionSet dirs = DirectionSet::ubo2003();
  BtfFloat btf = sample_to_btf(*brdf, dirs, dirs, 2, 3);
  EXPECT_EQ(btf.width(), 2);
  EXPECT_EQ(btf.height(), 3);
  for (size_t v = 0; v < dirs.size(); v += 7)
    for (size_t l = 0; l < dirs.size(); l += 5) {
      const float expected = 0.5f * std::cos(dirs[l].theta);
      EXPECT_NEAR(btf.value(1, 2, v, l, 0), expected, 1e-5f);
      EXPECT_NEAR(btf.value(0, 0, v, l, 2), expected, 1e-5f);
    }
  BtfFloat plain = sample_to_btf(*brdf, dirs, dirs, 1, 1, BtfValueConvention::brdf);
  EXPECT_NEAR(plain.value(0, 0, 80, 80, 1), 0.5f, 1e-6f);
}

// ---- failure classes -------------------------------------------------------------------------

TEST(MeasuredBrdfFailure, EveryTruncationIsRejectedAsShort) {
  const auto bytes = make_mbsdf(1, 2, 3, std::vector<float>(2 * 2 * 3 * 3, 0.1f));
  ASSERT_TRUE(parse_mbsdf(bytes).ok());
  for (size_t n = 0; n < bytes.size(); ++n) {
    auto r = parse_mbsdf(std::span<const uint8_t>(bytes.data(), n), "cut");
    ASSERT_FALSE(r.ok()) << "prefix of " << n << " bytes was accepted";
    EXPECT_FALSE(r.message().empty());
    if (n >= 43 + 12) {
      EXPECT_EQ(r.status(), Status::short_output) << r.message();
    }
  }
}

TEST(MeasuredBrdfFailure, WrongFirstLine) {
  auto bytes = make_mbsdf(1, 2, 3, std::vector<float>(36, 0.1f));
  bytes[18] = '2';  // "V2"
  auto r = parse_mbsdf(bytes, "x.mbsdf");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("NVIDIA ARC MBSDF V1"), std::string::npos) << r.message();
  EXPECT_NE(r.message().find("x.mbsdf"), std::string::npos) << r.message();
}

TEST(MeasuredBrdfFailure, WrongPartLine) {
  auto bytes = make_mbsdf(1, 2, 3, std::vector<float>(36, 0.1f), "MBSDF_DATA_REFRACTION=\n");
  auto r = parse_mbsdf(bytes);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("REFRACTION"), std::string::npos) << r.message();
}

TEST(MeasuredBrdfFailure, NanAndInfinityAreRejectedWithTheirCell) {
  std::vector<float> values(2 * 2 * 3 * 3, 0.1f);
  values[3 * (1 * 3 * 2 + 0 * 3 + 2) + 1] = NAN;  // θ_in 1, θ_out 0, φ 2, green
  auto r = parse_mbsdf(make_mbsdf(1, 2, 3, values));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("NaN"), std::string::npos) << r.message();
  EXPECT_NE(r.message().find("theta_in 1, theta_out 0, phi 2, channel 1"), std::string::npos) << r.message();
  values[3 * (1 * 3 * 2 + 0 * 3 + 2) + 1] = INFINITY;
  EXPECT_FALSE(parse_mbsdf(make_mbsdf(1, 2, 3, values)).ok());
}

TEST(MeasuredBrdfFailure, HugeFiniteValuesThatWouldInterpolateToInfinityAreRejected) {
  // ±3e38 are finite floats, but lo + t·(hi − lo) between them overflows to infinity.
  std::vector<float> values(2 * 2 * 3 * 3, 0.1f);
  values[0] = 3e38f;
  values[3] = -3e38f;
  auto r = parse_mbsdf(make_mbsdf(1, 2, 3, values));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status(), Status::bad_data);
  EXPECT_NE(r.message().find("too large"), std::string::npos) << r.message();
  values[0] = kMbsdfMaxMagnitude;
  values[3] = -kMbsdfMaxMagnitude;
  auto ok = parse_mbsdf(make_mbsdf(1, 2, 3, values));
  ASSERT_TRUE(ok.ok()) << ok.message();
  for (float phi : {0.0f, 0.3f, 1.0f, 3.0f})
    for (int c = 0; c < 3; ++c) EXPECT_TRUE(std::isfinite(ok->evaluate_angles(0.2f, 0.4f, phi)[c]));
}

TEST(MeasuredBrdfFailure, AbsurdResolutionsAreRejectedBeforeAllocating) {
  for (auto [rt, rp] : {std::pair<uint32_t, uint32_t>{0, 90},
                        {45, 0},
                        {0xffffffffu, 90},
                        {45, 0x80000000u},
                        {kMbsdfMaxResolution + 1, 1}}) {
    auto r = parse_mbsdf(make_mbsdf(1, rt, rp, {}));
    ASSERT_FALSE(r.ok()) << rt << " x " << rp;
    EXPECT_EQ(r.status(), Status::bad_data) << r.message();
    EXPECT_NE(r.message().find("resolution"), std::string::npos) << r.message();
  }
  // Plausible resolution but the file does not hold the table: short, with the sizes named.
  auto r = parse_mbsdf(make_mbsdf(1, 1000, 1000, std::vector<float>(10, 0.0f)));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status(), Status::short_output);
  EXPECT_NE(r.message().find("12000000000 bytes"), std::string::npos) << r.message();
}

TEST(MeasuredBrdfFailure, UnknownTypeAndTrailingBytes) {
  auto r = parse_mbsdf(make_mbsdf(7, 2, 3, std::vector<float>(36, 0.1f)));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("type 7"), std::string::npos) << r.message();
  auto bytes = make_mbsdf(1, 2, 3, std::vector<float>(36, 0.1f));
  bytes.push_back('x');
  auto t = parse_mbsdf(bytes);
  ASSERT_FALSE(t.ok());
  EXPECT_EQ(t.status(), Status::bad_data);
  EXPECT_NE(t.message().find("1 trailing bytes"), std::string::npos) << t.message();
}

TEST(MeasuredBrdfFailure, TransmissionPartIsValidatedAndRepeatedPartsRejected) {
  auto bytes = make_mbsdf(1, 2, 3, std::vector<float>(36, 0.1f));
  const auto trans = make_mbsdf(0, 2, 2, std::vector<float>(8, 0.2f), "MBSDF_DATA_TRANSMISSION=\n");
  bytes.insert(bytes.end(), trans.begin() + 20, trans.end());
  auto ok = parse_mbsdf(bytes);
  ASSERT_TRUE(ok.ok()) << ok.message();
  EXPECT_TRUE(ok->had_transmission());
  EXPECT_EQ(ok->channels(), 3);
  auto twice = make_mbsdf(1, 2, 3, std::vector<float>(36, 0.1f));
  const auto again = make_mbsdf(1, 2, 3, std::vector<float>(36, 0.1f));
  twice.insert(twice.end(), again.begin() + 20, again.end());
  auto r = parse_mbsdf(twice);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("second reflection"), std::string::npos) << r.message();
  // Only a transmission part: no reflection.
  auto only_t = make_mbsdf(0, 2, 2, std::vector<float>(8, 0.2f), "MBSDF_DATA_TRANSMISSION=\n");
  EXPECT_FALSE(parse_mbsdf(only_t).ok());
}

TEST(MeasuredBrdfFailure, MissingFileIsAnIoError) {
  auto r = read_mbsdf("/nonexistent/dir/file.mbsdf");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status(), Status::io_error);
  EXPECT_NE(r.message().find("/nonexistent/dir/file.mbsdf"), std::string::npos);
}

}  // namespace
