// btflod-demo — the RAW BTF reference of the report: the last view rendered from the tabulated
// BTF itself (each material's store, btf/btf_store.hpp) instead of its factorisation, so the
// report measures how far the streamed BSVTF image (and the FMF one) is from the material, not
// only from the FMF.
//
// Both reference images are ray-cast on the CPU (backend/cpu_reference.hpp's analytic scene,
// the renderers' camera and light) with `supersample`² rays per pixel (box filter), at the
// finest level (bilinear texel interpolation, wrap), with the shaders' angular lookup tables
// (paper 000 §4: 3 light × 3 view taps, multiplied barycentric weights):
//   raw  Σ_ij w_l,i w_v,j ρ'(x, v_j, l_i) from the store (the tabulated values), and
//   fmf  the same taps through U·V'(x) (paper 000 eq. 5): the factorisation error alone, since
//        every other step is shared.
// The store is read once, block by block in file order (one sequential pass, memory: one block
// and the per-sample lists), so the raw reference works for stores larger than RAM (paper 000's
// 512² × 151² material is ~36 GB): the rays are cast first, each sample's four texels are
// bucketed by store block, and each block's columns are applied to the samples that need them.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "btflod/btf/btf_store.hpp"
#include "btflod/metrics/image_metrics.hpp"
#include "stream_render.hpp"

