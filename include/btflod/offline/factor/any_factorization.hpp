// btflod — one type for "any factorised representation" with a reader that dispatches on the
// kind stored in the factor file (factor_file.hpp), for tools (convert CLI, evaluation) that
// do not know in advance which representation a file holds.
#pragma once

#include <span>
#include <string>
#include <variant>
#include <vector>

#include "btflod/core/file_io.hpp"
#include "btflod/offline/factor/factor_file.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/laplacian_pca.hpp"
#include "btflod/offline/factor/local_pca.hpp"
#include "btflod/offline/factor/pca_views.hpp"
#include "btflod/offline/factor/spmm.hpp"

namespace btflod {

using AnyFactorization = std::variant<Fmf, PcaViews, LaplacianPca, LocalPca, Spmm>;

/// Short name of the representation ("fmf", "pca-k", "laplacian", "lpca", "spmm").
inline const char* factorization_name(const AnyFactorization& f) noexcept {
  switch (f.index()) {
    case 0:
      return "fmf";
    case 1:
      return "pca-k";
    case 2:
      return "laplacian";
    case 3:
      return "lpca";
    default:
      return "spmm";
  }
}

/// Parses any factor file. Safe for untrusted input; the error names what was wrong.
inline Result<AnyFactorization> parse_factorization(std::span<const uint8_t> bytes) {
  auto file = FactorFile::parse(bytes);
  if (!file) return file.error();
  auto wrap = [](auto r) -> Result<AnyFactorization> {
    if (!r) return r.error();
    return AnyFactorization(std::move(*r));
  };
  switch (file->kind) {
    case FactorKind::fmf:
      return wrap(Fmf::deserialize(bytes));
    case FactorKind::pca_views:
      return wrap(PcaViews::deserialize(bytes));
    case FactorKind::laplacian_pca:
      return wrap(LaplacianPca::deserialize(bytes));
    case FactorKind::local_pca:
      return wrap(LocalPca::deserialize(bytes));
    case FactorKind::spmm:
      return wrap(Spmm::deserialize(bytes));
  }
  return make_error(Status::bad_data, "factor file: unknown kind");
}

/// Reads and parses a factor file from disk.
inline Result<AnyFactorization> load_factorization(const std::string& path) {
  auto bytes = read_file_bytes(path);
  if (!bytes) return bytes.error();
  auto f = parse_factorization(*bytes);
  if (!f) return make_error(f.status(), "%s: %s", path.c_str(), f.message().c_str());
  return f;
}

/// Serialises any representation.
inline std::vector<uint8_t> serialize_factorization(const AnyFactorization& f) {
  return std::visit([](const auto& x) { return x.serialize(); }, f);
}

/// Writes a representation to disk (atomically, via write_file_bytes).
inline VoidResult save_factorization(const AnyFactorization& f, const std::string& path) {
  const auto bytes = serialize_factorization(f);
  return write_file_bytes(path, bytes);
}

/// Size in bytes of the stored representation (as each type's size_bytes()).
inline size_t factorization_size_bytes(const AnyFactorization& f) noexcept {
  return std::visit([](const auto& x) { return x.size_bytes(); }, f);
}

/// Float32 source bytes / size.
inline double factorization_compression_ratio(const AnyFactorization& f) noexcept {
  return std::visit([](const auto& x) { return x.compression_ratio(); }, f);
}

/// The shape (size, directions) of the represented BTF.
inline const BtfShape& factorization_shape(const AnyFactorization& f) noexcept {
  return std::visit([](const auto& x) -> const BtfShape& { return x.shape; }, f);
}

/// Full reconstruction at the finest LOD (allocates the BTF).
inline BtfFloat reconstruct_factorization(const AnyFactorization& f) {
  return std::visit([](const auto& x) { return x.reconstruct(); }, f);
}

}  // namespace btflod
