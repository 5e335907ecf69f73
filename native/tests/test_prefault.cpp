// Large buffers and their pages. prefault (native/src/runtime/prefault.h): mapping a
// buffer's pages ahead keeps its contents and its neighbours', makes the pages
// resident, and offers the whole 2 MiB stretches inside it to transparent huge
// pages unless ARAP_NO_HUGE_PAGES is set. allocate_large and LargeBuffer
// (large_allocation.h, large_buffer.h): 2 MiB-aligned zeroed memory, usable to
// the last byte asked for, offered to huge pages the same way.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/mman.h>
#include <unistd.h>
#include <vector>

#include "runtime/large_allocation.h"
#include "runtime/large_buffer.h"
#include "runtime/prefault.h"

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

TEST(LargeAllocation, AlignedZeroedWritableToTheLastByteAndAdvisedUnlessSwitchedOff) {
  unsetenv("ARAP_NO_HUGE_PAGES");
  // Sizes around the rounding of the last partial 2 MiB (kept as is below 1 MiB of it, made whole above).
  for (const std::size_t bytes : {arap::kLargeAllocation, 2 * kMiB, 2 * kMiB + 4096 + 5, 3 * kMiB - 1, 3 * kMiB + 7,
                                  5 * kMiB + 3 * kMiB / 4}) {
    auto* data = static_cast<unsigned char*>(arap::allocate_large(bytes));
    ASSERT_NE(data, nullptr);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(data) % (2 * kMiB), 0u) << bytes;
    std::size_t nonzero = 0;
    for (std::size_t k = 0; k < bytes; ++k) nonzero += data[k] != 0;
    EXPECT_EQ(nonzero, 0u) << bytes;
    for (std::size_t k = 0; k < bytes; ++k) data[k] = static_cast<unsigned char>(k * 7);
    for (std::size_t k = 0; k < bytes; k += 4099) ASSERT_EQ(data[k], static_cast<unsigned char>(k * 7)) << bytes;
    ASSERT_EQ(data[bytes - 1], static_cast<unsigned char>((bytes - 1) * 7)) << bytes;
    // Every size here maps at least one whole 2 MiB (1 MiB is at least half of its 2 MiB).
    if (transparent_huge_pages_configured()) {
      EXPECT_TRUE(advised_huge(data, data + bytes)) << bytes;
    }
    arap::free_large(data, bytes);
  }
  setenv("ARAP_NO_HUGE_PAGES", "1", 1);
  void* off = arap::allocate_large(4 * kMiB);
  EXPECT_FALSE(advised_huge(off, static_cast<unsigned char*>(off) + 4 * kMiB));
  arap::free_large(off, 4 * kMiB);
  unsetenv("ARAP_NO_HUGE_PAGES");
}

TEST(LargeAllocation, LargeBufferGrowsCopiesAndShrinksAcrossTheThreshold) {
  // From operator new's storage to mapped storage and back, contents kept.
  arap::LargeBuffer<double> v;
  const std::size_t large = 3 * arap::kLargeAllocation / sizeof(double);
  for (std::size_t k = 0; k < large; ++k) v.push_back(static_cast<double>(k));
  arap::LargeBuffer<double> copy = v;
  for (std::size_t k = 0; k < large; k += 997) ASSERT_EQ(copy[k], static_cast<double>(k));
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(copy.data()) % (2 * kMiB), 0u);
  copy.resize(100);
  copy.shrink_to_fit();
  EXPECT_EQ(copy.back(), 99.0);
  v = std::move(copy);
  EXPECT_EQ(v.size(), 100u);
  EXPECT_EQ(v[42], 42.0);
}

}  // namespace
