// btflod — BTFs stored as folders of images (the Bonn UBO2003 distribution and its variants).
//
// Each (view, light) image is one 8-bit sRGB JPEG or PNG file whose name carries the angles in
// degrees as keys: tl/pl (light θ/φ) and tv/pv (view θ/φ). Spellings seen in the wild:
//   "00008 tl000 pl000 tv030 pv030.jpg"
//   "WoolPKNT256_00084_tl015_pl000_tv015_pv120.jpg"
//   "tv030_pv060/tl000_pl000_tv030_pv060.png"      (per-view folders)
//   "tv030_pv060/tl015_pl000.png"                   (view keys only in the folder name)
// The parser finds the keys wherever they are (never at fixed offsets): a key is "tl", "pl",
// "tv" or "pv" (any case) at the start of the text or after a non-alphanumeric character,
// optionally followed by '=' or ':', then a decimal number ("015", "23.5", "-7.5"), then the
// end of the text or a non-alphanumeric character. Keys from the folder names (relative to the
// BTF's root folder) and the file name are merged; a key given twice must agree.
//
// Angles map to a DirectionSet (UBO2003, UBO2014, one given by the caller, or one built from
// the angles found) with DirectionSet::find_degrees; images are decoded by offline/btf/image_io.hpp
// and linearised into a BtfFloat.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "btflod/core/color.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/progress.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/thread_pool.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/btf/image_io.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/math/math.hpp"

namespace btflod {

/// The four angle keys of a UBO image name, in degrees, and which of them were present.
struct UboAngleKeys {
  enum Key : int { tl = 0, pl = 1, tv = 2, pv = 3 };
  std::array<float, 4> degrees{0.0f, 0.0f, 0.0f, 0.0f};
  std::array<bool, 4> present{false, false, false, false};

