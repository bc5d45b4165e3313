// btflod — Eigen, included as a system header.
//
// Every btflod header that needs Eigen includes it through this file. The pragmas mark Eigen's
// code as system code for GCC and clang, and silence the warnings Eigen is known to trigger
// after inlining into user code (-Wmaybe-uninitialized, -Warray-bounds, -Wclass-memaccess at -O2
// and above), so that a consumer building with -Wall -Werror and Eigen on a plain -I path sees
// none of them. Offline code only: per-frame headers never include this file.
#pragma once

#if defined(__GNUC__)
#pragma GCC system_header
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Warray-bounds"
#if !defined(__clang__)
#pragma GCC diagnostic ignored "-Wclass-memaccess"
#endif
#endif

#include <Eigen/Dense>

#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif
