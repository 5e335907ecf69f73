#include "prefault.h"

#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
// Linux 5.14's value: older C library headers (Debian 11's, where the distributed
// module is built) lack the name; an older kernel refuses the advice (EINVAL), harmlessly.
#ifndef MADV_POPULATE_WRITE
#define MADV_POPULATE_WRITE 23
#endif
#endif

#include "large_allocation.h"

namespace arap {

void prefault(void* data, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_POPULATE_WRITE)
  constexpr std::size_t kWorthIt = std::size_t(64) << 10;  // below this, a few faults cost less than the call
  if (bytes < kWorthIt) return;
  const std::uintptr_t page = page_size();
  // Whole pages inside the buffer only: the pages it shares with neighbours are left alone.
  const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(data) + page - 1) / page * page;
  const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(data) + bytes) / page * page;
  if (end <= begin) return;
#if defined(MADV_HUGEPAGE)
  // The whole 2 MiB-aligned stretches inside the buffer may be backed by
  // transparent huge pages (where the system allows it on request, the
  // default "madvise" setting): one fault per 2 MiB instead of 512. The
  // buffer is written in full, so no huge page holds memory nobody uses.
  const std::uintptr_t huge_begin = (begin + kHugePage - 1) / kHugePage * kHugePage;
  const std::uintptr_t huge_end = end / kHugePage * kHugePage;
  if (huge_end > huge_begin && huge_pages_wanted())
    madvise(reinterpret_cast<void*>(huge_begin), huge_end - huge_begin, MADV_HUGEPAGE);
#endif
  madvise(reinterpret_cast<void*>(begin), end - begin, MADV_POPULATE_WRITE);
#else
  (void)data, (void)bytes;
#endif
}

}  // namespace arap