  bool complete() const noexcept { return present[0] && present[1] && present[2] && present[3]; }
  bool any() const noexcept { return present[0] || present[1] || present[2] || present[3]; }
  /// "tl pl" style list of the keys that are missing (empty when complete).
  std::string missing() const {
    static const char* names[4] = {"tl", "pl", "tv", "pv"};
    std::string out;
    for (int k = 0; k < 4; ++k) {
      if (present[k]) continue;
      if (!out.empty()) out.push_back(' ');
      out.append(names[k]);
    }
    return out;
  }
};

namespace detail {

inline bool ubo_is_alnum(char c) noexcept { return std::isalnum(static_cast<unsigned char>(c)) != 0; }

/// Parses a decimal number at text[i...]: [+-]? digits [. digits]? (at most 12 characters);
/// returns the characters consumed (0 when there is no number).
inline size_t ubo_parse_number(std::string_view text, size_t i, double& value) noexcept {
  size_t j = i;
  bool negative = false;
  if (j < text.size() && (text[j] == '+' || text[j] == '-')) negative = text[j++] == '-';
  double v = 0.0;
  size_t digits = 0;
  while (j < text.size() && std::isdigit(static_cast<unsigned char>(text[j])) && j - i < 12) {
    v = v * 10.0 + (text[j++] - '0');
    ++digits;
  }
  if (digits == 0) return 0;
  if (j + 1 < text.size() && text[j] == '.' && std::isdigit(static_cast<unsigned char>(text[j + 1]))) {
    ++j;
    double scale = 0.1;
    while (j < text.size() && std::isdigit(static_cast<unsigned char>(text[j])) && j - i < 12) {
      v += (text[j++] - '0') * scale;
      scale *= 0.1;
    }
  }
  value = negative ? -v : v;
  return j - i;
}

}  // namespace detail

/// Parses the angle keys out of one name (a file stem or a folder name; any text). Text that is
/// not a key is ignored, so material names and running numbers may appear anywhere.
/// Returns bad_data when a key appears twice with different values or an angle is out of range
/// (θ outside [0, 90], |φ| > 360); the message quotes the text. Keys may be absent (check
/// complete()). Safe on untrusted input (bounded by the text length, no allocation besides the
/// error message). Thread-safe.
inline Result<UboAngleKeys> parse_ubo_angle_keys(std::string_view text) {
  UboAngleKeys keys;
  for (size_t i = 0; i + 1 < text.size(); ++i) {
    if (i > 0 && detail::ubo_is_alnum(text[i - 1])) continue;
    const char a = static_cast<char>(std::tolower(static_cast<unsigned char>(text[i])));
    const char b = static_cast<char>(std::tolower(static_cast<unsigned char>(text[i + 1])));
    int key = -1;
    if (a == 't' && b == 'l')
      key = UboAngleKeys::tl;
    else if (a == 'p' && b == 'l')
      key = UboAngleKeys::pl;
    else if (a == 't' && b == 'v')
      key = UboAngleKeys::tv;
    else if (a == 'p' && b == 'v')
      key = UboAngleKeys::pv;
    if (key < 0) continue;
    size_t j = i + 2;
    if (j < text.size() && (text[j] == '=' || text[j] == ':')) ++j;
    double value = 0.0;
    const size_t n = detail::ubo_parse_number(text, j, value);
    if (n == 0) continue;  // e.g. "plastic": not a key
    j += n;
    if (j < text.size() && detail::ubo_is_alnum(text[j])) continue;  // "tv30x": not a key
    const bool is_theta = key == UboAngleKeys::tl || key == UboAngleKeys::tv;
    if (is_theta ? (value < 0.0 || value > 90.0) : (value < -360.0 || value > 360.0)) {
      return make_error(Status::bad_data, "'%.*s': %.*s = %g is out of range (θ: 0 to 90, φ: -360 to 360 degrees)",
                        static_cast<int>(text.size()), text.data(), 2, text.data() + i, value);
    }
    const auto f = static_cast<float>(value);
    if (keys.present[key] && std::abs(keys.degrees[key] - f) > 1e-4f)
      return make_error(Status::bad_data, "'%.*s': key %.*s appears twice with different values (%g and %g)",
                        static_cast<int>(text.size()), text.data(), 2, text.data() + i,
                        static_cast<double>(keys.degrees[key]), value);
    keys.degrees[key] = f;
    keys.present[key] = true;
    i = j - 1;
  }
  return keys;
}

/// Parses the keys of an image path relative to the BTF folder: every folder name and the file
/// stem (the name without its extension) are parsed with parse_ubo_angle_keys() and merged.
/// Returns bad_data when two components disagree about a key, or when the keys are not
/// complete (the message lists the missing ones). Safe on untrusted input. Thread-safe.
inline Result<UboAngleKeys> parse_ubo_image_path(const std::filesystem::path& relative) {
  UboAngleKeys merged;
  std::vector<std::string> parts;
  for (const auto& part : relative.parent_path()) parts.push_back(part.string());
  parts.push_back(relative.stem().string());
  for (const auto& part : parts) {
    auto keys = parse_ubo_angle_keys(part);
    if (!keys) return keys.error();
    for (int k = 0; k < 4; ++k) {
      if (!keys->present[k]) continue;
      if (merged.present[k] && std::abs(merged.degrees[k] - keys->degrees[k]) > 1e-4f)
        return make_error(Status::bad_data, "'%s': the folder and file names disagree (%g vs %g)",
                          relative.string().c_str(), static_cast<double>(merged.degrees[k]),
                          static_cast<double>(keys->degrees[k]));
      merged.degrees[k] = keys->degrees[k];
      merged.present[k] = true;
    }
  }
  if (!merged.complete())
    return make_error(Status::bad_data, "'%s': cannot parse the angles: missing key(s) %s (expected tl, pl, tv, pv)",
                      relative.string().c_str(), merged.missing().c_str());
  return merged;
}

/// Which direction sets read_ubo2003_folder() maps the angles to.
enum class UboDirections : uint8_t {
  automatic,   ///< UBO2003 when the names hold exactly its 81 light and 81 view directions,
               ///< else UBO2014 likewise (151), else built from the angles found
  ubo2003,     ///< DirectionSet::ubo2003() for lights and views
  ubo2014,     ///< DirectionSet::ubo2014() for lights and views
  from_files,  ///< distinct angles found, sorted by θ then φ in [0, 360)
  custom,      ///< custom_views / custom_lights of the options
};

/// Options of read_ubo2003_folder().
struct Ubo2003ReadOptions {
  UboDirections directions = UboDirections::automatic;
  DirectionSet custom_views;
  DirectionSet custom_lights;
  /// Angle tolerance when matching names to directions (names round to whole degrees).
  float tolerance_deg = 0.6f;
  /// Images whose names do not parse are skipped with a warning instead of failing.
  bool ignore_unparseable_images = false;
  /// Folder depth searched below the root (per-view folders need 1).
  int max_depth = 3;
  /// Limit on the number of directory entries visited (guards against a wrong root).
  size_t max_entries = 200000;
  ImageLimits image_limits;
  /// Largest BTF (W·H·nV·nL·3 floats).
  uint64_t max_samples = uint64_t{1} << 31;
  ProgressCallback progress;
  /// Pool for decoding; null uses default_thread_pool().
  ThreadPool* pool = nullptr;
};

/// A BTF read from an image folder.
struct Ubo2003Folder {
  BtfFloat btf;
  /// Files that were skipped (not images, unparseable names when allowed, too deep).
  std::vector<std::string> warnings;
  /// image_paths[v * n_light + l] is the file (relative to the root) of view v, light l.
  std::vector<std::string> image_paths;
};

namespace detail {

inline bool ubo_is_image_extension(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".jpg" || ext == ".jpeg" || ext == ".png";
}

struct UboEntry {
  std::string relative;  // generic form, '/' separators
  UboAngleKeys keys;
};

/// Distinct (θ, φ) pairs in degrees, deduplicated within tol, sorted by θ then φ in [0, 360).
inline DirectionSet ubo_set_from_angles(std::vector<std::pair<float, float>> deg, float tol, const char* name) {
  for (auto& [t, p] : deg) {
    p = std::fmod(p, 360.0f);
    if (p < 0.0f) p += 360.0f;
    if (t < tol) p = 0.0f;  // the pole: φ is meaningless
  }
  std::sort(deg.begin(), deg.end());
  std::vector<std::pair<float, float>> unique;
  for (const auto& d : deg) {
    bool dup = false;
    for (const auto& u : unique)
      if (std::abs(u.first - d.first) <= tol && std::abs(wrap_degrees_signed(u.second - d.second)) <= tol) {
        dup = true;
        break;
      }
    if (!dup) unique.push_back(d);
  }
  std::vector<std::pair<float, float>> rad;
  rad.reserve(unique.size());
  for (const auto& [t, p] : unique) rad.emplace_back(degrees_to_radians(t), degrees_to_radians(p));
  return DirectionSet::from_radians(name, rad);
}

inline std::string ubo_describe(const DirectionSet& set, size_t i) {
  return format_message("θ=%g φ=%g", std::round(radians_to_degrees(set[i].theta) * 10.0f) / 10.0,
                        std::round(radians_to_degrees(set[i].phi) * 10.0f) / 10.0);
}

}  // namespace detail

/// How an angle-named image set stores its images: which files are images, how to read one's
/// size, and how to decode one into linear RGB floats. read_ubo2003_folder() uses 8-bit sRGB
/// JPEG/PNG; offline/btf/openexr_image_set.hpp uses OpenEXR. Both share everything else (names,
/// direction sets, limits, errors).
struct AngleImageCodec {
  /// Names the accepted files in warnings, e.g. "JPEG/PNG".
  const char* kind = "JPEG/PNG";
  /// True for files of this codec (by extension).
  std::function<bool(const std::filesystem::path&)> accepts;
  /// Size of the image at `path`; errors as probe_image (insufficient_space beyond limits).
  std::function<Result<ImageInfo>(const std::string& path, const ImageLimits& limits)> probe;
  /// Decodes `path` into width × height × 3 linear floats at dst; bad_data when its size is
  /// not width × height. Called concurrently from the pool.
  std::function<VoidResult(const std::string& path, const ImageLimits& limits, int width, int height, float* dst)>
      decode;
};

namespace detail {

/// Reads the file at `path` (at most limits.max_file_bytes) and returns parse(its bytes as a
/// std::span<const uint8_t>), a Result; a failed parse's message is prefixed with "<path>: ".
/// Read failures are returned as read_file_bytes() reports them (they name the path already).
template <class Parse>
auto parse_image_file(const std::string& path, const ImageLimits& limits, Parse&& parse)
    -> decltype(parse(std::span<const uint8_t>{})) {
  auto bytes = read_file_bytes(path, limits.max_file_bytes);
  if (!bytes) return bytes.error();
  auto parsed = parse(std::span<const uint8_t>(*bytes));
  if (!parsed) return Error{parsed.status(), path + ": " + parsed.message()};
  return parsed;
}

inline AngleImageCodec srgb8_image_codec() {
  AngleImageCodec c;
  c.kind = "JPEG/PNG";
  c.accepts = [](const std::filesystem::path& p) { return ubo_is_image_extension(p); };
  c.probe = [](const std::string& path, const ImageLimits& limits) -> Result<ImageInfo> {
    return parse_image_file(path, limits, [&](std::span<const uint8_t> bytes) { return probe_image(bytes, limits); });
  };
  c.decode = [](const std::string& path, const ImageLimits& limits, int width, int height, float* dst) -> VoidResult {
    auto img = load_image(path, 3, limits);
    if (!img) return img.error();
    if (img->width() != width || img->height() != height)
      return make_error(Status::bad_data, "%s: image is %dx%d, expected %dx%d; all images must have one size",
                        path.c_str(), img->width(), img->height(), width, height);
    const float* table = srgb8_to_linear_table();
    const uint8_t* src = img->data();
    for (size_t j = 0; j < img->size(); ++j) dst[j] = table[src[j]];
    return {};
  };
  return c;
}

}  // namespace detail

/// Reads a BTF stored as a set of angle-named images decoded by `codec` (see the header comment
/// for the names). Errors and behaviour as read_ubo2003_folder(), with codec.kind naming the
/// accepted files. Safe on untrusted folders. Thread-safe (no shared state besides the pool).
inline Result<Ubo2003Folder> read_angle_image_set(const std::filesystem::path& root, const AngleImageCodec& codec,
                                                  const Ubo2003ReadOptions& options = {});

/// Reads a BTF stored as a folder of UBO-style images (see the header comment for the names).
/// Returns, with a message naming the files involved:
///   io_error when the folder cannot be listed or an image cannot be read;
///   bad_data for an image name that does not parse (unless ignore_unparseable_images), angles
///   that are not in the chosen direction set, two images for the same (view, light) pair,
///   images of differing sizes, missing (view, light) combinations (the first few are named),
///   and undecodable images;
///   insufficient_space when an image or the whole BTF exceeds the limits.
/// Files that are not JPEG/PNG are skipped and listed in warnings. Files are processed in
/// sorted path order, so results and the reported error are deterministic. Images are decoded
/// in parallel on the pool. Safe on untrusted folders (sizes are checked before allocating).
inline Result<Ubo2003Folder> read_ubo2003_folder(const std::filesystem::path& root,
                                                 const Ubo2003ReadOptions& options = {}) {
  return read_angle_image_set(root, detail::srgb8_image_codec(), options);
}

inline Result<Ubo2003Folder> read_angle_image_set(const std::filesystem::path& root, const AngleImageCodec& codec,
                                                  const Ubo2003ReadOptions& options) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(root, ec))
    return make_error(Status::io_error, "%s: not a folder%s%s", root.string().c_str(), ec ? ": " : "",
                      ec ? ec.message().c_str() : "");
  Ubo2003Folder out;
  std::vector<detail::UboEntry> entries;
  std::vector<std::string> all_paths;
  {
    fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec);
    if (ec) return make_error(Status::io_error, "%s: cannot list: %s", root.string().c_str(), ec.message().c_str());
    size_t visited = 0;
    for (; it != fs::recursive_directory_iterator(); it.increment(ec)) {
      if (ec) return make_error(Status::io_error, "%s: cannot list: %s", root.string().c_str(), ec.message().c_str());
      if (++visited > options.max_entries)
        return make_error(Status::insufficient_space, "%s: more than %zu entries; is this the right folder?",
                          root.string().c_str(), options.max_entries);
      const fs::path rel = it->path().lexically_relative(root);
      if (it->is_directory(ec)) {
        if (it.depth() >= options.max_depth) {
          out.warnings.push_back("not searched (deeper than max_depth): " + rel.generic_string());
          it.disable_recursion_pending();
        }
        continue;
      }
      all_paths.push_back(rel.generic_string());
    }
  }
  std::sort(all_paths.begin(), all_paths.end());
  for (const auto& rel : all_paths) {
    if (!codec.accepts(fs::path(rel))) {
      out.warnings.push_back(std::string("ignored (not a ") + codec.kind + " image): " + rel);
      continue;
    }
    auto keys = parse_ubo_image_path(fs::path(rel));
    if (!keys) {
      if (options.ignore_unparseable_images) {
        out.warnings.push_back("ignored: " + keys.message());
        continue;
      }
      return Error{Status::bad_data, root.string() + ": " + keys.message()};
    }
    entries.push_back({rel, *keys});
  }
  if (entries.empty())
    return make_error(Status::bad_data, "%s: no images with tl/pl/tv/pv angles in their names (%zu files looked at)",
                      root.string().c_str(), all_paths.size());

  // Choose the direction sets.
  DirectionSet views, lights;
  const float tol = options.tolerance_deg;
  auto all_match = [&](const DirectionSet& set, size_t expect_count, bool light) {
    if (expect_count && set.size() != expect_count) return false;
    for (const auto& e : entries) {
      const int t = light ? UboAngleKeys::tl : UboAngleKeys::tv;
      if (set.find_degrees(e.keys.degrees[t], e.keys.degrees[t + 1], tol) == set.size()) return false;
    }
    return true;
  };
  auto found = [&](bool light) {
    std::vector<std::pair<float, float>> deg;
    const int t = light ? UboAngleKeys::tl : UboAngleKeys::tv;
    for (const auto& e : entries) deg.emplace_back(e.keys.degrees[t], e.keys.degrees[t + 1]);
    return detail::ubo_set_from_angles(std::move(deg), tol, light ? "folder lights" : "folder views");
  };
  switch (options.directions) {
    case UboDirections::ubo2003:
      views = lights = DirectionSet::ubo2003();
      break;
    case UboDirections::ubo2014:
      views = lights = DirectionSet::ubo2014();
      break;
    case UboDirections::custom:
      if (options.custom_views.empty() || options.custom_lights.empty())
        return make_error(Status::invalid_argument, "read_ubo2003_folder: custom direction sets are empty");
      views = options.custom_views;
      lights = options.custom_lights;
      break;
    case UboDirections::from_files:
      views = found(false);
      lights = found(true);
      break;
    case UboDirections::automatic: {
      const DirectionSet fv = found(false), fl = found(true);
      const DirectionSet u3 = DirectionSet::ubo2003(), u14 = DirectionSet::ubo2014();
      if (fv.size() == u3.size() && fl.size() == u3.size() && all_match(u3, 0, false) && all_match(u3, 0, true)) {
        views = lights = u3;
      } else if (fv.size() == u14.size() && fl.size() == u14.size() && all_match(u14, 0, false) &&
                 all_match(u14, 0, true)) {
        views = lights = u14;
      } else {
        views = fv;
        lights = fl;
      }
      break;
    }
  }
  const size_t n_view = views.size(), n_light = lights.size();
  std::vector<int64_t> slot(n_view * n_light, -1);
  for (size_t i = 0; i < entries.size(); ++i) {
    const auto& k = entries[i].keys.degrees;
    const size_t v = views.find_degrees(k[UboAngleKeys::tv], k[UboAngleKeys::pv], tol);
    const size_t l = lights.find_degrees(k[UboAngleKeys::tl], k[UboAngleKeys::pl], tol);
    if (v == n_view || l == n_light)
      return make_error(Status::bad_data, "%s: '%s': %s direction (θ=%g, φ=%g) is not in the %s set '%s'",
                        root.string().c_str(), entries[i].relative.c_str(), v == n_view ? "view" : "light",
                        static_cast<double>(v == n_view ? k[UboAngleKeys::tv] : k[UboAngleKeys::tl]),
                        static_cast<double>(v == n_view ? k[UboAngleKeys::pv] : k[UboAngleKeys::pl]),
                        v == n_view ? "view" : "light", (v == n_view ? views : lights).name().c_str());
    int64_t& s = slot[v * n_light + l];
    if (s >= 0)
      return make_error(Status::bad_data, "%s: duplicate images for view %zu (%s), light %zu (%s): '%s' and '%s'",
                        root.string().c_str(), v, detail::ubo_describe(views, v).c_str(), l,
                        detail::ubo_describe(lights, l).c_str(), entries[static_cast<size_t>(s)].relative.c_str(),
                        entries[i].relative.c_str());
    s = static_cast<int64_t>(i);
  }
  size_t missing = 0;
  std::string missing_list;
  for (size_t i = 0; i < slot.size(); ++i) {
    if (slot[i] >= 0) continue;
    if (++missing <= 5)
      missing_list += format_message("%s view %zu (%s) × light %zu (%s)", missing_list.empty() ? "" : ";", i / n_light,
                                     detail::ubo_describe(views, i / n_light).c_str(), i % n_light,
                                     detail::ubo_describe(lights, i % n_light).c_str());
  }
  if (missing)
    return make_error(Status::bad_data, "%s: missing %zu of %zu (view, light) images in set %s × %s: %s%s",
                      root.string().c_str(), missing, slot.size(), views.name().c_str(), lights.name().c_str(),
                      missing_list.c_str(), missing > 5 ? "; ..." : "");

  // Size from the first image (in slot order), then decode everything in parallel.
  const std::string first = entries[static_cast<size_t>(slot[0])].relative;
  auto info = codec.probe((root / first).string(), options.image_limits);
  if (!info) return info.error();
  auto count = BtfFloat::checked_sample_count(static_cast<uint64_t>(info->width), static_cast<uint64_t>(info->height),
                                              n_view, n_light, options.max_samples);
  if (!count) return Error{count.status(), root.string() + ": " + count.message()};
  out.btf = BtfFloat(info->width, info->height, views, lights);
  out.image_paths.resize(slot.size());
  for (size_t i = 0; i < slot.size(); ++i) out.image_paths[i] = entries[static_cast<size_t>(slot[i])].relative;

  std::vector<Error> errors(slot.size(), Error{Status::success, {}});
  std::atomic<size_t> done{0};
  std::atomic<bool> cancelled{false};
  std::mutex progress_mutex;
  ThreadPool& pool = options.pool ? *options.pool : default_thread_pool();
  pool.parallel_for(0, slot.size(), 4, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      if (cancelled.load(std::memory_order_relaxed)) return;
      const std::string path = (root / out.image_paths[i]).string();
      float* dst = out.btf.image(i / n_light, i % n_light).data();
      auto decoded = codec.decode(path, options.image_limits, out.btf.width(), out.btf.height(), dst);
      if (!decoded) {
        errors[i] = decoded.status() == Status::bad_data &&
                            decoded.message().find("all images must have one size") != std::string::npos
                        ? Error{Status::bad_data, decoded.message() + " (the first image, '" + first + "', sets it)"}
                        : decoded.error();
        continue;
      }
      const size_t n = done.fetch_add(1) + 1;
      if (options.progress) {
        std::lock_guard lock(progress_mutex);
        if (!options.progress("decode images", static_cast<double>(n) / static_cast<double>(slot.size())))
          cancelled.store(true);
      }
    }
  });
  if (cancelled.load()) return make_error(Status::cancelled, "%s: cancelled", root.string().c_str());
  for (const auto& e : errors)
    if (e.status != Status::success) return e;  // the first failing image in (view, light) order
  return out;
}

