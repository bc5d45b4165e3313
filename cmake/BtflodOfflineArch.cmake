# Vectorised builds of the OFFLINE tools (btflod-convert, bench_factor and one twin of the factor
# tests): Eigen's float GEMM is ~2x faster with AVX2 + FMA than with the x86-64 baseline (SSE2).
#
#   -DBTFLOD_OFFLINE_ARCH=AUTO (default)  x86-64-v3 (AVX2, FMA, F16C, BMI1/2, LZCNT, MOVBE) if the
#                                        compiler accepts it AND the build machine can run it
#                                        (configure-time CPUID + XGETBV check); else no flags
#   -DBTFLOD_OFFLINE_ARCH=ON              x86-64-v3 without the run check (cross builds)
#   -DBTFLOD_OFFLINE_ARCH=OFF             no flags (baseline x86-64)
#   -DBTFLOD_OFFLINE_ARCH=<march>         -march=<march> without a check, e.g. native, x86-64-v4
#
# The flags go on WHOLE executables only (btflod_use_offline_arch), never on some translation
# units of one executable: Eigen's inline functions compiled with different flags in one program
# are an ODR hazard. The btflod INTERFACE target and its headers stay flag-agnostic; library
# consumers choose their own flags. Result: BTFLOD_OFFLINE_ARCH_FLAGS (empty = none).
set(BTFLOD_OFFLINE_ARCH "AUTO" CACHE STRING "Flags for the offline tools: AUTO, ON (x86-64-v3), OFF, or a -march value")
set_property(CACHE BTFLOD_OFFLINE_ARCH PROPERTY STRINGS AUTO ON OFF)

include(CheckCXXCompilerFlag)

