// The backend test cases, written once and instantiated for each GPU backend
// (test_gl_backend.cpp, test_vk_backend.cpp) with BTFLOD_BACKEND_TEST_CASES(Name, factory),
// where factory is `std::unique_ptr<btflod::Backend>(std::string& why_unavailable)`.
// A backend that cannot be created skips with the reason (never passes silently).
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <span>
#include <string>
#include <thread>

#include "test_shader_scene.hpp"

namespace btflod::backend_cases {

using namespace btflod::test_scene;

inline ShaderConfig fmf_config(DirectionParameterisation p, AngularLookup lookup) {
  ShaderConfig c;
  c.components = 5;
  c.angular.parameterisation = p;
  c.angular.lookup = lookup;
  c.angular.resolution = 32;
  c.vt.tile_size = 64;
  c.vt.border = 4;
  c.vt.slots_x = 4;
  c.vt.slots_y = 4;
  c.vt.cache_layers = 2;
  c.vt.finest_level = 2;
  return c;
}

inline FrameDesc frame_desc() {
  FrameDesc f;
  f.width = kSize;
  f.height = kSize;
  f.feedback_width = 32;
  f.feedback_height = 32;
  return f;
}

/// fmf_config() with the parabolic map and the 9-tap barycentric lookup.
inline ShaderConfig default_fmf_config() {
  return fmf_config(DirectionParameterisation::parabolic, AngularLookup::barycentric);
}

/// The quad of quad_vertices() / quad_indices() on `be`.
inline Result<MeshHandle> create_quad_mesh(Backend& be) {
  const auto verts = quad_vertices();
  const auto idx = quad_indices();
  return be.create_mesh(MeshData{verts, idx});
}

/// Runs `test_case(Backend&)` on a backend made by `make`; skips with the reason when the
/// backend cannot be created.
template <class Factory, class Case>
void with_backend(Factory make, Case test_case) {
  std::string why;
  std::unique_ptr<Backend> be = make(why);
  if (!be) GTEST_SKIP() << "GPU backend unavailable: " << why;
  test_case(*be);
}

/// Checks the feedback words `words` (32 × 32 texels) against eq. 1–2 for the quad over the
/// middle half of a `width` × `height` screen (make_params(0.5f), texture 37, λ = 1 over 256 ×
/// 256 texels): texel (x, y) samples pixel (block_w · x + sx, block_h · y + sy); pixels on the
/// quad give its word, the others the empty word. `covered` is the number of texels on the quad.
inline void expect_quad_feedback(std::span<const uint32_t> words, int width, int height, int block_w, int block_h,
                                 int sx, int sy, int covered, const std::string& what) {
  ASSERT_EQ(words.size(), 32u * 32u);
  const FeedbackWordLayout layout;
  int on_quad = 0, mismatches = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      const int px = block_w * x + sx, py = block_h * y + sy;
      uint32_t expect = layout.empty_word;
      if (px >= width / 4 && px < 3 * width / 4 && py < height) {
        glm::vec3 world;
        glm::vec2 uv;
        pixel_to_quad(px, py, width, height, 0.5f, world, uv);
        expect = pack_feedback_word(
            layout, FeedbackSample{37, 1, static_cast<uint32_t>(uv.x * 2.0f), static_cast<uint32_t>(uv.y * 2.0f)});
        ++on_quad;
      }
      const uint32_t w = words[static_cast<size_t>(y) * 32 + static_cast<size_t>(x)];
      if (w != expect && ++mismatches <= 5)
        ADD_FAILURE() << what << " texel (" << x << ", " << y << "): word " << std::hex << w << " expected " << expect;
    }
  EXPECT_EQ(on_quad, covered) << what;
  EXPECT_EQ(mismatches, 0) << what;
}

/// Ends the frame, reads its colour target into `colour`, waits for the GPU and takes the
/// frame's 32 × 32 feedback words into `fb`; every step must succeed.
inline void end_frame_and_read_back(Backend& be, Image<float>& colour, FeedbackFrame& fb) {
  ASSERT_EQ(be.end_frame(), Status::success);
  ASSERT_EQ(be.read_color(colour.view()), Status::success);
  ASSERT_EQ(be.wait_idle(), Status::success);
  ASSERT_TRUE(be.poll_feedback(fb));
  ASSERT_EQ(fb.words.size(), 32u * 32u);
}

