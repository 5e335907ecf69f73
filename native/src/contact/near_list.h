// The watched pairs found near where a list was made, grouped by that distance
// into kBuckets equal slices of [0, reach) (a counting sort: linear, stable).
// A move that can bring pairs at most `within` nearer than they were listed
// scans only the slices below `within`; the caller still tests each pair's
// own distance. Nothing is allocated once the vectors have grown, and they
// grow only after checking that the room fits in memory: on a mesh whose
// triangles are far smaller than its mean edge, the pairs within reach can
// outnumber what the machine holds (docs/contact.md, Limits).
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "runtime/memory_headroom.h"

namespace arap::contact {

struct NearPair {
  double distance;  // where the list was made
  std::uint64_t key;
};

// Appends a pair to `into`, growing it only after checking that the room fits in memory.
// Throws arap::Error(OutOfMemory) when the list would not fit.
// Twice the block: the lists that a NearList fills from it follow.
inline void keep_near_pair(std::vector<NearPair>& into, double distance, std::uint64_t key) {
  push_within_headroom(into, NearPair{distance, key}, 2,
                       "Self Contact's list of near surface pairs (the mesh has triangles far "
                       "smaller than its mean edge; turn Self Contact off or remesh it more evenly)");
}

class NearList {
 public:
  static constexpr int kBuckets = 64;

  void start(double reach) {
    reach_ = reach;
    found_.clear();
  }
  // Throws arap::Error(OutOfMemory) when the list would not fit in memory.
  void add(double distance, std::uint64_t key) { keep_near_pair(found_, distance, key); }
  // Groups what add() found by distance; pairs() is then in slice order.
  void finish() {
    std::fill(begin_, begin_ + kBuckets + 1, 0);
    for (const NearPair& n : found_) ++begin_[bucket(n.distance) + 1];
    for (int b = 0; b < kBuckets; ++b) begin_[b + 1] += begin_[b];
    pairs_.resize(found_.size());
    int next[kBuckets];
    std::copy(begin_, begin_ + kBuckets, next);
    for (const NearPair& n : found_) pairs_[next[bucket(n.distance)]++] = n;
  }
  const std::vector<NearPair>& pairs() const { return pairs_; }
  // How many of pairs() (from the front) can be nearer than `within`.
  size_t count_below(double within) const {
    if (!(within < reach_)) return pairs_.size();
    return static_cast<size_t>(begin_[bucket(within) + 1]);
  }

 private:
  int bucket(double distance) const {
    const double slice = distance / reach_ * kBuckets;
    return slice >= kBuckets - 1 ? kBuckets - 1 : (slice > 0 ? static_cast<int>(slice) : 0);
  }
  double reach_ = 1;
  int begin_[kBuckets + 1] = {};
  std::vector<NearPair> found_, pairs_;
};

}  // namespace arap::contact
