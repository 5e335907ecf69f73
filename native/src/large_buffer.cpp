#include "large_buffer.h"

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace arap::large_buffer {

void* allocate(std::size_t bytes) {
#if defined(__linux__)
  void* p = nullptr;
  if (posix_memalign(&p, kHugePage, bytes) != 0) throw std::bad_alloc();
#else
  void* p = std::malloc(bytes);
  if (!p) throw std::bad_alloc();
#endif
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  // Whole huge pages only: the tail keeps ordinary pages. A refusal (no THP in
  // this kernel) changes nothing but the speed of the first touch.
  static const bool advise = !std::getenv("ARAP_NO_HUGE_PAGES");
  if (advise) madvise(p, bytes / kHugePage * kHugePage, MADV_HUGEPAGE);
#endif
  return p;
}

}  // namespace arap::large_buffer
