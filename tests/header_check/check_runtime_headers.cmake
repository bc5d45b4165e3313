# The runtime (per-frame) headers stay cheap and portable (DESIGN.md "Runtime vs offline"):
#   1. preprocessed alone, none of them pulls in Eigen, <immintrin.h> (any x86 intrinsics header)
#      or GLM;
#   2. all of them compile together with -fno-exceptions -fno-rtti -Wall -Wextra -Werror, with
#      GCC and with clang (when found);
#   3. all of them pass `em++ -std=c++20 -fsyntax-only` (Debian's emscripten 3.1.6: clang 14 +
#      libc++ 13); skipped with a message when em++ is absent;
#   4. the per-frame headers (all of the above but the thread-owning conveniences) pull in none of
#      the standard headers that make a translation unit expensive (threads, futures, iostreams,
#      <memory>, <regex>, …; README "Compile cost"), so that including them stays cheap;
#   5. dependencies point one way: core/ → nothing, runtime/ → core/, each offline/ area → the
#      areas listed for it (a forbidden include anywhere in include/btflod fails the check).
# Run by ctest (test runtime_headers_check):
#   cmake -DSOURCE_DIR=<repo> -DWORK_DIR=<dir> -DGXX=<g++> [-DCLANGXX=<clang++>] [-DEMXX=<em++>]
#         -P check_runtime_headers.cmake
cmake_minimum_required(VERSION 3.25)
foreach(v SOURCE_DIR WORK_DIR GXX)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "check_runtime_headers.cmake: ${v} not set")
  endif()
endforeach()
set(inc ${SOURCE_DIR}/include)

