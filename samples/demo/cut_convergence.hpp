// btflod-demo — frames to converge after a camera cut (--cut): once the flight has settled at
// its last view, the camera cuts to another view of the path and holds it while the Streamer
// streams what that view needs, until streaming is quiet (nothing requested, pending or uploaded
// for 5 frames, at least one vote window). That last frame is the converged image; every frame
// since the cut is compared with it (SSIM of the sRGB-encoded images, offline/metrics/image_metrics.hpp)
// and the figure reported is the first frame from which every later frame stays within
// SSIM 0.99 of it, with the payload bytes received and the seconds spent until then. The link
// is the demo's throttled one (--bandwidth), so bytes and frames are what a viewer would wait.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "btflod/core/image.hpp"
#include "btflod/core/result.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"
#include "stream_render.hpp"

namespace btflod::demo {

/// What --cut measured.
struct CutConvergence {
  bool done = false;
  uint32_t from_view = 0, to_view = 0;  ///< camera path positions before and after the cut
  double threshold = 0.99;              ///< SSIM to the converged frame
  uint32_t frames_run = 0;              ///< frames from the cut until streaming was quiet (or the cap)
  bool quiet = false;                   ///< streaming went quiet within the cap
  uint32_t frames_to_threshold = 0;     ///< first frame (1 = the frame rendered right after the cut) from which
                                        ///< every later frame is within `threshold` of the converged one
  uint64_t bytes_to_threshold = 0;      ///< payload bytes read from the link from the cut until that frame (tiles
                                        ///< read before and still in the Streamer's payload cache cost none)
  uint32_t tiles_to_threshold = 0;      ///< tiles uploaded into the cache from the cut until that frame
  uint64_t bytes_to_quiet = 0;          ///< … until the converged frame
  double seconds_to_threshold = 0;      ///< wall time from the cut until that frame
  double first_ssim = 0;                ///< the frame right after the cut vs the converged frame
  std::vector<double> ssim;             ///< per frame since the cut, vs the converged frame
};

/// Runs the cut on `streamer` (its flight and settle done): `frames` frames of path, first
/// frame number `first_frame`, camera at path position `to_view` after the cut (from
/// `from_view`), at most `max_frames` frames; `bytes_before_cut`: the payload bytes received
/// before it (the last frame's FrameRecord::bytes_received). Sleeps 20 ms per frame, as the settle does, so
/// the throttled link delivers in step with the frames.
inline Result<CutConvergence> measure_cut_convergence(StreamingRenderer& streamer, uint32_t first_frame,
                                                      uint32_t from_view, uint32_t to_view, uint32_t frames,
                                                      uint32_t max_frames, uint64_t bytes_before_cut,
                                                      Image<float>& bsvtf, Image<float>& fmf) {
  if (max_frames == 0) return make_error(Status::invalid_argument, "--cut: no frame to run");
  CutConvergence c;
  c.from_view = from_view;
  c.to_view = to_view;
  const uint32_t vote_window = streamer.vote_window_frames();
  std::vector<Image<float>> shown;  // sRGB-encoded, one per frame since the cut
  std::vector<uint64_t> bytes;
  std::vector<uint32_t> tiles;
  std::vector<double> seconds;
  const auto t0 = std::chrono::steady_clock::now();
  uint32_t quiet_frames = 0;
  for (uint32_t k = 0; k < max_frames; ++k) {
    auto rec = streamer.frame(first_frame + k, to_view, frames, bsvtf, fmf);
    if (!rec) return rec.error();
    shown.push_back(to_display(bsvtf));
    bytes.push_back(rec->bytes_received - bytes_before_cut);
    tiles.push_back((tiles.empty() ? 0u : tiles.back()) + rec->uploads);
    seconds.push_back(ms_since(t0) / 1000.0);
    quiet_frames = rec->requests == 0 && rec->uploads == 0 && streamer.pending_tiles() == 0 ? quiet_frames + 1 : 0;
    if (quiet_frames >= 5 && k + 1 >= vote_window) {
      c.quiet = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  c.frames_run = static_cast<uint32_t>(shown.size());
  const Image<float>& converged = shown.back();
  c.ssim.resize(shown.size());
  for (size_t i = 0; i < shown.size(); ++i) c.ssim[i] = mean_ssim(shown[i].view(), converged.view());
  size_t first_within = shown.size() - 1;  // the converged frame itself is within
  while (first_within > 0 && c.ssim[first_within - 1] >= c.threshold) --first_within;
  c.frames_to_threshold = static_cast<uint32_t>(first_within + 1);
  c.bytes_to_threshold = bytes[first_within];
  c.tiles_to_threshold = tiles[first_within];
  c.bytes_to_quiet = bytes.back();
  c.seconds_to_threshold = seconds[first_within];
  c.first_ssim = c.ssim.front();
  c.done = true;
  return c;
}

}  // namespace btflod::demo
