// btflod-demo — the RAW BTF reference of the report: the last view rendered from the tabulated
// BTF itself (each material's store, offline/btf/btf_store.hpp) instead of its factorisation, so the
// report measures how far the streamed BSVTF image (and the FMF one) is from the material, not
// only from the FMF.
//
// Both reference images are ray-cast on the CPU (offline/render/cpu_reference.hpp's analytic scene,
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
// RawReferenceBuilder does this material by material, so that each store is needed only for its
// own pass (the paper profile deletes it right after: one store on disk at a time).
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "btflod/offline/btf/btf_store.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"
#include "stream_render.hpp"

namespace btflod::demo {

/// The two reference images and what producing them cost.
struct RawReference {
  Image<float> raw;      ///< from the tabulated BTF (linear RGBA)
  Image<float> fmf_cpu;  ///< from the FMF, same rays and taps (linear RGBA)
  /// The GPU's texture filter instead of supersampling: one ray through each pixel centre, the
  /// level of detail of OpenGL's isotropic minification (λ = log2 of the larger screen-space
  /// derivative of the texel coordinate, as the FMF sampler and vt_lambda) and trilinear
  /// filtering over the box-filtered mip chain — of the raw BTF (raw_gpu_filter) and of V′
  /// through U (fmf_gpu_filter). Empty (has_gpu_filter false, gpu_filter_note says why) unless
  /// every material's texel count and virtual texture are powers of two.
  Image<float> raw_gpu_filter, fmf_gpu_filter;
  bool has_gpu_filter = false;
  std::string gpu_filter_note;
  /// Per pixel (row-major), the material its pixel-centre ray hits, or ~0u for the background:
  /// the mask of the per-material figures (image_error's `pixel_material`).
  std::vector<uint32_t> pixel_material;
  double seconds = 0;
  uint64_t bytes_read = 0;  ///< store bytes read (one pass over each material's store)
  uint32_t supersample = 1;
};

/// Error of an image against the raw reference: SSIM of the sRGB-encoded images (as the frame
/// SSIM), PSNR of the same (range 1), RMSE of the linear radiance, and ΔE*ab (CIE 1976, D65) of
/// what the PNGs show — each pixel's linear RGB clamped to [0, 1] and converted to CIELAB
/// (offline/metrics/image_metrics.hpp's linear_srgb_to_lab) — as its mean and 99th percentile over the
/// pixels. `pixels` counts the pixels compared.
struct ImageError {
  double ssim = 0, psnr = 0, rmse = 0;
  double de_mean = 0, de_p99 = 0;
  uint64_t pixels = 0;
  std::string filter;  ///< the rays and filter of both images, e.g. "same rays: 4×4 per pixel, box filter"
};

/// Every pixel of the images, or only those whose pixel-centre ray hits material `only` of
/// `pixel_material` (RawReference::pixel_material). The masked SSIM is the mean of the SSIM map
/// (metrics' ssim_map, 11 × 11 Gaussian window) over the window positions centred on the
/// material's pixels; its PSNR, RMSE and ΔE are over the material's pixels. All zero when no
/// pixel qualifies.
inline ImageError image_error(const Image<float>& reference, const Image<float>& image,
                              const std::vector<uint32_t>* pixel_material = nullptr, uint32_t only = 0) {
  ImageError e;
  const int W = reference.width(), H = reference.height();
  if (image.width() != W || image.height() != H || W == 0 || H == 0) return e;
  const bool masked = pixel_material != nullptr && pixel_material->size() == static_cast<size_t>(W) * H;
  const auto in = [&](int x, int y) {
    return !masked ||
           (*pixel_material)[static_cast<size_t>(y) * static_cast<size_t>(W) + static_cast<size_t>(x)] == only;
  };
  const Image<float> a = to_display(reference), b = to_display(image);
  if (!masked) {
    e.ssim = mean_ssim(a.view(), b.view());
  } else {
    double sum = 0.0;
    uint64_t n = 0;
    for (int c = 0; c < 3; ++c) {
      int mw = 0;
      const std::vector<double> map = ssim_map(a.view(), b.view(), c, SsimOptions{}, &mw);
      if (mw <= 0) continue;
      const int r = (W - mw) / 2;
      for (size_t i = 0; i < map.size(); ++i) {
        const int x = static_cast<int>(i % static_cast<size_t>(mw)) + r,
                  y = static_cast<int>(i / static_cast<size_t>(mw)) + r;
        if (in(x, y)) sum += map[i], ++n;
      }
    }
    e.ssim = n ? sum / static_cast<double>(n) : 0.0;
  }
  double se_display = 0.0, se_linear = 0.0;
  std::vector<double> de;
  de.reserve(static_cast<size_t>(W) * static_cast<size_t>(H));
  double de_sum = 0.0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      if (!in(x, y)) continue;
      double clamped[2][3];
      for (int c = 0; c < 3; ++c) {
        const double dd = static_cast<double>(a.at(x, y, c)) - b.at(x, y, c);
        const double dl = static_cast<double>(reference.at(x, y, c)) - image.at(x, y, c);
        se_display += dd * dd;
        se_linear += dl * dl;
        clamped[0][c] = std::clamp(static_cast<double>(reference.at(x, y, c)), 0.0, 1.0);
        clamped[1][c] = std::clamp(static_cast<double>(image.at(x, y, c)), 0.0, 1.0);
      }
      const auto la = linear_srgb_to_lab(clamped[0][0], clamped[0][1], clamped[0][2]);
      const auto lb = linear_srgb_to_lab(clamped[1][0], clamped[1][1], clamped[1][2]);
      const double d = std::sqrt((la[0] - lb[0]) * (la[0] - lb[0]) + (la[1] - lb[1]) * (la[1] - lb[1]) +
                                 (la[2] - lb[2]) * (la[2] - lb[2]));
      de.push_back(d);
      de_sum += d;
    }
  e.pixels = de.size();
  if (de.empty()) return e;
  const double n3 = 3.0 * static_cast<double>(de.size());
  e.psnr = se_display > 0.0 ? 10.0 * std::log10(n3 / se_display) : std::numeric_limits<double>::infinity();
  e.rmse = std::sqrt(se_linear / n3);
  e.de_mean = de_sum / static_cast<double>(de.size());
  // Nearest rank: the smallest value with at least 99 % of the pixels at or below it.
  const size_t rank = static_cast<size_t>(std::ceil(0.99 * static_cast<double>(de.size())));
  const size_t k = std::min(de.size() - 1, rank > 0 ? rank - 1 : 0);
  std::nth_element(de.begin(), de.begin() + static_cast<std::ptrdiff_t>(k), de.end());
  e.de_p99 = de[k];
  return e;
}

