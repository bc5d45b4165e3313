// Tests for offline/btf/bonn_btf.hpp. Files are built byte by byte here (independently of the
// library's encoder) following the documented layout, so a layout misreading in both reader
// and writer would still fail; then round trips (factorise → write → read → reconstruct) and
// the failure classes: TruncatedInput, WrongSignature, SizeDoesNotMatchFile, NaNInHeader,
// TrailingBytes, OversizedCount.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "btflod/core/bytes.hpp"
#include "btflod/core/half.hpp"
#include "btflod/offline/btf/bonn_btf.hpp"
#include "test_btf_helpers.hpp"

namespace {

using namespace btflod;
using btflod_test::expect_one_warning;
using btflod_test::expect_refused;

// ---- an independent byte-level builder ---------------------------------------------------------

struct Offsets {
  size_t meta_size = 0, ppmm = 0, rgb_scale = 0, xml_size = 0, channel_count = 0, n_view = 0, first_view_theta = 0,
         first_light_theta = 0, width = 0, n_rot = 0, max_k = 0, color_mean = 0, first_k = 0, first_rows = 0,
         first_sxv = 0, end = 0;
};

struct Spec {
  std::string signature = "!DFMF08FCR";
  uint32_t n_view = 2, n_light = 3, w = 2, h = 1;
  int32_t color_model = 0;
  uint32_t cosine = 0;
  uint8_t scalar = 4;
  std::vector<float> view_theta = {0.0f, 0.5f}, light_theta = {0.0f, 0.3f, 1.0f};
  // DFMF: per channel, U (rows × k) and SxV (cols × k), k = 1
  std::vector<std::vector<float>> u, sxv;
  // FMF
  uint32_t drr = 0;
  // FMF height map header: the two u32 values as written (btflod: rows, cols; btflib's writer:
  // width, height) and the samples in file order.
  uint32_t hm_first = 2, hm_second = 1;
  std::vector<float> height_samples = {0.5f, -1.0f};
};

void put_scalars(ByteWriter& w, const std::vector<float>& v, uint8_t scalar) {
  for (float x : v) {
    if (scalar == 2)
      w.u16(float_to_half_bits(x));
    else
      w.f32(x);
  }
}

std::vector<uint8_t> build(const Spec& s, Offsets* off = nullptr) {
  Offsets o;
  ByteWriter w;
  w.text(s.signature);
  o.meta_size = w.size();
  w.u32(0);
  w.u32(4);
  w.fixed_string("setup", 80);
  w.fixed_string("sensor", 80);
  w.fixed_string("light", 80);
  o.ppmm = w.size();
  w.f32(10.0f);
  o.rgb_scale = w.size();
  w.f32(1.0f);
  w.f32(1.0f);
  w.f32(1.0f);
  w.u32(s.cosine);
  o.xml_size = w.size();
  w.u32(5);
  w.text("<x/>!");
  o.channel_count = w.size();
  w.u32(3);
  for (const char* n : {"R", "G", "B"}) {
    w.u32(1);
    w.text(n);
  }
  w.patch(o.meta_size, static_cast<uint32_t>(w.size() - o.meta_size));
  o.n_view = w.size();
  w.u32(s.n_view);
  for (uint32_t v = 0; v < s.n_view; ++v) {
    if (v == 0) o.first_view_theta = w.size();
    w.f32(s.view_theta[v]);
    w.f32(0.25f * static_cast<float>(v));
    w.u32(s.n_light);
    for (uint32_t l = 0; l < s.n_light; ++l) {
      if (v == 0 && l == 0) o.first_light_theta = w.size();
      w.f32(s.light_theta[l]);
      w.f32(0.5f * static_cast<float>(l));
    }
  }
  o.width = w.size();
  w.u32(s.w);
  w.u32(s.h);
  o.n_rot = w.size();
  w.u32(1);
  for (int i = 0; i < 9; ++i) w.f32(i % 4 == 0 ? 1.0f : 0.0f);
  if (s.signature == "!DFMF08FCR") {
    o.max_k = w.size();
    w.u32(1);
    w.write(s.color_model);
    o.color_mean = w.size();
    for (int i = 0; i < 3; ++i) w.f32(0.0f);
    for (int i = 0; i < 9; ++i) w.f32(i % 4 == 0 ? 1.0f : 0.0f);
    for (int c = 0; c < 3; ++c) {
      w.u8(s.scalar);
      if (c == 0) o.first_k = w.size();
      w.u32(1);
      if (c == 0) o.first_rows = w.size();
      w.u32(s.n_view * s.n_light);
      w.u32(s.w * s.h);
      put_scalars(w, {1.0f}, s.scalar);
      put_scalars(w, s.u[c], s.scalar);
      if (c == 0) o.first_sxv = w.size();
      put_scalars(w, s.sxv[c], s.scalar);
    }
  } else {
    w.u8(2);  // header version
    w.u32(s.drr);
    w.u32(s.hm_first);
    w.u32(s.hm_second);
    for (float hv : s.height_samples) w.u16(float_to_half_bits(hv));
    o.max_k = w.size();
    w.u32(1);
    w.u8(s.scalar);
    o.first_k = w.size();
    w.u32(1);
    o.first_rows = w.size();
    w.u32(3 * s.n_view * s.n_light);
    w.u32(s.w * s.h);
    put_scalars(w, {1.0f}, s.scalar);
    put_scalars(w, s.u[0], s.scalar);
    o.first_sxv = w.size();
    put_scalars(w, s.sxv[0], s.scalar);
  }
  o.end = w.size();
  if (off) *off = o;
  return w.take();
}

// A DFMF spec with distinct, exactly representable (also in half) values.
Spec dfmf_spec() {
  Spec s;
  s.u.resize(3);
  s.sxv.resize(3);
  for (int c = 0; c < 3; ++c) {
    for (uint32_t r = 0; r < s.n_view * s.n_light; ++r) s.u[c].push_back(0.25f * static_cast<float>(r + 1) + c);
    s.sxv[c] = {0.5f, 2.0f};  // x = 0, x = 1 (h = 1)
  }
  return s;
}

template <class T>
void put(std::vector<uint8_t>& bytes, size_t at, T v) {
  std::memcpy(bytes.data() + at, &v, sizeof v);
}

// Calls f(v, l, x, c) for every sample of a spec's first texel row: views, lights, x, RGB.
template <class Fn>
void for_each_sample(const Spec& s, Fn&& f) {
  for (uint32_t v = 0; v < s.n_view; ++v)
    for (uint32_t l = 0; l < s.n_light; ++l)
      for (int x = 0; x < static_cast<int>(s.w); ++x)
        for (int c = 0; c < 3; ++c) f(v, l, x, c);
}

// ---- decoding hand-built files --------------------------------------------------------------------

TEST(BonnBtf, HandBuiltDfmfDecodesRowLPlusNlTimesVAndColumnXPlusWTimesY) {
  const Spec s = dfmf_spec();
  const auto bytes = build(s);
  auto f = read_bonn_btf(bytes);
  ASSERT_TRUE(f) << f.message();
  EXPECT_EQ(f->format, BonnFormat::dfmf);
  EXPECT_EQ(f->width, 2);
  EXPECT_EQ(f->height, 1);
  EXPECT_EQ(f->views.size(), 2u);
  EXPECT_EQ(f->lights.size(), 3u);
  EXPECT_EQ(f->xml, "<x/>!");
  EXPECT_EQ(f->measurement_setup, "setup");
  EXPECT_FLOAT_EQ(f->ppmm, 10.0f);
  ASSERT_EQ(f->rotations.size(), 1u);
  EXPECT_FLOAT_EQ(f->views[1].theta, 0.5f);
  EXPECT_FLOAT_EQ(f->views[1].phi, 0.25f);
  EXPECT_FLOAT_EQ(f->lights[2].theta, 1.0f);
  ASSERT_EQ(f->factors.size(), 3u);
  EXPECT_TRUE(f->warnings.empty());
  auto btf = reconstruct_bonn_btf(*f);
  ASSERT_TRUE(btf) << btf.message();
  for_each_sample(s, [&](uint32_t v, uint32_t l, int x, int c) {
    const float expected = s.u[c][l + 3 * v] * s.sxv[c][x];
    EXPECT_FLOAT_EQ(btf->at(x, 0, v, l, c), expected) << v << " " << l << " " << x << " " << c;
  });
}

TEST(BonnBtf, HalfScalarsDecodeToTheSameValues) {
  Spec s = dfmf_spec();
  s.scalar = 2;
  auto f = read_bonn_btf(build(s));
  ASSERT_TRUE(f) << f.message();
  EXPECT_EQ(f->factors[1].scalar_size, 2);
  auto btf = reconstruct_bonn_btf(*f);
  ASSERT_TRUE(btf);
  EXPECT_FLOAT_EQ(btf->at(1, 0, 1, 2, 1), s.u[1][5] * s.sxv[1][1]);
}

TEST(BonnBtf, YuvColourModelIsUndone) {
  Spec s = dfmf_spec();
  s.color_model = 1;
  auto f = read_bonn_btf(build(s));
  ASSERT_TRUE(f) << f.message();
  auto btf = reconstruct_bonn_btf(*f);
  ASSERT_TRUE(btf);
  const float y = s.u[0][4] * s.sxv[0][1], u = s.u[1][4] * s.sxv[1][1], v = s.u[2][4] * s.sxv[2][1];
  // Y'UV (BT.601) → RGB, the matrix btflib uses.
  EXPECT_NEAR(btf->at(1, 0, 1, 1, 0), y + 1.13983f * v, 1e-4);
  EXPECT_NEAR(btf->at(1, 0, 1, 1, 1), y - 0.39465f * u - 0.5806f * v, 1e-4);
  EXPECT_NEAR(btf->at(1, 0, 1, 1, 2), y + 2.03211f * u, 1e-4);
}

TEST(BonnBtf, CosineFlagDividesByCosThetaLight) {
  Spec s = dfmf_spec();
  s.cosine = 1;
  auto f = read_bonn_btf(build(s));
  ASSERT_TRUE(f) << f.message();
  EXPECT_TRUE(f->cosine_in_data);
  auto btf = reconstruct_bonn_btf(*f);
  ASSERT_TRUE(btf);
  EXPECT_NEAR(btf->at(0, 0, 0, 2, 0), s.u[0][2] * s.sxv[0][0] / std::cos(1.0f), 1e-5);
  BonnReconstructOptions keep;
  keep.remove_cosine = false;
  auto raw = reconstruct_bonn_btf(*f, keep);
  ASSERT_TRUE(raw);
  EXPECT_FLOAT_EQ(raw->at(0, 0, 0, 2, 0), s.u[0][2] * s.sxv[0][0]);
  // Asked for a convention, the flag decides: flag 1 holds ρ·cos already.
  auto cos_conv = reconstruct_bonn_btf(*f, bonn_reconstruct_options(BtfValueConvention::abrdf_cos_light));
  ASSERT_TRUE(cos_conv);
  EXPECT_FLOAT_EQ(cos_conv->at(0, 0, 0, 2, 0), s.u[0][2] * s.sxv[0][0]);
  // Flag 0: the data is ρ; the ρ·cos convention multiplies by cosθ_l, the ρ one keeps it.
  s.cosine = 0;
  auto f0 = read_bonn_btf(build(s));
  ASSERT_TRUE(f0) << f0.message();
  EXPECT_FALSE(f0->cosine_in_data);
  auto times_cos = reconstruct_bonn_btf(*f0, bonn_reconstruct_options(BtfValueConvention::abrdf_cos_light));
  ASSERT_TRUE(times_cos);
  EXPECT_NEAR(times_cos->at(0, 0, 0, 2, 0), s.u[0][2] * s.sxv[0][0] * std::cos(1.0f), 1e-6);
  auto as_rho = reconstruct_bonn_btf(*f0, bonn_reconstruct_options(BtfValueConvention::brdf));
  ASSERT_TRUE(as_rho);
  EXPECT_FLOAT_EQ(as_rho->at(0, 0, 0, 2, 0), s.u[0][2] * s.sxv[0][0]);
}

// A small FMF file: one 3-channel, 2-view, 3-light U block with entries 0.125·r, S·Vᵀ = {1, −0.5}.
Spec fmf_spec() {
  Spec s;
  s.signature = "!FMF12FCER";
  s.drr = 1;
  s.u.resize(1);
  s.sxv.resize(1);
  for (uint32_t r = 0; r < 3 * 2 * 3; ++r) s.u[0].push_back(0.125f * static_cast<float>(r));
  s.sxv[0] = {1.0f, -0.5f};
  return s;
}

TEST(BonnBtf, FmfRowsAreChannelFastestAndDynamicRangeIsRestored) {
  const Spec s = fmf_spec();
  auto f = read_bonn_btf(build(s));
  ASSERT_TRUE(f) << f.message();
  EXPECT_EQ(f->format, BonnFormat::fmf);
  EXPECT_EQ(f->dynamic_range_reduction, 1u);
  ASSERT_EQ(f->height_map.size(), 2u);
  EXPECT_FLOAT_EQ(f->height_map[1], -1.0f);
  auto btf = reconstruct_bonn_btf(*f);
  ASSERT_TRUE(btf) << btf.message();
  for_each_sample(s, [&](uint32_t v, uint32_t l, int x, int c) {
    const float logv = s.u[0][c + 3 * (l + 3 * v)] * s.sxv[0][x];
    EXPECT_NEAR(btf->at(x, 0, v, l, c), std::exp(logv) - 1e-5f, 1e-5f);
  });
}

TEST(BonnBtf, TransposedMatricesAreSwappedWithAWarning) {
  Spec s = dfmf_spec();
  auto bytes = build(s);
  auto ref = read_bonn_btf(bytes);
  ASSERT_TRUE(ref);
  // Rebuild with rows/cols swapped and U/SxV exchanged: 2 × 6 instead of 6 × 2.
  ByteWriter w;
  Offsets o;
  build(s, &o);
  w.raw(bytes.data(), o.max_k + 4 + 4 + 48);
  for (int c = 0; c < 3; ++c) {
    w.u8(4);
    w.u32(1);
    w.u32(2);
    w.u32(6);
    w.f32(1.0f);
    for (float x : s.sxv[c]) w.f32(x);
    for (float x : s.u[c]) w.f32(x);
  }
  auto f = read_bonn_btf(w.bytes());
  ASSERT_TRUE(f) << f.message();
  ASSERT_EQ(f->warnings.size(), 3u);
  auto a = reconstruct_bonn_btf(*ref);
  auto b = reconstruct_bonn_btf(*f);
  ASSERT_TRUE(a && b);
  for (size_t i = 0; i < a->samples().size(); ++i) ASSERT_FLOAT_EQ(a->samples()[i], b->samples()[i]);
}

// ---- round trips -------------------------------------------------------------------------------

BtfFloat low_rank_btf(int rank, uint32_t seed) {
  const DirectionSet views = DirectionSet::ubo2003();
  std::vector<std::pair<float, float>> l = {{0.0f, 0.0f}, {0.4f, 1.0f}, {0.8f, 2.0f}, {1.1f, -1.0f}, {0.6f, 3.0f}};
  BtfFloat btf(6, 5, views, DirectionSet::from_radians("five", l));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> d(0.05f, 1.0f);
  const size_t rows = btf.view_count() * btf.light_count();
  for (int c = 0; c < 3; ++c)
    for (int j = 0; j < rank; ++j) {
      std::vector<float> a(rows), b(btf.texel_count());
      for (auto& x : a) x = d(rng);
      for (auto& x : b) x = d(rng);
      for (size_t r = 0; r < rows; ++r)
        for (size_t t = 0; t < b.size(); ++t) btf.samples()[(r * b.size() + t) * 3 + c] += a[r] * b[t] / rank;
    }
  return btf;
}

double max_abs_diff(const BtfFloat& a, const BtfFloat& b) {
  double m = 0;
  for (size_t i = 0; i < a.samples().size(); ++i)
    m = std::max(m, static_cast<double>(std::abs(a.samples()[i] - b.samples()[i])));
  return m;
}

TEST(BonnBtf, FactorizeWriteReadReconstructRoundTripIsExactForLowRank) {
  const BtfFloat btf = low_rank_btf(2, 7);
  for (BonnColorModel model : {BonnColorModel::rgb, BonnColorModel::yuv, BonnColorModel::ycocg}) {
    DfmfFactorizeOptions opt;
    opt.components = 6;  // colour decorrelation mixes channels: rank ≤ 6 per decorrelated channel
    opt.color_model = model;
    auto f = factorize_bonn_dfmf(btf, opt);
    ASSERT_TRUE(f) << f.message();
    const std::string path = std::string(BTFLOD_TEST_TMP_DIR) + "/bonn_roundtrip.btf";
    std::filesystem::create_directories(BTFLOD_TEST_TMP_DIR);
    ASSERT_TRUE(write_bonn_dfmf(path, *f));
    auto back = read_bonn_btf(path);
    ASSERT_TRUE(back) << back.message();
    EXPECT_EQ(back->views.name(), "UBO2003");  // recognised from the angles
    EXPECT_EQ(back->color_model, static_cast<int32_t>(model));
    EXPECT_TRUE(back->cosine_in_data);  // factorised in btflod's convention, ρ·cosθ_l
    // Reconstructed in the same convention: the stored values, whatever the flag.
    auto rec = reconstruct_bonn_btf(*back, bonn_reconstruct_options(BtfValueConvention::abrdf_cos_light));
    ASSERT_TRUE(rec) << rec.message();
    EXPECT_LT(max_abs_diff(*rec, btf), 2e-5) << "model " << static_cast<int>(model);
  }
}

TEST(BonnBtf, EncodeReadEncodeIsByteIdentical) {
  for (uint8_t scalar : {uint8_t{2}, uint8_t{4}, uint8_t{8}}) {
    DfmfFactorizeOptions opt;
    opt.components = 3;
    opt.scalar_size = scalar;
    auto f = factorize_bonn_dfmf(low_rank_btf(3, 1), opt);
    ASSERT_TRUE(f);
    f->xml = "<measurement/>";
    f->cosine_in_data = true;
    f->rotations.push_back({1, 0, 0, 0, 1, 0, 0, 0, 1});
    auto a = encode_bonn_btf(*f);
    ASSERT_TRUE(a) << a.message();
    auto parsed = read_bonn_btf(*a);
    ASSERT_TRUE(parsed) << parsed.message();
    auto b = encode_bonn_btf(*parsed);
    ASSERT_TRUE(b);
    EXPECT_EQ(*a, *b) << "scalar size " << int(scalar);
  }
}

TEST(BonnBtf, TruncationErrorFollowsEckartYoung) {
  const BtfFloat btf = low_rank_btf(4, 3);
  DfmfFactorizeOptions opt;
  opt.components = 2;
  auto f = factorize_bonn_dfmf(btf, opt);
  ASSERT_TRUE(f);
  auto rec = reconstruct_bonn_btf(*f, bonn_reconstruct_options(BtfValueConvention::abrdf_cos_light));
  ASSERT_TRUE(rec);
  // Independent SVD of the red channel: the squared error of the best rank-2 approximation
  // is the sum of the dropped squared singular values.
  const Eigen::Index rows = static_cast<Eigen::Index>(btf.view_count() * btf.light_count());
  const Eigen::Index cols = static_cast<Eigen::Index>(btf.texel_count());
  Eigen::MatrixXd a(rows, cols);
  double err2 = 0;
  for (Eigen::Index r = 0; r < rows; ++r)
    for (Eigen::Index t = 0; t < cols; ++t) {
      const size_t i = (static_cast<size_t>(r * cols + t)) * 3;
      a(r, t) = btf.samples()[i];
      const double d = btf.samples()[i] - rec->samples()[i];
      err2 += d * d;
    }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a);
  double dropped = 0;
  for (Eigen::Index j = 2; j < svd.singularValues().size(); ++j)
    dropped += svd.singularValues()[j] * svd.singularValues()[j];
  EXPECT_GT(dropped, 1e-3);
  EXPECT_NEAR(err2, dropped, 1e-3 * dropped);
}

