// btflod — progress reporting for long offline steps.
#pragma once

#include <functional>
#include <string_view>

namespace btflod {

/// Called with a stage name and the completed fraction in [0, 1]. May be called from worker
/// threads, but never concurrently for the same operation (callers serialise it). Return
/// false to request cancellation; operations that support it then return Status::cancelled.
using ProgressCallback = std::function<bool(std::string_view stage, double fraction)>;

/// Invokes cb when set; returns true (continue) when there is no callback.
inline bool report_progress(const ProgressCallback& cb, std::string_view stage, double fraction) {
  return cb ? cb(stage, fraction) : true;
}

}  // namespace btflod
