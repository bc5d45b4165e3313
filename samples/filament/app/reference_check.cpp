#include "reference_check.hpp"

#include <cmath>
#include <cstdio>

#include "btflod/core/image.hpp"
#include "btflod/offline/btf/image_io.hpp"
#include "btflod/runtime/lod/lod_selector.hpp"

using namespace btflod;

namespace sample {

ReferenceCheck::ReferenceCheck(const Streamer& s, std::vector<const BsvtfAngularTables*> tables)
    : streamer_(s), tables_(std::move(tables)), cache_(s.cache()), u_(tables_.size()) {
  for (size_t m = 0; m < u_.size(); ++m) {
    u_[m].light_count = tables_[m]->light_count;
    u_[m].view_count = tables_[m]->view_count;
    u_[m].textures = Image<float>(1, 1, static_cast<int>(s.component_count(static_cast<uint32_t>(m))));  // sets C
    u_[m].angular.assign(
        size_t{tables_[m]->light_count} * tables_[m]->view_count * 3 * s.component_count(static_cast<uint32_t>(m)),
        0.0f);
  }
}

void ReferenceCheck::mirror(const StreamerOutputs& out) {
  for (size_t i = 0; i < out.tile_upload_count; ++i) {  // in the cache's format (rgba16f or rgba8_affine)
    const StreamerTileUpload& u = out.tile_uploads[i];
    cache_.upload(streamer_.cache(), u.slot, u.texels, u.unorm8, u.map);
  }
  for (size_t i = 0; i < out.packet_upload_count; ++i) {
    const StreamerPacketUpload& p = out.packet_uploads[i];
    EigenTextures& e = u_[p.material];
    write_u_packet(to_u_packet_upload(p), e.light_count, e.view_count, streamer_.component_count(p.material),
                   e.angular);
  }
}

glm::vec3 ReferenceCheck::shade(const SurfaceHit& hit, const Camera& cam, glm::vec3 to_light, glm::vec3 light_color,
                                std::span<const float> v) const {
  const glm::vec3 wl = to_local(hit, glm::normalize(to_light));
  const glm::vec3 wv = to_local(hit, glm::normalize(cam.position - hit.position));
  const BsvtfAngularTables& t = *tables_[hit.material];
  return shade_fmf(u_[hit.material], angular_table_sample(t.data(), 0, DirectionParameterisation::parabolic, false, wl),
                   angular_table_sample(t.data(), 1, DirectionParameterisation::parabolic, false, wv), v) *
         light_color;
}

double ReferenceCheck::psnr(const Image<float>& ref, std::span<const float> rgba, const std::string& png) {
  double se = 0.0, peak = 0.0;
  for (int y = 0; y < ref.height(); ++y)
    for (int x = 0; x < ref.width(); ++x)
      for (int c = 0; c < 3; ++c) {
        const double d = ref.at(x, y, c) - rgba[(static_cast<size_t>(y) * ref.width() + x) * 4 + c];
        se += d * d;
        peak = std::max(peak, static_cast<double>(ref.at(x, y, c)));
      }
  (void)write_png_srgb(png, ref.view());
  const double mse = se / (3.0 * ref.width() * ref.height());
  return mse > 0 ? 10.0 * std::log10(peak * peak / mse) : 200.0;
}

bool ReferenceCheck::run(const Scene& scene, const Camera& cam, glm::vec3 to_light, glm::vec3 light_color,
                         float lod_bias, std::span<const float> rgba, std::span<const uint32_t> words,
                         uint32_t decimation, double min_psnr, const std::string& out_dir) {
  const TileCache& cache = streamer_.cache();
  Image<float> ref(static_cast<int>(cam.width), static_cast<int>(cam.height), 4, 0.0f);
  uint64_t pixels = 0, finest = 0;
  std::vector<float> comps;
  for_each_pixel_hit(scene, cam, [&](uint32_t x, uint32_t y, float, float, const SurfaceHit& hit) {
    if (!hit.hit) return;
    // V′ through the tile cache's own page table: the deepest resident tile, bilinear.
    const uint32_t m = hit.material, first = streamer_.first_texture(m), n = streamer_.texture_count(m);
    comps.assign(4 * n, 0.0f);
    for (uint32_t k = 0; k < n; ++k) {
      const uint32_t level = cache_.sample(cache, first + k, hit.texcoord.x, hit.texcoord.y, &comps[4 * k]);
      if (k == 0 && level == cache.set().levels_of(first).finest_level()) ++finest;
    }
    comps.resize(streamer_.component_count(m));
    const glm::vec3 rgb = shade(hit, cam, to_light, light_color, comps);
    for (int c = 0; c < 3; ++c) ref.at(static_cast<int>(x), static_cast<int>(y), c) = rgb[c];
    ++pixels;
  });
  const double db = psnr(ref, rgba, out_dir + "/reference.png");
  std::printf(
      "check: bsvtf: PSNR %.3f dB vs the CPU reference (bound %.1f), %llu of %llu covered pixels at the finest level\n",
      db, min_psnr, static_cast<unsigned long long>(finest), static_cast<unsigned long long>(pixels));
  const bool feedback_ok = compare_feedback("converged view", scene, cam, lod_bias, words, decimation, 0.95, 0.001);
  return db >= min_psnr && pixels > 0 && finest * 10 >= pixels * 9 && feedback_ok;  // bounds: docs/filament.md
}

bool ReferenceCheck::run_fmf(const Scene& scene, const Camera& cam, glm::vec3 to_light, glm::vec3 light_color,
                             uint32_t material, const Image<float>& v, std::span<const float> rgba, double min_psnr,
                             const std::string& out_dir) {
  Image<float> ref(static_cast<int>(cam.width), static_cast<int>(cam.height), 4, 0.0f);
  std::vector<float> comps(static_cast<size_t>(v.channels()));
  uint64_t pixels = 0;
  for_each_pixel_hit(scene, cam, [&](uint32_t x, uint32_t y, float, float, const SurfaceHit& hit) {
    if (!hit.hit || hit.material != material) return;
    sample_repeat_bilinear(v, hit.texcoord, comps);  // GL_LINEAR, GL_REPEAT
    const glm::vec3 rgb = shade(hit, cam, to_light, light_color, comps);
    for (int c = 0; c < 3; ++c) ref.at(static_cast<int>(x), static_cast<int>(y), c) = rgb[c];
    ++pixels;
  });
  const double db = psnr(ref, rgba, out_dir + "/reference_fmf.png");
  std::printf("check: fmf (resident V'): PSNR %.3f dB vs the CPU reference (bound %.1f), %llu pixels\n", db, min_psnr,
              static_cast<unsigned long long>(pixels));
  return db >= min_psnr && pixels > 0;
}

bool ReferenceCheck::compare_feedback(const char* label, const Scene& scene, const Camera& cam, float lod_bias,
                                      std::span<const uint32_t> words, uint32_t decimation, double min_equal,
                                      double max_other) const {
  // The CPU's word at each feedback pixel centre of a camera with decimation× fewer pixels; the
  // Filament pass adds log2(decimation) levels to its λ (btflod_lod.y), the CPU's bias subtracts them.
  Camera fcam = cam;
  fcam.width = cam.width / decimation;
  fcam.height = cam.height / decimation;
  const DerivativeLod selector{lod_bias - std::log2(static_cast<float>(decimation))};
  uint64_t equal = 0, one_level = 0, other = 0;
  for_each_pixel_hit(scene, fcam, [&](uint32_t x, uint32_t y, float px, float py, const SurfaceHit& hit) {
    const uint32_t cpu = feedback_word(fcam, hit, px, py, streamer_.cache().set(), selector);
    const uint32_t gpu = words[size_t{y} * fcam.width + x];
    if (cpu == gpu) {
      ++equal;
      return;
    }
    const FeedbackTile a = unpack_feedback(cpu), b = unpack_feedback(gpu);
    const bool near = cpu != kFeedbackNone && gpu != kFeedbackNone && a.material == b.material &&
                      (a.level + 1 == b.level || b.level + 1 == a.level);
    ++(near ? one_level : other);
  });
  const double total = static_cast<double>(equal + one_level + other);
  std::printf(
      "check: %s: feedback words %llu of %.0f equal to the CPU's (bound %.0f %%), %llu one level apart, "
      "%llu other (bound %.1f %%)\n",
      label, static_cast<unsigned long long>(equal), total, 100 * min_equal, static_cast<unsigned long long>(one_level),
      static_cast<unsigned long long>(other), 100 * max_other);
  return static_cast<double>(equal) >= min_equal * total && static_cast<double>(other) <= max_other * total;
}

}  // namespace sample
