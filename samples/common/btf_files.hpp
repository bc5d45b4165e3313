// btflod samples — load and save BTF materials in every format the library reads, chosen by
// content (load) or by path (save), for the demo and every btflod-convert command.
//
//   .mbsdf file (NVIDIA ARC MBSDF)  → btf/measured_brdf.hpp (sampled on UBO2003 × UBO2003, 1×1)
//   Bonn .btf (!DFMF08FCR, !FMF12FCER) → btf/bonn_btf.hpp (read + reconstruct; save: DFMF)
//   a directory of UBO2003-style images → btf/ubo2003_folder.hpp (read; save: PNG folder)
//
// The Bonn and folder formats are compiled in when their headers exist (__has_include), so the
// samples build at every stage of the library; missing ones report Status::unsupported.
#pragma once

#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>

#include "btflod/btf/measured_brdf.hpp"
#include "btflod/btf/tabulated_btf.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/progress.hpp"
#include "btflod/core/result.hpp"

#if __has_include("btflod/btf/bonn_btf.hpp")
#include "btflod/btf/bonn_btf.hpp"
#define BTFLOD_SAMPLES_HAVE_BONN 1
#else
#define BTFLOD_SAMPLES_HAVE_BONN 0
#endif
#if __has_include("btflod/btf/ubo2003_folder.hpp")
#include "btflod/btf/ubo2003_folder.hpp"
#define BTFLOD_SAMPLES_HAVE_UBO_FOLDER 1
#else
#define BTFLOD_SAMPLES_HAVE_UBO_FOLDER 0
#endif

namespace btflod::samples {

enum class BtfFileKind { missing, unknown, mbsdf, bonn, image_folder };

inline const char* file_kind_name(BtfFileKind k) noexcept {
  switch (k) {
    case BtfFileKind::missing: return "missing";
    case BtfFileKind::unknown: return "unknown";
    case BtfFileKind::mbsdf: return "NVIDIA ARC MBSDF measured BRDF";
    case BtfFileKind::bonn: return "Bonn binary BTF";
    case BtfFileKind::image_folder: return "UBO2003-style image folder";
  }
  return "unknown";
}

/// What a path holds, judged by its first bytes (files) or by being a directory.
inline BtfFileKind detect_btf_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return BtfFileKind::image_folder;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return BtfFileKind::missing;
  char head[16] = {};
  const size_t n = std::fread(head, 1, sizeof head, f);
  std::fclose(f);
  const std::string_view s(head, n);
  if (s.starts_with("NVIDIA ARC MBSDF")) return BtfFileKind::mbsdf;
  if (s.starts_with("!DFMF") || s.starts_with("!FMF")) return BtfFileKind::bonn;
  return BtfFileKind::unknown;
}

/// Loads any supported material as a tabulated float BTF (linear RGB, ρ·cosθ_l as stored).
/// An .mbsdf file becomes a 1×1 BTF on UBO2003 × UBO2003 directions. Errors name the path.
inline Result<BtfFloat> load_btf(const std::string& path, const ProgressCallback& progress = {}) {
  (void)progress;
  switch (detect_btf_file(path)) {
    case BtfFileKind::missing:
      return make_error(Status::io_error, "%s: cannot open (missing or unreadable)", path.c_str());
    case BtfFileKind::unknown:
      return make_error(Status::unsupported, "%s: not a format btflod reads (MBSDF, Bonn .btf, image folder)",
                        path.c_str());
    case BtfFileKind::mbsdf: {
      auto brdf = read_mbsdf(path);
      if (!brdf) return brdf.error();
      return sample_to_btf(*brdf, DirectionSet::ubo2003(), DirectionSet::ubo2003());
    }
    case BtfFileKind::bonn: {
#if BTFLOD_SAMPLES_HAVE_BONN
      auto file = read_bonn_btf(path);
      if (!file) return file.error();
      // btflod's samples work in ρ·cosθ_l (BtfValueConvention::abrdf_cos_light), whatever the
      // file's cosine flag says it holds.
      const BonnReconstructOptions opts = bonn_reconstruct_options(BtfValueConvention::abrdf_cos_light);
      auto btf = reconstruct_bonn_btf(*file, opts);
      if (!btf) return Error{btf.status(), path + ": " + btf.message()};
      return btf;
#else
      return make_error(Status::unsupported, "%s: this build has no Bonn .btf reader", path.c_str());
#endif
    }
    case BtfFileKind::image_folder: {
#if BTFLOD_SAMPLES_HAVE_UBO_FOLDER
      auto folder = read_ubo2003_folder(path);
      if (!folder) return folder.error();
      return std::move(folder->btf);
#else
      return make_error(Status::unsupported, "%s: this build has no UBO2003 image-folder reader", path.c_str());
#endif
    }
  }
  return make_error(Status::unsupported, "%s: unknown file kind", path.c_str());
}

/// How save_btf() writes.
struct SaveOptions {
  /// DFMF components per channel (Bonn .btf output).
  int components = 16;
  ProgressCallback progress;
};

/// True when `path` names a Bonn file (".btf" extension); anything else is an image folder.
inline bool is_bonn_path(const std::string& path) {
  return std::filesystem::path(path).extension() == ".btf";
}

/// Writes a BTF: a path ending in .btf becomes a Bonn DFMF file (factorised to
/// options.components per channel), any other path a UBO2003-style folder of 8-bit sRGB PNGs
/// (values clamped to [0, 1]).
inline VoidResult save_btf(const BtfFloat& btf, const std::string& path, const SaveOptions& options = {}) {
  (void)btf;  // unused when a writer is not compiled in
  (void)options;
  if (is_bonn_path(path)) {
#if BTFLOD_SAMPLES_HAVE_BONN
    DfmfFactorizeOptions fo;
    fo.components = options.components;
    fo.progress = options.progress;
    auto file = factorize_bonn_dfmf(btf, fo);
    if (!file) return Error{file.status(), path + ": " + file.message()};
    return write_bonn_dfmf(path, *file);
#else
    return make_error(Status::unsupported, "%s: this build has no Bonn .btf writer", path.c_str());
#endif
  }
#if BTFLOD_SAMPLES_HAVE_UBO_FOLDER
  // 8-bit sRGB PNGs: values are clamped to [0, 1] (specular peaks above 1 are lost).
  return write_ubo2003_folder(btf, path);
#else
  return make_error(Status::unsupported, "%s: this build has no UBO2003 image-folder writer (use a .btf path)",
                    path.c_str());
#endif
}

}  // namespace btflod::samples