// ---- failure classes ---------------------------------------------------------------------------

// FMF height map header: btflod reads and writes (rows, cols); btflib's writer stores (width,
// height). For a non-square texture whose height map has the texture's size, the header's order
// is unambiguous and both are accepted; a square map is read rows first.
TEST(BonnBtf, FmfHeightMapHeaderIsAcceptedInEitherOrderWhenTheTextureSizeDecides) {
  Spec s;
  s.signature = "!FMF12FCER";
  s.w = 3;
  s.h = 2;
  s.u.resize(1);
  s.sxv.resize(1);
  for (uint32_t r = 0; r < 3 * 2 * 3; ++r) s.u[0].push_back(0.125f * static_cast<float>(r));
  s.sxv[0] = {1.0f, -0.5f, 0.25f, 2.0f, 0.5f, 1.5f};
  s.height_samples = {0.0f, 0.25f, 0.5f, 1.0f, 1.25f, 1.5f};  // row-major, 2 rows of 3
  s.hm_first = 2;                                             // rows first (btflod)
  s.hm_second = 3;
  // Reads bytes and checks the height map's shape and the order its header was read in.
  const auto read_height_map = [](const std::vector<uint8_t>& bytes, int rows, int cols, bool width_first) {
    auto f = read_bonn_btf(bytes);
    EXPECT_TRUE(f) << f.message();
    if (f) {
      EXPECT_EQ(f->height_map_rows, rows);
      EXPECT_EQ(f->height_map_cols, cols);
      EXPECT_EQ(f->height_map_width_first, width_first);
    }
    return f;
  };
  auto rows_first = read_height_map(build(s), 2, 3, false);
  ASSERT_TRUE(rows_first);
  EXPECT_TRUE(rows_first->warnings.empty());
  s.hm_first = 3;  // width first (btflib's writer)
  s.hm_second = 2;
  const auto width_first_bytes = build(s);
  auto width_first = read_height_map(width_first_bytes, 2, 3, true);
  ASSERT_TRUE(width_first);
  EXPECT_EQ(width_first->height_map, rows_first->height_map);
  ASSERT_EQ(width_first->warnings.size(), 1u);
  EXPECT_NE(width_first->warnings[0].find("width first"), std::string::npos) << width_first->warnings[0];
  // Re-encoding keeps the file's order.
  auto again = encode_bonn_btf(*width_first);
  ASSERT_TRUE(again) << again.message();
  EXPECT_EQ(*again, width_first_bytes);
  // A height map of another size is read rows first, as the header says.
  s.hm_first = 1;
  s.hm_second = 6;
  ASSERT_TRUE(read_height_map(build(s), 1, 6, false));
}

