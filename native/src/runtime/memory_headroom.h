// How much more memory this process can take before the system refuses it or
// kills the process. On Linux, allocations rarely fail: memory is overcommitted
// and the OOM killer ends the process when the pages are touched (in Blender:
// every unsaved change lost). So a large allocation is checked first against
// the least of
//   - the memory the system has left: MemAvailable + SwapFree (/proc/meminfo);
//   - the memory cgroup's limit less its usage, at every level of the
//     process's cgroup (v2: memory.max - memory.current; v1:
//     memory.limit_in_bytes - memory.usage_in_bytes): a container or a Slurm
//     job kills at that limit;
//   - the address-space limit (RLIMIT_AS) less the process's address space
//     (VmSize): above it, allocations fail.
// Where none can be read (not Linux), nothing is known and nothing is refused.
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

namespace arap {

struct MemoryHeadroom {
  std::size_t bytes = static_cast<std::size_t>(-1);  // the least of the limits; -1: none known
  std::string limit;                                 // which limit that is, in words ("" when none is known)
};

MemoryHeadroom memory_headroom();

// "1.4 GiB", "350 MiB": for messages.
std::string format_bytes(double bytes);

// Throws arap::Error(OutOfMemory) naming `what`, both figures and the limit
// when `bytes` more would not fit in memory_headroom().
void require_headroom(double bytes, const std::string& what);

// Room for more elements in `v` (its capacity doubled, by at least 4096),
// after require_headroom() for the new block times `copies` (1, or more when
// buffers of the same size will follow it): for lists whose length only the
// input decides, so that a hostile input is refused instead of killed.
template <class T>
void grow_within_headroom(std::vector<T>& v, double copies, const std::string& what) {
  const std::size_t capacity = v.capacity() + std::max<std::size_t>(4096, v.capacity());
  require_headroom(copies * static_cast<double>(capacity * sizeof(T)), what);
  v.reserve(capacity);
}

// Appends x to v, making room through grow_within_headroom() when v is full.
template <class T>
void push_within_headroom(std::vector<T>& v, const T& x, double copies, const char* what) {
  if (v.size() == v.capacity()) grow_within_headroom(v, copies, what);
  v.push_back(x);
}

}  // namespace arap
