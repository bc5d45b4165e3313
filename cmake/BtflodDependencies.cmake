# Dependencies of the btflod INTERFACE target. btflodConfig.cmake repeats these lookups for
# consumers, so keep the two in step.
include(GNUInstallDirs)
find_package(Threads REQUIRED)
find_package(glm CONFIG REQUIRED)
find_package(Eigen3 3.3 CONFIG REQUIRED NO_MODULE)
find_package(ZLIB REQUIRED)
find_package(PkgConfig REQUIRED)
# Debian's libstb-dev ships the stb implementations as a library (libstb), found via stb.pc.
pkg_check_modules(BTFLOD_STB REQUIRED IMPORTED_TARGET GLOBAL stb)
