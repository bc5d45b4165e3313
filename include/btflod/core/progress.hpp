// btflod — progress reporting for long offline steps.
//
// ProgressCallback is a small owning, copyable callable (the subset of std::function<bool(
// std::string_view, double)> that callers use: built from any callable or nullptr, copied, tested
// for emptiness, called), so that headers holding one (runtime/codec/container.hpp's build options, the
// readers' options) do not pull <functional> and its <unordered_map> into every translation unit.
#pragma once

#include <cstddef>
#include <string_view>
#include <type_traits>
#include <utility>

namespace btflod {

/// Called with a stage name and the completed fraction in [0, 1]. May be called from worker
/// threads, but never concurrently for the same operation (callers serialise it). Return
/// false to request cancellation; operations that support it then return Status::cancelled.
/// Empty by default (and when built from nullptr). Copying allocates a copy of the callable;
/// building from a callable allocates once. Not for per-frame use.
class ProgressCallback {
 public:
  ProgressCallback() noexcept = default;
  ProgressCallback(std::nullptr_t) noexcept {}  // NOLINT: implicit, as std::function's
  /// Wraps any callable invocable as bool(std::string_view, double).
  template <class F, class D = std::decay_t<F>,
            class = std::enable_if_t<!std::is_same_v<D, ProgressCallback> && !std::is_same_v<D, std::nullptr_t> &&
                                     std::is_invocable_r_v<bool, D&, std::string_view, double>>>
  ProgressCallback(F&& f)  // NOLINT: implicit, as std::function's
      : impl_(new Model<D>(std::forward<F>(f))) {}
  ProgressCallback(const ProgressCallback& o) : impl_(o.impl_ != nullptr ? o.impl_->clone() : nullptr) {}
  ProgressCallback(ProgressCallback&& o) noexcept : impl_(std::exchange(o.impl_, nullptr)) {}
  ProgressCallback& operator=(ProgressCallback o) noexcept {
    std::swap(impl_, o.impl_);
    return *this;
  }
  ~ProgressCallback() { delete impl_; }

  /// True when a callable is held.
  explicit operator bool() const noexcept { return impl_ != nullptr; }
  /// Calls the callable. Precondition: *this holds one.
  bool operator()(std::string_view stage, double fraction) const { return impl_->call(stage, fraction); }

 private:
  struct Concept {
    virtual ~Concept() = default;
    virtual bool call(std::string_view stage, double fraction) = 0;
    virtual Concept* clone() const = 0;
  };
  template <class F>
  struct Model final : Concept {
    template <class G>
    explicit Model(G&& g) : f(std::forward<G>(g)) {}
    bool call(std::string_view stage, double fraction) override { return static_cast<bool>(f(stage, fraction)); }
    Concept* clone() const override { return new Model(f); }
    F f;
  };
  Concept* impl_ = nullptr;
};

/// Invokes cb when set; returns true (continue) when there is no callback.
inline bool report_progress(const ProgressCallback& cb, std::string_view stage, double fraction) {
  return cb ? cb(stage, fraction) : true;
}

}  // namespace btflod
