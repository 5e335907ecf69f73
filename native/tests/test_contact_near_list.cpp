// The near-pair list's grouping by distance (contact/near_list.h): what a move
// scans holds every pair nearer than its bound, and the grouping is stable.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "contact/near_list.h"

using arap::contact::NearList;
using arap::contact::NearPair;

TEST(ContactNearList, ScansEveryPairNearerThanTheBound) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> distance(0.0, 1.5);
  NearList list;
  list.start(1.5);
  std::vector<NearPair> added;
  for (std::uint64_t k = 0; k < 5000; ++k) {
    const double d = k % 50 == 0 ? 0.0 : (k % 77 == 0 ? 1.5 : distance(rng));  // both ends too
    list.add(d, k);
    added.push_back({d, k});
  }
  list.finish();
  ASSERT_EQ(list.pairs().size(), added.size());
  for (double within : {0.0, 1e-9, 0.01, 0.3, 0.7499, 1.0, 1.49, 1.5, 2.0}) {
    const size_t scanned = list.count_below(within);
    std::vector<bool> seen(added.size(), false);
    for (size_t i = 0; i < scanned; ++i) seen[list.pairs()[i].key] = true;
    for (const NearPair& n : added) {
      if (n.distance < within) {
        EXPECT_TRUE(seen[n.key]) << "within " << within << " missed " << n.distance;
      }
    }
    // Beyond what is scanned, nothing is nearer than the bound.
    for (size_t i = scanned; i < list.pairs().size(); ++i) EXPECT_GE(list.pairs()[i].distance, within);
  }
  // Slices in order of distance; inside a slice, the order pairs were added in.
  for (size_t i = 1; i < list.pairs().size(); ++i) {
    const NearPair& a = list.pairs()[i - 1];
    const NearPair& b = list.pairs()[i];
    const int slice_a = static_cast<int>(a.distance / 1.5 * NearList::kBuckets);
    const int slice_b = static_cast<int>(b.distance / 1.5 * NearList::kBuckets);
    if (std::min(slice_a, NearList::kBuckets - 1) == std::min(slice_b, NearList::kBuckets - 1)) {
      EXPECT_LT(a.key, b.key);
    } else {
      EXPECT_LT(a.distance, b.distance);
    }
  }
}

TEST(ContactNearList, StartsEmptyAgain) {
  NearList list;
  list.start(1.0);
  list.add(0.5, 1);
  list.finish();
  list.start(2.0);
  list.finish();
  EXPECT_TRUE(list.pairs().empty());
  EXPECT_EQ(list.count_below(1.0), 0u);
}
