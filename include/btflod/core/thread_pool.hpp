// btflod — a small fixed-size thread pool for the expensive offline steps (synthesis,
// factorisation, tile building, decoding). Per-frame code submits work without allocating
// only through pre-sized job queues in stream/; this pool is for offline use.
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdlib>
#include <deque>
#include <exception>
#include <functional>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

namespace btflod {

class ThreadPool {
 public:
  /// Starts `threads` workers; 0 means std::thread::hardware_concurrency() (at least 1), or the
  /// value of the BTFLOD_THREADS environment variable when set.
  explicit ThreadPool(unsigned threads = 0) {
    if (threads == 0) {
      if (const char* env = std::getenv("BTFLOD_THREADS"))
        threads = static_cast<unsigned>(std::strtoul(env, nullptr, 10));
      if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
    }
    workers_.reserve(threads);
    for (unsigned i = 0; i < threads; ++i) workers_.emplace_back([this] { worker_loop(); });
  }
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;
  /// Finishes queued tasks, then joins the workers.
  ~ThreadPool() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    for (auto& t : workers_) t.join();
  }

  unsigned thread_count() const noexcept { return static_cast<unsigned>(workers_.size()); }

  /// Queues a task; the future carries its result or exception. Thread-safe.
  template <class F>
  auto submit(F&& task) -> std::future<decltype(task())> {
    using R = decltype(task());
    auto packaged = std::make_shared<std::packaged_task<R()>>(std::forward<F>(task));
    std::future<R> result = packaged->get_future();
    {
      std::lock_guard lock(mutex_);
      queue_.emplace_back([packaged] { (*packaged)(); });
    }
    wake_.notify_one();
    return result;
  }

  /// Calls body(begin_i, end_i) on disjoint chunks covering [begin, end), at most `grain`
  /// items per chunk, on the workers and the calling thread; returns when all are done.
  /// The first exception thrown by a chunk is rethrown here after every chunk has finished
  /// (builds with -fno-exceptions compile without that forwarding).
  /// Chunks are claimed in ascending order, so results written per index are deterministic.
  template <class F>
  void parallel_for(size_t begin, size_t end, size_t grain, F&& body) {
    if (end <= begin) return;
    grain = std::max<size_t>(grain, 1);
    const size_t chunks = (end - begin + grain - 1) / grain;
    std::atomic<size_t> next{0};
    std::exception_ptr failure;
    std::mutex failure_mutex;
    auto run_chunks = [&] {
      for (size_t c; (c = next.fetch_add(1)) < chunks;) {
        const size_t b = begin + c * grain;
        const size_t e = std::min(end, b + grain);
#if defined(__cpp_exceptions) || defined(__EXCEPTIONS)
        try {
          body(b, e);
        } catch (...) {
          std::lock_guard lock(failure_mutex);
          if (!failure) failure = std::current_exception();
        }
#else  // built with -fno-exceptions: nothing can be thrown, nothing to forward
        body(b, e);
#endif
      }
    };
    const size_t helpers = std::min<size_t>(workers_.size(), chunks > 0 ? chunks - 1 : 0);
    std::vector<std::future<void>> pending;
    pending.reserve(helpers);
    for (size_t i = 0; i < helpers; ++i) pending.push_back(submit(run_chunks));
    run_chunks();
    for (auto& p : pending) p.wait();
#if defined(__cpp_exceptions) || defined(__EXCEPTIONS)
    if (failure) std::rethrow_exception(failure);
#else
    (void)failure_mutex;
#endif
  }

 private:
  void worker_loop() {
    for (;;) {
      std::function<void()> task;
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
        if (queue_.empty()) return;  // stopping and drained
        task = std::move(queue_.front());
        queue_.pop_front();
      }
      task();
    }
  }

  std::vector<std::thread> workers_;
  std::deque<std::function<void()>> queue_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
};

/// A process-wide pool with hardware_concurrency() workers, created on first use. Thread-safe.
inline ThreadPool& default_thread_pool() {
  static ThreadPool pool;
  return pool;
}

}  // namespace btflod
