#include "large_allocation.h"

#include <cstdint>
#include <cstdlib>
#include <new>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace arap {

namespace {

std::size_t round_up(std::size_t x, std::size_t to) { return (x + to - 1) / to * to; }

// The mapping behind a request: whole pages, and the last partial 2 MiB made
// whole when it is at least half used (a huge page then costs less than the
// small pages it replaces, and at most 1 MiB is mapped beyond the buffer).
// Depends on `bytes` alone, so that free_large unmaps what allocate_large mapped.
std::size_t mapped_size(std::size_t bytes) {
  const std::size_t pages = round_up(bytes, page_size());
  return pages % kHugePage >= kHugePage / 2 ? round_up(pages, kHugePage) : pages;
}

}  // namespace

std::size_t page_size() {
#if defined(__linux__)
  static const std::size_t page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  return page;
#else
  return 4096;
#endif
}

bool huge_pages_wanted() { return !std::getenv("ARAP_NO_HUGE_PAGES"); }

#if defined(__linux__) && defined(MAP_ANONYMOUS)

void* allocate_large(std::size_t bytes) {
  const std::size_t size = mapped_size(bytes);
  // Map 2 MiB more than needed and cut the unaligned ends off.
  const std::size_t reserve = size + kHugePage;
  void* raw = mmap(nullptr, reserve, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) throw std::bad_alloc();
  const auto base = reinterpret_cast<std::uintptr_t>(raw);
  const std::uintptr_t aligned = round_up(base, kHugePage);
  if (aligned > base) munmap(raw, aligned - base);
  if (base + reserve > aligned + size) munmap(reinterpret_cast<void*>(aligned + size), base + reserve - aligned - size);
  void* data = reinterpret_cast<void*>(aligned);
#if defined(MADV_HUGEPAGE)
  if (huge_pages_wanted() && size >= kHugePage) madvise(data, size / kHugePage * kHugePage, MADV_HUGEPAGE);
#endif
  return data;
}

void free_large(void* data, std::size_t bytes) noexcept {
  if (data) munmap(data, mapped_size(bytes));
}

#else

void* allocate_large(std::size_t bytes) {
  void* data = std::aligned_alloc(kHugePage, round_up(bytes, kHugePage));
  if (!data) throw std::bad_alloc();
  return data;
}

void free_large(void* data, std::size_t) noexcept { std::free(data); }

#endif

}  // namespace arap
