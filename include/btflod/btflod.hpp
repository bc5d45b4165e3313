// btflod — umbrella header: includes every public header of the library.
// Engines may include the per-area headers instead to keep compile times down.
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
#include "btflod/core/eigen.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/image.hpp"
#include "btflod/core/image_io.hpp"
#include "btflod/core/math.hpp"
#include "btflod/core/progress.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/simd.hpp"
#include "btflod/core/thin_svd.hpp"
#include "btflod/core/thread_pool.hpp"
#include "btflod/core/unique_handle.hpp"

// btf
#include "btflod/btf/bonn_btf.hpp"
#include "btflod/btf/btf_files.hpp"
#include "btflod/btf/btf_store.hpp"
#include "btflod/btf/directions.hpp"
#include "btflod/btf/heightfield.hpp"
#include "btflod/btf/measured_brdf.hpp"
#include "btflod/btf/synthesizer.hpp"
#include "btflod/btf/tabulated_btf.hpp"
#include "btflod/btf/ubo2003_folder.hpp"

// angular
#include "btflod/angular/angular_sample.hpp"
#include "btflod/angular/delaunay.hpp"
#include "btflod/angular/interpolators.hpp"
#include "btflod/angular/nine_tap.hpp"
#include "btflod/angular/parameterization.hpp"
#include "btflod/angular/regular_grid.hpp"
#include "btflod/angular/ring_search.hpp"
#include "btflod/angular/triangle_locator.hpp"

// factor
#include "btflod/factor/analytic_brdf.hpp"
#include "btflod/factor/any_factorization.hpp"
#include "btflod/factor/factor_file.hpp"
#include "btflod/factor/fmf.hpp"
#include "btflod/factor/fmf_out_of_core.hpp"
#include "btflod/factor/fmf_stream.hpp"
#include "btflod/factor/laplacian_pca.hpp"
#include "btflod/factor/levenberg_marquardt.hpp"
#include "btflod/factor/local_pca.hpp"
#include "btflod/factor/low_rank_btf.hpp"
#include "btflod/factor/out_of_core_svd.hpp"
#include "btflod/factor/pca_views.hpp"
#include "btflod/factor/spmm.hpp"
#include "btflod/factor/truncated_svd.hpp"

// metrics
#include "btflod/metrics/btf_metrics.hpp"
#include "btflod/metrics/image_metrics.hpp"

// lod
#include "btflod/lod/feedback.hpp"
#include "btflod/lod/feedback_trace.hpp"
#include "btflod/lod/lod_selector.hpp"

// vt
#include "btflod/vt/bsvtf_build.hpp"
#include "btflod/vt/cache_config.hpp"
#include "btflod/vt/cache_format.hpp"
#include "btflod/vt/scheduler.hpp"
#include "btflod/vt/tile_cache.hpp"
#include "btflod/vt/tile_id.hpp"
#include "btflod/vt/tile_pyramid.hpp"
#include "btflod/vt/vt_layout.hpp"

// codec
#include "btflod/codec/container.hpp"
#include "btflod/codec/dct.hpp"
#include "btflod/codec/perceptual_tolerance.hpp"
#include "btflod/codec/quantize.hpp"
#include "btflod/codec/rendered_rate_control.hpp"
#include "btflod/codec/tile_codec.hpp"

// stream (stream/http_source.hpp is not included: it needs libcurl, see its header)
#include "btflod/stream/file_source.hpp"
#include "btflod/stream/payload_cache.hpp"
#include "btflod/stream/thread_executor.hpp"
#include "btflod/stream/tile_source.hpp"
// runtime
#include "btflod/runtime/allocator.hpp"
#include "btflod/runtime/streamer.hpp"

// shader
#include "btflod/shader/glsl_generator.hpp"
#include "btflod/shader/hlsl_generator.hpp"
#include "btflod/shader/shader_config.hpp"
#include "btflod/shader/std140.hpp"

// backend
#include "btflod/backend/backend.hpp"
#include "btflod/backend/cpu_reference.hpp"
#include "btflod/backend/page_table_writes.hpp"
#include "btflod/backend/representation_packing.hpp"
#include "btflod/backend/spmm_packing.hpp"
#include "btflod/backend/streamer_outputs.hpp"

// render (ray-tracer shading, sampling and progressive accumulation; paper 003 §4)
#include "btflod/render/integrator.hpp"
#include "btflod/render/primitives.hpp"
#include "btflod/render/sampling.hpp"
#include "btflod/render/shading.hpp"
#include "btflod/render/surface.hpp"
