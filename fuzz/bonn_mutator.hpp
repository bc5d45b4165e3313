// Structure-aware mutation of Bonn `.btf` files (offline/btf/bonn_btf.hpp) for libFuzzer.
//
// A Bonn file has no checksums, but every count in it (views, lights, width · height, k, rows,
// cols, string lengths) must agree with the bytes that follow, so byte-level mutation mostly
// produces files the reader refuses at the first count. This mutator parses the input, changes
// ONE field of the parsed file — a header scalar (colour model, cosine flag, meta and FMF header
// versions, dynamic-range method, scalar size), a float (ppmm, rgb scale, colour mean or matrix,
// a direction angle, a singular value, an entry of U or SxV) set to a special value, a string,
// the component count k (every channel at once), the texture shape (width ↔ height) or the
// height map — and writes the file again with encode_bonn_btf(), so every count stays
// consistent and the mutation reaches colour decoding and reconstruction. An input the reader
// refuses, a file the writer refuses, and one mutation in eight get plain byte-level mutation,
// so the reader's own checks keep being exercised. BTFLOD_FUZZ_BYTES=1 (byte_mode()) turns the
// structure-aware part off for comparison runs.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <span>
#include <utility>
#include <vector>

#include "btflod/offline/btf/bonn_btf.hpp"
#include "structure_mutators.hpp"