// A file cut anywhere is truncation (short_output), never "oversized count" or any other class,
// whichever field the cut falls in: every prefix of a small DFMF and a small FMF file.
TEST(BonnBtf, TruncatedInputIsShortOutputAtEveryLength) {
  for (const Spec& spec : {dfmf_spec(), fmf_spec()}) {
    const auto bytes = build(spec);
    ASSERT_TRUE(read_bonn_btf(bytes)) << spec.signature;
    for (size_t n = 0; n < bytes.size(); ++n) {
      auto f = read_bonn_btf(std::span<const uint8_t>(bytes.data(), n));
      ASSERT_FALSE(f) << "accepted a " << spec.signature << " file cut to " << n << " of " << bytes.size() << " bytes";
      EXPECT_EQ(f.status(), Status::short_output)
          << spec.signature << " cut to " << n << " of " << bytes.size() << " bytes: " << f.message();
      EXPECT_NE(f.message().find("truncated"), std::string::npos) << f.message();
    }
  }
}

TEST(BonnBtf, TruncatedInputInsideTheMatricesIsShortOutput) {
  Offsets o;
  const auto bytes = build(dfmf_spec(), &o);
  expect_refused(read_bonn_btf(std::span<const uint8_t>(bytes.data(), o.first_sxv + 2)), Status::short_output,
                 "truncated");
}

