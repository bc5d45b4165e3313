// btflod samples — a text progress bar for long offline steps, usable as a
// btflod::ProgressCallback (core/progress.hpp).
//
// On a terminal it redraws one line in place ("synth: render  [#######-------]  48%"); when the
// stream is not a terminal (CI logs) it prints one line per stage and at every 25%, so logs
// stay short. Header-only; samples include it as "common/progress_bar.hpp".
#pragma once

#include <cstdio>
#include <string>
#include <string_view>

#include <unistd.h>

#include "btflod/core/progress.hpp"

namespace btflod::samples {

class ProgressBar {
 public:
  /// Draws on `out` (stderr by default) with the given label prefix; `enabled = false` makes
  /// every call a no-op (e.g. for --quiet).
  explicit ProgressBar(std::string label = {}, std::FILE* out = stderr, bool enabled = true)
      : label_(std::move(label)),
        out_(out),
        enabled_(enabled && out != nullptr),
        tty_(out != nullptr && ::isatty(::fileno(out)) != 0) {}
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;
  ~ProgressBar() { finish(); }

  /// Shows `fraction` (clamped to [0, 1]) of `stage`. Always returns true (never cancels).
  /// Not thread-safe: callers serialise (btflod's long operations do).
  bool update(std::string_view stage, double fraction) {
    if (!enabled_) return true;
    if (!(fraction >= 0.0)) fraction = 0.0;
    if (fraction > 1.0) fraction = 1.0;
    const int percent = static_cast<int>(fraction * 100.0);
    const bool new_stage = stage != stage_;
    if (!new_stage && percent == percent_) return true;
    if (tty_) {
      if (new_stage && drawn_) std::fputc('\n', out_);
      constexpr int kWidth = 30;
      const int filled = static_cast<int>(fraction * kWidth);
      std::string bar(static_cast<size_t>(filled), '#');
      bar.append(static_cast<size_t>(kWidth - filled), '-');
      std::fprintf(out_, "\r%s%s%.*s [%s] %3d%%", label_.c_str(), label_.empty() ? "" : ": ",
                   static_cast<int>(stage.size()), stage.data(), bar.c_str(), percent);
      drawn_ = true;
    } else if (new_stage || percent / 25 != percent_ / 25) {
      std::fprintf(out_, "%s%s%.*s %3d%%\n", label_.c_str(), label_.empty() ? "" : ": ", static_cast<int>(stage.size()),
                   stage.data(), percent);
    }
    std::fflush(out_);
    stage_.assign(stage);
    percent_ = percent;
    return true;
  }

  /// A callback forwarding to update(); the bar must outlive every use of it.
  ProgressCallback callback() {
    return [this](std::string_view stage, double fraction) { return update(stage, fraction); };
  }

  /// Ends the current line (if one is being redrawn). Idempotent.
  void finish() {
    if (enabled_ && tty_ && drawn_) {
      std::fputc('\n', out_);
      std::fflush(out_);
    }
    drawn_ = false;
  }

 private:
  std::string label_;
  std::FILE* out_;
  bool enabled_;
  bool tty_;
  bool drawn_ = false;
  std::string stage_;
  int percent_ = -1;
};

}  // namespace btflod::samples
