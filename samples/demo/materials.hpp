// btflod-demo — material preparation: synthesise small procedural BTFs, factorise them (FMF,
// paper 000 eq. 4–5), lay the eigen-textures out as a virtual texture, build the .bsvtf
// streaming container, and the angular lookup tables the shaders read (paper 000 §4).
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "btflod/core/file_io.hpp"
#include "btflod/core/half.hpp"
#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/angular/parameterization.hpp"
#include "btflod/offline/btf/btf_store.hpp"
#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/build/tile_pyramid.hpp"
#include "btflod/offline/factor/any_factorization.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/fmf_out_of_core.hpp"
#include "btflod/offline/factor/fmf_rank.hpp"
#include "btflod/offline/factor/fmf_stream.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "common/bsvtf_input.hpp"

namespace btflod::demo {

/// Settings of the material preparation.
struct MaterialSettings {
  int size = 32;        ///< synthesised texels per side
  uint32_t repeat = 8;  ///< the virtual texture holds the material tiled repeat × repeat
  /// FMF rank C (⌈C/4⌉ RGBA virtual textures; btflod-demo --components) when rank_target_ssim
  /// is 0; otherwise the largest rank a material may get.
  uint32_t components = 8;
  /// > 0: each material's rank is chosen from what a viewer sees (offline/factor/fmf_rank.hpp,
  /// choose_fmf_rank()): the smallest of rank_candidates whose displayed (view, light) images
  /// reach this mean SSIM on the training views; 0: every material at `components`. In-memory
  /// path only (the paper profile's out-of-core FMF has a fixed C).
  double rank_target_ssim = 0.0;
  std::vector<int> rank_candidates{4, 8, 12, 16};
  float rank_exposure = 2.1f;  ///< display exposure of the choice: the scene's sun (≈ 2.1)
  uint32_t tile_size = 32;     ///< T
  uint32_t border = 4;         ///< B (T + 2B must be a multiple of 8)
  uint32_t angular_resolution = 32;
  float quality = 60.0f;  ///< tile codec quality
  /// Entropy coder of the tiles (BsvtfBuildOptions::entropy_coder): zstd where the build has it.
  TileEntropyCoder entropy_coder = default_tile_entropy_coder();
  uint64_t seed = 1;
  /// Every material synthesised as this kind (--material); unset: cloth, stone, leather, tiles in turn.
  std::optional<SynthMaterial> kind;
  /// One bounce of diffuse interreflection in the synthesis (--interreflection; SynthesisOptions).
  bool interreflection = false;
  /// A measured BRDF as every material's base reflectance (--brdf; SynthesisOptions::measured_brdf),
  /// named `brdf_name` in the material names; null: the analytic one.
  const MeasuredBrdf* measured_brdf = nullptr;
  std::string brdf_name;
  /// The domain the FMF is computed in (--value-encoding; core/value_transform.hpp).
  ValueTransform transform{};
  /// Paper 000's configuration: 151 × 151 directions (ubo2014), the BTF synthesised view by view
  /// into a BTF store of halves and factorised out of core within `memory_budget`
  /// (offline/factor/fmf_out_of_core.hpp); otherwise the small in-memory path (demo_directions()).
  bool paper = false;
  uint64_t memory_budget = uint64_t{2} << 30;
  bool quiet = true;  ///< no progress lines on stderr
  /// Paper path: a folder of prebuilt inputs. When it holds `<name>.btfstore` (e.g. made by
  /// `btflod-convert synth --profile paper`, or a symbolic link to one), that store is the
  /// material (its own texel count; never deleted) instead of a synthesised one; when it also
  /// holds `<name>.fmf` (`btflod-convert factor`), that FMF is used instead of factorising.
  std::string inputs_dir;
};

/// How often the paper profile repeats a material of `texels` per side in its virtual texture
/// (up to at least 512 texels).
inline uint32_t paper_repeat(int texels) { return static_cast<uint32_t>(std::max(1, (512 + texels - 1) / texels)); }

/// Paper 000's material settings for `size` texels per side (§7: C = 100, T = 64 with 4 texels of
/// padding; the virtual texture holds the material repeated up to at least 512 texels).
inline MaterialSettings paper_material_settings(int size) {
  MaterialSettings s;
  s.size = size;
  s.paper = true;
  s.components = 100;
  s.tile_size = 64;
  s.border = 4;
  s.angular_resolution = 64;
  s.repeat = paper_repeat(size);
  return s;
}

/// The small direction set of the demo (views and lights): rings at θ = 0, 30, 55, 75° with
/// 1, 6, 8, 8 directions — far fewer than UBO2003's 81 so that synthesis and FMF stay fast.
inline DirectionSet demo_directions() {
  const float thetas[] = {0.0f, 30.0f, 55.0f, 75.0f};
  const int counts[] = {1, 6, 8, 8};
  const float offsets[] = {0.0f, 0.0f, 22.5f, 0.0f};
  return DirectionSet::from_rings("demo-23", thetas, counts, offsets, false);
}

/// One material ready for both renderers.
struct DemoMaterial {
  std::string name;
  uint32_t light_count = 0, view_count = 0;
  uint32_t components = 0;
  std::vector<float> u;         ///< backend layout ((light·views + view)·3 + colour)·C + c
  Image<float> eigen_textures;  ///< V'·Σ tiled: M × N × C
  std::vector<uint32_t> light_index, view_index;
  std::vector<float> light_weight, view_weight;
  uint32_t angular_resolution = 0;
  EigenTextures eigen;  ///< for the tile pyramid
  std::string bsvtf_path;
  std::vector<uint8_t> bsvtf;     ///< the container bytes
  double fmf_relative_error = 0;  ///< ‖BTF − U·Vᵀ‖ / ‖BTF‖ on the synthesised material
  /// MaterialSettings::rank_target_ssim > 0: each candidate rank tried, with its displayed-image
  /// SSIM on the training and held-out views (the last one is the chosen rank `components`).
  std::vector<FmfRankPoint> rank_curve;
  bool rank_target_met = false;
  uint32_t finest_level = 0;
  int texels = 0;               ///< material texels per side (the virtual texture repeats it)
  std::string store_path;       ///< the raw BTF as a store (offline/btf/btf_store.hpp): the raw reference
  bool store_prebuilt = false;  ///< the store came from MaterialSettings::inputs_dir (never deleted)
  bool fmf_prebuilt = false;    ///< the FMF came from MaterialSettings::inputs_dir
  uint64_t store_bytes = 0;     ///< its file size
  uint64_t fmf_half_bytes = 0;  ///< U and V·Σ as halves (paper 000 Table 1's "FMF" file size)
  double seconds_synthesis = 0, seconds_factor = 0, seconds_build = 0;
  double seconds_error = 0;  ///< the streamed error pass against the store (paper path)
  double seconds_raw = 0;    ///< its raw-BTF reference pass (raw_reference.hpp)

