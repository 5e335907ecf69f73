// std::vector for the bind's large buffers (the factor's entries and rows,
// the spokes): resizing does not zero-fill (every element is written before
// it is read), and from 2 MiB up the storage is aligned to 2 MiB and offered
// to Linux's transparent huge pages (madvise), so that the first touch of
// each 2 MiB costs one page fault instead of 512. Only these buffers get the
// advice; nothing about the process's allocator changes. ARAP_NO_HUGE_PAGES
// in the environment turns the advice off (to measure it).
#pragma once

#include <cstddef>
#include <cstdlib>
#include <memory>
#include <new>
#include <utility>
#include <vector>

namespace arap {

namespace large_buffer {
constexpr std::size_t kHugePage = std::size_t(2) << 20;
// 2 MiB-aligned storage of `bytes` (>= kHugePage), huge pages advised where available.
void* allocate(std::size_t bytes);
inline void deallocate(void* p) { std::free(p); }
}  // namespace large_buffer

template <class T>
struct LargeBufferAllocator : std::allocator<T> {
  using value_type = T;
  template <class U>
  struct rebind {
    using other = LargeBufferAllocator<U>;
  };
  LargeBufferAllocator() noexcept = default;
  template <class U>
  LargeBufferAllocator(const LargeBufferAllocator<U>&) noexcept {}

  T* allocate(std::size_t n) {
    if (n * sizeof(T) < large_buffer::kHugePage) return std::allocator<T>::allocate(n);
    return static_cast<T*>(large_buffer::allocate(n * sizeof(T)));
  }
  void deallocate(T* p, std::size_t n) noexcept {
    if (n * sizeof(T) < large_buffer::kHugePage) return std::allocator<T>::deallocate(p, n);
    large_buffer::deallocate(p);
  }
  // Value-initialisation (resize(n)) default-initialises: no zero fill.
  template <class U>
  void construct(U* p) noexcept(noexcept(::new (static_cast<void*>(p)) U)) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

template <class T, class U>
bool operator==(const LargeBufferAllocator<T>&, const LargeBufferAllocator<U>&) noexcept {
  return true;
}
template <class T, class U>
bool operator!=(const LargeBufferAllocator<T>&, const LargeBufferAllocator<U>&) noexcept {
  return false;
}

template <class T>
using LargeBuffer = std::vector<T, LargeBufferAllocator<T>>;

}  // namespace arap
