// btflod — a ready-made thread pool that runs a runtime's decode jobs (runtime/streamer.hpp's
// StreamerJobQueue) for engines that do not want to schedule them on their own workers. Kept
// out of the runtime headers: it is the only part that includes <thread>.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

#include "btflod/runtime/streamer.hpp"

namespace btflod {

/// `threads` workers that claim and run jobs whenever the queue's update() makes some runnable.
/// Registers itself as the queue's job notify hook. Destroy it (it joins its threads) before
/// the Streamer; the queue reference stays valid when the Streamer is moved.
class ThreadExecutor {
 public:
  ThreadExecutor(StreamerJobQueue& queue, unsigned threads) : queue_(queue) {
    queue_.set_job_notify(&ThreadExecutor::wake, this);
    for (unsigned i = 0; i < (threads == 0 ? 1u : threads); ++i) workers_.emplace_back([this] { loop(); });
  }
  ThreadExecutor(const ThreadExecutor&) = delete;
  ThreadExecutor& operator=(const ThreadExecutor&) = delete;
  /// Unregisters the hook, lets running jobs finish and joins the workers.
  ~ThreadExecutor() {
    queue_.set_job_notify(nullptr, nullptr);
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    cv_.notify_all();
    for (auto& t : workers_) t.join();
  }
  /// Wakes the workers (also called by the queue's update()). Thread-safe.
  void notify() {
    {
      std::lock_guard lock(mutex_);
      ++signals_;
    }
    cv_.notify_all();
  }
  /// Jobs run since construction.
  uint64_t jobs_run() const {
    std::lock_guard lock(mutex_);
    return jobs_run_;
  }

 private:
  static void wake(void* self) { static_cast<ThreadExecutor*>(self)->notify(); }
  void loop() {
    uint64_t seen = 0;
    for (;;) {
      {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return stopping_ || signals_ != seen; });
        if (stopping_) return;
        seen = signals_;
      }
      for (uint32_t j = queue_.acquire_job(); j != StreamerJobQueue::kNoJob; j = queue_.acquire_job()) {
        queue_.run_job(j);
        std::lock_guard lock(mutex_);
        ++jobs_run_;
      }
    }
  }

  StreamerJobQueue& queue_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool stopping_ = false;
  uint64_t signals_ = 0;
  uint64_t jobs_run_ = 0;
  std::vector<std::thread> workers_;
};

}  // namespace btflod
