// btflod — BTFs stored as sets of OpenEXR images (HDR, linear RGB), the form in which Bonn's
// btflib reads measured image sets: one file per (view, light) pair named
//   "tv{θv}_pv{φv}_tl{θl}_pl{φl}.exr"                   (btflib's naming)
//   "<prefix>00008_tl000_pl000_tv030_pv030.exr"          (the UBO2003 naming of ubo2003_folder.hpp)
// Angles are parsed wherever they appear in the path (parse_ubo_image_path), so per-view folders
// and other spellings work as for the PNG/JPEG folders; direction sets, size limits and errors
// are those of read_ubo2003_folder() (the two share read_angle_image_set()).
//
// Images hold R, G and B channels of type HALF or FLOAT (any compression OpenEXR reads); values
// are linear and read as they are (no transfer curve). Decoding goes through OpenEXR's C++
// library (Debian libopenexr-dev 3.1) from memory (an Imf::IStream over the file's bytes), with
// every OpenEXR exception turned into a Result.
//
// This header needs OpenEXR: it is available when btflod is configured with
// BTFLOD_WITH_OPENEXR=ON (the default when CMake finds OpenEXR), which links OpenEXR::OpenEXR
// through the btflod target and defines BTFLOD_WITH_OPENEXR=1. No other btflod header includes
// it, so programs that do not read EXR sets never see OpenEXR's headers.
#pragma once

#if !defined(BTFLOD_WITH_OPENEXR) || !BTFLOD_WITH_OPENEXR
#error \
    "btflod/offline/btf/openexr_image_set.hpp needs OpenEXR: configure btflod with -DBTFLOD_WITH_OPENEXR=ON (Debian: libopenexr-dev)"
#endif

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <filesystem>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfVersion.h>

#include "btflod/core/enum_names.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/image.hpp"
#include "btflod/core/result.hpp"
#include "btflod/offline/btf/image_io.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/btf/ubo2003_folder.hpp"

namespace btflod {

/// Channel type written by encode_exr() / write_exr_image_set().
enum class ExrPixelType : uint8_t { half, float32 };
/// File naming written by write_exr_image_set().
enum class ExrNaming : uint8_t {
  btflib,   ///< "tv030_pv060_tl015_pl000.exr" (Bonn btflib)
  ubo2003,  ///< "<prefix>00008_tl015_pl000_tv030_pv060.exr"
};

namespace detail {

/// An OpenEXR input stream over bytes in memory; reading past the end throws (OpenEXR's
/// contract), which decode_exr() turns into short_output.
class ExrMemoryIStream final : public Imf::IStream {
 public:
  explicit ExrMemoryIStream(std::span<const uint8_t> bytes) : Imf::IStream("memory"), bytes_(bytes) {}
  bool read(char c[], int n) override {
    if (n < 0 || static_cast<uint64_t>(n) > bytes_.size() - pos_) {
      truncated_ = true;
      throw std::out_of_range("EXR data ends early");
    }
    if (n > 0) std::memcpy(c, bytes_.data() + pos_, static_cast<size_t>(n));
    pos_ += static_cast<uint64_t>(n);
    return pos_ < bytes_.size();
  }
  uint64_t tellg() override { return pos_; }
  void seekg(uint64_t pos) override { pos_ = std::min<uint64_t>(pos, bytes_.size()); }
  bool truncated() const noexcept { return truncated_; }

 private:
  std::span<const uint8_t> bytes_;
  uint64_t pos_ = 0;
  bool truncated_ = false;
};

/// An OpenEXR output stream into a growing byte vector.
class ExrMemoryOStream final : public Imf::OStream {
 public:
  ExrMemoryOStream() : Imf::OStream("memory") {}
  void write(const char c[], int n) override {
    if (n <= 0) return;
    if (pos_ + static_cast<uint64_t>(n) > bytes_.size()) bytes_.resize(pos_ + static_cast<uint64_t>(n));
    std::memcpy(bytes_.data() + pos_, c, static_cast<size_t>(n));
    pos_ += static_cast<uint64_t>(n);
  }
  uint64_t tellp() override { return pos_; }
  void seekp(uint64_t pos) override { pos_ = pos; }
  std::vector<uint8_t> take() { return std::move(bytes_); }

