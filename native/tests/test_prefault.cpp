// prefault (native/src/prefault.h): mapping a buffer's pages ahead keeps its
// contents and its neighbours', makes the pages resident, and offers the whole
// 2 MiB stretches inside it to transparent huge pages unless
// ARAP_NO_HUGE_PAGES is set.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/mman.h>
#include <unistd.h>
#include <vector>

#include "prefault.h"

namespace {

constexpr std::size_t kMiB = std::size_t(1) << 20;

// An anonymous mapping of its own, so that its flags are not shared with the heap's.
struct Mapping {
  explicit Mapping(std::size_t bytes) : size(bytes) {
    void* p = mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    data = p == MAP_FAILED ? nullptr : static_cast<unsigned char*>(p);
  }
  ~Mapping() {
    if (data) munmap(data, size);
  }
  unsigned char* data;
  std::size_t size;
};

// True when some part of [begin, end) lies in a mapping whose VmFlags hold "hg" (MADV_HUGEPAGE).
bool advised_huge(const void* begin, const void* end) {
  std::ifstream smaps("/proc/self/smaps");
  std::string line;
  std::uintptr_t lo = 0, hi = 0;
  const auto b = reinterpret_cast<std::uintptr_t>(begin), e = reinterpret_cast<std::uintptr_t>(end);
  while (std::getline(smaps, line)) {
    std::uintptr_t from, to;
    char dash;
    std::istringstream head(line);
    if (line.find("VmFlags:") == 0) {
      if (lo < e && hi > b && (line.find(" hg") != std::string::npos)) return true;
    } else if (head >> std::hex >> from >> dash >> to && dash == '-') {
      lo = from, hi = to;
    }
  }
  return false;
}

bool transparent_huge_pages_configured() {
  std::ifstream enabled("/sys/kernel/mm/transparent_hugepage/enabled");
  return enabled.good();
}

TEST(Prefault, KeepsTheBufferAndItsNeighboursAndMakesItResident) {
  Mapping map(8 * kMiB);
  ASSERT_NE(map.data, nullptr);
  // Written before, so that populating must not lose what is there; the
  // prefaulted range starts and ends inside pages.
  for (std::size_t k = 0; k < map.size; k += 4096) map.data[k] = static_cast<unsigned char>(k / 4096 + 1);
  map.data[100] = 77;
  unsigned char* const begin = map.data + 1000;
  const std::size_t bytes = 6 * kMiB + 123;
  arap::prefault(begin, bytes);
  for (std::size_t k = 0; k < map.size; k += 4096)
    ASSERT_EQ(map.data[k], static_cast<unsigned char>(k / 4096 + 1)) << "page " << k / 4096;
  EXPECT_EQ(map.data[100], 77);

  Mapping fresh(8 * kMiB);
  ASSERT_NE(fresh.data, nullptr);
  arap::prefault(fresh.data, fresh.size);
  for (std::size_t k = 0; k < fresh.size; k += 4096) ASSERT_EQ(fresh.data[k], 0) << "page " << k / 4096;
  // Where the kernel populates on request (Linux >= 5.14), every page is resident now.
  if (madvise(fresh.data, 4096, MADV_POPULATE_WRITE) == 0) {
    std::vector<unsigned char> resident(fresh.size / 4096);
    ASSERT_EQ(mincore(fresh.data, fresh.size, resident.data()), 0);
    for (std::size_t k = 0; k < resident.size(); ++k) EXPECT_TRUE(resident[k] & 1) << "page " << k;
  }
}

TEST(Prefault, OffersWhole2MiBStretchesToHugePagesUnlessSwitchedOff) {
  if (!transparent_huge_pages_configured()) GTEST_SKIP() << "this kernel has no transparent huge pages";
  unsetenv("ARAP_NO_HUGE_PAGES");
  Mapping small(8 * kMiB);
  ASSERT_NE(small.data, nullptr);
  // Under 2 MiB: no stretch to offer.
  arap::prefault(small.data + 4096, kMiB);
  EXPECT_FALSE(advised_huge(small.data, small.data + small.size));

  Mapping large(8 * kMiB);
  ASSERT_NE(large.data, nullptr);
  arap::prefault(large.data + 1000, 6 * kMiB);
  EXPECT_TRUE(advised_huge(large.data, large.data + large.size));

  setenv("ARAP_NO_HUGE_PAGES", "1", 1);
  Mapping off(8 * kMiB);
  ASSERT_NE(off.data, nullptr);
  arap::prefault(off.data + 1000, 6 * kMiB);
  EXPECT_FALSE(advised_huge(off.data, off.data + off.size));
  unsetenv("ARAP_NO_HUGE_PAGES");
}

}  // namespace