namespace btflod::demo {

/// The two reference images and what producing them cost.
struct RawReference {
  Image<float> raw;      ///< from the tabulated BTF (linear RGBA)
  Image<float> fmf_cpu;  ///< from the FMF, same rays and taps (linear RGBA)
  double seconds = 0;
  uint64_t bytes_read = 0;  ///< store bytes read (one pass over each material's store)
  uint32_t supersample = 1;
};

/// Error of an image against the raw reference: SSIM of the sRGB-encoded images (as the frame
/// SSIM), PSNR of the same (range 1) and RMSE of the linear radiance.
struct ImageError {
  double ssim = 0, psnr = 0, rmse = 0;
};

inline ImageError image_error(const Image<float>& reference, const Image<float>& image) {
  ImageError e;
  const Image<float> a = to_display(reference), b = to_display(image);
  e.ssim = mean_ssim(a.view(), b.view());
  e.psnr = psnr(a.view(), b.view(), 1.0);
  Image<float> ra(reference.width(), reference.height(), 3), rb = ra;
  for (int y = 0; y < ra.height(); ++y)
    for (int x = 0; x < ra.width(); ++x)
      for (int c = 0; c < 3; ++c) ra.at(x, y, c) = reference.at(x, y, c), rb.at(x, y, c) = image.at(x, y, c);
  e.rmse = rmse(ra.view(), rb.view());
  return e;
}

namespace detail_raw {

struct Sample {
  uint32_t material = 0;
  AngularSample light, view;
  glm::vec3 raw{0.0f};  ///< accumulated over the four texels
};

struct TexelRef {
  uint32_t texel = 0;   ///< t = y·W + x in the material
  uint32_t sample = 0;  ///< index into the samples
  float weight = 0.0f;  ///< bilinear weight
};

inline void lookup(const DemoMaterial& m, const std::vector<uint32_t>& idx, const std::vector<float>& wt, glm::vec3 dir,
                   AngularSample& out) {
  const glm::ivec2 t = shader_table_texel(shader_direction_to_unit_square(DirectionParameterisation::parabolic, dir),
                                          m.angular_resolution);
  const size_t o = (static_cast<size_t>(t.y) * m.angular_resolution + static_cast<size_t>(t.x)) * 3;
  for (size_t k = 0; k < 3; ++k) {
    out.index[k] = idx[o + k];
    out.weight[k] = wt[o + k];
  }
}

}  // namespace detail_raw

/// Renders the raw and FMF references of `view` (see the file comment). `materials[i].store_path`
/// must name a complete store of material i's BTF. Returns the store's errors (named) and
/// unsupported for C above CpuFrameRenderer::kMaxComponents. Allocates; uses the default thread
/// pool for the rays.
inline Result<RawReference> render_raw_reference(const std::vector<DemoMaterial>& materials, const scene::View& view,
                                                 uint32_t supersample) {
  const auto t_start = std::chrono::steady_clock::now();
  RawReference ref;
  ref.supersample = std::max(1u, supersample);
  const uint32_t ssn = ref.supersample;
  for (const DemoMaterial& m : materials)
    if (m.components > CpuFrameRenderer::kMaxComponents)
      return make_error(Status::unsupported, "%s: C = %u above %u", m.name.c_str(), m.components,
                        CpuFrameRenderer::kMaxComponents);
  const Scene scene = analytic_demo_scene(static_cast<uint32_t>(materials.size()));
  Camera cam;
  cam.position = view.eye;
  cam.target = view.target;
  cam.fov_y_degrees = view.fov_y_degrees;
  cam.width = view.width;
  cam.height = view.height;
  const ShaderParams p = scene::view_params(view, glm::vec3(0.5f, 0.8f, 0.35f), glm::vec3(2.2f, 2.1f, 2.0f));
  const glm::vec3 light_dir = glm::normalize(glm::vec3(p.light)), light_color = glm::vec3(p.light_color);
  const int W = static_cast<int>(view.width), H = static_cast<int>(view.height);
  ref.raw = Image<float>(W, H, 4);
  ref.fmf_cpu = Image<float>(W, H, 4);
  const size_t n_samples = static_cast<size_t>(W) * H * ssn * ssn;
  std::vector<detail_raw::Sample> samples(n_samples);
  std::vector<uint8_t> hit(n_samples, 0);
  std::vector<glm::vec3> fmf_rgb(n_samples, glm::vec3(0.0f));
  // Per material, the texel references of its samples (filled per row range, then merged).
  const size_t nm = materials.size();
  std::vector<std::vector<std::vector<detail_raw::TexelRef>>> refs_per_row(static_cast<size_t>(H));
  default_thread_pool().parallel_for(0, static_cast<size_t>(H), 2, [&](size_t y0, size_t y1) {
    float comps[CpuFrameRenderer::kMaxComponents];
    for (size_t y = y0; y < y1; ++y) {
      auto& refs = refs_per_row[y];
      refs.assign(nm, {});
      for (int x = 0; x < W; ++x)
        for (uint32_t sy = 0; sy < ssn; ++sy)
          for (uint32_t sx = 0; sx < ssn; ++sx) {
            const size_t si = ((y * static_cast<size_t>(W) + static_cast<size_t>(x)) * ssn + sy) * ssn + sx;
            const float px = static_cast<float>(x) + (static_cast<float>(sx) + 0.5f) / static_cast<float>(ssn);
            const float py = static_cast<float>(y) + (static_cast<float>(sy) + 0.5f) / static_cast<float>(ssn);
            const SurfaceHit h = scene.intersect(cam.ray(px, py));
            if (!h.hit) continue;
            hit[si] = 1;
            const DemoMaterial& m = materials[h.material];
            detail_raw::Sample& s = samples[si];
            s.material = h.material;
            detail_raw::lookup(m, m.light_index, m.light_weight, to_local(h, light_dir), s.light);
            detail_raw::lookup(m, m.view_index, m.view_weight, to_local(h, glm::normalize(cam.position - h.position)),
                               s.view);
            // Bilinear over the virtual texture (the material repeated), as the CPU FMF shading.
            const Image<float>& v = m.eigen_textures;
            const float fx = h.texcoord.x * static_cast<float>(v.width()) - 0.5f;
            const float fy = h.texcoord.y * static_cast<float>(v.height()) - 0.5f;
            const int x0 = static_cast<int>(std::floor(fx)), y0i = static_cast<int>(std::floor(fy));
            const float ax = fx - static_cast<float>(x0), ay = fy - static_cast<float>(y0i);
            const auto wrap = [](int i, int n) { return ((i % n) + n) % n; };
            const int xs[2] = {wrap(x0, v.width()), wrap(x0 + 1, v.width())};
            const int ys[2] = {wrap(y0i, v.height()), wrap(y0i + 1, v.height())};
            const float wx[2] = {1.0f - ax, ax}, wy[2] = {1.0f - ay, ay};
            for (int k = 0; k < v.channels() && k < static_cast<int>(CpuFrameRenderer::kMaxComponents); ++k) {
              const float top = v.at(xs[0], ys[0], k) * wx[0] + v.at(xs[1], ys[0], k) * wx[1];
              const float bot = v.at(xs[0], ys[1], k) * wx[0] + v.at(xs[1], ys[1], k) * wx[1];
              comps[k] = top * wy[0] + bot * wy[1];
            }
            fmf_rgb[si] = shade_fmf(m.eigen, s.light, s.view, std::span<const float>(comps, m.components));
            for (int j = 0; j < 2; ++j)
              for (int i = 0; i < 2; ++i) {
                const float w = wx[i] * wy[j];
                if (w == 0.0f) continue;
                const uint32_t tx = static_cast<uint32_t>(xs[i] % m.texels),
                               ty = static_cast<uint32_t>(ys[j] % m.texels);
                refs[h.material].push_back({ty * static_cast<uint32_t>(m.texels) + tx, static_cast<uint32_t>(si), w});
              }
          }
    }
  });
  // One pass over each store: bucket the references by block, then apply each block's columns.
  for (size_t mi = 0; mi < nm; ++mi) {
    const DemoMaterial& m = materials[mi];
    auto store = BtfStore::open(m.store_path);
    if (!store) return store.error();
    const BtfStoreInfo& info = store->info();
    if (info.width != m.texels || info.height != m.texels || info.views.size() != m.view_count ||
        info.lights.size() != m.light_count)
      return make_error(Status::bad_data, "%s: store shape differs from material %s", m.store_path.c_str(),
                        m.name.c_str());
    const size_t B = info.block_texels, nl = info.lights.size(), rows = store->rows();
    std::vector<std::vector<detail_raw::TexelRef>> by_block(info.block_count());
    for (auto& row : refs_per_row)
      for (const detail_raw::TexelRef& r : row[mi]) by_block[r.texel / B].push_back(r);
    std::vector<float> cols;
    std::vector<uint8_t> scratch;
    for (size_t b = 0; b < by_block.size(); ++b) {
      if (by_block[b].empty()) continue;
      const size_t t0 = b * B, cnt = info.block_width(b);
      cols.resize(rows * cnt);
      if (auto r = store->read_columns(t0, cnt, cols.data(), rows, scratch); !r) return r.error();
      ref.bytes_read += static_cast<uint64_t>(rows) * cnt * info.value_size();
      for (const detail_raw::TexelRef& r : by_block[b]) {
        detail_raw::Sample& s = samples[r.sample];
        const float* col = cols.data() + (r.texel - t0) * rows;
        glm::vec3 rgb(0.0f);
        for (size_t i = 0; i < 3; ++i)
          for (size_t j = 0; j < 3; ++j) {
            const float w = s.light.weight[i] * s.view.weight[j];
            if (w == 0.0f) continue;
            const float* px = col + (static_cast<size_t>(s.view.index[j]) * nl + s.light.index[i]) * 3;
            rgb += w * glm::vec3(px[0], px[1], px[2]);
          }
        s.raw += r.weight * rgb;
      }
    }
  }
  // Resolve: box filter over the subsamples, light colour, the renderers' background.
  const float inv = 1.0f / static_cast<float>(ssn * ssn);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      glm::vec3 raw(0.0f), fmf(0.0f);
      for (uint32_t k = 0; k < ssn * ssn; ++k) {
        const size_t si = (static_cast<size_t>(y) * W + static_cast<size_t>(x)) * ssn * ssn + k;
        const glm::vec3 bg(0.45f, 0.55f, 0.7f);
        raw += hit[si] ? samples[si].raw * light_color : bg;
        fmf += hit[si] ? fmf_rgb[si] * light_color : bg;
      }
      for (int c = 0; c < 3; ++c) ref.raw.at(x, y, c) = raw[c] * inv, ref.fmf_cpu.at(x, y, c) = fmf[c] * inv;
      ref.raw.at(x, y, 3) = 1.0f;
      ref.fmf_cpu.at(x, y, 3) = 1.0f;
    }
  ref.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return ref;
}

}  // namespace btflod::demo
