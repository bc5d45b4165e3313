# Installs the built project into a scratch prefix, then configures, builds and runs the
# consumer project against it with find_package(btflod CONFIG REQUIRED).
cmake_policy(SET CMP0009 NEW)  # GLOB_RECURSE below does not follow symlinks
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BINARY_DIR} --prefix ${prefix} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "install failed (${rc})")
endif()
# 1. An engine: find_package(btflod COMPONENTS runtime), built and run. The compiler's dependency
#    file lists every header main.cpp and the runtime implementation read: none may be GLM's,
#    Eigen's, stb's or OpenEXR's, although all four are installed on this machine.
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/consumer -B ${WORK_DIR}/build
                -DCMAKE_PREFIX_PATH=${prefix} -DBTFLOD_EXPECT_LIBDEFLATE=${WITH_LIBDEFLATE}
                -DBTFLOD_CONSUMER_RUNTIME_ONLY=ON -G "Unix Makefiles"
                # Unoptimised: what is checked is the package (targets, defines, links), and the
                # implementation TU compiles in two thirds of its -O3 time.
                -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-O0
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "runtime consumer configure failed (${rc})")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "runtime consumer build failed (${rc})")
endif()
file(GLOB_RECURSE depfiles ${WORK_DIR}/build/CMakeFiles/consumer.dir/*.d)
if(NOT depfiles)
  message(FATAL_ERROR "no compiler dependency file found under ${WORK_DIR}/build/CMakeFiles/consumer.dir")
endif()
set(read_headers 0)
foreach(d IN LISTS depfiles)
  file(READ ${d} deps)
  string(REGEX MATCHALL "[^ \t\n\\:]+\\.(h|hpp|hxx|inl|tcc)" headers "${deps}")
  list(LENGTH headers nh)
  math(EXPR read_headers "${read_headers} + ${nh}")
  foreach(hdr IN LISTS headers)
    if(hdr MATCHES "/glm/|/eigen3/|/Eigen/|/stb/|stb_image|/OpenEXR/|/Imath/")
      message(FATAL_ERROR "the runtime consumer read ${hdr} (${d})")
    endif()
  endforeach()
endforeach()
message(STATUS "runtime consumer: ${read_headers} headers read, none of GLM, Eigen, stb or OpenEXR")
execute_process(COMMAND ${WORK_DIR}/build/consumer RESULT_VARIABLE rc OUTPUT_VARIABLE out)
message(STATUS "${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "consumer run failed (${rc})")
endif()

# 2. A tool: find_package(btflod) loads both components (configured only; see CMakeLists.txt).
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/consumer -B ${WORK_DIR}/build_tools
                -DCMAKE_PREFIX_PATH=${prefix} -DBTFLOD_EXPECT_LIBDEFLATE=${WITH_LIBDEFLATE}
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "whole-library consumer configure failed (${rc})")
endif()

# 3. The command-line tools are installed beside the package when they were built.
foreach(tool btflod-convert btflod-bench)
  file(GLOB_RECURSE built ${BINARY_DIR}/samples/${tool})
  if(built AND NOT EXISTS ${prefix}/bin/${tool})
    message(FATAL_ERROR "${tool} was built but is not installed in ${prefix}/bin")
  elseif(built)
    message(STATUS "${tool} installed in ${prefix}/bin")
  endif()
endforeach()