 private:
  std::vector<uint8_t> bytes_;
  uint64_t pos_ = 0;
};

/// OpenEXR refuses to even allocate line buffers for images larger than this (its global
/// limit, set once to btflod's image dimension limit); per-call ImageLimits are checked after.
inline void exr_set_global_limits() {
  static std::once_flag once;
  std::call_once(once, [] {
    Imf::Header::setMaxImageSize(kMaxImageDimension, kMaxImageDimension);
    Imf::Header::setMaxTileSize(kMaxImageDimension, kMaxImageDimension);
  });
}

/// Walks the attribute list of a single-part header (name NUL, type NUL, u32 size, value; an
/// empty name ends it) without allocating. OpenEXR allocates each attribute's declared size
/// before reading its value, so without this check a hostile size (up to 4 GiB) is allocated,
/// and then the read fails. Returns nullptr when every attribute fits in `bytes`, else a static
/// description; `truncated` then says whether the bytes simply end too early. Untrusted input.
inline const char* exr_scan_attributes(std::span<const uint8_t> bytes, bool& truncated) noexcept {
  size_t p = 8;
  truncated = true;
  auto skip_string = [&]() -> const char* {  // a NUL-terminated name of at most 255 bytes
    const size_t start = p;
    while (p < bytes.size() && bytes[p] != 0) {
      if (p - start >= 255) {
        truncated = false;
        return "an attribute name or type is longer than 255 bytes";
      }
      ++p;
    }
    if (p >= bytes.size()) return "the header ends inside an attribute name";
    ++p;
    return nullptr;
  };
  for (;;) {
    if (p >= bytes.size()) return "the header ends before its terminating byte";
    if (bytes[p] == 0) return nullptr;  // end of the header
    if (const char* why = skip_string()) return why;
    if (const char* why = skip_string()) return why;
    if (bytes.size() - p < 4) return "the header ends inside an attribute size";
    uint32_t size = 0;
    std::memcpy(&size, bytes.data() + p, 4);
    p += 4;
    if (size > bytes.size() - p) return "an attribute declares more bytes than the file holds";
    p += size;
  }
}

inline const char* exr_pixel_type_name(Imf::PixelType t) {
  static constexpr const char* kNames[] = {"UINT", "HALF", "FLOAT"};  // Imf::PixelType order
  return enum_value_name<Imf::FLOAT>(t, kNames);
}

/// Runs `body` (a callable returning a Result) and turns an exception OpenEXR throws while
/// reading `stream` into its error: short_output "exr: truncated input: <ends_early>" when the
/// stream ran out of bytes, else bad_data "exr: <failure>: <exception text>" ("exr: <failure>"
/// for an exception not derived from std::exception).
template <class Body>
auto exr_read_guarded(const ExrMemoryIStream& stream, const char* ends_early, const char* failure, Body&& body)
    -> decltype(body()) {
  try {
    return body();
  } catch (const std::exception& e) {
    if (stream.truncated()) return make_error(Status::short_output, "exr: truncated input: %s", ends_early);
    return make_error(Status::bad_data, "exr: %s: %s", failure, e.what());
  } catch (...) {
    return make_error(Status::bad_data, "exr: %s", failure);
  }
}
}  // namespace detail

/// Size and channel types of an EXR file held in memory, read from its header only.
struct ExrInfo {
  int width = 0;
  int height = 0;
  bool rgb_half = false;  ///< R, G, B are HALF (else FLOAT)
};

/// Reads the header of an OpenEXR file in memory. Returns, with a message naming the problem:
/// short_output when the bytes end inside the header (an attribute declaring more bytes than
/// remain included: checked before OpenEXR allocates it); bad_data for a file that is not
/// OpenEXR (wrong magic number), a multi-part or deep file, a header OpenEXR rejects, missing R,
/// G or B channels, channel types other than HALF/FLOAT, or subsampled channels;
/// insufficient_space when the data window exceeds `limits`. Safe on untrusted bytes (OpenEXR's
/// exceptions are caught). Thread-safe.
inline Result<ExrInfo> probe_exr(std::span<const uint8_t> bytes, const ImageLimits& limits = {}) {
  detail::exr_set_global_limits();
  if (bytes.size() < 8)
    return make_error(Status::short_output, "exr: truncated input: %zu bytes, the magic number and version need 8",
                      bytes.size());
  int magic = 0, version = 0;
  std::memcpy(&magic, bytes.data(), 4);
  std::memcpy(&version, bytes.data() + 4, 4);
  if (magic != Imf::MAGIC) return make_error(Status::bad_data, "exr: not an OpenEXR file (wrong magic number)");
  if (Imf::isMultiPart(version) || Imf::isNonImage(version))
    return make_error(Status::bad_data, "exr: multi-part or deep OpenEXR files are not image sets (version flags 0x%x)",
                      static_cast<unsigned>(version) & ~0xffu);
  bool truncated = false;
  if (const char* why = detail::exr_scan_attributes(bytes, truncated))
    return make_error(truncated ? Status::short_output : Status::bad_data, "exr: %s%s",
                      truncated ? "truncated input: " : "", why);
  detail::ExrMemoryIStream stream(bytes);
  return detail::exr_read_guarded(stream, "the header ends early", "bad header", [&]() -> Result<ExrInfo> {
    Imf::Header header;
    stream.seekg(8);
    header.readFrom(stream, version);
    header.sanityCheck(Imf::isTiled(version));
    const Imath::Box2i dw = header.dataWindow();
    const int64_t w = int64_t{dw.max.x} - dw.min.x + 1, h = int64_t{dw.max.y} - dw.min.y + 1;
    if (w <= 0 || h <= 0)
      return make_error(Status::bad_data, "exr: empty data window (%lld x %lld)", (long long)w, (long long)h);
    if (w > limits.max_width || h > limits.max_height ||
        static_cast<uint64_t>(w) * static_cast<uint64_t>(h) > limits.max_pixels)
      return make_error(Status::insufficient_space,
                        "exr: data window %lld x %lld exceeds the limit %dx%d (%llu pixels); refusing to decode",
                        (long long)w, (long long)h, limits.max_width, limits.max_height,
                        static_cast<unsigned long long>(limits.max_pixels));
    ExrInfo info;
    info.width = static_cast<int>(w);
    info.height = static_cast<int>(h);
    const Imf::ChannelList& channels = header.channels();
    std::string present;
    for (auto it = channels.begin(); it != channels.end(); ++it)
      present += std::string(present.empty() ? "" : ", ") + it.name();
    int halves = 0;
    for (const char* name : {"R", "G", "B"}) {
      const Imf::Channel* c = channels.findChannel(name);
      if (!c)
        return make_error(Status::bad_data, "exr: no %s channel (channels: %s); expected R, G and B", name,
                          present.empty() ? "none" : present.c_str());
      if (c->type != Imf::HALF && c->type != Imf::FLOAT)
        return make_error(Status::bad_data, "exr: channel %s is %s, expected HALF or FLOAT", name,
                          detail::exr_pixel_type_name(c->type));
      if (c->xSampling != 1 || c->ySampling != 1)
        return make_error(Status::bad_data, "exr: channel %s is subsampled (%d x %d); expected full resolution", name,
                          c->xSampling, c->ySampling);
      halves += c->type == Imf::HALF;
    }
    info.rgb_half = halves == 3;
    return info;
  });
}

/// Decodes an OpenEXR file in memory into a width × height × 3 linear float image (R, G, B;
/// HALF channels are widened exactly). Errors as probe_exr(), plus short_output when the pixel
/// data ends early, bad_data for pixel data OpenEXR cannot decode or a NaN/infinite sample
/// (named by pixel and channel). Safe on untrusted bytes. Thread-safe.
inline Result<Image<float>> decode_exr(std::span<const uint8_t> bytes, const ImageLimits& limits = {}) {
  auto info = probe_exr(bytes, limits);
  if (!info) return info.error();
  detail::ExrMemoryIStream stream(bytes);
  return detail::exr_read_guarded(
      stream, "pixel data ends early", "cannot decode the pixels", [&]() -> Result<Image<float>> {
        Imf::InputFile file(stream);
        const Imath::Box2i dw = file.header().dataWindow();
        Image<float> out(info->width, info->height, 3);
        Imf::FrameBuffer fb;
        const size_t xs = 3 * sizeof(float), ys = xs * static_cast<size_t>(info->width);
        const char* names[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; ++c) fb.insert(names[c], Imf::Slice::Make(Imf::FLOAT, out.data() + c, dw, xs, ys));
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        if (!file.isComplete() || stream.truncated())
          return make_error(Status::short_output, "exr: truncated input: pixel data ends early");
        const float* p = out.data();
        for (size_t i = 0; i < out.size(); ++i)
          if (!std::isfinite(p[i]))
            return make_error(Status::bad_data, "exr: pixel (%zu, %zu) channel %s is %s, expected a finite value",
                              (i / 3) % static_cast<size_t>(info->width), (i / 3) / static_cast<size_t>(info->width),
                              names[i % 3], std::isnan(p[i]) ? "NaN" : "infinite");
        return out;
      });
}

/// Encodes a 3-channel linear float image as a scanline OpenEXR file (R, G, B; ZIP compression)
/// with HALF or FLOAT channels. Returns invalid_argument for an empty image or a channel count
/// other than 3; io_error if OpenEXR fails. Thread-safe.
inline Result<std::vector<uint8_t>> encode_exr(ImageView<const float> image, ExrPixelType type = ExrPixelType::half) {
  if (image.width() <= 0 || image.height() <= 0 || image.channels() != 3)
    return make_error(Status::invalid_argument, "encode_exr: image is %dx%d with %d channels, expected 3 channels",
                      image.width(), image.height(), image.channels());
  detail::exr_set_global_limits();
  try {
    Imf::Header header(image.width(), image.height());
    header.compression() = Imf::ZIP_COMPRESSION;
    const Imf::PixelType pt = type == ExrPixelType::half ? Imf::HALF : Imf::FLOAT;
    const char* names[3] = {"R", "G", "B"};
    for (const char* n : names) header.channels().insert(n, Imf::Channel(pt));
    // OpenEXR's writer needs the frame buffer in the channels' type: a dense copy as halves
    // (IEEE binary16 bits, core/half.hpp) or floats.
    const size_t count = static_cast<size_t>(image.width()) * static_cast<size_t>(image.height()) * 3;
    std::vector<uint16_t> halves(type == ExrPixelType::half ? count : 0);
    std::vector<float> floats(type == ExrPixelType::float32 ? count : 0);
    for (int y = 0, i = 0; y < image.height(); ++y)
      for (int x = 0; x < image.width(); ++x)
        for (int c = 0; c < 3; ++c, ++i) {
          const float v = image.at(x, y, c);
          if (type == ExrPixelType::half) {
            halves[static_cast<size_t>(i)] = float_to_half_bits(v);
          } else {
            floats[static_cast<size_t>(i)] = v;
          }
        }
    char* base =
        type == ExrPixelType::half ? reinterpret_cast<char*>(halves.data()) : reinterpret_cast<char*>(floats.data());
    const size_t elem = type == ExrPixelType::half ? sizeof(uint16_t) : sizeof(float);
    detail::ExrMemoryOStream stream;
    {
      Imf::OutputFile file(stream, header);
      Imf::FrameBuffer fb;
      for (int c = 0; c < 3; ++c)
        fb.insert(names[c], Imf::Slice(pt, base + static_cast<size_t>(c) * elem, 3 * elem,
                                       3 * elem * static_cast<size_t>(image.width())));
      file.setFrameBuffer(fb);
      file.writePixels(image.height());
    }
    return stream.take();
  } catch (const std::exception& e) {
    return make_error(Status::io_error, "encode_exr: OpenEXR failed: %s", e.what());
  }
}

/// The codec read_angle_image_set() uses for OpenEXR sets (files ending in .exr, any case).
inline AngleImageCodec exr_image_codec() {
  AngleImageCodec c;
  c.kind = "OpenEXR";
  c.accepts = [](const std::filesystem::path& p) {
    std::string ext = p.extension().string();
    for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return ext == ".exr";
  };
  c.probe = [](const std::string& path, const ImageLimits& limits) -> Result<ImageInfo> {
    auto info = detail::parse_image_file(path, limits,
                                         [&](std::span<const uint8_t> bytes) { return probe_exr(bytes, limits); });
    if (!info) return info.error();
    ImageInfo out;
    out.width = info->width;
    out.height = info->height;
    out.channels = 3;
    return out;
  };
  c.decode = [](const std::string& path, const ImageLimits& limits, int width, int height, float* dst) -> VoidResult {
    auto img = detail::parse_image_file(path, limits,
                                        [&](std::span<const uint8_t> bytes) { return decode_exr(bytes, limits); });
    if (!img) return img.error();
    if (img->width() != width || img->height() != height)
      return make_error(Status::bad_data, "%s: image is %dx%d, expected %dx%d; all images must have one size",
                        path.c_str(), img->width(), img->height(), width, height);
    std::memcpy(dst, img->data(), img->size() * sizeof(float));
    return {};
  };
  return c;
}

/// Reads a BTF stored as a folder of OpenEXR images named with tl/pl/tv/pv angles (btflib's
/// "tv030_pv060_tl015_pl000.exr", the UBO2003 naming, per-view folders; see
/// ubo2003_folder.hpp). Returns, with a message naming the files involved: io_error when the
/// folder or a file cannot be read; bad_data for names that do not parse, directions outside
/// the chosen set, duplicates, missing (view, light) pairs, images of differing sizes, files
/// OpenEXR cannot decode, missing R/G/B channels and NaN/Inf samples; short_output for a
/// truncated file; insufficient_space beyond options.image_limits / max_samples. Files that are
/// not .exr are skipped and listed in warnings. Decodes in parallel on the pool; deterministic.
/// Safe on untrusted folders.
inline Result<Ubo2003Folder> read_exr_image_set(const std::filesystem::path& root,
                                                const Ubo2003ReadOptions& options = {}) {
  return read_angle_image_set(root, exr_image_codec(), options);
}

/// Options of write_exr_image_set().
struct ExrImageSetWriteOptions {
  ExrNaming naming = ExrNaming::btflib;
  ExrPixelType pixel_type = ExrPixelType::half;
  /// Text before the running number of UBO2003 names (e.g. a material name).
  std::string prefix;
};

/// Writes every (view, light) image of a BTF as an OpenEXR file (linear values as they are,
/// HALF or FLOAT channels) named so that read_exr_image_set() and btflib parse the angles:
/// degrees, φ in [0, 360), whole angles as "%03d", fractional ones with one decimal. Creates
/// `dir` when missing; files with the same names are replaced. Returns invalid_argument for an
/// empty BTF, io_error naming the file that failed. Not thread-safe for the same folder.
inline VoidResult write_exr_image_set(const BtfFloat& btf, const std::filesystem::path& dir,
                                      const ExrImageSetWriteOptions& options = {}) {
  namespace fs = std::filesystem;
  if (btf.empty()) return make_error(Status::invalid_argument, "%s: empty BTF", dir.string().c_str());
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return make_error(Status::io_error, "%s: cannot create: %s", dir.string().c_str(), ec.message().c_str());
  size_t counter = 0;
  for (size_t v = 0; v < btf.view_count(); ++v) {
    const std::string tv = "tv" + detail::ubo_format_angle(btf.views()[v].theta, false);
    const std::string pv = "pv" + detail::ubo_format_angle(btf.views()[v].phi, true);
    for (size_t l = 0; l < btf.light_count(); ++l, ++counter) {
      const std::string tl = "tl" + detail::ubo_format_angle(btf.lights()[l].theta, false);
      const std::string pl = "pl" + detail::ubo_format_angle(btf.lights()[l].phi, true);
      const std::string name =
          options.naming == ExrNaming::btflib
              ? tv + "_" + pv + "_" + tl + "_" + pl + ".exr"
              : options.prefix + format_message("%05zu", counter) + "_" + tl + "_" + pl + "_" + tv + "_" + pv + ".exr";
      auto bytes = encode_exr(btf.image(v, l), options.pixel_type);
      const std::string path = (dir / name).string();
      if (!bytes) return Error{bytes.status(), path + ": " + bytes.message()};
      if (auto w = write_file_bytes(path, *bytes); !w) return w;
    }
  }
  return {};
}

}  // namespace btflod
