// btflod — allocation callbacks (what libdeflate's libdeflate_set_memory_allocator and VMA's
// VkAllocationCallbacks give an engine), and a standard-library allocator over them so that the
// containers of the per-frame objects (lod/, vt/) allocate through the engine's callbacks at
// set-up, and RuntimeArray<T>, the fixed arrays of the runtime objects (runtime/, stream/).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <span>
#include <type_traits>
#include <utility>

namespace btflod {

/// Allocation callbacks given at creation. Both null: global operator new / delete (aligned).
/// allocate returns memory of at least `bytes` bytes aligned to `alignment` (a power of two ≤
/// 64), or null on failure; deallocate receives the same size and alignment. Called only from
/// the thread that creates or destroys the runtime object.
struct RuntimeAllocator {
  void* (*allocate)(void* user, size_t bytes, size_t alignment) = nullptr;
  void (*deallocate)(void* user, void* pointer, size_t bytes, size_t alignment) = nullptr;
  void* user = nullptr;

  /// Allocates through the callbacks (or operator new). Returns null on failure. noexcept.
  void* allocate_bytes(size_t bytes, size_t alignment) const noexcept {
    if (bytes == 0) bytes = 1;
    if (allocate != nullptr) return allocate(user, bytes, alignment);
    return ::operator new(bytes, std::align_val_t(alignment), std::nothrow);
  }
  /// Releases memory from allocate_bytes() with the same size and alignment. noexcept.
  void deallocate_bytes(void* p, size_t bytes, size_t alignment) const noexcept {
    if (p == nullptr) return;
    if (bytes == 0) bytes = 1;
    if (deallocate != nullptr) return deallocate(user, p, bytes, alignment);
    ::operator delete(p, std::align_val_t(alignment), std::nothrow);
  }
};

/// A standard allocator (for std::vector) that allocates through a RuntimeAllocator. Used by
/// the per-frame objects only while they are set up (their containers never grow afterwards).
/// When the callback fails the program aborts, as std::allocator does without exceptions:
/// set-up memory is not optional. Equal when their callbacks and user pointers are.
template <class T>
struct CallbackAllocator {
  using value_type = T;
  // The callbacks travel with the container's memory on moves, copies and swaps.
  using propagate_on_container_move_assignment = std::true_type;
  using propagate_on_container_copy_assignment = std::true_type;
  using propagate_on_container_swap = std::true_type;
  RuntimeAllocator callbacks;

  CallbackAllocator() noexcept = default;
  explicit CallbackAllocator(const RuntimeAllocator& c) noexcept : callbacks(c) {}
  template <class U>
  CallbackAllocator(const CallbackAllocator<U>& o) noexcept : callbacks(o.callbacks) {}

  /// n objects' memory. Aborts when the callback fails or n is too large.
  T* allocate(size_t n) {
    if (n > SIZE_MAX / sizeof(T)) std::abort();
    void* p = callbacks.allocate_bytes(n * sizeof(T), alignment());
    if (p == nullptr) std::abort();
    return static_cast<T*>(p);
  }
  /// Returns memory from allocate(n).
  void deallocate(T* p, size_t n) noexcept { callbacks.deallocate_bytes(p, n * sizeof(T), alignment()); }

  template <class U>
  friend bool operator==(const CallbackAllocator& a, const CallbackAllocator<U>& b) noexcept {
    return a.callbacks.allocate == b.callbacks.allocate && a.callbacks.deallocate == b.callbacks.deallocate &&
           a.callbacks.user == b.callbacks.user;
  }

 private:
  static constexpr size_t alignment() noexcept { return alignof(T) < 16 ? 16 : alignof(T); }
};

/// A fixed-size array allocated once through a RuntimeAllocator (no growth, no copies): the
/// storage of the runtime's per-frame buffers. Elements are value-initialised; movable only.
template <class T>
class RuntimeArray {
 public:
  using value_type = T;
  RuntimeArray() = default;
  RuntimeArray(const RuntimeArray&) = delete;
  RuntimeArray& operator=(const RuntimeArray&) = delete;
  RuntimeArray(RuntimeArray&& o) noexcept { swap(o); }
  RuntimeArray& operator=(RuntimeArray&& o) noexcept {
    if (this != &o) {
      reset();
      swap(o);
    }
    return *this;
  }
  ~RuntimeArray() { reset(); }

  /// Allocates n value-initialised elements (releasing any previous ones). Returns false when
  /// the allocator fails (the array is then empty). Set-up only.
  bool allocate(const RuntimeAllocator& allocator, size_t n) noexcept {
    reset();
    if (n == 0) return true;
    if (n > SIZE_MAX / sizeof(T)) return false;
    void* p = allocator.allocate_bytes(n * sizeof(T), alignof(T) < 16 ? 16 : alignof(T));
    if (p == nullptr) return false;
    allocator_ = allocator;
    data_ = static_cast<T*>(p);
    for (size_t i = 0; i < n; ++i) ::new (static_cast<void*>(data_ + i)) T();
    size_ = n;
    return true;
  }
  /// Destroys the elements and returns the memory. noexcept.
  void reset() noexcept {
    if (data_ == nullptr) return;
    for (size_t i = size_; i-- > 0;) data_[i].~T();
    allocator_.deallocate_bytes(data_, size_ * sizeof(T), alignof(T) < 16 ? 16 : alignof(T));
    data_ = nullptr;
    size_ = 0;
  }
  T* data() noexcept { return data_; }
  const T* data() const noexcept { return data_; }
  size_t size() const noexcept { return size_; }
  T& operator[](size_t i) noexcept { return data_[i]; }
  const T& operator[](size_t i) const noexcept { return data_[i]; }
  std::span<T> span() noexcept { return {data_, size_}; }
  std::span<const T> span() const noexcept { return {data_, size_}; }

 private:
  void swap(RuntimeArray& o) noexcept {
    std::swap(data_, o.data_);
    std::swap(size_, o.size_);
    std::swap(allocator_, o.allocator_);
  }
  T* data_ = nullptr;
  size_t size_ = 0;
  RuntimeAllocator allocator_;
};

/// Bytes and allocations a set-up makes, computed without making them: the memory queries of
/// the runtime objects (Streamer::memory_required(), TileCache::memory_required(), …) add up
/// their arrays with it, in the sizes their create() allocates.
struct AllocationTally {
  uint64_t bytes = 0;
  uint64_t allocations = 0;
  /// One array of n elements of a container's value type (std::vector assign/reserve or
  /// RuntimeArray::allocate); nothing when n is 0.
  template <class Container>
  constexpr void array(uint64_t n) noexcept {
    block(n * sizeof(typename Container::value_type));
  }
  /// One allocation of `size` bytes; nothing when size is 0.
  constexpr void block(uint64_t size) noexcept {
    if (size == 0) return;
    bytes += size;
    ++allocations;
  }
  constexpr AllocationTally& operator+=(const AllocationTally& o) noexcept {
    bytes += o.bytes;
    allocations += o.allocations;
    return *this;
  }
};

}  // namespace btflod
