// std::vector for large buffers that are written in full before they are
// read (the factor's entries and rows, the spokes, the edge groups and graph):
// resize(n) default-initialises the new elements instead of zero-filling
// them, which saves a pass over memory the size of the buffer.
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <utility>
#include <vector>

#include "large_allocation.h"

namespace arap {

// With OnLargePages, requests of kLargeAllocation bytes or more are mapped
// 2 MiB-aligned for huge pages (large_allocation.h): for the buffers that live
// as long as the binding (the spokes, the factor), not for temporaries, whose
// memory the C library reuses within the bind.
template <class T, bool OnLargePages = false>
struct DefaultInitAllocator : std::allocator<T> {
  using value_type = T;
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U, OnLargePages>;
  };
  DefaultInitAllocator() noexcept = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U, OnLargePages>&) noexcept {}
  T* allocate(std::size_t n) {
    if (OnLargePages && n * sizeof(T) >= kLargeAllocation) return static_cast<T*>(allocate_large(n * sizeof(T)));
    return std::allocator<T>::allocate(n);
  }
  void deallocate(T* p, std::size_t n) noexcept {
    if (OnLargePages && n * sizeof(T) >= kLargeAllocation) return free_large(p, n * sizeof(T));
    std::allocator<T>::deallocate(p, n);
  }
  // What resize(n) calls for each new element: default-initialisation.
  template <class U>
  void construct(U* p) noexcept(noexcept(::new (static_cast<void*>(p)) U)) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

template <class T, class U, bool L>
bool operator==(const DefaultInitAllocator<T, L>&, const DefaultInitAllocator<U, L>&) noexcept {
  return true;
}
template <class T, class U, bool L>
bool operator!=(const DefaultInitAllocator<T, L>&, const DefaultInitAllocator<U, L>&) noexcept {
  return false;
}

// An UninitializedVector whose large storage can sit on huge pages.
template <class T>
using LargeBuffer = std::vector<T, DefaultInitAllocator<T, true>>;

// Resized without zero-filling: write every element before reading it.
template <class T>
using UninitializedVector = std::vector<T, DefaultInitAllocator<T>>;

}  // namespace arap
