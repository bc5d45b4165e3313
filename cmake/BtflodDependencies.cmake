# Dependencies of the btflod INTERFACE target. btflodConfig.cmake repeats these lookups for
# consumers, so keep the two in step.
include(GNUInstallDirs)
find_package(Threads REQUIRED)
find_package(glm CONFIG REQUIRED)
find_package(Eigen3 3.3 CONFIG REQUIRED NO_MODULE)
find_package(ZLIB REQUIRED)
find_package(PkgConfig REQUIRED)
# option(<option> "<doc>" <found>) for an optional dependency, ON by default when it was found;
# when it is ON but <target> does not exist, a configure error: "<option> is ON but <missing>
# (Debian: <debian package>)", with how to proceed.
macro(btflod_optional_dependency option doc found target missing debian)
  option(${option} "${doc}" ${found})
  if(${option} AND NOT TARGET ${target})
    message(FATAL_ERROR "${option} is ON but ${missing} (Debian: ${debian}); "
                        "install it or configure with -D${option}=OFF")
  endif()
endmacro()
# Debian's libstb-dev ships the stb implementations as a library (libstb), found via stb.pc.
pkg_check_modules(BTFLOD_STB REQUIRED IMPORTED_TARGET GLOBAL stb)
# libdeflate: the tile codec's faster inflate backend (runtime/codec/tile_codec.hpp; docs/bsvtf_format.md
# has the decode times). ON puts BTFLOD_TILE_CODEC_LIBDEFLATE=1 and the library on the btflod
# INTERFACE target, so every program built with btflod (samples, demo, CLI, pipeline, consumers
# of the installed package) decodes with it. OFF keeps zlib's inflate (the tested fallback). The
# macro is read by the implementation TU only (btflod::implementation): it changes no type.
pkg_check_modules(BTFLOD_LIBDEFLATE QUIET IMPORTED_TARGET GLOBAL libdeflate)
btflod_optional_dependency(BTFLOD_WITH_LIBDEFLATE "Decode tiles with libdeflate (default ON when pkg-config finds it)"
                           "${BTFLOD_LIBDEFLATE_FOUND}" PkgConfig::BTFLOD_LIBDEFLATE
                           "pkg-config does not find libdeflate" libdeflate-dev)
# zstd: the tile codec's optional zstd entropy coder (tile format 3; runtime/codec/tile_codec.hpp,
# docs/bsvtf_format.md "Entropy stage"). ON puts BTFLOD_TILE_CODEC_ZSTD=1 and libzstd on the
# btflod INTERFACE target (read by the implementation TU only; it changes no type). OFF: decoders
# reject zstd-coded tiles with a clear error and encoders write deflate (format 2) only.
pkg_check_modules(BTFLOD_ZSTD QUIET IMPORTED_TARGET GLOBAL libzstd)
btflod_optional_dependency(BTFLOD_WITH_ZSTD "zstd entropy coder for tiles (default ON when pkg-config finds libzstd)"
                           "${BTFLOD_ZSTD_FOUND}" PkgConfig::BTFLOD_ZSTD "pkg-config does not find libzstd" libzstd-dev)
message(STATUS "btflod: tile zstd coder: ${BTFLOD_WITH_ZSTD}")
# OpenEXR (Debian libopenexr-dev 3.1, CMake configs): offline/btf/openexr_image_set.hpp reads and writes
# BTFs stored as OpenEXR image sets (Bonn btflib's format for measured images). ON puts
# BTFLOD_WITH_OPENEXR=1 and OpenEXR::OpenEXR on the btflod INTERFACE target; no other header
# includes OpenEXR. OFF (or the package missing): that header is unavailable, the rest unchanged.
find_package(OpenEXR CONFIG QUIET)
btflod_optional_dependency(BTFLOD_WITH_OPENEXR "Read/write OpenEXR image sets (default ON when CMake finds OpenEXR)"
                           "${OpenEXR_FOUND}" OpenEXR::OpenEXR "find_package(OpenEXR CONFIG) fails" libopenexr-dev)
message(STATUS "btflod: OpenEXR image sets: ${BTFLOD_WITH_OPENEXR}")
# OpenBLAS (Debian libopenblas-dev, openblas.pc): ON defines EIGEN_USE_BLAS (and
# BTFLOD_WITH_OPENBLAS=1) on the btflod INTERFACE target, so Eigen's float/double GEMMs (the
# randomised SVD's products, offline/factor/truncated_svd.hpp) call OpenBLAS's sgemm/dgemm; the macro
# changes Eigen's code in every TU, hence on the target, not per file. OFF (default): Eigen's own
# GEMM. docs/factor.md has the figures of both.
option(BTFLOD_WITH_OPENBLAS "Eigen's dense products through OpenBLAS (EIGEN_USE_BLAS); default OFF" OFF)
if(BTFLOD_WITH_OPENBLAS)
  pkg_check_modules(BTFLOD_OPENBLAS REQUIRED IMPORTED_TARGET GLOBAL openblas)
  message(STATUS "btflod: dense products: OpenBLAS (BTFLOD_WITH_OPENBLAS=ON)")
endif()
if(BTFLOD_WITH_LIBDEFLATE)
  message(STATUS "btflod: tile inflate backend: libdeflate (BTFLOD_WITH_LIBDEFLATE=ON)")
else()
  message(STATUS "btflod: tile inflate backend: zlib (BTFLOD_WITH_LIBDEFLATE=OFF)")
endif()
