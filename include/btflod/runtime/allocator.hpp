// btflod — allocator callbacks for the runtime (RuntimeAllocator, core/allocator.hpp; what
// libdeflate's libdeflate_set_memory_allocator and VMA's VkAllocationCallbacks give an engine):
// every buffer a runtime object allocates at creation goes through them, nothing allocates
// afterwards.
#pragma once

#include <cstddef>
#include <cstdint>
#include <new>
#include <span>
#include <type_traits>
#include <utility>

#include "btflod/core/allocator.hpp"

namespace btflod {

/// A fixed-size array allocated once through a RuntimeAllocator (no growth, no copies): the
/// storage of the runtime's per-frame buffers. Elements are value-initialised; movable only.
template <class T>
class RuntimeArray {
 public:
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

}  // namespace btflod