function(btflod_resolve_offline_arch out)
  set(mode "${BTFLOD_OFFLINE_ARCH}")
  string(TOUPPER "${mode}" upper)
  if(upper STREQUAL "OFF" OR upper STREQUAL "" OR upper STREQUAL "FALSE" OR upper STREQUAL "NO" OR upper STREQUAL "0")
    set(${out} "" PARENT_SCOPE)
    return()
  endif()
  if(NOT upper STREQUAL "AUTO" AND NOT upper STREQUAL "ON")
    set(${out} "-march=${mode}" PARENT_SCOPE)  # user-chosen, unchecked
    return()
  endif()
  if(NOT CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$")
    if(upper STREQUAL "ON")
      message(WARNING "btflod: BTFLOD_OFFLINE_ARCH=ON needs x86-64; processor is ${CMAKE_SYSTEM_PROCESSOR}, no flags used")
    endif()
    set(${out} "" PARENT_SCOPE)
    return()
  endif()
  check_cxx_compiler_flag("-march=x86-64-v3" BTFLOD_CXX_HAS_MARCH_X86_64_V3)
  if(BTFLOD_CXX_HAS_MARCH_X86_64_V3)
    set(flags "-march=x86-64-v3")
  else()
    set(flags -mavx -mavx2 -mfma -mf16c -mbmi -mbmi2 -mlzcnt -mmovbe)
  endif()
  if(upper STREQUAL "ON")
    set(${out} "${flags}" PARENT_SCOPE)
    return()
  endif()
  # AUTO: can this (build) machine run x86-64-v3 code? The probe itself is compiled WITHOUT the
  # flags, so that it reports instead of dying of SIGILL on an older CPU.
  if(CMAKE_CROSSCOMPILING)
    message(STATUS "btflod: offline tools: cross-compiling, no arch flags (set BTFLOD_OFFLINE_ARCH=ON to force)")
    set(${out} "" PARENT_SCOPE)
    return()
  endif()
  if(NOT DEFINED BTFLOD_BUILD_CPU_RUNS_X86_64_V3)
    set(probe ${CMAKE_BINARY_DIR}/CMakeFiles/btflod_x86_64_v3_probe.cpp)
    file(WRITE ${probe} [=[
#include <cpuid.h>
// x86-64-v3 = AVX, AVX2, BMI1, BMI2, F16C, FMA, LZCNT, MOVBE, OSXSAVE with YMM state enabled.
int main() {
  unsigned a = 0, b = 0, c = 0, d = 0;
  if (!__get_cpuid(1, &a, &b, &c, &d)) return 1;
  const bool fma = c & (1u << 12), movbe = c & (1u << 22), osxsave = c & (1u << 27), avx = c & (1u << 28),
             f16c = c & (1u << 29);
  if (!(fma && movbe && osxsave && avx && f16c)) return 2;
  unsigned xlo = 0, xhi = 0;
  __asm__ volatile("xgetbv" : "=a"(xlo), "=d"(xhi) : "c"(0));
  if ((xlo & 6u) != 6u) return 3;  // the OS saves XMM and YMM state
  if (!__get_cpuid_count(7, 0, &a, &b, &c, &d)) return 4;
  const bool bmi1 = b & (1u << 3), avx2 = b & (1u << 5), bmi2 = b & (1u << 8);
  if (!(bmi1 && avx2 && bmi2)) return 5;
  if (!__get_cpuid(0x80000001u, &a, &b, &c, &d)) return 6;
  if (!(c & (1u << 5))) return 7;  // LZCNT (ABM)
  return 0;
}
]=])
    try_run(run_result compile_ok ${CMAKE_BINARY_DIR}/CMakeFiles/btflod_x86_64_v3_probe ${probe})
    if(compile_ok AND "${run_result}" STREQUAL "0")
      set(runs TRUE)
    else()
      set(runs FALSE)
    endif()
    set(BTFLOD_BUILD_CPU_RUNS_X86_64_V3 ${runs} CACHE INTERNAL "build machine runs x86-64-v3 code")
  endif()
  if(BTFLOD_BUILD_CPU_RUNS_X86_64_V3)
    set(${out} "${flags}" PARENT_SCOPE)
  else()
    message(STATUS "btflod: offline tools: the build machine cannot run x86-64-v3, no arch flags")
    set(${out} "" PARENT_SCOPE)
  endif()
endfunction()

btflod_resolve_offline_arch(BTFLOD_OFFLINE_ARCH_FLAGS)
if(BTFLOD_OFFLINE_ARCH_FLAGS)
  message(STATUS "btflod: offline tools (btflod-convert, bench_factor, test_factor_svd_offline_arch) built with: ${BTFLOD_OFFLINE_ARCH_FLAGS}")
endif()

# btflod_use_offline_arch(<target>): compile the WHOLE executable <target> with the offline flags.
# It also links the implementation TU compiled with the same flags (btflod_project_options reads
# the BTFLOD_OFFLINE_ARCH property), so the SVD in that TU is vectorised too.
function(btflod_use_offline_arch target)
  if(BTFLOD_OFFLINE_ARCH_FLAGS)
    target_compile_options(${target} PRIVATE ${BTFLOD_OFFLINE_ARCH_FLAGS})
    set_target_properties(${target} PROPERTIES BTFLOD_OFFLINE_ARCH ON)
  endif()
endfunction()

# btflod_add_offline_arch_test(<name>): tests/<name>.cpp once more as <name>_offline_arch, built
# with the offline flags, so that the factor code is tested both as the default (SSE2) build and
# as the vectorised build the offline tools use. Nothing happens without offline flags, in
# sanitizer builds, or when BTFLOD_TEST_FILTER excludes <name>. Call after add_subdirectory(tests).
function(btflod_add_offline_arch_test name)
  if(NOT BTFLOD_OFFLINE_ARCH_FLAGS OR BTFLOD_SANITIZE)
    return()
  endif()
  if(BTFLOD_TEST_FILTER AND NOT name MATCHES "${BTFLOD_TEST_FILTER}")
    return()
  endif()
  find_package(GTest REQUIRED)
  include(GoogleTest)
  set(src ${PROJECT_SOURCE_DIR}/tests/${name}.cpp)
  if(NOT EXISTS ${src})
    message(WARNING "btflod: ${src} does not exist, no offline-arch twin")
    return()
  endif()
  btflod_read_directives(${src} extra_links labels directives_ok)
  if(NOT directives_ok)
    return()
  endif()
  add_executable(${name}_offline_arch ${src})
  target_link_libraries(${name}_offline_arch PRIVATE btflod::btflod btflod_project_options GTest::gtest GTest::gtest_main
                        ${extra_links})
  target_compile_definitions(${name}_offline_arch PRIVATE BTFLOD_SHARED_DIR="${BTFLOD_SHARED_DIR}"
                             BTFLOD_TEST_TMP_DIR="${PROJECT_BINARY_DIR}/tests/tmp" BTFLOD_TEST_OFFLINE_ARCH=1)
  btflod_use_offline_arch(${name}_offline_arch)
  set_target_properties(${name}_offline_arch PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/tests)
  gtest_discover_tests(${name}_offline_arch TEST_PREFIX "offline_arch." DISCOVERY_TIMEOUT 60 PROPERTIES LABELS "${labels}")
endfunction()
