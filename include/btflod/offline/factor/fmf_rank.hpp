// btflod — choosing the FMF rank C from what a viewer sees instead of fixing it.
//
// The relative Frobenius error of paper 000 eq. 4 does not say what a rendering looks like (a
// glossy material can have the smallest error and the worst image: docs/fidelity.md). Here the
// rank is chosen from displayed images: for a (view, light) pair of the measured BTF, its W × H
// RGB image times an exposure, clamped to [0, 1] and sRGB-encoded as a display shows it, against
// the same image of the factorisation (decoded, core/value_transform.hpp), by mean SSIM.
//
// The views are split in two: the rank is chosen on the training views (even view indices) and
// reported on the held-out views (odd indices), so the target is met on views the choice did not
// see. One factorisation at the largest candidate rank serves every candidate: truncating U and
// V·Σ to their first C columns is the best rank-C approximation of the encoded matrix for an
// exact SVD (Eckart–Young) and within the randomised SVD's tolerance otherwise (offline/factor/fmf.hpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "btflod/core/color.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"

namespace btflod {

/// Options of choose_fmf_rank().
struct FmfRankOptions {
  /// The factorisation (its `components` is ignored: the largest candidate is used).
  FmfOptions fmf{};
  /// Ranks to try, ascending; the first whose training-view SSIM reaches `min_ssim` is chosen.
  std::vector<int> candidates{4, 8, 12, 16, 24, 32};
  /// Target: mean SSIM of the displayed images of the training views (every light).
  double min_ssim = 0.95;
  /// Display exposure applied before clamping (the demo's light is about 2.1).
  float exposure = 1.0f;
};

/// One candidate rank and its displayed-image SSIM on both view sets.
struct FmfRankPoint {
  int components = 0;
  double training_ssim = 0.0;  ///< even view indices, every light
  double held_out_ssim = 0.0;  ///< odd view indices, every light
};

/// What choose_fmf_rank() found.
struct FmfRankChoice {
  Fmf fmf;                          ///< truncated to the chosen rank
  int components = 0;               ///< the chosen rank
  bool target_met = false;          ///< false: no candidate reached the target (the largest is returned)
  std::vector<FmfRankPoint> curve;  ///< every candidate tried, in order (up to the chosen one)
};

/// The first `components` components of an FMF: U's and V·Σ's leading columns, the ambient
/// table's, the singular values. Precondition: 0 < components ≤ f.components. Allocates.
inline Fmf truncate_fmf(const Fmf& f, int components) {
  Fmf out;
  out.shape = f.shape;
  out.transform = f.transform;
  out.components = components;
  const size_t from = static_cast<size_t>(f.components), to = static_cast<size_t>(components);
  const auto take = [&](const std::vector<float>& in, std::vector<float>& dst) {
    const size_t rows = in.size() / from;
    dst.resize(rows * to);
    for (size_t r = 0; r < rows; ++r) std::copy_n(in.data() + r * from, to, dst.data() + r * to);
  };
  take(f.u, out.u);
  take(f.v, out.v);
  take(f.u_ambient, out.u_ambient);
  out.singular_values.assign(f.singular_values.begin(),
                             f.singular_values.begin() + std::min(f.singular_values.size(), to));
  out.svd_report = f.svd_report;
  return out;
}

/// Mean SSIM between the displayed images of `btf` and of `f` (same shape) over the views
/// first_view, first_view + view_step, … and every light (0, 2: the training views; 1, 2: the
/// held-out ones; 0, 1: all). Precondition: view_step ≥ 1. Allocates two images.
inline double fmf_displayed_ssim(const BtfFloat& btf, const Fmf& f, uint32_t first_view, uint32_t view_step,
                                 float exposure) {
  const int w = btf.width(), h = btf.height();
  Image<float> a(w, h, 3), b(w, h, 3);
  const auto display = [exposure](float x) { return linear_to_srgb(std::clamp(exposure * x, 0.0f, 1.0f)); };
  double sum = 0.0;
  size_t n = 0;
  for (uint32_t v = first_view; v < btf.view_count(); v += view_step)
    for (uint32_t l = 0; l < btf.light_count(); ++l) {
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const glm::vec3 r = f.evaluate_measured(x, y, v, l);
          for (int c = 0; c < 3; ++c) {
            a.at(x, y, c) = display(btf.at(x, y, v, l, c));
            b.at(x, y, c) = display(r[c]);
          }
        }
      sum += mean_ssim(a.view(), b.view());
      ++n;
    }
  return n ? sum / static_cast<double>(n) : 0.0;
}

/// Factorises `btf` once at the largest candidate rank and returns the smallest candidate rank
/// whose displayed images of the training views reach options.min_ssim (or the largest, with
/// target_met = false), truncated to it, with the SSIM of every candidate tried on the training
/// and the held-out views. Errors: invalid_argument (no candidates, a rank ≤ 0 or not ascending,
/// fewer than 2 views, a target outside (0, 1]), and factorize_fmf()'s. Allocates; O(candidates ×
/// samples) besides the factorisation.
inline Result<FmfRankChoice> choose_fmf_rank(const BtfFloat& btf, const FmfRankOptions& options,
                                             const ProgressCallback& progress = {}) {
  if (options.candidates.empty() || options.candidates.front() <= 0 ||
      !std::is_sorted(options.candidates.begin(), options.candidates.end()) ||
      std::adjacent_find(options.candidates.begin(), options.candidates.end()) != options.candidates.end())
    return make_error(Status::invalid_argument, "choose_fmf_rank: candidate ranks must be positive and ascending");
  if (btf.view_count() < 2)
    return make_error(Status::invalid_argument, "choose_fmf_rank: %zu view(s); training and held-out views need 2",
                      btf.view_count());
  if (!(options.min_ssim > 0.0 && options.min_ssim <= 1.0) || !(options.exposure > 0.0f))
    return make_error(Status::invalid_argument, "choose_fmf_rank: target SSIM %g or exposure %g out of range",
                      options.min_ssim, static_cast<double>(options.exposure));
  FmfOptions fo = options.fmf;
  fo.components = options.candidates.back();
  auto full = factorize_fmf(btf, fo, progress);
  if (!full) return full.error();
  FmfRankChoice choice;
  for (int c : options.candidates) {
    const int kept = std::min(c, full->components);
    Fmf f = truncate_fmf(*full, kept);
    FmfRankPoint p{kept, fmf_displayed_ssim(btf, f, 0, 2, options.exposure),
                   fmf_displayed_ssim(btf, f, 1, 2, options.exposure)};
    choice.curve.push_back(p);
    choice.fmf = std::move(f);
    choice.components = kept;
    if (p.training_ssim >= options.min_ssim) {
      choice.target_met = true;
      break;
    }
    if (kept == full->components) break;  // the matrix has no more components
  }
  return choice;
}

}  // namespace btflod
