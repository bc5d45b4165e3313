// A tiny consumer: proves the installed package is usable with find_package (and that an engine
// builds a material's angular lookup tables with the runtime alone). Built as an engine
// (find_package(btflod COMPONENTS runtime): btflod::runtime, runtime headers only, the runtime
// half of the implementation) and, on demand, as a tool (btflod::btflod, every header, both
// halves; BTFLOD_CONSUMER_WHOLE_LIBRARY).
#if defined(BTFLOD_CONSUMER_WHOLE_LIBRARY)
#include <btflod/btflod.hpp>
#else
#include <btflod/core/half.hpp>
#include <btflod/runtime/angular/bsvtf_angular_tables.hpp>
#include <btflod/runtime/codec/container.hpp>
#include <btflod/runtime/codec/tile_codec.hpp>
#include <btflod/runtime/shader/glsl_generator.hpp>
#include <btflod/runtime/streamer.hpp>
#endif

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

namespace {
// A one-tile container (T = 16, B = 4, 4 components) of 7 light and 7 view directions (the pole
// and a ring of 6 at 45°), written and read back as an engine receives it.
btflod::Result<btflod::BsvtfDirectory> small_container() {
  btflod::BsvtfMetadata md;
  md.material_name = "consumer";
  md.width = md.height = md.tile_size = 16;
  md.border = 4;
  md.component_count = 4;
  md.light_set = md.view_set = "pole + 6 at 45 degrees";
  md.light_directions = {0.0f, 0.0f, 1.0f};
  for (int k = 0; k < 6; ++k) {
    const float phi = static_cast<float>(k) * 1.04719755f, s = 0.70710678f;
    md.light_directions.insert(md.light_directions.end(), {s * std::cos(phi), s * std::sin(phi), s});
  }
  md.view_directions = md.light_directions;
  md.u_rows = 7 * 7 * 3;
  const std::vector<float> u(size_t{md.u_rows} * md.component_count, 0.25f);
  // Varying values: the codec's tolerance scales with each component's range.
  std::vector<float> samples(md.layout().sample_count());
  for (size_t i = 0; i < samples.size(); ++i) samples[i] = 0.5f + 0.25f * std::sin(0.1f * static_cast<float>(i));
  const btflod::BsvtfTileInput tile{btflod::TileId{0, 0, 0, 0}, samples, 1.0f};
  auto file =
      btflod::build_bsvtf(md, u, std::span<const btflod::BsvtfTileInput>(&tile, 1), btflod::BsvtfBuildOptions{});
  if (!file) return file.error();
  return btflod::read_bsvtf(*file);
}

// The angular lookup tables of the container's directions, built from its metadata with the
// runtime alone (no GLM): every texel names directions of the set and carries finite weights
// that sum to 1.
bool angular_tables_ok(const btflod::ShaderConfig& shader) {
  auto dir = small_container();
  if (!dir) {
    std::printf("btflod consumer: container: %s\n", dir.error().message.c_str());
    return false;
  }
  auto tables = btflod::build_bsvtf_angular_tables(dir->metadata, shader.angular);
  if (!tables) {
    std::printf("btflod consumer: angular tables: %s\n", tables.error().message.c_str());
    return false;
  }
  const size_t texels = size_t{tables->resolution} * tables->resolution;
  bool ok = texels > 0 && tables->light_count == 7 && tables->view_count == 7 &&
            tables->light_weight.size() == texels * 3 && tables->view_index.size() == texels * 3 &&
            tables->weight_rgba.size() == texels * 8;
  for (size_t i = 0; ok && i < texels; ++i) {
    float sum = 0.0f;
    for (size_t c = 0; c < 3; ++c) {
      const float w = tables->light_weight[i * 3 + c];
      ok = ok && std::isfinite(w) && w >= 0.0f && tables->light_index[i * 3 + c] < 7 &&
           tables->view_index[i * 3 + c] < 7 && std::isfinite(tables->view_weight[i * 3 + c]);
      sum += w;
    }
    ok = ok && std::abs(sum - 1.0f) < 1e-4f;
  }
  std::printf("btflod consumer: angular tables %u x %u, %zu light + %zu view texels checked\n", tables->resolution,
              tables->resolution, texels, texels);
  return ok;
}
}  // namespace

int main() {
  const btflod::Half h(0.5f);
  std::printf("btflod consumer: half(0.5) = %g\n", static_cast<double>(h.to_float()));
  // The installed package carries the inflate backend it was built with (BTFLOD_WITH_LIBDEFLATE):
  // the define (read by the implementation TU only) and libdeflate's link come through
  // find_package and the implementation target, nothing set here.
  const btflod::TileDecoder decoder(btflod::TileLayout{16, 4, 4});
#if defined(BTFLOD_EXPECT_LIBDEFLATE)
  const bool backend_ok = decoder.backend() == btflod::InflateBackend::libdeflate;
#else
  const bool backend_ok = decoder.backend() == btflod::InflateBackend::zlib;
#endif
  std::printf("btflod consumer: tile inflate backend %s\n",
              decoder.backend() == btflod::InflateBackend::libdeflate ? "libdeflate" : "zlib");
  // The runtime links: a Streamer refuses an empty world with a message (no allocation made).
  btflod::StreamerConfig config;
  const bool refused = !btflod::Streamer::create({}, config);
  // The shader generator is runtime code: the BSVTF program's GLSL comes from the runtime half.
  const auto program =
      btflod::generate_program(btflod::ShaderProgram::bsvtf, btflod::GlslTarget::gl450_core, btflod::ShaderConfig{});
  const bool shaders_ok = program && program->fragment.find("#version 450 core") != std::string::npos;
  std::printf("btflod consumer: BSVTF fragment shader %zu bytes\n", program ? program->fragment.size() : size_t{0});
  // A material's angular lookup tables (what the shader binds as angular_index/angular_weight)
  // are runtime code: built here from a container's metadata without any offline dependency.
  const bool tables_ok = angular_tables_ok(btflod::ShaderConfig{});
  return shaders_ok && tables_ok && h.to_float() == 0.5f && backend_ok && refused ? 0 : 1;
}