/// Mean and spread of the rgb values: a blank or constant render must not pass.
inline void expect_has_content(const Image<float>& img) {
  double sum = 0, sq = 0;
  size_t n = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < 3; ++c) {
        sum += img.at(x, y, c);
        sq += static_cast<double>(img.at(x, y, c)) * img.at(x, y, c);
        ++n;
      }
  const double mean = sum / static_cast<double>(n);
  EXPECT_GT(mean, 0.05);
  EXPECT_GT(sq / static_cast<double>(n) - mean * mean, 1e-4);
}

inline void fmf_matches_cpu(Backend& be, DirectionParameterisation p, AngularLookup lookup) {
  const ShaderConfig config = fmf_config(p, lookup);
  ASSERT_TRUE(be.init(config, 2).ok());
  const Material m = make_material(config, 40, 24);
  auto mesh = create_quad_mesh(be);
  ASSERT_TRUE(mesh.ok()) << mesh.message();
  auto mat = be.create_material(m.data(true));
  ASSERT_TRUE(mat.ok()) << mat.message();
  const ShaderParams params = make_params();
  ASSERT_EQ(be.begin_frame(frame_desc()), Status::success);
  ASSERT_EQ(be.draw(ShaderProgram::fmf, *mesh, *mat, params), Status::success);
  ASSERT_EQ(be.end_frame(), Status::success);
  Image<float> img(kSize, kSize, 4);
  ASSERT_EQ(be.read_color(img.view()), Status::success);
  const Image<float> ref = reference_fmf(m, params);
  expect_has_content(ref);
  expect_has_content(img);
  const double psnr = psnr_rgb(ref, img);
  std::printf("[ %s ] FMF %s/%s PSNR vs CPU = %.2f dB\n", be.name(),
              p == DirectionParameterisation::parabolic ? "parabolic" : "concentric",
              lookup == AngularLookup::barycentric ? "9-tap" : "nearest", psnr);
  EXPECT_GE(psnr, 40.0);
}

inline void fmf_parabolic_9tap(Backend& be) {
  fmf_matches_cpu(be, DirectionParameterisation::parabolic, AngularLookup::barycentric);
}

inline void fmf_concentric_nearest(Backend& be) {
  fmf_matches_cpu(be, DirectionParameterisation::elevated_concentric, AngularLookup::nearest);
}

/// BSVTF through a partially filled cache: raw component group 0 (debug view) and the shaded
/// image agree with the CPU reference at LOD bias 0 (finest level where resident) and 0.5
/// (trilinear where both levels are resident).
inline void bsvtf_partial_cache(Backend& be) {
  const ShaderConfig config = default_fmf_config();
  const int M = 256, N = 256;  // T = 64 → L = 2: 1 + 4 + 16 tiles per group
  ASSERT_TRUE(be.init(config, 2).ok());
  const Material m = make_material(config, M, N);
  const Pyramid pyr = build_pyramid(m, 2);
  const CacheFill fill = fill_cache(pyr, config.vt, M, N);
  ASSERT_EQ(fill.uploads.size(), 2u * (1 + 4 + 8));
  ASSERT_EQ(be.upload_tiles(fill.uploads), Status::success);
  ASSERT_EQ(be.apply_page_table_writes(fill.deltas), Status::success);
  auto mesh = create_quad_mesh(be);
  ASSERT_TRUE(mesh.ok());
  auto mat = be.create_material(m.data(false));  // V' comes only from the cache
  ASSERT_TRUE(mat.ok()) << mat.message();
  for (float bias : {0.0f, 0.5f}) {
    ShaderParams params = make_params();
    params.vt_extent = glm::vec4(M, N, 2, 0);
    params.lod.x = bias;
    const float lambda = 2.0f - std::log2(static_cast<float>(M) / kSize) - bias;
    for (uint32_t debug : {1u, 0u}) {
      params.ids = glm::uvec4(0, 0, debug, 0);
      ASSERT_EQ(be.begin_frame(frame_desc()), Status::success);
      ASSERT_EQ(be.draw(ShaderProgram::bsvtf, *mesh, *mat, params), Status::success);
      ASSERT_EQ(be.end_frame(), Status::success);
      Image<float> img(kSize, kSize, 4);
      ASSERT_EQ(be.read_color(img.view()), Status::success);
      Image<float> ref(kSize, kSize, 4, 0.0f);
      Image<float> finest_only(kSize, kSize, 4, 0.0f);  // what a renderer ignoring the page table shows
      for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
          glm::vec3 world;
          glm::vec2 uv;
          pixel_to_quad(x, y, kSize, kSize, 1.0f, world, uv);
          float v[8] = {0, 0, 0, 0, 0, 0, 0, 0};
          reference_vt_sample(pyr, config.vt, M, N, 0, uv, lambda, v);
          reference_vt_sample(pyr, config.vt, M, N, 1, uv, lambda, v + 4);
          float f[8];
          bilinear(pyr.levels[0][2], uv.x * M, uv.y * N, false, f);
          bilinear(pyr.levels[1][2], uv.x * M, uv.y * N, false, f + 4);
          if (debug) {
            for (int k = 0; k < 4; ++k) {
              ref.at(x, y, k) = v[k];
              finest_only.at(x, y, k) = f[k];
            }
          } else {
            const glm::vec3 c = eq5(m, world, params, v), cf = eq5(m, world, params, f);
            for (int k = 0; k < 3; ++k) {
              ref.at(x, y, k) = c[k];
              finest_only.at(x, y, k) = cf[k];
            }
          }
        }
      expect_has_content(img);
      const double psnr = psnr_rgb(ref, img);
      const double psnr_wrong = psnr_rgb(finest_only, img);
      std::printf("[ %s ] BSVTF bias %.1f %s: PSNR vs CPU = %.2f dB (vs finest-only %.2f dB)\n", be.name(), bias,
                  debug ? "raw V" : "shaded", psnr, psnr_wrong);
      EXPECT_GE(psnr, 40.0);
      EXPECT_LT(psnr_wrong, psnr - 6.0) << "the partial cache must be visible: the right half is coarser";
    }
  }
}

