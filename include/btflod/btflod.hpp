// btflod — umbrella header: includes the public headers of the library.
// Engines include the per-frame headers under btflod/runtime/ (and btflod/core/) instead: they are
// cheap to compile and need none of the offline dependencies (README "Building against it").
//
// The implementation. btflod is header-only, but its non-inline code is compiled once per
// program (the VMA_IMPLEMENTATION / STB_IMAGE_IMPLEMENTATION pattern), in two halves:
//   BTFLOD_RUNTIME_IMPLEMENTATION  SIMD kernels and their CPU dispatch (core/simd.hpp), CRC-32,
//                                  the inflate/deflate back ends (zlib; libdeflate when
//                                  BTFLOD_TILE_CODEC_LIBDEFLATE is defined), the codecs, container
//                                  reader and writer, shader generators, tile-pyramid builder
//   BTFLOD_FACTOR_IMPLEMENTATION   the Eigen decompositions too heavy to instantiate in every TU
//                                  (SVDs, PCAs, SPMM)
// BTFLOD_IMPLEMENTATION defines both:
//
//   // btflod_implementation.cpp — one per program
//   #define BTFLOD_IMPLEMENTATION
//   #include <btflod/btflod.hpp>
//
// With CMake, linking btflod::runtime_implementation (the runtime half) or btflod::implementation
// (both) adds cmake/btflod_*_implementation.cpp to the executable or shared library. Every other
// TU includes any header without the macros and sees declarations only; a program without the
// implementation fails to link (undefined btflod::… symbols), never misbehaves. The macros change
// no type: only function definitions are added.
#pragma once

// core
#include "btflod/core/allocator.hpp"
#include "btflod/core/angular_row_order.hpp"
#include "btflod/core/bit_cast.hpp"
#include "btflod/core/bytes.hpp"
#include "btflod/core/color.hpp"
#include "btflod/core/dct.hpp"
#include "btflod/core/enum_names.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/image.hpp"
#include "btflod/core/progress.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/simd.hpp"
#include "btflod/core/thread_pool.hpp"
#include "btflod/core/unique_handle.hpp"
#include "btflod/core/vec.hpp"
#include "btflod/offline/math/math.hpp"

// runtime
#include "btflod/runtime/allocator.hpp"
#include "btflod/runtime/streamer.hpp"

// runtime/angular
#include "btflod/runtime/angular/angular_sample.hpp"
#include "btflod/runtime/angular/bsvtf_angular_tables.hpp"
#include "btflod/runtime/angular/delaunay.hpp"
#include "btflod/runtime/angular/hemisphere_maps.hpp"
#include "btflod/runtime/angular/lookup_table.hpp"
#include "btflod/runtime/angular/triangle_locator.hpp"

// offline/angular
#include "btflod/offline/angular/angular_sample.hpp"
#include "btflod/offline/angular/delaunay.hpp"
#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/angular/interpolators.hpp"
#include "btflod/offline/angular/nine_tap.hpp"
#include "btflod/offline/angular/parameterization.hpp"
#include "btflod/offline/angular/regular_grid.hpp"
#include "btflod/offline/angular/ring_search.hpp"
#include "btflod/offline/angular/table_lookup.hpp"

// runtime/backend
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/backend/page_table_writes.hpp"
#include "btflod/runtime/backend/streamer_outputs.hpp"

// runtime/codec
#include "btflod/runtime/codec/container.hpp"
#include "btflod/runtime/codec/quantize.hpp"
#include "btflod/runtime/codec/tile_codec.hpp"

// runtime/lod
#include "btflod/runtime/lod/feedback.hpp"
#include "btflod/runtime/lod/feedback_trace.hpp"
#include "btflod/runtime/lod/lod_selector.hpp"

// runtime/shader
#include "btflod/runtime/shader/glsl_generator.hpp"
#include "btflod/runtime/shader/hlsl_generator.hpp"
#include "btflod/runtime/shader/shader_config.hpp"
#include "btflod/runtime/shader/std140.hpp"

// runtime/stream (runtime/stream/http_source.hpp is not included: it needs libcurl, see its header)
#include "btflod/runtime/stream/file_source.hpp"
#include "btflod/runtime/stream/payload_cache.hpp"
#include "btflod/runtime/stream/thread_executor.hpp"
#include "btflod/runtime/stream/tile_source.hpp"

// runtime/vt
#include "btflod/runtime/vt/cache_bc5.hpp"
#include "btflod/runtime/vt/cache_config.hpp"
#include "btflod/runtime/vt/cache_format.hpp"
#include "btflod/runtime/vt/scheduler.hpp"
#include "btflod/runtime/vt/tile_cache.hpp"
#include "btflod/runtime/vt/tile_id.hpp"
#include "btflod/runtime/vt/vt_layout.hpp"

// offline/btf
#include "btflod/offline/btf/bonn_btf.hpp"
#include "btflod/offline/btf/btf_files.hpp"
#include "btflod/offline/btf/btf_store.hpp"
#include "btflod/offline/btf/heightfield.hpp"
#include "btflod/offline/btf/image_io.hpp"
#include "btflod/offline/btf/measured_brdf.hpp"
#include "btflod/offline/btf/synthesizer.hpp"
#include "btflod/offline/btf/tabulated_btf.hpp"
#include "btflod/offline/btf/ubo2003_folder.hpp"

// offline/build
#include "btflod/offline/build/bsvtf_build.hpp"
#include "btflod/offline/build/perceptual_tolerance.hpp"
#include "btflod/offline/build/tile_pyramid.hpp"

// offline/factor
#include "btflod/offline/factor/analytic_brdf.hpp"
#include "btflod/offline/factor/any_factorization.hpp"
#include "btflod/offline/factor/factor_file.hpp"
#include "btflod/offline/factor/fmf.hpp"
#include "btflod/offline/factor/fmf_out_of_core.hpp"
#include "btflod/offline/factor/fmf_stream.hpp"
#include "btflod/offline/factor/laplacian_pca.hpp"
#include "btflod/offline/factor/levenberg_marquardt.hpp"
#include "btflod/offline/factor/local_pca.hpp"
#include "btflod/offline/factor/low_rank_btf.hpp"
#include "btflod/offline/factor/out_of_core_svd.hpp"
#include "btflod/offline/factor/pca_views.hpp"
#include "btflod/offline/factor/spmm.hpp"
#include "btflod/offline/factor/truncated_svd.hpp"

// offline/linalg
#include "btflod/offline/math/eigen.hpp"
#include "btflod/offline/math/thin_svd.hpp"

// offline/metrics
#include "btflod/offline/metrics/btf_metrics.hpp"
#include "btflod/offline/metrics/image_metrics.hpp"

// offline/packing
#include "btflod/offline/packing/representation_packing.hpp"
#include "btflod/offline/packing/spmm_packing.hpp"

// offline/render
#include "btflod/offline/render/cpu_reference.hpp"
#include "btflod/offline/render/integrator.hpp"
#include "btflod/offline/render/primitives.hpp"
#include "btflod/offline/render/sampling.hpp"
#include "btflod/offline/render/shading.hpp"
#include "btflod/offline/render/surface.hpp"