namespace btflod_fuzz {

/// A float a reader must survive: NaN, ±inf, 0, −0, denormal, huge, tiny, negative, or a small
/// perturbation of `v`.
inline float special_float(std::minstd_rand& rng, float v) {
  switch (rng() % 10) {
    case 0:
      return std::numeric_limits<float>::quiet_NaN();
    case 1:
      return std::numeric_limits<float>::infinity();
    case 2:
      return -std::numeric_limits<float>::infinity();
    case 3:
      return 0.0f;
    case 4:
      return -0.0f;
    case 5:
      return std::numeric_limits<float>::denorm_min();
    case 6:
      return 3.0e38f;
    case 7:
      return -v;
    case 8:
      return v * 1.0e6f;
    default:
      return v + static_cast<float>(static_cast<int>(rng() % 201) - 100) * 0.01f;
  }
}

/// Mutates one field of a parsed Bonn file in place (see the file comment).
inline void mutate_bonn_fields(btflod::BonnBtfFile& f, std::minstd_rand& rng) {
  using btflod::BonnMatrix;
  if (f.factors.empty() || f.channel_names.empty()) return;  // the reader never accepts such a file
  auto any_factors = [&]() -> btflod::BonnFactors& { return f.factors[rng() % f.factors.size()]; };
  switch (rng() % 12) {
    case 0:
      f.color_model = static_cast<int32_t>(rng() % 12) - 2;
      break;
    case 1:
      f.cosine_in_data = !f.cosine_in_data;
      break;
    case 2:
      f.meta_version = 1 + rng() % 4;
      break;
    case 3:
      f.dynamic_range_reduction = rng() % 4;
      f.fmf_header_version = static_cast<uint8_t>(rng() % 4);
      break;
    case 4: {
      static constexpr uint8_t kSizes[] = {2, 4, 8};
      any_factors().scalar_size = kSizes[rng() % 3];
      break;
    }
    case 5: {  // one header float
      float* fields[] = {&f.ppmm, &f.rgb_scale[rng() % 3], &f.color_mean[rng() % 3], &f.color_matrix[rng() % 9]};
      float* target = fields[rng() % 4];
      *target = special_float(rng, *target);
      break;
    }
    case 6: {  // one direction angle
      btflod::DirectionSet& set = (rng() % 2) ? f.views : f.lights;
      if (set.empty()) break;
      std::vector<std::pair<float, float>> angles(set.size());
      for (size_t i = 0; i < set.size(); ++i) angles[i] = {set[i].theta, set[i].phi};
      auto& a = angles[rng() % angles.size()];
      if (rng() % 2)
        a.first = special_float(rng, a.first);
      else
        a.second = special_float(rng, a.second);
      set = btflod::DirectionSet::from_radians(set.name(), angles);
      break;
    }
    case 7: {  // one singular value or matrix entry
      btflod::BonnFactors& fac = any_factors();
      const int which = static_cast<int>(rng() % 3);
      if (which == 0 && !fac.s.empty()) {
        float& v = fac.s[rng() % fac.s.size()];
        v = special_float(rng, v);
      } else {
        BonnMatrix& m = which == 1 ? fac.u : fac.sxv;
        if (m.size() == 0) break;
        float& v = m.data()[rng() % static_cast<size_t>(m.size())];
        v = special_float(rng, v);
      }
      break;
    }
    case 8: {  // a string, mutated byte-wise
      std::string* fields[] = {&f.measurement_setup, &f.xml, &f.channel_names[rng() % f.channel_names.size()]};
      std::string& s = *fields[rng() % 3];
      if (s.empty()) s.push_back('x');  // libFuzzer mutates at least one byte
      std::vector<uint8_t> bytes(s.begin(), s.end());
      bytes.resize(bytes.size() + 16);
      bytes.resize(LLVMFuzzerMutate(bytes.data(), s.size(), bytes.size()));
      s.assign(bytes.begin(), bytes.end());
      break;
    }
    case 9: {  // the component count k of every channel: drop the last component or repeat it
      const bool grow = rng() % 2;
      for (btflod::BonnFactors& fac : f.factors) {
        const Eigen::Index k = fac.u.cols();
        if (k == 0 || fac.sxv.cols() != k) return;
        const Eigen::Index k2 = grow ? k + 1 : k - 1;
        BonnMatrix u(fac.u.rows(), k2), sxv(fac.sxv.rows(), k2);
        const Eigen::Index keep = std::min(k, k2);
        u.leftCols(keep) = fac.u.leftCols(keep);
        sxv.leftCols(keep) = fac.sxv.leftCols(keep);
        if (grow) {
          u.col(k) = fac.u.col(k - 1);
          sxv.col(k) = fac.sxv.col(k - 1);
        }
        fac.u = std::move(u);
        fac.sxv = std::move(sxv);
        fac.s.resize(static_cast<size_t>(k2), fac.s.empty() ? 1.0f : fac.s.back());
      }
      f.max_components = static_cast<uint32_t>(f.factors.empty() ? 0 : f.factors[0].u.cols());
      break;
    }
    case 10:
      std::swap(f.width, f.height);
      break;  // same w·h columns, another shape
    default:  // the height map: drop it, transpose it, or a special sample
      if (f.height_map.empty() || rng() % 3 == 0) {
        f.height_map.clear();
        f.height_map_rows = f.height_map_cols = 0;
      } else if (rng() % 2) {
        std::swap(f.height_map_rows, f.height_map_cols);
        f.height_map_width_first = !f.height_map_width_first;
      } else {
        float& v = f.height_map[rng() % f.height_map.size()];
        v = special_float(rng, v);
      }
      break;
  }
}

/// LLVMFuzzerCustomMutator body for Bonn `.btf` inputs.
inline size_t mutate_bonn_btf(uint8_t* data, size_t size, size_t max_size, unsigned seed) {
  std::minstd_rand rng(seed);
  if (byte_mode() || rng() % 8 == 0) return LLVMFuzzerMutate(data, size, max_size);
  auto file = btflod::read_bonn_btf(std::span<const uint8_t>(data, size));
  if (!file) return LLVMFuzzerMutate(data, size, max_size);
  mutate_bonn_fields(*file, rng);
  auto encoded = btflod::encode_bonn_btf(*file);
  if (!encoded || encoded->size() > max_size) return LLVMFuzzerMutate(data, size, max_size);
  std::memcpy(data, encoded->data(), encoded->size());
  return encoded->size();
}

}  // namespace btflod_fuzz
