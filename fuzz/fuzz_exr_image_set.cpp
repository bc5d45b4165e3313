// libFuzzer target for offline/btf/openexr_image_set.hpp: probe_exr and decode_exr (the per-image step
// of read_exr_image_set, reading from memory through an Imf::IStream) must never crash, hang,
// leak or read out of bounds on any input; every rejection explains itself, and an accepted
// image has the probed size and only finite samples.
//
// Speed: decode_exr probes the header itself (a rejection by probe_exr is its rejection, with
// probe_exr's message), so the target calls probe_exr again only for an accepted image, to
// compare the sizes: one header parse per rejected input instead of two.
// btflod-link: OpenEXR::OpenEXR
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#if defined(BTFLOD_WITH_OPENEXR) && BTFLOD_WITH_OPENEXR
#include "btflod/offline/btf/openexr_image_set.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  btflod::ImageLimits limits;  // small: hostile headers must be refused before allocating
  limits.max_width = 512;
  limits.max_height = 512;
  limits.max_pixels = 1 << 16;
  const std::span<const uint8_t> bytes(data, size);
  auto img = btflod::decode_exr(bytes, limits);
  if (!img.ok()) {
    if (img.message().empty()) std::abort();
    return 0;
  }
  auto info = btflod::probe_exr(bytes, limits);
  if (!info.ok() || img->width() != info->width || img->height() != info->height || img->channels() != 3) std::abort();
  for (size_t i = 0; i < img->size(); ++i)
    if (!std::isfinite(img->data()[i])) std::abort();
  return 0;
}
#else
extern "C" int LLVMFuzzerTestOneInput(const uint8_t*, size_t) { return 0; }
#endif