TEST(BonnBtf, WrongSignatureIsRejected) {
  auto bytes = build(dfmf_spec());
  bytes[9] = 'X';
  expect_refused(read_bonn_btf(bytes), Status::bad_data, "wrong signature '!DFMF08FCX'");
  std::memcpy(bytes.data(), "!PVF06FCR\0", 10);
  EXPECT_EQ(read_bonn_btf(bytes).status(), Status::unsupported);
  EXPECT_EQ(read_bonn_btf(std::vector<uint8_t>{'!', 'D'}).status(), Status::short_output);
}

TEST(BonnBtf, SizeDoesNotMatchFileInMetaBlock) {
  Offsets o;
  auto bytes = build(dfmf_spec(), &o);
  uint32_t size;
  std::memcpy(&size, bytes.data() + o.meta_size, 4);
  put<uint32_t>(bytes, o.meta_size, size + 4);
  expect_refused(read_bonn_btf(bytes), Status::bad_data, "size does not match");
}

TEST(BonnBtf, SizeDoesNotMatchFileInMatrixShape) {
  Offsets o;
  auto bytes = build(dfmf_spec(), &o);
  put<uint32_t>(bytes, o.first_rows, 7);  // nL·nV is 6
  expect_refused(read_bonn_btf(bytes), Status::bad_data, "7 × 2, expected 6 × 2");
}

