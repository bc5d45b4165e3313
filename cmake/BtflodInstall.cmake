include(CMakePackageConfigHelpers)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/btflod DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
# Two export sets, so that an engine's find_package(btflod COMPONENTS runtime) loads the runtime
# targets alone and looks for none of the offline dependencies (btflodConfig.cmake.in).
install(TARGETS btflod_runtime btflod_runtime_implementation EXPORT btflodRuntimeTargets)
install(TARGETS btflod btflod_implementation EXPORT btflodTargets)
# btflod::runtime_implementation / btflod::implementation compile these into the program that
# links them (see CMakeLists.txt); btflod_implementation.cpp is both in one TU, for other builds.
install(FILES ${PROJECT_SOURCE_DIR}/cmake/btflod_runtime_implementation.cpp
              ${PROJECT_SOURCE_DIR}/cmake/btflod_factor_implementation.cpp
              ${PROJECT_SOURCE_DIR}/cmake/btflod_implementation.cpp DESTINATION ${CMAKE_INSTALL_DATADIR}/btflod)
install(EXPORT btflodRuntimeTargets NAMESPACE btflod:: DESTINATION ${CMAKE_INSTALL_DATADIR}/btflod/cmake)
install(EXPORT btflodTargets NAMESPACE btflod:: DESTINATION ${CMAKE_INSTALL_DATADIR}/btflod/cmake)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/btflodConfig.cmake.in
  ${PROJECT_BINARY_DIR}/btflodConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_DATADIR}/btflod/cmake)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/btflodConfigVersion.cmake
  COMPATIBILITY SameMajorVersion ARCH_INDEPENDENT)
install(FILES ${PROJECT_BINARY_DIR}/btflodConfig.cmake ${PROJECT_BINARY_DIR}/btflodConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_DATADIR}/btflod/cmake)