inline void feedback_words(Backend& be) {
  const ShaderConfig config = default_fmf_config();
  ASSERT_TRUE(be.init(config, 2).ok());
  auto mesh = create_quad_mesh(be);
  ASSERT_TRUE(mesh.ok());
  // Quad over the middle half of the screen: at 32×32 feedback, 16 texels/pixel in x, 8 in y;
  // lod.y = log2(256/32) = 3 restores screen-resolution derivatives: λ = 2 − log2(16) + 3 = 1.
  ShaderParams params = make_params(0.5f);
  params.vt_extent = glm::vec4(256, 256, 2, 0);
  params.lod.y = 3.0f;
  params.ids = glm::uvec4(0, 37, 0, 0);
  ASSERT_EQ(be.begin_frame(frame_desc()), Status::success);
  ASSERT_EQ(be.draw_feedback(*mesh, params), Status::success);
  ASSERT_EQ(be.end_frame(), Status::success);
  ASSERT_EQ(be.wait_idle(), Status::success);
  FeedbackFrame fb;
  ASSERT_TRUE(be.poll_feedback(fb));
  ASSERT_EQ(fb.width, 32u);
  ASSERT_EQ(fb.height, 32u);
  ASSERT_EQ(fb.words.size(), 32u * 32u);
  // Texel (x, y) of the feedback pass is pixel (x, y) of a 32 × 32 screen.
  expect_quad_feedback(fb.words, 32, 32, 1, 1, 0, 0, 16 * 32, "feedback pass");
  EXPECT_FALSE(be.poll_feedback(fb)) << "one frame gives one readback";
}