/// Image format written by write_ubo2003_folder().
enum class UboImageFormat : uint8_t { png, jpeg };
/// File layout written by write_ubo2003_folder().
enum class UboLayout : uint8_t {
  flat,              ///< "<prefix>00008_tl000_pl000_tv030_pv030.png" in the folder
  per_view_folders,  ///< "tv030_pv030/tl000_pl000.png" (view keys only in the folder name)
};

/// Options of write_ubo2003_folder().
struct Ubo2003WriteOptions {
  UboImageFormat format = UboImageFormat::png;
  int jpeg_quality = 95;
  UboLayout layout = UboLayout::flat;
  /// Text before the running number of flat names (e.g. a material name).
  std::string prefix;
  /// Separator between the name's fields: '_' or ' ' (both occur in UBO data).
  char separator = '_';
};

namespace detail {

/// Degrees for a file name: whole numbers as "%03d", others with one decimal ("023.5").
inline std::string ubo_format_angle(float radians, bool wrap_360) {
  double d = radians_to_degrees(radians);
  if (wrap_360) {
    d = std::fmod(d, 360.0);
    if (d < 0) d += 360.0;
  }
  const double r = std::round(d);
  if (std::abs(d - r) < 1e-3) {
    const int i = static_cast<int>(r) % (wrap_360 ? 360 : 1000);
    return format_message("%03d", i);
  }
  return format_message("%05.1f", d);
}

}  // namespace detail

