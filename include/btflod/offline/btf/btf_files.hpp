// btflod — load and save a BTF material in any format the library reads, chosen by content
// (load_btf) or by path (save_btf): the one call from a user's file to a tabulated BTF, before
// factorising and building a stream (docs/factor.md).
//
//   .mbsdf file (NVIDIA ARC MBSDF)     → offline/btf/measured_brdf.hpp (sampled on UBO2003 × UBO2003, 1×1)
//   Bonn .btf (!DFMF08FCR, !FMF12FCER) → offline/btf/bonn_btf.hpp (read + reconstruct; save: DFMF)
//   a directory of UBO2003-style images → offline/btf/ubo2003_folder.hpp (read; save: PNG folder)
//
// Offline (allocates, reads files, and saving a .btf factorises: it needs btflod::implementation).
#pragma once

#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>

#include "btflod/core/enum_names.hpp"
#include "btflod/core/progress.hpp"
#include "btflod/core/result.hpp"
#include "btflod/offline/btf/bonn_btf.hpp"
#include "btflod/offline/btf/measured_brdf.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/btf/ubo2003_folder.hpp"

namespace btflod {

/// What a path holds (detect_btf_file()).
enum class BtfFileKind { missing, unknown, mbsdf, bonn, image_folder };

/// A readable name of a kind, for messages.
inline const char* btf_file_kind_name(BtfFileKind k) noexcept {
  static constexpr const char* kNames[] = {"missing", "unknown", "NVIDIA ARC MBSDF measured BRDF", "Bonn binary BTF",
                                           "UBO2003-style image folder"};
  return enum_value_name<BtfFileKind::image_folder>(k, kNames);
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
inline Result<BtfFloat> load_btf(const std::string& path) {
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
      auto file = read_bonn_btf(path);
      if (!file) return file.error();
      // Everything downstream works in ρ·cosθ_l (BtfValueConvention::abrdf_cos_light), whatever
      // the file's cosine flag says it holds.
      const BonnReconstructOptions opts = bonn_reconstruct_options(BtfValueConvention::abrdf_cos_light);
      auto btf = reconstruct_bonn_btf(*file, opts);
      if (!btf) return Error{btf.status(), path + ": " + btf.message()};
      return btf;
    }
    case BtfFileKind::image_folder: {
      auto folder = read_ubo2003_folder(path);
      if (!folder) return folder.error();
      return std::move(folder->btf);
    }
  }
  return make_error(Status::unsupported, "%s: unknown file kind", path.c_str());
}

/// How save_btf() writes.
struct BtfSaveOptions {
  /// DFMF components per channel (Bonn .btf output).
  int components = 16;
  ProgressCallback progress;
};

/// True when `path` names a Bonn file (".btf" extension); anything else is an image folder.
inline bool is_bonn_btf_path(const std::string& path) { return std::filesystem::path(path).extension() == ".btf"; }

/// Writes a BTF: a path ending in .btf becomes a Bonn DFMF file (factorised to
/// options.components per channel), any other path a UBO2003-style folder of 8-bit sRGB PNGs
/// (values clamped to [0, 1]).
inline VoidResult save_btf(const BtfFloat& btf, const std::string& path, const BtfSaveOptions& options = {}) {
  if (is_bonn_btf_path(path)) {
    DfmfFactorizeOptions fo;
    fo.components = options.components;
    fo.progress = options.progress;
    auto file = factorize_bonn_dfmf(btf, fo);
    if (!file) return Error{file.status(), path + ": " + file.message()};
    return write_bonn_dfmf(path, *file);
  }
  // 8-bit sRGB PNGs: values are clamped to [0, 1] (specular peaks above 1 are lost).
  return write_ubo2003_folder(btf, path);
}

}  // namespace btflod
