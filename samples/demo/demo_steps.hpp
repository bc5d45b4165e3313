// btflod-demo — helpers shared by the demo's steps (the steps themselves live in materials.hpp,
// raw_reference.hpp, stream_render.hpp and report.hpp; main.cpp calls them in order).
#pragma once

#include <chrono>

namespace btflod::demo {

/// Wall-clock seconds of a step, for the summary.
class Stopwatch {
 public:
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace btflod::demo
