// The runtime half of btflod's non-inline code: everything an engine links, none of it needing
// Eigen — the SIMD kernels and CPU dispatch (core/simd.hpp), CRC-32 and the inflate/deflate back
// ends (zlib, libdeflate), the tile codec and container reader/writer, the feedback trace, the
// Streamer (runtime/streamer_*.hpp), the GLSL/HLSL/Filament shader generators, and the
// tile-pyramid builder that writing a .bsvtf needs (the one offline header here: it needs no
// Eigen, and a player that writes containers should not pay for the factorisation half).
// About 10 s of CPU at -O2 (the factor half: about 100 s).
//
// Link exactly one of: btflod::runtime_implementation (this file alone: engines, players) or
// btflod::implementation (this file and btflod_factor_implementation.cpp: tools that factorise).
// A build without CMake compiles this file (and the factor file when it factorises) once per
// program, or btflod_implementation.cpp, which is both in one translation unit.
//
// Only the headers whose implementation section is guarded by BTFLOD_RUNTIME_IMPLEMENTATION are
// included here; a header that gains such a section is added to this list.
#define BTFLOD_RUNTIME_IMPLEMENTATION
#include "btflod/core/bytes.hpp"
#include "btflod/core/dct.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/simd.hpp"
#include "btflod/core/simd_kernels.hpp"
#include "btflod/offline/build/tile_pyramid.hpp"
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"
#include "btflod/runtime/lod/feedback_trace.hpp"
#include "btflod/runtime/shader/glsl_generator.hpp"
#include "btflod/runtime/shader/hlsl_generator.hpp"
#include "btflod/runtime/shader/hlsl_pieces.hpp"
#include "btflod/runtime/shader/hlsl_programs.hpp"
#include "btflod/runtime/streamer.hpp"
