// A counting replacement of the global allocation functions, for tests that prove "no heap
// allocation" on a per-frame path: every operator new / new[] call, on any thread, in its
// throwing and nothrow forms, adds one to btflod_test::global_news(). Compare the count before
// and after the code under test.
//
// Include this header in exactly ONE source file of a test executable: it defines the
// replaceable allocation functions ([new.delete.single], [new.delete.array]), which may be
// defined once per program. The nothrow forms are replaced too: the sanitizers' runtimes define
// them without calling the replaced operator new, so their blocks would otherwise reach the
// free() below from another allocator (RawInflater/RawDeflater allocate with new (std::nothrow)).
// The aligned forms are left to the implementation (they pair with their own deletes). The
// deallocation functions are not inlined: GCC would otherwise see free() applied to the
// result of a new-expression and warn (-Wmismatched-new-delete) in every caller.
//
// Under ThreadSanitizer nothing is replaced and global_news() stays 0: TSan's runtime defines
// the global operator new itself, in the same program, so a replacement cannot be linked. The
// allocation checks are made by the release and ASan stages; the TSan stage checks for races.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>

#if defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define BTFLOD_TEST_NO_NEW_REPLACEMENT 1
#endif
#endif
#if defined(__SANITIZE_THREAD__) && !defined(BTFLOD_TEST_NO_NEW_REPLACEMENT)
#define BTFLOD_TEST_NO_NEW_REPLACEMENT 1
#endif

namespace btflod_test {

inline std::atomic<uint64_t> g_global_news{0};

/// operator new / new[] calls since the program started (all threads, all replaced forms).
inline uint64_t global_news() noexcept { return g_global_news.load(std::memory_order_relaxed); }

/// malloc with a count; never returns null for a successful call (size 0 allocates 1 byte).
inline void* counted_malloc(std::size_t n) noexcept {
  g_global_news.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(n ? n : 1);
}

}  // namespace btflod_test

#if !defined(BTFLOD_TEST_NO_NEW_REPLACEMENT)
[[gnu::noinline]] void* operator new(std::size_t n) {
  if (void* p = btflod_test::counted_malloc(n)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void* operator new[](std::size_t n) {
  if (void* p = btflod_test::counted_malloc(n)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void operator delete(void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete[](void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
[[gnu::noinline]] void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  return btflod_test::counted_malloc(n);
}
[[gnu::noinline]] void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  return btflod_test::counted_malloc(n);
}
[[gnu::noinline]] void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
#endif  // BTFLOD_TEST_NO_NEW_REPLACEMENT
