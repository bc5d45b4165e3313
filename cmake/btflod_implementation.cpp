// The one translation unit that compiles btflod's non-inline code: the SIMD kernels and CPU
// dispatch (core/simd.hpp), CRC-32 and the inflate/deflate back ends (zlib, libdeflate), and the
// offline numerics that are too heavy to instantiate in every translation unit (the truncated
// SVD's Eigen decompositions) and offline code that needs threads (build_bsvtf's encoder). Link
// exactly one copy into each program: the CMake target btflod::implementation adds this file to
// the executable or shared library that links it; a build without CMake compiles this file once
// (or any .cpp that defines BTFLOD_IMPLEMENTATION and then includes <btflod/btflod.hpp>).
//
// Only the headers that have an implementation section are included here (each one's section
// sits under `#if defined(BTFLOD_IMPLEMENTATION)` at its end), so that editing any other header
// does not recompile this TU. A header that gains such a section is added to this list.
#define BTFLOD_IMPLEMENTATION
#include "btflod/codec/container.hpp"
#include "btflod/codec/dct.hpp"
#include "btflod/codec/tile_codec.hpp"
#include "btflod/core/bytes.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/simd.hpp"
#include "btflod/core/simd_kernels.hpp"
#include "btflod/core/thin_svd.hpp"
#include "btflod/factor/laplacian_pca.hpp"
#include "btflod/factor/local_pca.hpp"
#include "btflod/factor/spmm.hpp"
#include "btflod/factor/out_of_core_svd.hpp"
#include "btflod/factor/truncated_svd.hpp"
#include "btflod/lod/feedback_trace.hpp"
#include "btflod/shader/glsl_generator.hpp"
#include "btflod/shader/hlsl_generator.hpp"
#include "btflod/shader/hlsl_pieces.hpp"
#include "btflod/shader/hlsl_programs.hpp"
#include "btflod/vt/tile_pyramid.hpp"
