# Per-file build directives, so a test or benchmark can declare what it needs without anyone
# editing a shared CMakeLists.txt. Lines in the source file of the form
#   // btflod-link: CURL::libcurl PkgConfig::BTFLOD_TURBOJPEG
#   // btflod-label: gpu
# add link libraries (targets that must exist; the file is skipped with a message when one is
# missing) and ctest labels (default label: unit).
#
# Optional libraries found here and usable in btflod-link lines:
#   CURL::libcurl, PkgConfig::BTFLOD_TURBOJPEG, PkgConfig::BTFLOD_LIBDEFLATE,
#   PkgConfig::BTFLOD_ZSTD, PkgConfig::BTFLOD_JPEG, btflod_squish, OpenGL::EGL, OpenGL::OpenGL, Vulkan::Vulkan, and any target that
#   samples/ defines (samples are added before tests and benchmarks).
find_package(CURL QUIET)
find_package(OpenGL QUIET COMPONENTS EGL OpenGL)
find_package(Vulkan QUIET)
pkg_check_modules(BTFLOD_TURBOJPEG QUIET IMPORTED_TARGET GLOBAL libturbojpeg)
# PkgConfig::BTFLOD_LIBDEFLATE comes from BtflodDependencies.cmake (BTFLOD_WITH_LIBDEFLATE).
pkg_check_modules(BTFLOD_ZSTD QUIET IMPORTED_TARGET GLOBAL libzstd)
# libjpeg (Debian libjpeg62-turbo-dev): the coefficient API, for bench_codec_entropy's JPEG Huffman row.
pkg_check_modules(BTFLOD_JPEG QUIET IMPORTED_TARGET GLOBAL libjpeg)
# libsquish (Debian libsquish-dev): the BC4 encoder bench_cache_bc5 compares the project's with.
# Found by its header and library: Debian 12's libsquish.pc names /include as its include folder.
find_path(BTFLOD_SQUISH_INCLUDE_DIR squish.h)
find_library(BTFLOD_SQUISH_LIBRARY squish)
if(BTFLOD_SQUISH_INCLUDE_DIR AND BTFLOD_SQUISH_LIBRARY AND NOT TARGET btflod_squish)
  add_library(btflod_squish INTERFACE)
  target_include_directories(btflod_squish SYSTEM INTERFACE ${BTFLOD_SQUISH_INCLUDE_DIR})
  target_link_libraries(btflod_squish INTERFACE ${BTFLOD_SQUISH_LIBRARY})
endif()
# MPI (Debian: libopenmpi-dev, openmpi-bin): the distributed factorisation (offline/factor/mpi_svd.hpp).
# ON defines the target btflod_mpi (MPI::MPI_CXX), usable in btflod-link lines; OFF leaves the
# MPI command, tests and benchmarks out.
find_package(MPI QUIET COMPONENTS CXX)
option(BTFLOD_WITH_MPI "Build the MPI factorisation command and tests (default ON when MPI is found)" ${MPI_CXX_FOUND})
if(BTFLOD_WITH_MPI)
  if(NOT MPI_CXX_FOUND)
    message(FATAL_ERROR "BTFLOD_WITH_MPI is ON but find_package(MPI) finds no C++ MPI (Debian: libopenmpi-dev); "
                        "install it or configure with -DBTFLOD_WITH_MPI=OFF")
  endif()
  add_library(btflod_mpi INTERFACE)
  target_link_libraries(btflod_mpi INTERFACE MPI::MPI_CXX)
endif()
message(STATUS "btflod: MPI factorisation: ${BTFLOD_WITH_MPI}")

# btflod_read_directives(<source> <out_links> <out_labels> <out_ok>)
function(btflod_read_directives src out_links out_labels out_ok)
  file(STRINGS ${src} link_lines REGEX "^// btflod-link:")
  file(STRINGS ${src} label_lines REGEX "^// btflod-label:")
  set(links "")
  set(labels "")
  set(ok TRUE)
  foreach(line IN LISTS link_lines)
    string(REGEX REPLACE "^// btflod-link:[ ]*" "" rest "${line}")
    separate_arguments(items UNIX_COMMAND "${rest}")
    foreach(t IN LISTS items)
      if(TARGET ${t})
        list(APPEND links ${t})
      else()
        message(STATUS "btflod: skipping ${src}: link target ${t} not available")
        set(ok FALSE)
      endif()
    endforeach()
  endforeach()
  foreach(line IN LISTS label_lines)
    string(REGEX REPLACE "^// btflod-label:[ ]*" "" rest "${line}")
    separate_arguments(items UNIX_COMMAND "${rest}")
    list(APPEND labels ${items})
  endforeach()
  if(NOT labels)
    set(labels unit)
  endif()
  set(${out_links} ${links} PARENT_SCOPE)
  set(${out_labels} ${labels} PARENT_SCOPE)
  set(${out_ok} ${ok} PARENT_SCOPE)
endfunction()

# btflod_add_directed_executable(<source> <out_name> [<library>...]): an executable named after
# <source> (its file name without extension), linked with the <library> arguments followed by
# the source's btflod-link targets. <out_name> receives its name, or is empty (and nothing is
# added) when a btflod-link target is missing.
function(btflod_add_directed_executable src out_name)
  get_filename_component(name ${src} NAME_WE)
  btflod_read_directives(${src} links labels ok)
  if(NOT ok)
    set(${out_name} "" PARENT_SCOPE)
    return()
  endif()
  add_executable(${name} ${src})
  target_link_libraries(${name} PRIVATE ${ARGN} ${links})
  set(${out_name} ${name} PARENT_SCOPE)
endfunction()
