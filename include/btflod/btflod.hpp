// btflod — umbrella header: includes every public header of the library.
// Engines may include the per-area headers instead to keep compile times down.
#pragma once

// core
#include "btflod/core/bytes.hpp"
#include "btflod/core/color.hpp"
#include "btflod/core/file_io.hpp"
#include "btflod/core/half.hpp"
#include "btflod/core/image.hpp"
#include "btflod/core/image_io.hpp"
#include "btflod/core/math.hpp"
#include "btflod/core/progress.hpp"
#include "btflod/core/result.hpp"
#include "btflod/core/thread_pool.hpp"

// btf
#include "btflod/btf/bonn_btf.hpp"
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

// metrics

// lod

// vt
#include "btflod/vt/tile_id.hpp"

// codec

// stream

// shader

// backend
