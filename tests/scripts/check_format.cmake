# Every C and C++ source of the project is formatted as .clang-format says (clang-format 14,
# --dry-run --Werror): include/, samples/, tests/, bench/, fuzz/ and cmake/. A file that must keep
# a hand layout says so with `// clang-format off` and a reason.
# Usage: cmake -DSOURCE_DIR=<repo> -DCLANG_FORMAT=<clang-format> -P check_format.cmake
if(NOT CLANG_FORMAT)
  message(FATAL_ERROR "clang-format not found (Debian: clang-format); ./run.sh test installs it")
endif()
set(files)
foreach(dir include samples tests bench fuzz cmake)
  file(GLOB_RECURSE found LIST_DIRECTORIES false
       "${SOURCE_DIR}/${dir}/*.cpp" "${SOURCE_DIR}/${dir}/*.hpp" "${SOURCE_DIR}/${dir}/*.h"
       "${SOURCE_DIR}/${dir}/*.inl" "${SOURCE_DIR}/${dir}/*.c")
  foreach(f IN LISTS found)
    # Build folders a sample may keep inside the tree (e.g. samples/filament/app/build) and
    # generated sources are not the project's.
    if(NOT f MATCHES "/build[^/]*/|/_deps/|/node_modules/")
      list(APPEND files "${f}")
    endif()
  endforeach()
endforeach()
list(LENGTH files count)
if(count LESS 100)
  message(FATAL_ERROR "format check: only ${count} sources found under ${SOURCE_DIR}")
endif()
execute_process(COMMAND "${CLANG_FORMAT}" --dry-run --Werror ${files}
                WORKING_DIRECTORY "${SOURCE_DIR}" RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_VARIABLE out)
if(NOT rc EQUAL 0)
  string(REGEX MATCHALL "[^\n]*: error: [^\n]*" lines "${err}")
  set(names)
  foreach(l IN LISTS lines)
    string(REGEX REPLACE ":[0-9]+:[0-9]+: error:.*" "" name "${l}")
    list(APPEND names "${name}")
  endforeach()
  list(REMOVE_DUPLICATES names)
  list(JOIN names "\n  " listing)
  message(FATAL_ERROR "format check: these files differ from .clang-format (run clang-format -i on them):\n  ${listing}")
endif()
message(STATUS "format check: ${count} sources formatted as .clang-format says")