/// Writes every (view, light) image of a BTF as an 8-bit sRGB PNG or JPEG (linear values are
/// clamped to [0, 1], NaN → 0) with UBO-style names that read_ubo2003_folder() parses: angles
/// in degrees, φ in [0, 360), fractional angles with one decimal. Creates `dir` (and per-view
/// folders) when missing; existing files with the same names are replaced. Returns io_error
/// naming the file that failed, invalid_argument for an empty BTF or bad options.
/// Not thread-safe for the same folder.
inline VoidResult write_ubo2003_folder(const BtfFloat& btf, const std::filesystem::path& dir,
                                       const Ubo2003WriteOptions& options = {}) {
  namespace fs = std::filesystem;
  if (btf.empty()) return make_error(Status::invalid_argument, "%s: empty BTF", dir.string().c_str());
  if (options.separator != '_' && options.separator != ' ')
    return make_error(Status::invalid_argument, "%s: separator must be '_' or ' '", dir.string().c_str());
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return make_error(Status::io_error, "%s: cannot create: %s", dir.string().c_str(), ec.message().c_str());
  const char sep = options.separator;
  const char* ext = options.format == UboImageFormat::png ? ".png" : ".jpg";
  size_t counter = 0;
  for (size_t v = 0; v < btf.view_count(); ++v) {
    const std::string tv = "tv" + detail::ubo_format_angle(btf.views()[v].theta, false);
    const std::string pv = "pv" + detail::ubo_format_angle(btf.views()[v].phi, true);
    fs::path folder = dir;
    if (options.layout == UboLayout::per_view_folders) {
      folder /= tv + sep + pv;
      fs::create_directories(folder, ec);
      if (ec)
        return make_error(Status::io_error, "%s: cannot create: %s", folder.string().c_str(), ec.message().c_str());
    }
    for (size_t l = 0; l < btf.light_count(); ++l, ++counter) {
      const std::string tl = "tl" + detail::ubo_format_angle(btf.lights()[l].theta, false);
      const std::string pl = "pl" + detail::ubo_format_angle(btf.lights()[l].phi, true);
      std::string name;
      if (options.layout == UboLayout::per_view_folders) {
        name = tl + sep + pl + ext;
      } else {
        name = options.prefix + format_message("%05zu", counter) + sep + tl + sep + pl + sep + tv + sep + pv + ext;
      }
      const Image<uint8_t> encoded = linear_to_srgb8_image(btf.image(v, l));
      const std::string path = (folder / name).string();
      VoidResult written = options.format == UboImageFormat::png
                               ? write_png(path, encoded.view())
                               : write_jpeg(path, encoded.view(), options.jpeg_quality);
      if (!written) return written;
    }
  }
  return {};
}

}  // namespace btflod
