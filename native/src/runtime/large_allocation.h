// Memory for the largest buffers that live as long as a binding (the factor,
// the spokes: LargeBuffer in large_buffer.h) mapped straight from the system,
// aligned to 2 MiB, so that transparent huge pages can back it: one page fault
// per 2 MiB instead of 512. Smaller requests go to operator new as usual.
#pragma once

#include <cstddef>

namespace arap {

// Requests of at least this many bytes are mapped.
constexpr std::size_t kLargeAllocation = std::size_t(1) << 20;

// A transparent huge page on x86-64 (and on 4 KiB-page ARM64).
constexpr std::size_t kHugePage = std::size_t(2) << 20;

// The system's page size (sysconf; 4 KiB where there is none).
std::size_t page_size();

// False when ARAP_NO_HUGE_PAGES is set in the environment (read at each call).
bool huge_pages_wanted();

// `bytes` (>= kLargeAllocation) of fresh zeroed memory, 2 MiB-aligned; throws
// std::bad_alloc when the system refuses. Give the same `bytes` back to free.
void* allocate_large(std::size_t bytes);
void free_large(void* data, std::size_t bytes) noexcept;

}  // namespace arap
