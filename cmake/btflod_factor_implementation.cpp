// The factorisation half of btflod's non-inline code: the Eigen decompositions too heavy to
// instantiate in every translation unit — the truncated, thin and out-of-core SVDs, the local
// and Laplacian PCAs and the SPMM fit. Needs the runtime half too (it calls the SIMD kernels,
// CRC-32 and the codecs): btflod::implementation compiles both; see
// btflod_runtime_implementation.cpp for which one a program links.
//
// Only the headers whose implementation section is guarded by BTFLOD_FACTOR_IMPLEMENTATION are
// included here; a header that gains such a section is added to this list.
#define BTFLOD_FACTOR_IMPLEMENTATION
#include "btflod/offline/factor/laplacian_pca.hpp"
#include "btflod/offline/factor/local_pca.hpp"
#include "btflod/offline/factor/out_of_core_svd.hpp"
#include "btflod/offline/factor/spmm.hpp"
#include "btflod/offline/factor/truncated_svd.hpp"
#include "btflod/offline/math/thin_svd.hpp"