  /// The angular lookup tables (spans into this object).
  AngularTablesData angular_tables() const noexcept {
    return AngularTablesData{angular_resolution, light_index, light_weight, view_index, view_weight};
  }
  /// The backend description (spans into this object).
  FmfMaterialData data(bool with_textures) const {
    FmfMaterialData d;
    d.components = components;
    d.light_count = light_count;
    d.view_count = view_count;
    d.eigen_abrdfs = u;
    if (with_textures) d.eigen_textures = eigen_textures.view();
    d.mipmaps = true;
    d.angular = angular_tables();
    d.transform = eigen.transform;
    return d;
  }
};

namespace detail_materials {
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace detail_materials

/// ‖A − D(U·(VΣ)ᵀ)‖_F / ‖A‖_F of an FMF against its store (D: its value transform's decode), streamed block by block
/// (memory: two blocks of columns). Returns the store's read errors.
inline Result<double> fmf_relative_error_against_store(const BtfStore& store, const Fmf& f) {
  const size_t m = store.rows(), n = store.columns(), C = static_cast<size_t>(f.components);
  using RowMat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  Eigen::Map<const RowMat> u(f.u.data(), static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(C));
  std::vector<float> cols;
  std::vector<uint8_t> scratch;
  double se = 0.0, ss = 0.0;
  for (size_t t0 = 0; t0 < n; t0 += store.info().block_texels) {
    const size_t cnt = std::min<size_t>(store.info().block_texels, n - t0);
    cols.resize(m * cnt);
    if (auto r = store.read_columns(t0, cnt, cols.data(), m, scratch); !r) return r.error();
    Eigen::Map<Eigen::MatrixXf> a(cols.data(), static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(cnt));
    Eigen::Map<const RowMat> v(f.v.data() + t0 * C, static_cast<Eigen::Index>(cnt), static_cast<Eigen::Index>(C));
    ss += static_cast<double>(a.squaredNorm());
    if (f.transform.is_linear())
      a -= u * v.transpose();
    else {  // the decoded reconstruction D(U·(VΣ)ᵀ); rows (image · 3 + colour): RGB triples consecutive
      Eigen::MatrixXf r = u * v.transpose();
      f.transform.decode_triples(r.data(), static_cast<size_t>(r.size()));
      a -= r;
    }
    se += static_cast<double>(a.squaredNorm());
  }
  return ss > 0.0 ? std::sqrt(se / ss) : 0.0;
}

inline Result<DemoMaterial> finish_material(DemoMaterial m, const Fmf& fmf, const DirectionSet& lights,
                                            const DirectionSet& views, const MaterialSettings& s,
                                            const std::string& out_dir);

/// Synthesises material `index` (cloth, stone, leather, tiles in turn, or s.kind; seed + index), factorises
/// it, builds its .bsvtf container into `out_dir` and its lookup tables, and keeps the raw BTF
/// as a store `out_dir`/<name>.btfstore (the raw reference of the report). Small path: in memory
/// (float32 store written afterwards). Paper path (s.paper): synthesised view by view into a
/// store of halves and factorised out of core (never holding the BTF whole). Allocates; the
/// slow part of the demo.
/// The factorisation itself goes to `fmf_out` when it is not null (the rate–distortion tool
/// truncates it to every rank it measures: offline/factor/fmf_rank.hpp truncate_fmf); the second half
/// is finish_material().
inline Result<DemoMaterial> prepare_material(uint32_t index, const MaterialSettings& s, const std::string& out_dir,
                                             Fmf* fmf_out = nullptr) {
  const SynthMaterial kinds[] = {SynthMaterial::cloth, SynthMaterial::stone, SynthMaterial::leather,
                                 SynthMaterial::tiles};
  const SynthMaterial kind = s.kind ? *s.kind : kinds[index % 4];
  SynthesisOptions so;
  so.interreflection = s.interreflection;
  so.measured_brdf = s.measured_brdf;
  so.views = s.paper ? DirectionSet::ubo2014() : demo_directions();
  so.lights = so.views;
  DemoMaterial m;
  m.name = (s.brdf_name.empty() ? "" : s.brdf_name + "-") + material_name(kind) + "-" + std::to_string(index);
  m.store_path = (std::filesystem::path(out_dir) / (m.name + ".btfstore")).string();
  m.texels = s.size;
  Fmf fmf;
  auto t0 = std::chrono::steady_clock::now();
  if (!s.paper) {
    auto btf = synthesize_material(kind, s.size, s.size, s.seed + index, so);
    if (!btf) return btf.error();
    m.seconds_synthesis = detail_materials::seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    FmfOptions fo;
    fo.components = static_cast<int>(s.components);
    fo.transform = s.transform;
    if (s.rank_target_ssim > 0.0) {  // the rank from displayed images (offline/factor/fmf_rank.hpp)
      FmfRankOptions ro;
      ro.fmf = fo;
      ro.candidates.clear();
      for (int c : s.rank_candidates)
        if (c <= static_cast<int>(s.components)) ro.candidates.push_back(c);
      if (ro.candidates.empty()) ro.candidates.push_back(static_cast<int>(s.components));
      ro.min_ssim = s.rank_target_ssim;
      ro.exposure = s.rank_exposure;
      auto choice = choose_fmf_rank(*btf, ro);
      if (!choice) return choice.error();
      fmf = std::move(choice->fmf);
      m.rank_curve = std::move(choice->curve);
      m.rank_target_met = choice->target_met;
    } else {
      auto f = factorize_fmf(*btf, fo);
      if (!f) return f.error();
      fmf = std::move(*f);
    }
    m.seconds_factor = detail_materials::seconds_since(t0);
    // Relative reconstruction error of the rank-C factorisation (eq. 4).
    double se = 0, ss = 0;
    for (int y = 0; y < btf->height(); ++y)
      for (int x = 0; x < btf->width(); ++x)
        for (uint32_t v = 0; v < btf->view_count(); ++v)
          for (uint32_t l = 0; l < btf->light_count(); ++l) {
            const glm::vec3 r = fmf.evaluate_measured(x, y, v, l);
            const auto img = btf->image(v, l);
            for (int c = 0; c < 3; ++c) {
              const double a = img.at(x, y, c);
              se += (a - r[c]) * (a - r[c]);
              ss += a * a;
            }
          }
    m.fmf_relative_error = ss > 0 ? std::sqrt(se / ss) : 0.0;
    if (auto w = write_btf_store(*btf, m.store_path, BtfStoreValueType::float32, 256); !w) return w.error();
  } else {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path inputs(s.inputs_dir);
    const std::string pre_store = (inputs / (m.name + ".btfstore")).string();
    const std::string pre_fmf = (inputs / (m.name + ".fmf")).string();
    m.store_prebuilt = !s.inputs_dir.empty() && fs::is_regular_file(pre_store, ec);
    m.fmf_prebuilt = m.store_prebuilt && fs::is_regular_file(pre_fmf, ec);
    if (m.store_prebuilt) {
      m.store_path = pre_store;
    } else {
      auto meso = make_mesostructure(kind, s.size, s.size, s.seed + index);
      if (!meso) return meso.error();
      auto writer =
          BtfStoreWriter::create(m.store_path, s.size, s.size, so.views, so.lights, BtfStoreValueType::float16, 256);
      if (!writer) return writer.error();
      VoidResult written;
      size_t views_done = 0;
      auto synth = synthesize_btf_views(*meso, so, [&](size_t v, std::span<const float> block) {
        written = writer->write_view(v, block);
        if (!s.quiet && (++views_done % 16 == 0 || views_done == so.views.size()))
          std::fprintf(stderr, "  %s: synthesised view %zu of %zu (%.0f s)\n", m.name.c_str(), views_done,
                       so.views.size(), detail_materials::seconds_since(t0));
        return static_cast<bool>(written);
      });
      if (!written) return written.error();
      if (!synth) return synth.error();
      if (auto f = writer->finish(); !f) return f.error();
      m.seconds_synthesis = detail_materials::seconds_since(t0);
      t0 = std::chrono::steady_clock::now();
    }
    auto store = BtfStore::open(m.store_path);
    if (!store) return store.error();
    if (store->info().width != store->info().height)
      return make_error(Status::unsupported, "%s: %dx%d texels: the demo needs a square material", m.store_path.c_str(),
                        store->info().width, store->info().height);
    if (store->info().views.size() != so.views.size() || store->info().lights.size() != so.lights.size())
      return make_error(Status::bad_data, "%s: %zu x %zu directions, the paper profile has %zu x %zu",
                        m.store_path.c_str(), store->info().views.size(), store->info().lights.size(), so.views.size(),
                        so.lights.size());
    so.views = store->info().views;
    so.lights = store->info().lights;
    m.texels = store->info().width;
    FmfOutOfCoreOptions fo;
    fo.components = static_cast<int>(s.components);
    fo.transform = s.transform;
    fo.svd.memory_budget = s.memory_budget;
    fo.svd.checkpoint_path = (fs::path(out_dir) / (m.name + ".btfstore.checkpoint")).string();
    ProgressCallback progress;
    if (!s.quiet)
      progress = [&m, t0](std::string_view stage, double fraction) {
        static thread_local std::string last;
        if (stage != last || fraction >= 1.0) {
          std::fprintf(stderr, "  %s: factor %.*s (%.0f s)\n", m.name.c_str(), static_cast<int>(stage.size()),
                       stage.data(), detail_materials::seconds_since(t0));
          last.assign(stage);
        }
        return true;
      };
    if (m.fmf_prebuilt) {
      auto f = load_factorization(pre_fmf);
      if (!f) return f.error();
      if (!std::holds_alternative<Fmf>(*f)) return make_error(Status::bad_data, "%s: not an FMF", pre_fmf.c_str());
      fmf = std::move(std::get<Fmf>(*f));
      if (fmf.shape.width != m.texels || fmf.shape.height != m.texels || fmf.shape.view_count() != so.views.size() ||
          fmf.shape.light_count() != so.lights.size() || fmf.components != static_cast<int>(s.components) ||
          fmf.u.size() != store->rows() * static_cast<size_t>(fmf.components) ||
          fmf.v.size() != store->columns() * static_cast<size_t>(fmf.components))
        return make_error(Status::bad_data, "%s: shape or C = %d differs from %s (C = %u expected)", pre_fmf.c_str(),
                          fmf.components, m.store_path.c_str(), s.components);
    } else {
      auto f = factorize_fmf_out_of_core(*store, fo, progress);
      if (!f) return f.error();
      std::remove(fo.svd.checkpoint_path.c_str());
      fmf = std::move(*f);
    }
    m.seconds_factor = detail_materials::seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    auto err = fmf_relative_error_against_store(*store, fmf);
    if (!err) return err.error();
    m.fmf_relative_error = *err;
    m.seconds_error = detail_materials::seconds_since(t0);
  }
  {
    std::error_code ec;
    m.store_bytes = std::filesystem::file_size(m.store_path, ec);
  }
  auto done = finish_material(std::move(m), fmf, so.lights, so.views, s, out_dir);
  if (done && fmf_out != nullptr) *fmf_out = std::move(fmf);
  return done;
}

/// The second half of prepare_material(): from a material's factorisation `fmf` (of
/// m.texels² texels, its own rank C = fmf.components) to everything both renderers read — U in
/// the backend's row order, V′·Σ repeated into the virtual texture, the angular lookup tables,
/// the tile pyramid and the .bsvtf container at s.quality (written into `out_dir`). `m` carries
/// the name, texel count, store and timings of the first half. Allocates.
inline Result<DemoMaterial> finish_material(DemoMaterial m, const Fmf& fmf, const DirectionSet& lights,
                                            const DirectionSet& views, const MaterialSettings& s,
                                            const std::string& out_dir) {
  const auto t0 = std::chrono::steady_clock::now();
  if (fmf.components <= 0 || fmf.components > 128 || fmf.shape.width != m.texels ||  // the shaders hold ≤ 128
      fmf.shape.height != m.texels || fmf.shape.light_count() != lights.size() ||
      fmf.shape.view_count() != views.size())
    return make_error(Status::invalid_argument, "%s: the FMF's shape or C = %d differs from the material's",
                      m.name.c_str(), fmf.components);
  m.fmf_half_bytes = (fmf.u.size() + fmf.v.size()) * 2;
  m.light_count = static_cast<uint32_t>(lights.size());
  m.view_count = static_cast<uint32_t>(views.size());
  m.components = static_cast<uint32_t>(fmf.components);
  const uint32_t C = m.components, L = m.light_count, V = m.view_count;
  // U: FMF rows (v·n_light + l)·3 + colour → backend/EigenTextures rows (l·n_view + v)·3 + colour.
  m.u.resize(static_cast<size_t>(L) * V * 3 * C);
  for (uint32_t l = 0; l < L; ++l)
    for (uint32_t v = 0; v < V; ++v)
      for (uint32_t col = 0; col < 3; ++col)
        for (uint32_t c = 0; c < C; ++c)
          m.u[((static_cast<size_t>(l) * V + v) * 3 + col) * C + c] =
              fmf.u[((static_cast<size_t>(v) * L + l) * 3 + col) * C + c];
  // V'·Σ tiled repeat × repeat (the material is tileable), so the virtual texture has several levels.
  const int w = m.texels, h = m.texels;
  const uint32_t repeat = s.paper ? paper_repeat(m.texels) : s.repeat;
  const int M = w * static_cast<int>(repeat), N = h * static_cast<int>(repeat);
  m.eigen_textures = Image<float>(M, N, static_cast<int>(C));
  for (int y = 0; y < N; ++y)
    for (int x = 0; x < M; ++x)
      for (uint32_t c = 0; c < C; ++c)
        m.eigen_textures.at(x, y, static_cast<int>(c)) = fmf.v[(static_cast<size_t>(y % h) * w + (x % w)) * C + c];
  m.eigen.textures = m.eigen_textures;
  m.eigen.angular = m.u;
  m.eigen.light_count = L;
  m.eigen.view_count = V;
  m.eigen.transform = fmf.transform;
  // Angular lookup tables (paper 000 §4): the rasterised Delaunay triangulation in the parabolic map.
  auto lt = LookupTableInterpolator<ParabolicMap>::build(lights, static_cast<int>(s.angular_resolution));
  if (!lt) return lt.error();
  auto vt = LookupTableInterpolator<ParabolicMap>::build(views, static_cast<int>(s.angular_resolution));
  if (!vt) return vt.error();
  m.angular_resolution = s.angular_resolution;
  const auto copy_table = [](const auto& t, std::vector<uint32_t>& idx, std::vector<float>& wt) {
    const auto& ii = t.index_table();
    const auto& ww = t.weight_table();
    idx.assign(ii.elements().begin(), ii.elements().end());
    wt.assign(ww.elements().begin(), ww.elements().end());
  };
  copy_table(*lt, m.light_index, m.light_weight);
  copy_table(*vt, m.view_index, m.view_weight);

  // Tile pyramid and .bsvtf container (closed-loop residual codec, paper 000 §6).
  // Every demo material is repeated over its object (scene/demo_scene.hpp; the shader wraps uv
  // with fract, FMF samples with GL_REPEAT): wrapped outer borders, no seam at the repeat.
  auto pyramid = TilePyramid::build(m.eigen, s.tile_size, s.border, TileEdge::wrap);
  if (!pyramid) return pyramid.error();
  m.finest_level = pyramid->geometry().finest_level;
  // The library's metadata (geometry, C, U's light-major rows, the value encoding).
  BsvtfMetadata md = bsvtf_metadata_for(m.eigen, *pyramid, direction_vectors(lights), direction_vectors(views), m.name);
  md.light_set = lights.name();
  md.view_set = views.name();
  const samples::BsvtfTileInputs inputs =
      samples::bsvtf_tiles_from_pyramid(*pyramid, md.level_count, s.tile_size, s.border);
  BsvtfBuildOptions bo;
  bo.quality = s.quality;
  bo.entropy_coder = s.entropy_coder;
  auto file = build_bsvtf(md, m.u, inputs.tiles, bo);
  if (!file) return file.error();
  m.bsvtf = std::move(*file);
  m.bsvtf_path = (std::filesystem::path(out_dir) / (m.name + ".bsvtf")).string();
  if (auto w2 = write_file_bytes(m.bsvtf_path, m.bsvtf); !w2) return w2.error();
  m.seconds_build = detail_materials::seconds_since(t0);
  return m;
}

/// What the demo holds on disk: the bytes of the regular files directly in its output folder
/// (stores, checkpoints, containers; prebuilt inputs are elsewhere) and the file system's free
/// space, sampled after each step, with the peak and the minimum over the samples.
class DiskMeter {
 public:
  explicit DiskMeter(std::string dir) : dir_(std::move(dir)) { sample(); }

