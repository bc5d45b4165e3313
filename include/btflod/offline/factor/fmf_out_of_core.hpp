// btflod — FMF (paper 000 §4, eq. 4–5) of a BTF held in an on-disk store (offline/btf/btf_store.hpp),
// out of core and optionally distributed: the factors of factorize_fmf() from
// out_of_core_svd() (offline/factor/out_of_core_svd.hpp) reading the store's column blocks.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "btflod/offline/btf/btf_store.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/out_of_core_svd.hpp"

namespace btflod {

/// Options of factorize_fmf_out_of_core().
struct FmfOutOfCoreOptions {
  int components = 16;  ///< rank C
  /// The SVD: algorithm (svd.svd, as FmfOptions::svd), memory budget, checkpoint, communicator.
  /// column_alignment and source_id are set from the store.
  OutOfCoreSvdOptions svd{};
  bool verify_checksums = true;  ///< check every block's CRC-32 as it is read
  /// The domain the factorisation is computed in (FmfOptions::transform); applied to each block read.
  ValueTransform transform{};
};

/// What factorize_fmf_out_of_core() measured besides the SVD report.
struct FmfOutOfCoreReport {
  OutOfCoreSvdReport svd;
  uint64_t bytes_read = 0;  ///< bytes this process read from the store
};

/// Factorises the BTF in `store` to rank C like factorize_fmf() (U, V·Σ, the ambient basis of
/// paper 000 §7), reading the store in column blocks within options.svd.memory_budget. With a
/// communicator of P processes every process must call this (each reads only its columns); the
/// returned Fmf is complete on rank 0 (V gathered there) and has an empty `v` elsewhere.
/// Returns out_of_core_svd()'s errors and the store's read errors (bad_data for a block that
/// fails its checksum). `report`, when given, receives the figures. Threading: options.svd.svd.pool.
inline Result<Fmf> factorize_fmf_out_of_core(const BtfStore& store, const FmfOutOfCoreOptions& options = {},
                                             const ProgressCallback& progress = {},
                                             FmfOutOfCoreReport* report = nullptr) {
  const BtfStoreInfo& info = store.info();
  const size_t m = info.rows(), n = info.columns();
  OutOfCoreSvdOptions so = options.svd;
  so.column_alignment = info.block_texels;
  so.source_id = store.content_id();
  std::atomic<uint64_t> bytes{0};
  const bool verify = options.verify_checksums;
  const ValueTransform tr = options.transform;
  if (!tr.valid()) return make_error(Status::invalid_argument, "factorize_fmf_out_of_core: invalid value transform");
  auto svd = out_of_core_svd(
      m, n, options.components,
      [&](size_t col0, size_t count, Eigen::MatrixXf& out, std::vector<uint8_t>& scratch) -> VoidResult {
        bytes += static_cast<uint64_t>(m) * count * info.value_size();
        VoidResult read = store.read_columns(col0, count, out.data(), static_cast<size_t>(out.rows()), scratch, verify);
        if (read && !tr.is_linear()) encode_columns(tr, count, out);
        return read;
      },
      so, progress);
  if (!svd) return svd.error();
  SvdCommunicator& comm = so.communicator ? *so.communicator : single_process_communicator();
  Fmf f;
  f.shape = BtfShape{info.width, info.height, info.views, info.lights};
  const Eigen::Index c = svd->svd.s.size();
  f.components = static_cast<int>(c);
  f.transform = tr;
  using RowMat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  f.u.resize(m * static_cast<size_t>(c));
  Eigen::Map<RowMat>(f.u.data(), static_cast<Eigen::Index>(m), c) = svd->svd.u;
  // V·Σ rows of this process, row-major, gathered in rank order (= texel order) on rank 0.
  const size_t nl = svd->report.column_end - svd->report.column_begin;
  std::vector<float> local(nl * static_cast<size_t>(c));
  Eigen::Map<RowMat>(local.data(), static_cast<Eigen::Index>(nl), c) = svd->svd.v * svd->svd.s.asDiagonal();
  if (comm.size() == 1) {
    f.v = std::move(local);
  } else {
    std::vector<size_t> counts(static_cast<size_t>(comm.size()));
    for (int r = 0; r < comm.size(); ++r) {
      const auto [b, e] = out_of_core_column_range(n, info.block_texels, r, comm.size());
      counts[static_cast<size_t>(r)] = (e - b) * static_cast<size_t>(c);
    }
    if (comm.rank() == 0) f.v.resize(n * static_cast<size_t>(c));
    if (auto s = comm.gather_to_root(local, f.v, counts); !s) return s.error();
  }
  f.singular_values.assign(svd->svd.s.data(), svd->svd.s.data() + c);
  f.svd_report = svd->svd.report;
  const auto w = ambient_light_weights(info.lights);
  const size_t nlights = info.lights.size(), cc = static_cast<size_t>(c);
  f.u_ambient.assign(info.views.size() * 3 * cc, 0.0f);
  for (size_t vi = 0; vi < info.views.size(); ++vi)
    for (size_t l = 0; l < nlights; ++l)
      for (size_t ch = 0; ch < 3; ++ch)
        for (size_t k = 0; k < cc; ++k)
          f.u_ambient[(vi * 3 + ch) * cc + k] += w[l] * f.u[((vi * nlights + l) * 3 + ch) * cc + k];
  if (report) {
    report->svd = svd->report;
    report->bytes_read = bytes;
  }
  return f;
}

}  // namespace btflod
