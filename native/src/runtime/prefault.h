// Large buffers about to be written in full: their pages mapped in one call
// instead of one page fault per 4 KiB on first touch, which costs about half
// as much CPU (Linux >= 5.14, MADV_POPULATE_WRITE; elsewhere, or when the
// kernel refuses, nothing happens and the pages fault in as usual). Only for
// memory the caller will write anyway: it becomes resident now, not later.
// Whole 2 MiB stretches of it are offered to transparent huge pages (unless
// ARAP_NO_HUGE_PAGES is set in the environment).
#pragma once

#include <cstddef>

namespace arap {

void prefault(void* data, std::size_t bytes);

// The elements [0, count) of a contiguous buffer (count defaults to its size).
template <class Buffer>
void prefault_buffer(Buffer& buffer, std::size_t count) {
  prefault(static_cast<void*>(buffer.data()), count * sizeof(*buffer.data()));
}
template <class Buffer>
void prefault_buffer(Buffer& buffer) {
  prefault_buffer(buffer, buffer.size());
}

// v.resize(count) with the pages mapped first.
template <class Vector>
void resize_prefaulted(Vector& v, std::size_t count) {
  v.reserve(count);
  prefault(static_cast<void*>(v.data()), count * sizeof(*v.data()));
  v.resize(count);
}

// v.assign(count, x) with the pages mapped first.
template <class Vector, class T>
void assign_prefaulted(Vector& v, std::size_t count, const T& x) {
  v.clear();
  v.reserve(count);
  prefault(static_cast<void*>(v.data()), count * sizeof(*v.data()));
  v.assign(count, x);
}

}  // namespace arap