  /// Measures now (never throws; unreadable entries count as 0).
  void sample() {
    namespace fs = std::filesystem;
    std::error_code ec;
    uint64_t sum = 0;
    for (fs::directory_iterator it(dir_, ec), end; !ec && it != end; it.increment(ec)) {
      std::error_code e2;
      if (it->is_regular_file(e2) && !it->is_symlink(e2)) {
        const uint64_t n = it->file_size(e2);
        if (!e2) sum += n;
      }
    }
    used_ = sum;
    peak_ = std::max(peak_, used_);
    const fs::space_info sp = fs::space(dir_, ec);
    free_ = ec ? 0 : sp.available;
    min_free_ = std::min(min_free_, free_);
  }
  uint64_t used() const noexcept { return used_; }
  uint64_t peak() const noexcept { return peak_; }
  uint64_t min_free() const noexcept { return min_free_; }
  /// "disk: 33.4 GiB in DIR (peak 33.4 GiB), 1.2 GiB free".
  std::string describe() const {
    char b[256];
    std::snprintf(b, sizeof b, "disk: %.2f GiB in the output folder (peak %.2f GiB), %.2f GiB free",
                  static_cast<double>(used_) / 1073741824.0, static_cast<double>(peak_) / 1073741824.0,
                  static_cast<double>(free_) / 1073741824.0);
    return b;
  }

 private:
  std::string dir_;
  uint64_t used_ = 0, peak_ = 0, free_ = 0, min_free_ = ~uint64_t{0};
};

}  // namespace btflod::demo