TEST(BonnBtf, NaNInHeaderIsRejected) {
  Offsets o;
  const auto good = build(dfmf_spec(), &o);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  struct Case {
    size_t at;
    float value;
    const char* field;
  } cases[] = {{o.ppmm, nan, "ppmm"},
               {o.rgb_scale + 4, inf, "rgb_scale[1]"},
               {o.first_view_theta, nan, "view θ"},
               {o.first_light_theta, -inf, "light θ"},
               {o.color_mean, nan, "colour mean"}};
  for (const auto& c : cases) {
    auto bytes = good;
    put<float>(bytes, c.at, c.value);
    auto f = read_bonn_btf(bytes);
    ASSERT_FALSE(f) << c.field;
    EXPECT_EQ(f.status(), Status::bad_data);
    EXPECT_NE(f.message().find("NaN in header"), std::string::npos) << f.message();
    EXPECT_NE(f.message().find(c.field), std::string::npos) << f.message();
  }
  // NaN inside a matrix is rejected too.
  auto bytes = good;
  put<float>(bytes, o.first_sxv, nan);
  expect_refused(read_bonn_btf(bytes), "SxV");
}

TEST(BonnBtf, TrailingBytesAreReported) {
  auto bytes = build(dfmf_spec());
  bytes.insert(bytes.end(), {1, 2, 3});
  expect_refused(read_bonn_btf(bytes), Status::bad_data, "trailing bytes: 3 bytes");
  BonnReadOptions allow;
  allow.allow_trailing_bytes = true;
  expect_one_warning(read_bonn_btf(bytes, allow), "3 trailing bytes");
}