namespace detail_raw {

struct Sample {  ///< a ray's angular taps
  AngularSample light, view;
};

struct TexelRef {
  uint32_t texel = 0;   ///< t = y·W + x in the material
  uint32_t sample = 0;  ///< index into the samples
  float weight = 0.0f;  ///< bilinear weight
};

/// A pixel-centre ray of the GPU-filter-matched references: its taps (texel-pyramid keys and
/// trilinear × bilinear weights, at most 2 levels × 4 texels) and angular taps.
struct FilteredSample {
  AngularSample light, view;
  uint32_t key[8] = {};
  float weight[8] = {};
  uint32_t taps = 0;
};

inline int exact_log2(int n) {
  int k = 0;
  while ((1 << k) < n) ++k;
  return (1 << k) == n ? k : -1;
}

// The shaders' angular lookup (offline/angular/table_lookup.hpp) of material m; layer 0 = light.
inline void lookup(const DemoMaterial& m, int layer, glm::vec3 dir, AngularSample& out) {
  out = angular_table_sample(m.angular_tables(), layer, DirectionParameterisation::parabolic, false, dir);
}

}  // namespace detail_raw

/// Builds the raw and FMF references of one view material by material (see the file comment),
/// so that each material's store is needed only while add_material() reads it: the rays are cast
/// first (cast(), before any store exists), each material's samples are resolved from its store
/// in one pass right after its factorisation (add_material()), and finish() returns the images.
/// The store can be deleted once add_material() has returned. Not thread-safe; uses the default
/// thread pool for the rays. Memory: about 60 bytes per ray plus 48 per ray of the material
/// being added (a 1280 x 720 view at 3 x 3 rays: about 0.9 GB).
class RawReferenceBuilder {
 public:
  /// Casts `supersample`² rays per pixel of `view` into the analytic scene of `material_count`
  /// materials (analytic_demo_scene). Returns invalid_argument for an empty view or no material.
  /// `gpu_filter` false leaves out the GPU-filter-matched images (and their work in add_material).
  static Result<RawReferenceBuilder> cast(uint32_t material_count, const scene::View& view, uint32_t supersample,
                                          bool gpu_filter = true) {
    if (material_count == 0 || view.width == 0 || view.height == 0)
      return make_error(Status::invalid_argument, "raw reference: empty view or no material");
    RawReferenceBuilder b;
    b.t_start_ = std::chrono::steady_clock::now();
    b.ssn_ = std::max(1u, supersample);
    if (!gpu_filter) b.gpu_filter_ok_ = false, b.gpu_filter_note_ = "not asked for";
    b.width_ = static_cast<int>(view.width), b.height_ = static_cast<int>(view.height);
    b.added_.assign(material_count, 0);
    const Scene scene = scene::analytic_demo_scene(material_count);
    const Camera cam = scene::to_camera(view);
    const ShaderParams p = scene::view_params(view, glm::vec3(0.5f, 0.8f, 0.35f), glm::vec3(2.2f, 2.1f, 2.0f));
    const glm::vec3 light_dir = glm::normalize(glm::vec3(p.light));
    b.light_color_ = glm::vec3(p.light_color);
    const uint32_t ssn = b.ssn_;
    const int W = b.width_;
    const size_t n = static_cast<size_t>(W) * static_cast<size_t>(b.height_) * ssn * ssn;
    b.rays_.assign(n, Ray{});
    b.raw_.assign(n, glm::vec3(0.0f));
    b.fmf_.assign(n, glm::vec3(0.0f));
    const size_t np = static_cast<size_t>(W) * static_cast<size_t>(b.height_);
    b.pixel_rays_.assign(np, Ray{});
    b.raw_f_.assign(np, glm::vec3(0.0f));
    b.fmf_f_.assign(np, glm::vec3(0.0f));
    default_thread_pool().parallel_for(0, static_cast<size_t>(b.height_), 2, [&](size_t y0, size_t y1) {
      for (size_t y = y0; y < y1; ++y)
        for (int x = 0; x < W; ++x)
          for (uint32_t sy = 0; sy < ssn; ++sy)
            for (uint32_t sx = 0; sx < ssn; ++sx) {
              const size_t si = ((y * static_cast<size_t>(W) + static_cast<size_t>(x)) * ssn + sy) * ssn + sx;
              const float px = static_cast<float>(x) + (static_cast<float>(sx) + 0.5f) / static_cast<float>(ssn);
              const float py = static_cast<float>(y) + (static_cast<float>(sy) + 0.5f) / static_cast<float>(ssn);
              const SurfaceHit h = scene.intersect(cam.ray(px, py));
              if (!h.hit) continue;
              Ray& r = b.rays_[si];
              r.material = h.material;
              r.texcoord = h.texcoord;
              r.light_local = to_local(h, light_dir);
              r.view_local = to_local(h, glm::normalize(cam.position - h.position));
            }
      // The pixel centre with its texture-coordinate footprint: the neighbouring pixels' rays
      // meet the hit's tangent plane; their uv offsets (in the dpdu, dpdv basis) are the screen
      // derivatives the rasteriser's dFdx/dFdy estimate.
      for (size_t y = y0; y < y1; ++y)
        for (int x = 0; x < W; ++x) {
          const float px = static_cast<float>(x) + 0.5f, py = static_cast<float>(y) + 0.5f;
          const SurfaceHit h = scene.intersect(cam.ray(px, py));
          if (!h.hit) continue;
          Ray& r = b.pixel_rays_[y * static_cast<size_t>(W) + static_cast<size_t>(x)];
          r.material = h.material;
          r.texcoord = h.texcoord;
          r.light_local = to_local(h, light_dir);
          r.view_local = to_local(h, glm::normalize(cam.position - h.position));
          const float uu = glm::dot(h.dpdu, h.dpdu), uv = glm::dot(h.dpdu, h.dpdv), vv = glm::dot(h.dpdv, h.dpdv);
          const float det = uu * vv - uv * uv;
          float rho = 1.0f;  // a whole texture per pixel when degenerate
          if (det > 0.0f) {
            rho = 0.0f;
            for (int k = 0; k < 2; ++k) {
              const ::btflod::Ray nr = cam.ray(px + (k == 0 ? 1.0f : 0.0f), py + (k == 1 ? 1.0f : 0.0f));
              const float denom = glm::dot(nr.direction, h.normal);
              if (std::fabs(denom) < 1e-12f) {
                rho = 1.0f;
                break;
              }
              const float t = glm::dot(h.position - nr.origin, h.normal) / denom;
              const glm::vec3 dp = nr.origin + t * nr.direction - h.position;
              const float pu = glm::dot(h.dpdu, dp), pv = glm::dot(h.dpdv, dp);
              const float du = (vv * pu - uv * pv) / det, dv = (uu * pv - uv * pu) / det;
              rho = std::max(rho, std::sqrt(du * du + dv * dv));
            }
          }
          r.footprint = rho;
        }
    });
    b.seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - b.t_start_).count();
    return b;
  }

  /// Resolves the rays that hit material `index` from `m`'s store (`m.store_path`, read once,
  /// block by block in file order) and its FMF (m.eigen_textures, m.u). Returns the store's
  /// errors (named), bad_data when the store's shape differs from `m`, unsupported for C above
  /// CpuFrameRenderer::kMaxComponents, invalid_argument for an index out of range or added twice.
  VoidResult add_material(uint32_t index, const DemoMaterial& m) {
    const auto t0 = std::chrono::steady_clock::now();
    if (index >= added_.size() || added_[index])
      return make_error(Status::invalid_argument, "raw reference: material %u out of range or added twice", index);
    if (m.components > CpuFrameRenderer::kMaxComponents)
      return make_error(Status::unsupported, "%s: C = %u above %u", m.name.c_str(), m.components,
                        CpuFrameRenderer::kMaxComponents);
    auto store = BtfStore::open(m.store_path);
    if (!store) return store.error();
    const BtfStoreInfo& info = store->info();
    if (info.width != m.texels || info.height != m.texels || info.views.size() != m.view_count ||
        info.lights.size() != m.light_count)
      return make_error(Status::bad_data, "%s: store shape differs from material %s", m.store_path.c_str(),
                        m.name.c_str());
    // The angular taps, the FMF on the same rays, and each ray's four texel references.
    const size_t n = rays_.size();
    std::vector<detail_raw::Sample> taps(n);
    const size_t chunks = ray_chunks(n, 4096);
    std::vector<std::vector<detail_raw::TexelRef>> refs(chunks);
    for_material_rays(rays_, index, chunks, [&](size_t c, size_t si, float* comps) {
      detail_raw::Sample& s = taps[si];
      int xs[2], ys[2];
      float wx[2], wy[2];
      fmf_[si] = shade_ray(m, rays_[si], s, comps, xs, ys, wx, wy);
      for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) {
          const float w = wx[i] * wy[j];
          if (w == 0.0f) continue;
          const uint32_t tx = static_cast<uint32_t>(xs[i] % m.texels), ty = static_cast<uint32_t>(ys[j] % m.texels);
          refs[c].push_back({ty * static_cast<uint32_t>(m.texels) + tx, static_cast<uint32_t>(si), w});
        }
    });
    // The GPU-filter-matched pixel rays: trilinear taps into the material's texel pyramid, the
    // FMF through V′'s mips, and one request (texel-pyramid key, direction pair) per raw tap.
    const size_t B = info.block_texels, nl = info.lights.size(), rows = store->rows();
    const int K = detail_raw::exact_log2(m.texels);
    const int Mv = m.eigen_textures.width(), KM = detail_raw::exact_log2(Mv);
    if (gpu_filter_ok_ && (K < 0 || KM < 0 || m.eigen_textures.height() != Mv)) {
      gpu_filter_ok_ = false;
      gpu_filter_note_ = m.name + ": texel count or virtual texture not a power of two";
      std::vector<glm::vec3>().swap(raw_f_);
      std::vector<glm::vec3>().swap(fmf_f_);
    }
    std::vector<size_t> key_offset;
    std::vector<std::vector<float>> vmip;  // V′ of the material (one period), box-filtered levels 0..K
    std::vector<detail_raw::FilteredSample> ftaps;
    std::vector<uint64_t> requests;      // sorted: key << 20 | (view · n_light + light)
    std::vector<uint32_t> key_begin;     // requests of key k: [key_begin[k], key_begin[k + 1])
    std::vector<glm::vec3> request_sum;  // per request, the sum of its key's texels (then the mean)
    const uint32_t C = m.components;
    if (gpu_filter_ok_) {
      const int S = m.texels;
      key_offset.assign(static_cast<size_t>(K) + 2, 0);
      for (int k = 0; k <= K; ++k)
        key_offset[static_cast<size_t>(k) + 1] =
            key_offset[static_cast<size_t>(k)] + static_cast<size_t>(S >> k) * (S >> k);
      vmip.resize(static_cast<size_t>(K) + 1);
      vmip[0].resize(static_cast<size_t>(S) * S * C);
      for (int y = 0; y < S; ++y)
        for (int x = 0; x < S; ++x)
          for (uint32_t c = 0; c < C; ++c)
            vmip[0][(static_cast<size_t>(y) * S + x) * C + c] = m.eigen_textures.at(x, y, static_cast<int>(c));
      for (int k = 1; k <= K; ++k) {
        const int s = S >> k;
        vmip[k].resize(static_cast<size_t>(s) * s * C);
        const std::vector<float>& f = vmip[static_cast<size_t>(k) - 1];
        for (int y = 0; y < s; ++y)
          for (int x = 0; x < s; ++x)
            for (uint32_t c = 0; c < C; ++c) {
              const auto at = [&](int xx, int yy) { return f[(static_cast<size_t>(yy) * (2 * s) + xx) * C + c]; };
              vmip[k][(static_cast<size_t>(y) * s + x) * C + c] =
                  0.25f * (at(2 * x, 2 * y) + at(2 * x + 1, 2 * y) + at(2 * x, 2 * y + 1) + at(2 * x + 1, 2 * y + 1));
            }
      }
      const size_t np = pixel_rays_.size();
      ftaps.resize(np);
      const size_t fchunks = ray_chunks(np, 1024);
      std::vector<std::vector<uint64_t>> req_chunks(fchunks);
      for_material_rays(pixel_rays_, index, fchunks, [&](size_t c, size_t pi, float* comps) {
        const Ray& r = pixel_rays_[pi];
        detail_raw::FilteredSample& f = ftaps[pi];
        detail_raw::lookup(m, 0, r.light_local, f.light);
        detail_raw::lookup(m, 1, r.view_local, f.view);
        // OpenGL's LINEAR_MIPMAP_LINEAR: λ ≤ 0 magnifies (level 0), else levels ⌊λ⌋ and ⌊λ⌋ + 1.
        const float lambda = std::log2(std::max(r.footprint * static_cast<float>(Mv), 1e-20f));
        int k0 = 0, k1 = 0;
        float w1 = 0.0f;
        if (lambda > 0.0f) {
          const float l = std::min(lambda, static_cast<float>(KM));
          k0 = static_cast<int>(std::floor(l));
          k1 = std::min(k0 + 1, KM);
          w1 = k1 == k0 ? 0.0f : l - static_cast<float>(k0);
        }
        std::fill(comps, comps + C, 0.0f);
        for (int li = 0; li < 2; ++li) {
          const int k = li == 0 ? k0 : k1;
          const float wl = li == 0 ? 1.0f - w1 : w1;
          if (wl == 0.0f) continue;
          const int sv = Mv >> k, kk = std::min(k, K), sm = S >> kk;
          const float fx = r.texcoord.x * static_cast<float>(sv) - 0.5f;
          const float fy = r.texcoord.y * static_cast<float>(sv) - 0.5f;
          const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
          const float ax = fx - static_cast<float>(x0), ay = fy - static_cast<float>(y0);
          for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 2; ++i) {
              const float w = wl * (i ? ax : 1.0f - ax) * (j ? ay : 1.0f - ay);
              if (w == 0.0f) continue;
              const int vx = (((x0 + i) % sv) + sv) % sv, vy = (((y0 + j) % sv) + sv) % sv;
              const size_t local = static_cast<size_t>(vy % sm) * sm + static_cast<size_t>(vx % sm);
              const float* vm = vmip[static_cast<size_t>(kk)].data() + local * C;
              for (uint32_t q = 0; q < C; ++q) comps[q] += w * vm[q];
              f.key[f.taps] = static_cast<uint32_t>(key_offset[static_cast<size_t>(kk)] + local);
              f.weight[f.taps] = w;
              ++f.taps;
            }
        }
        fmf_f_[pi] = shade_fmf(m.eigen, f.light, f.view, std::span<const float>(comps, C));
        for (uint32_t t = 0; t < f.taps; ++t)
          for (size_t a = 0; a < 3; ++a)
            for (size_t v = 0; v < 3; ++v)
              if (f.light.weight[a] * f.view.weight[v] != 0.0f)
                req_chunks[c].push_back(uint64_t{f.key[t]} << 20 |
                                        (uint64_t{f.view.index[v]} * nl + uint64_t{f.light.index[a]}));
      });
      for (auto& rc : req_chunks) {
        requests.insert(requests.end(), rc.begin(), rc.end());
        std::vector<uint64_t>().swap(rc);
      }
      std::sort(requests.begin(), requests.end());
      requests.erase(std::unique(requests.begin(), requests.end()), requests.end());
      const size_t n_keys = key_offset.back();
      key_begin.assign(n_keys + 1, 0);
      for (const uint64_t q : requests) ++key_begin[static_cast<size_t>(q >> 20) + 1];
      for (size_t k = 0; k < n_keys; ++k) key_begin[k + 1] += key_begin[k];
      request_sum.assign(requests.size(), glm::vec3(0.0f));
    }
    // One pass over the store: bucket the references by block, then apply each block's columns
    // (and add each texel to the requests of its texel-pyramid ancestors).
    std::vector<std::vector<detail_raw::TexelRef>> by_block(info.block_count());
    for (auto& chunk : refs) {
      for (const detail_raw::TexelRef& r : chunk) by_block[r.texel / B].push_back(r);
      std::vector<detail_raw::TexelRef>().swap(chunk);
    }
    std::vector<float> cols;
    std::vector<uint8_t> scratch;
    for (size_t b = 0; b < by_block.size(); ++b) {
      if (by_block[b].empty() && requests.empty()) continue;
      const size_t t0b = b * B, cnt = info.block_width(b);
      cols.resize(rows * cnt);
      if (auto r = store->read_columns(t0b, cnt, cols.data(), rows, scratch); !r) return r.error();
      bytes_read_ += static_cast<uint64_t>(rows) * cnt * info.value_size();
      for (const detail_raw::TexelRef& r : by_block[b]) {
        const detail_raw::Sample& s = taps[r.sample];
        const float* col = cols.data() + (r.texel - t0b) * rows;
        glm::vec3 rgb(0.0f);
        for (size_t i = 0; i < 3; ++i)
          for (size_t j = 0; j < 3; ++j) {
            const float w = s.light.weight[i] * s.view.weight[j];
            if (w == 0.0f) continue;
            const float* px = col + (static_cast<size_t>(s.view.index[j]) * nl + s.light.index[i]) * 3;
            rgb += w * glm::vec3(px[0], px[1], px[2]);
          }
        raw_[r.sample] += r.weight * rgb;
      }
      std::vector<detail_raw::TexelRef>().swap(by_block[b]);
      if (!requests.empty())
        for (size_t t = t0b; t < t0b + cnt; ++t) {
          const size_t x = t % static_cast<size_t>(m.texels), y = t / static_cast<size_t>(m.texels);
          const float* col = cols.data() + (t - t0b) * rows;
          for (int k = 0; k <= K; ++k) {
            const size_t sm = static_cast<size_t>(m.texels) >> k;
            const size_t key = key_offset[static_cast<size_t>(k)] + (y >> k) * sm + (x >> k);
            for (uint32_t q = key_begin[key]; q < key_begin[key + 1]; ++q) {
              const float* px = col + static_cast<size_t>(requests[q] & 0xFFFFFu) * 3;
              request_sum[q] += glm::vec3(px[0], px[1], px[2]);
            }
          }
        }
    }
    if (gpu_filter_ok_) {
      // Sums to means (a level-k texel averages 4^k texels), then each pixel's trilinear taps.
      for (int k = 0; k <= K; ++k)
        for (size_t key = key_offset[static_cast<size_t>(k)]; key < key_offset[static_cast<size_t>(k) + 1]; ++key)
          for (uint32_t q = key_begin[key]; q < key_begin[key + 1]; ++q)
            request_sum[q] *= 1.0f / static_cast<float>(size_t{1} << (2 * k));
      default_thread_pool().parallel_for(0, ftaps.size(), 4096, [&](size_t p0, size_t p1) {
        for (size_t pi = p0; pi < p1; ++pi) {
          if (pixel_rays_[pi].material != index) continue;
          const detail_raw::FilteredSample& f = ftaps[pi];
          glm::vec3 rgb(0.0f);
          for (uint32_t t = 0; t < f.taps; ++t)
            for (size_t a = 0; a < 3; ++a)
              for (size_t v = 0; v < 3; ++v) {
                const float w = f.weight[t] * f.light.weight[a] * f.view.weight[v];
                if (w == 0.0f) continue;
                const uint64_t want =
                    uint64_t{f.key[t]} << 20 | (uint64_t{f.view.index[v]} * nl + uint64_t{f.light.index[a]});
                const auto first = requests.begin() + key_begin[f.key[t]],
                           last = requests.begin() + key_begin[f.key[t] + 1];
                const auto it = std::lower_bound(first, last, want);
                rgb += w * request_sum[static_cast<size_t>(it - requests.begin())];
              }
          raw_f_[pi] = rgb;
        }
      });
    }
    added_[index] = 1;
    seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return {};
  }

  /// Shades the same-ray samples of material `index` again through `m`'s FMF — another rank,
  /// value encoding or the eigen-textures decoded from a container — keeping the raw samples:
  /// finish() then compares the new factorisation with the same raw image without reading the
  /// store again. The GPU-filter-matched FMF image is not updated (finish() leaves it out
  /// from then on). Returns invalid_argument until add_material(index, …) succeeded, unsupported
  /// for C above CpuFrameRenderer::kMaxComponents.
  VoidResult replace_fmf(uint32_t index, const DemoMaterial& m) {
    const auto t0 = std::chrono::steady_clock::now();
    if (index >= added_.size() || !added_[index])
      return make_error(Status::invalid_argument, "raw reference: material %u not added", index);
    if (m.components > CpuFrameRenderer::kMaxComponents)
      return make_error(Status::unsupported, "%s: C = %u above %u", m.name.c_str(), m.components,
                        CpuFrameRenderer::kMaxComponents);
    gpu_filter_ok_ = false;
    gpu_filter_note_ = "an FMF was replaced (replace_fmf): same rays only";
    const size_t n = rays_.size();
    default_thread_pool().parallel_for(0, n, 4096, [&](size_t s0, size_t s1) {
      float comps[CpuFrameRenderer::kMaxComponents];
      detail_raw::Sample s;
      int xs[2], ys[2];
      float wx[2], wy[2];
      for (size_t si = s0; si < s1; ++si)
        if (rays_[si].material == index) fmf_[si] = shade_ray(m, rays_[si], s, comps, xs, ys, wx, wy);
    });
    seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return {};
  }

  /// Store bytes read so far (one pass over each added material's store).
  uint64_t bytes_read() const noexcept { return bytes_read_; }

  /// The two images (box filter over the rays, light colour, the renderers' background).
  /// Returns invalid_argument until every material was added.
  Result<RawReference> finish() const {
    const auto t0 = std::chrono::steady_clock::now();
    for (size_t i = 0; i < added_.size(); ++i)
      if (!added_[i]) return make_error(Status::invalid_argument, "raw reference: material %zu not added", i);
    RawReference ref;
    ref.supersample = ssn_;
    ref.bytes_read = bytes_read_;
    ref.raw = Image<float>(width_, height_, 4);
    ref.fmf_cpu = Image<float>(width_, height_, 4);
    const uint32_t k2 = ssn_ * ssn_;
    const float inv = 1.0f / static_cast<float>(k2);
    const glm::vec3 bg(0.45f, 0.55f, 0.7f);
    for (int y = 0; y < height_; ++y)
      for (int x = 0; x < width_; ++x) {
        glm::vec3 raw(0.0f), fmf(0.0f);
        for (uint32_t k = 0; k < k2; ++k) {
          const size_t si = (static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x)) * k2 + k;
          const bool hit = rays_[si].material != kMiss;
          raw += hit ? raw_[si] * light_color_ : bg;
          fmf += hit ? fmf_[si] * light_color_ : bg;
        }
        for (int c = 0; c < 3; ++c) ref.raw.at(x, y, c) = raw[c] * inv, ref.fmf_cpu.at(x, y, c) = fmf[c] * inv;
        ref.raw.at(x, y, 3) = 1.0f;
        ref.fmf_cpu.at(x, y, 3) = 1.0f;
      }
    ref.has_gpu_filter = gpu_filter_ok_;
    ref.gpu_filter_note = gpu_filter_note_;
    ref.pixel_material.resize(pixel_rays_.size());
    for (size_t pi = 0; pi < pixel_rays_.size(); ++pi) ref.pixel_material[pi] = pixel_rays_[pi].material;
    if (gpu_filter_ok_) {
      ref.raw_gpu_filter = Image<float>(width_, height_, 4);
      ref.fmf_gpu_filter = Image<float>(width_, height_, 4);
      for (int y = 0; y < height_; ++y)
        for (int x = 0; x < width_; ++x) {
          const size_t pi = static_cast<size_t>(y) * static_cast<size_t>(width_) + static_cast<size_t>(x);
          const bool hit = pixel_rays_[pi].material != kMiss;
          const glm::vec3 raw = hit ? raw_f_[pi] * light_color_ : bg, fmf = hit ? fmf_f_[pi] * light_color_ : bg;
          for (int c = 0; c < 3; ++c) ref.raw_gpu_filter.at(x, y, c) = raw[c], ref.fmf_gpu_filter.at(x, y, c) = fmf[c];
          ref.raw_gpu_filter.at(x, y, 3) = 1.0f;
          ref.fmf_gpu_filter.at(x, y, 3) = 1.0f;
        }
    }
    ref.seconds = seconds_ + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return ref;
  }

 private:
  static constexpr uint32_t kMiss = ~0u;
  struct Ray {
    uint32_t material = kMiss;
    glm::vec2 texcoord{0.0f};
    glm::vec3 light_local{0.0f}, view_local{0.0f};
    float footprint = 0.0f;  ///< pixel rays: max |∂uv/∂x|, |∂uv/∂y| per pixel (uv in [0, 1))
  };
  /// How many chunks a pass over `rays` rays is split into: one per `rays_per_chunk`, 1 to 256.
  static size_t ray_chunks(size_t rays, size_t rays_per_chunk) {
    return std::max<size_t>(1, std::min<size_t>(256, rays / rays_per_chunk));
  }
  /// Calls body(chunk, i, comps) on the thread pool for every ray i of `rays` that hit material
  /// `material`; the rays are split into `chunks` contiguous chunks (chunk < chunks indexes the
  /// caller's per-chunk outputs), `comps` is a per-thread scratch of kMaxComponents floats.
  template <class Body>
  static void for_material_rays(const std::vector<Ray>& rays, uint32_t material, size_t chunks, Body&& body) {
    const size_t n = rays.size();
    default_thread_pool().parallel_for(0, chunks, 1, [&](size_t c0, size_t c1) {
      float comps[CpuFrameRenderer::kMaxComponents];
      for (size_t c = c0; c < c1; ++c)
        for (size_t i = n * c / chunks; i < n * (c + 1) / chunks; ++i)
          if (rays[i].material == material) body(c, i, comps);
    });
  }
  /// One ray through `m`'s FMF (paper 000 eq. 5): its angular taps into `s`, V′ bilinear over
  /// the virtual texture (the material repeated, wrapped) into `comps`, and the four texels and
  /// weights it read. Returns the radiance before the light colour.
  static glm::vec3 shade_ray(const DemoMaterial& m, const Ray& r, detail_raw::Sample& s, float* comps, int xs[2],
                             int ys[2], float wx[2], float wy[2]) {
    detail_raw::lookup(m, 0, r.light_local, s.light);
    detail_raw::lookup(m, 1, r.view_local, s.view);
    const Image<float>& v = m.eigen_textures;
    const float fx = r.texcoord.x * static_cast<float>(v.width()) - 0.5f;
    const float fy = r.texcoord.y * static_cast<float>(v.height()) - 0.5f;
    const int x0 = static_cast<int>(std::floor(fx)), y0 = static_cast<int>(std::floor(fy));
    const float ax = fx - static_cast<float>(x0), ay = fy - static_cast<float>(y0);
    const auto wrap = [](int i, int k) { return ((i % k) + k) % k; };
    xs[0] = wrap(x0, v.width()), xs[1] = wrap(x0 + 1, v.width());
    ys[0] = wrap(y0, v.height()), ys[1] = wrap(y0 + 1, v.height());
    wx[0] = 1.0f - ax, wx[1] = ax, wy[0] = 1.0f - ay, wy[1] = ay;
    for (int k = 0; k < v.channels() && k < static_cast<int>(CpuFrameRenderer::kMaxComponents); ++k) {
      const float top = v.at(xs[0], ys[0], k) * wx[0] + v.at(xs[1], ys[0], k) * wx[1];
      const float bot = v.at(xs[0], ys[1], k) * wx[0] + v.at(xs[1], ys[1], k) * wx[1];
      comps[k] = top * wy[0] + bot * wy[1];
    }
    return shade_fmf(m.eigen, s.light, s.view, std::span<const float>(comps, m.components));
  }
  std::chrono::steady_clock::time_point t_start_;
  uint32_t ssn_ = 1;
  int width_ = 0, height_ = 0;
  glm::vec3 light_color_{1.0f};
  std::vector<Ray> rays_;
  std::vector<glm::vec3> raw_, fmf_;  ///< per ray: raw BTF and FMF radiance before the light colour
  std::vector<Ray> pixel_rays_;       ///< one per pixel centre, with its footprint (GPU-filter-matched)
  std::vector<glm::vec3> raw_f_, fmf_f_;
  bool gpu_filter_ok_ = true;
  std::string gpu_filter_note_;
  std::vector<uint8_t> added_;
  uint64_t bytes_read_ = 0;
  double seconds_ = 0;
};

/// Renders the raw and FMF references of `view` at once (RawReferenceBuilder over every
/// material). `materials[i].store_path` must name a complete store of material i's BTF. Returns
/// the store's errors (named) and unsupported for C above CpuFrameRenderer::kMaxComponents.
/// Allocates; uses the default thread pool for the rays.
inline Result<RawReference> render_raw_reference(const std::vector<DemoMaterial>& materials, const scene::View& view,
                                                 uint32_t supersample) {
  auto b = RawReferenceBuilder::cast(static_cast<uint32_t>(materials.size()), view, supersample);
  if (!b) return b.error();
  for (size_t i = 0; i < materials.size(); ++i)
    if (auto r = b->add_material(static_cast<uint32_t>(i), materials[i]); !r) return r.error();
  return b->finish();
}

}  // namespace btflod::demo
