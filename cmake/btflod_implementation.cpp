// All of btflod's non-inline code in one translation unit, for builds without CMake: the
// runtime half (btflod_runtime_implementation.cpp) and the factorisation half
// (btflod_factor_implementation.cpp). Equivalent to a .cpp that defines BTFLOD_IMPLEMENTATION
// and includes <btflod/btflod.hpp>. Compile it once per program, or only the runtime file for a
// program that does not factorise. CMake builds use btflod::implementation or
// btflod::runtime_implementation instead (two translation units, compiled in parallel).
// The runtime's sections first: the factorisation's headers include runtime headers, whose
// implementation sections must see BTFLOD_RUNTIME_IMPLEMENTATION the first time they are read.
#include "btflod_runtime_implementation.cpp"

#include "btflod_factor_implementation.cpp"
