// A tiny consumer: proves the installed package is usable with find_package. Built as an engine
// (find_package(btflod COMPONENTS runtime): btflod::runtime, runtime headers only, the runtime
// half of the implementation) and, on demand, as a tool (btflod::btflod, every header, both
// halves; BTFLOD_CONSUMER_WHOLE_LIBRARY).
#if defined(BTFLOD_CONSUMER_WHOLE_LIBRARY)
#include <btflod/btflod.hpp>
#else
#include <btflod/core/half.hpp>
#include <btflod/runtime/codec/tile_codec.hpp>
#include <btflod/runtime/shader/glsl_generator.hpp>
#include <btflod/runtime/streamer.hpp>
#endif

#include <cstdio>

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
  return shaders_ok && h.to_float() == 0.5f && backend_ok && refused ? 0 : 1;
}
