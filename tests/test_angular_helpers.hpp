// Shared by the angular tests (test_angular_*.cpp): running one check over every built-in
// direction set and every square parameterisation.
#pragma once

#include "btflod/offline/angular/directions.hpp"
#include "btflod/offline/angular/parameterization.hpp"

namespace btflod_test {

// Calls check.template operator()<Map>(set) for each built-in direction set (UBO2003, UBO2014)
// and each map (parabolic, elevated concentric, orthographic); e.g. with the lambda
// []<class Map>(const DirectionSet& set) { ... }.
template <class Check>
void for_each_builtin_set_and_map(Check&& check) {
  for (const btflod::DirectionSet& set : {btflod::DirectionSet::ubo2003(), btflod::DirectionSet::ubo2014()}) {
    check.template operator()<btflod::ParabolicMap>(set);
    check.template operator()<btflod::ElevatedConcentricMap>(set);
    check.template operator()<btflod::OrthographicMap>(set);
  }
}

}  // namespace btflod_test
