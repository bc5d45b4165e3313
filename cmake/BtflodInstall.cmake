include(CMakePackageConfigHelpers)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/btflod DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS btflod btflod_implementation EXPORT btflodTargets)
# btflod::implementation compiles this file into the program that links it (see CMakeLists.txt).
install(FILES ${PROJECT_SOURCE_DIR}/cmake/btflod_implementation.cpp DESTINATION ${CMAKE_INSTALL_DATADIR}/btflod)
install(EXPORT btflodTargets NAMESPACE btflod:: DESTINATION ${CMAKE_INSTALL_DATADIR}/btflod/cmake)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/btflodConfig.cmake.in
  ${PROJECT_BINARY_DIR}/btflodConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_DATADIR}/btflod/cmake)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/btflodConfigVersion.cmake
  COMPATIBILITY SameMajorVersion ARCH_INDEPENDENT)
install(FILES ${PROJECT_BINARY_DIR}/btflodConfig.cmake ${PROJECT_BINARY_DIR}/btflodConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_DATADIR}/btflod/cmake)