/// bsvtf_feedback: the colour pass writes the colour of bsvtf and every pixel's feedback word;
/// the readback is FrameDesc's sample of each 8 × 8 block, the word a feedback pass jittered onto
/// that pixel writes (and the word eq. 1–2 give there).
inline void colour_pass_feedback(Backend& be) {
  const ShaderConfig config = default_fmf_config();
  const int M = 256, N = 256;
  ASSERT_TRUE(be.init(config, 2).ok());
  const Material m = make_material(config, M, N);
  const Pyramid pyr = build_pyramid(m, 2);
  const CacheFill fill = fill_cache(pyr, config.vt, M, N);
  ASSERT_EQ(be.upload_tiles(fill.uploads), Status::success);
  ASSERT_EQ(be.apply_page_table_writes(fill.deltas), Status::success);
  auto mesh = create_quad_mesh(be);
  ASSERT_TRUE(mesh.ok());
  auto mat = be.create_material(m.data(false));
  ASSERT_TRUE(mat.ok()) << mat.message();
  // Quad over the middle half of the screen: 2 texels per pixel in x, 1 in y → λ = 1.
  ShaderParams params = make_params(0.5f);
  params.vt_extent = glm::vec4(M, N, 2, 0);
  params.ids = glm::uvec4(0, 37, 0, 0);
  FrameDesc bad = frame_desc();
  bad.feedback_sample_x = 8;  // blocks are 256 / 32 = 8 pixels wide
  EXPECT_EQ(be.begin_frame(bad), Status::invalid_argument);
  for (const auto& [sx, sy] : {std::pair<uint32_t, uint32_t>{5, 2}, {0, 7}}) {
    FrameDesc desc = frame_desc();
    desc.feedback_sample_x = sx;
    desc.feedback_sample_y = sy;
    Image<float> colour(kSize, kSize, 4), plain(kSize, kSize, 4);
    FeedbackFrame fb;
    ASSERT_EQ(be.begin_frame(desc), Status::success);
    ASSERT_EQ(be.draw(ShaderProgram::bsvtf_feedback, *mesh, *mat, params), Status::success);
    ASSERT_NO_FATAL_FAILURE(end_frame_and_read_back(be, colour, fb));
    const std::vector<uint32_t> words(fb.words.begin(), fb.words.end());
    // The same view through bsvtf and a separate feedback pass (lod.y = log2 8) whose projection
    // is shifted so that each texel centre sees pixel (sx, sy) of its block (y from the top).
    ShaderParams jittered = params;
    const float dx = static_cast<float>(sx), dy_from_bottom = static_cast<float>(7 - sy);
    jittered.model_view_proj =
        glm::translate(glm::mat4(1.0f), glm::vec3((0.5f - (dx + 0.5f) / 8.0f) * 2.0f / 32.0f,
                                                  (0.5f - (dy_from_bottom + 0.5f) / 8.0f) * 2.0f / 32.0f, 0.0f)) *
        glm::mat4(params.model_view_proj);
    jittered.lod.y = 3.0f;
    ASSERT_EQ(be.begin_frame(desc), Status::success);
    ASSERT_EQ(be.draw_feedback(*mesh, jittered), Status::success);
    ASSERT_EQ(be.draw(ShaderProgram::bsvtf, *mesh, *mat, params), Status::success);
    ASSERT_NO_FATAL_FAILURE(end_frame_and_read_back(be, plain, fb));
    const std::string sample = "sample (" + std::to_string(sx) + ", " + std::to_string(sy) + ") ";
    expect_quad_feedback(words, kSize, kSize, 8, 8, static_cast<int>(sx), static_cast<int>(sy), 16 * 32,
                         sample + "colour pass");
    expect_quad_feedback(fb.words, kSize, kSize, 8, 8, static_cast<int>(sx), static_cast<int>(sy), 16 * 32,
                         sample + "feedback pass");
    expect_has_content(colour);
    EXPECT_GE(psnr_rgb(plain, colour), 200.0) << "output 0 of bsvtf_feedback is bsvtf's colour";
  }
  // A height that is no multiple of the block: 190 rows over 32 texels → blocks of 8 × 6 pixels;
  // with sample (3, 5) the last texel row asks for pixel row 191, past the screen: empty words.
  // (λ = 1 still: 2 texels per pixel in x, 256/190 in y.)
  FrameDesc odd = frame_desc();
  odd.height = 190;
  odd.feedback_sample_x = 3;
  odd.feedback_sample_y = 5;
  ASSERT_EQ(odd.feedback_block_height(), 6u);
  ASSERT_EQ(be.begin_frame(odd), Status::success);
  ASSERT_EQ(be.draw(ShaderProgram::bsvtf_feedback, *mesh, *mat, params), Status::success);
  ASSERT_EQ(be.end_frame(), Status::success);
  ASSERT_EQ(be.wait_idle(), Status::success);
  FeedbackFrame odd_fb;
  ASSERT_TRUE(be.poll_feedback(odd_fb));
  ASSERT_EQ(odd_fb.words.size(), 32u * 32u);
  expect_quad_feedback(odd_fb.words, kSize, 190, 8, 6, 3, 5, 16 * 31, "190 rows");
  // The next frame, with neither a feedback pass nor bsvtf_feedback, reads nothing back.
  ASSERT_EQ(be.begin_frame(frame_desc()), Status::success);
  ASSERT_EQ(be.draw(ShaderProgram::bsvtf, *mesh, *mat, params), Status::success);
  ASSERT_EQ(be.end_frame(), Status::success);
  ASSERT_EQ(be.wait_idle(), Status::success);
  FeedbackFrame fb;
  EXPECT_FALSE(be.poll_feedback(fb)) << "no feedback drawn, none read back";
}