TEST(BonnBtf, OversizedCountIsRejectedBeforeAllocating) {
  Offsets o;
  const auto good = build(dfmf_spec(), &o);
  struct Case {
    size_t at;
    uint32_t value;
    const char* needle;
  } cases[] = {{o.n_view, 0xffffffffu, "view count = 4294967295"},
               {o.xml_size, 0x7fffffffu, "XML string"},
               {o.channel_count, 1000, "channel count 1000"},
               {o.n_rot, 0x40000000u, "rotation count"},
               {o.first_k, 0xfffffff0u, "components"},
               {o.width, 0x7fffffffu, "texture size"}};
  for (const auto& c : cases) {
    auto bytes = good;
    put<uint32_t>(bytes, c.at, c.value);
    auto f = read_bonn_btf(bytes);
    ASSERT_FALSE(f) << c.needle;
    EXPECT_EQ(f.status(), Status::bad_data) << f.message();
    EXPECT_NE(f.message().find(c.needle), std::string::npos) << f.message();
  }
}

TEST(BonnBtf, ReconstructRefusesHugeAndUnsupported) {
  auto f = read_bonn_btf(build(dfmf_spec()));
  ASSERT_TRUE(f);
  BonnReconstructOptions small;
  small.max_samples = 35;  // 2·1·2·3·3 = 36
  EXPECT_EQ(reconstruct_bonn_btf(*f, small).status(), Status::insufficient_space);
  f->color_model = 2;  // Lab
  auto r = reconstruct_bonn_btf(*f);
  EXPECT_EQ(r.status(), Status::unsupported);
  EXPECT_NE(r.message().find("colour model 2"), std::string::npos);
}

TEST(BonnBtf, ConvenienceWriteAndLoad) {
  const BtfFloat btf = low_rank_btf(1, 11);
  const std::string path = std::string(BTFLOD_TEST_TMP_DIR) + "/bonn_convenience.btf";
  std::filesystem::create_directories(BTFLOD_TEST_TMP_DIR);
  DfmfFactorizeOptions opt;
  opt.components = 3;
  ASSERT_TRUE(write_bonn_dfmf(path, btf, opt));
  auto back = load_bonn_btf(path, {}, bonn_reconstruct_options(BtfValueConvention::abrdf_cos_light));
  ASSERT_TRUE(back) << back.message();
  EXPECT_LT(max_abs_diff(*back, btf), 2e-5);
}

TEST(BonnBtf, MissingFileIsIoError) {
  auto f = read_bonn_btf(std::string("/nonexistent/x.btf"));
  EXPECT_EQ(f.status(), Status::io_error);
}

}  // namespace