# The runtime headers: every header under btflod/runtime/ (what an engine runs per frame or at
# material load) and btflod/core/ (the foundations both sides use). New headers in these folders
# are checked automatically.
file(GLOB_RECURSE runtime_headers RELATIVE ${inc} ${inc}/btflod/runtime/*.hpp ${inc}/btflod/core/*.hpp)
# Known exceptions, each with the reason. A header listed here is skipped by all three checks.
set(exceptions
    # Platform I/O by design: the libcurl HTTP range source (not in btflod.hpp; needs libcurl).
    btflod/runtime/stream/http_source.hpp
    # The x86 kernels of the CPU dispatch: included by the runtime implementation file only
    # (cmake/btflod_runtime_implementation.cpp), never by a per-frame header.
    btflod/core/simd_kernels.hpp)
# Headers that are checked for forbidden includes (1) but not compiled with em++ (3), with the
# reason.
set(em_exceptions "")
# Conveniences that own threads or use the platform's clock: checked by 1-3, exempt from the
# heavy standard headers of check 4. The per-frame API leaves threads and I/O to the engine
# (runtime/streamer.hpp's decode jobs, AsyncTileSource); these are ready-made defaults for
# programs that do not care.
set(convenience_headers
    # A thread pool running the Streamer's decode jobs: <thread>, <mutex>, <condition_variable>.
    btflod/runtime/stream/thread_executor.hpp
    # POSIX pread and a throttled source that sleeps (<chrono>, <thread>).
    btflod/runtime/stream/file_source.hpp
    # The worker pool of the container writer and the offline readers (<thread>, <mutex>).
    btflod/core/thread_pool.hpp)
# Standard headers a per-frame header must not reach (check 4), as the file names the
# preprocessor enters (libstdc++ and libc++ alike: .../c++/<version>/<name>). With libstdc++ 12,
# <memory>, <thread> and <chrono> all bring in <ostream> and the locale machinery.
set(heavy_std_headers thread future mutex shared_mutex condition_variable semaphore stop_token chrono
    regex iostream istream ostream sstream fstream memory locale random filesystem)
list(REMOVE_ITEM runtime_headers ${exceptions})
list(REMOVE_DUPLICATES runtime_headers)
list(SORT runtime_headers)
foreach(h IN LISTS runtime_headers)
  if(NOT EXISTS ${inc}/${h})
    list(REMOVE_ITEM runtime_headers ${h})
  endif()
endforeach()
list(LENGTH runtime_headers n)
message(STATUS "runtime headers checked: ${n}")

file(MAKE_DIRECTORY ${WORK_DIR})
set(failures "")

# 1. Forbidden includes, one header at a time (so a failure names the header that pulls them in).
foreach(h IN LISTS runtime_headers)
  string(MAKE_C_IDENTIFIER ${h} id)
  file(WRITE ${WORK_DIR}/pp_${id}.cpp "#include \"${h}\"\n")
  execute_process(COMMAND ${GXX} -std=c++20 -E -I${inc} ${WORK_DIR}/pp_${id}.cpp
                  OUTPUT_VARIABLE pp ERROR_VARIABLE err RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    list(APPEND failures "${h}: does not preprocess: ${err}")
    continue()
  endif()
  # Line markers name every file the preprocessor entered: # <line> "<path>" <flags>
  string(REGEX MATCHALL "# [0-9]+ \"[^\"]*\"" markers "${pp}")
  list(REMOVE_DUPLICATES markers)
  # Check 1 for every header; check 4 (heavy standard headers) for the per-frame ones only. The
  # first offending file of each kind is reported.
  set(rules "/Eigen/|/eigen3/|[a-z0-9]*intrin\\.h|/glm/")
  set(reasons "includes")
  if(NOT h IN_LIST convenience_headers)
    list(JOIN heavy_std_headers "|" heavy)
    list(APPEND rules "/c\\+\\+/[^/\"]+/(${heavy})\"$")
    list(APPEND reasons "is a per-frame header and includes a heavy standard header (README \"Compile cost\"):")
  endif()
  foreach(rule reason IN ZIP_LISTS rules reasons)
    foreach(m IN LISTS markers)
      if(m MATCHES "${rule}")
        string(REGEX REPLACE "# [0-9]+ \"([^\"]*)\"" "\\1" path "${m}")
        list(APPEND failures "${h} ${reason} ${path}")
        break()
      endif()
    endforeach()
  endforeach()
endforeach()

# 0. Every header with an implementation section is compiled by the implementation file of its
#    half: BTFLOD_RUNTIME_IMPLEMENTATION sections by cmake/btflod_runtime_implementation.cpp,
#    BTFLOD_FACTOR_IMPLEMENTATION sections by cmake/btflod_factor_implementation.cpp (otherwise
#    its definitions would be missing from programs that link btflod::runtime_implementation or
#    btflod::implementation); every section names exactly one half.
file(GLOB_RECURSE all_headers RELATIVE ${inc} ${inc}/btflod/*.hpp)
foreach(half IN ITEMS RUNTIME FACTOR)
  string(TOLOWER ${half} lower)
  file(READ ${SOURCE_DIR}/cmake/btflod_${lower}_implementation.cpp impl_tu_${half})
endforeach()
foreach(h IN LISTS all_headers)
  file(STRINGS ${inc}/${h} any_section REGEX "^#if.*BTFLOD_IMPLEMENTATION")
  if(NOT any_section)
    continue()
  endif()
  set(halves 0)
  foreach(half IN ITEMS RUNTIME FACTOR)
    file(STRINGS ${inc}/${h} impl_lines
         REGEX "^#if defined\\(BTFLOD_IMPLEMENTATION\\) \\|\\| defined\\(BTFLOD_${half}_IMPLEMENTATION\\)$")
    if(impl_lines)
      math(EXPR halves "${halves} + 1")
      string(TOLOWER ${half} lower)
      if(NOT impl_tu_${half} MATCHES "#include \"${h}\"")
        list(APPEND failures "${h} has a ${lower} implementation section but cmake/btflod_${lower}_implementation.cpp does not include it")
      endif()
    endif()
  endforeach()
  if(NOT halves EQUAL 1)
    list(APPEND failures "${h}: its implementation section must be guarded by `#if defined(BTFLOD_IMPLEMENTATION) || defined(BTFLOD_RUNTIME_IMPLEMENTATION)` or `... || defined(BTFLOD_FACTOR_IMPLEMENTATION)`")
  endif()
endforeach()

# 2 + 3. All runtime headers in one translation unit (each header alone already compiles: the
# btflod_headers_compile_alone target).
set(all_tu ${WORK_DIR}/all_runtime_headers.cpp)
set(content "// Generated by check_runtime_headers.cmake\n")
foreach(h IN LISTS runtime_headers)
  string(APPEND content "#include \"${h}\"\n")
endforeach()
string(APPEND content "int main() { return 0; }\n")
file(WRITE ${all_tu} "${content}")
set(strict -std=c++20 -fsyntax-only -fno-exceptions -fno-rtti -Wall -Wextra -Wpedantic -Werror -I${inc})
foreach(cxx IN ITEMS ${GXX} ${CLANGXX})
  execute_process(COMMAND ${cxx} ${strict} ${all_tu} OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    string(SUBSTRING "${err}" 0 3000 err)
    list(APPEND failures "${cxx} -fno-exceptions -fno-rtti: ${err}")
  else()
    message(STATUS "${cxx} -fno-exceptions -fno-rtti -Werror: ${n} runtime headers compile")
  endif()
endforeach()
if(NOT CLANGXX)
  message(STATUS "clang++ not found: the clang compile was skipped")
endif()

if(NOT EMXX)
  message(STATUS "SKIPPED: em++ not found (Debian: emscripten); the emscripten check did not run")
else()
  # zlib: emscripten provides it as a port (-sUSE_ZLIB=1, fetched over the network at link time)
  # or from source (samples/web); for a syntax check the host's zlib.h and zconf.h stand in for
  # the identical headers (never the host's whole /usr/include).
  set(em_inc ${WORK_DIR}/emscripten_include)
  file(MAKE_DIRECTORY ${em_inc})
  foreach(zh zlib.h zconf.h)
    find_file(host_${zh} ${zh} PATHS /usr/include /usr/include/x86_64-linux-gnu NO_DEFAULT_PATH NO_CACHE)
    if(host_${zh})
      file(COPY_FILE ${host_${zh}} ${em_inc}/${zh} ONLY_IF_DIFFERENT)
    endif()
  endforeach()
  set(em_headers ${runtime_headers})
  if(em_exceptions)
    list(REMOVE_ITEM em_headers ${em_exceptions})
  endif()
  set(em_tu ${WORK_DIR}/all_runtime_headers_em.cpp)
  set(content "// Generated by check_runtime_headers.cmake\n")
  foreach(h IN LISTS em_headers)
    string(APPEND content "#include \"${h}\"\n")
  endforeach()
  file(WRITE ${em_tu} "${content}")
  execute_process(COMMAND ${EMXX} -std=c++20 -fsyntax-only -fno-exceptions -fno-rtti -I${inc} -isystem ${em_inc} ${em_tu}
                  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    string(SUBSTRING "${err}" 0 3000 err)
    list(APPEND failures "em++ -fsyntax-only: ${err}")
  else()
    list(LENGTH em_headers ne)
    message(STATUS "em++ -std=c++20 -fsyntax-only: ${ne} runtime headers compile")
  endif()
endif()

# 5. Dependencies point one way (README "Layout"): core/ includes only core/; runtime/ only core/
#    and runtime/; each offline/ area the areas listed for it. A forbidden include fails here
#    with the line that made it, whether it sits in the declarations or in an implementation
#    section.
# The offline areas form a chain: math → angular → btf → metrics → factor → packing / render,
# with build/ (the .bsvtf builder) beside them; each may use the runtime it writes for.
set(layer_areas core runtime offline/math offline/angular offline/btf offline/metrics offline/build
    offline/factor offline/packing offline/render)
set(allowed_core core)
set(allowed_runtime core runtime)
set(allowed_offline/math core offline/math)
set(allowed_offline/angular core runtime offline/math offline/angular)
set(allowed_offline/btf core offline/math offline/angular offline/btf)
set(allowed_offline/metrics core offline/btf offline/metrics)
set(allowed_offline/build core runtime offline/angular offline/build)
set(allowed_offline/factor core runtime offline/math offline/angular offline/btf offline/metrics offline/build
    offline/factor)
set(allowed_offline/packing core runtime offline/angular offline/factor offline/packing)
set(allowed_offline/render core runtime offline/math offline/angular offline/btf offline/factor offline/build
    offline/render)
# The area of a path under include/ (btflod/<area>/...), or "" outside every known area.
function(btflod_area_of path out)
  set(found "")
  foreach(a IN LISTS layer_areas)
    string(LENGTH "btflod/${a}/" alen)
    string(SUBSTRING "${path}" 0 ${alen} prefix)
    if(prefix STREQUAL "btflod/${a}/")
      set(found ${a})
    endif()
  endforeach()
  set(${out} "${found}" PARENT_SCOPE)
endfunction()
file(GLOB_RECURSE layered_files RELATIVE ${inc} ${inc}/btflod/*.hpp ${inc}/btflod/*.inl)
list(REMOVE_ITEM layered_files btflod/btflod.hpp)
foreach(h IN LISTS layered_files)
  btflod_area_of("${h}" area)
  if(area STREQUAL "")
    list(APPEND failures "${h} lies outside the known areas (btflod/core, btflod/runtime, btflod/offline/<area>): add its area to check 5")
    continue()
  endif()
  file(STRINGS ${inc}/${h} include_lines REGEX "^[ \t]*#[ \t]*include[ \t]*[\"<]btflod/")
  foreach(line IN LISTS include_lines)
    string(REGEX REPLACE "^[^\"<]*[\"<](btflod/[^\">]+)[\">].*$" "\\1" target "${line}")
    btflod_area_of("${target}" target_area)
    if(target_area STREQUAL "" OR NOT target_area IN_LIST allowed_${area})
      list(APPEND failures "${h} (area ${area}) must not include ${target}: ${area} may include ${allowed_${area}}")
    endif()
  endforeach()
endforeach()
list(LENGTH layered_files nlayered)
message(STATUS "include directions checked in ${nlayered} headers")

if(failures)
  list(JOIN failures "\n  " text)
  message(FATAL_ERROR "runtime header check failed:\n  ${text}")
endif()
message(STATUS "runtime header check passed")