inline void feedback_ring(Backend& be) {
  const ShaderConfig config = default_fmf_config();
  ASSERT_TRUE(be.init(config, 2).ok());
  auto mesh = create_quad_mesh(be);
  ASSERT_TRUE(mesh.ok());
  const uint32_t ring = be.feedback_ring_size();
  ASSERT_GE(ring, 2u);
  ShaderParams params = make_params();
  params.vt_extent = glm::vec4(256, 256, 2, 0);
  const uint32_t frames = ring + 2;
  for (uint32_t f = 0; f < frames; ++f) {
    params.ids.y = f;  // the frame number travels in the material field
    ASSERT_EQ(be.begin_frame(frame_desc()), Status::success);
    ASSERT_EQ(be.draw_feedback(*mesh, params), Status::success);
    ASSERT_EQ(be.end_frame(), Status::success);  // never waits: the oldest readbacks are dropped
  }
  EXPECT_EQ(be.dropped_feedback(), 2u);
  // Poll without waiting until everything arrives (bounded), in frame order.
  uint64_t expected = 2;
  FeedbackFrame fb;
  for (int spin = 0; spin < 2000 && expected < frames; ++spin) {
    if (be.poll_feedback(fb)) {
      EXPECT_EQ(fb.frame, expected);
      EXPECT_EQ(unpack_feedback_word(FeedbackWordLayout{}, fb.words[16 * 32 + 16]).texture, expected);
      ++expected;
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  EXPECT_EQ(expected, frames);
  EXPECT_FALSE(be.poll_feedback(fb));
}

inline void rejects_bad_input(Backend& be) {
  const ShaderConfig config = default_fmf_config();
  ASSERT_TRUE(be.init(config, 2).ok());
  std::vector<uint16_t> texels(72 * 72 * 4, 0);
  const TileUpload bad_slot{config.vt.slot_count(), texels};
  EXPECT_EQ(be.upload_tiles({&bad_slot, 1}), Status::invalid_argument);
  const TileUpload short_tile{0, std::span<const uint16_t>(texels).first(100)};
  EXPECT_EQ(be.upload_tiles({&short_tile, 1}), Status::invalid_argument);
  const PageTableWrite bad_layer{TileId{2, 0, 0, 0}, 2, 0};
  EXPECT_EQ(be.apply_page_table_writes({&bad_layer, 1}), Status::invalid_argument);
  const PageTableWrite bad_texel{TileId{0, 1, 2, 0}, 1, 0};  // mip 1 is 2×2
  EXPECT_EQ(be.apply_page_table_writes({&bad_texel, 1}), Status::invalid_argument);
  Material m = make_material(config, 8, 8);
  m.light_index[5] = 999;  // names a direction that does not exist
  auto mat = be.create_material(m.data(true));
  ASSERT_FALSE(mat.ok());
  EXPECT_NE(mat.message().find("angular index"), std::string::npos) << mat.message();
  Material wrong_c = make_material(default_fmf_config(), 8, 8);
  wrong_c.config.components = 4;
  FmfMaterialData d = wrong_c.data(true);
  d.components = 4;
  EXPECT_FALSE(be.create_material(d).ok());
  const std::vector<uint32_t> bad_idx = {0, 1, 7};
  const auto verts = quad_vertices();
  EXPECT_FALSE(be.create_mesh(MeshData{verts, bad_idx}).ok());
  EXPECT_EQ(be.draw(ShaderProgram::fmf, MeshHandle{1}, MaterialHandle{1}, ShaderParams{}), Status::invalid_argument);
}

}  // namespace btflod::backend_cases

// One test of the suite `suite` running backend_cases::`test_case` on a backend from `factory`.
#define BTFLOD_BACKEND_TEST_CASE(suite, test, factory, test_case) \
  TEST(suite, test) { btflod::backend_cases::with_backend(factory, btflod::backend_cases::test_case); }

#define BTFLOD_BACKEND_TEST_CASES(Name, factory)                                                                     \
  BTFLOD_BACKEND_TEST_CASE(Name##Backend, FmfParabolic9TapMatchesCpuReference, factory, fmf_parabolic_9tap)          \
  BTFLOD_BACKEND_TEST_CASE(Name##Backend, FmfConcentricNearestMatchesCpuReference, factory, fmf_concentric_nearest)  \
  BTFLOD_BACKEND_TEST_CASE(Name##Backend, BsvtfThroughPartialCacheMatchesCpuReference, factory, bsvtf_partial_cache) \
  BTFLOD_BACKEND_TEST_CASE(Name##Backend, FeedbackDecodesToExpectedWords, factory, feedback_words)                   \
  BTFLOD_BACKEND_TEST_CASE(Name##Backend, FeedbackRingNeverWaitsAndDropsOldest, factory, feedback_ring)              \
  BTFLOD_BACKEND_TEST_CASE(Name##Backend, ColourPassFeedbackMatchesFeedbackPass, factory, colour_pass_feedback)      \
  BTFLOD_BACKEND_TEST_CASE(Name##Backend, RejectsBadInput, factory, rejects_bad_input)
