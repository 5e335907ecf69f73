// Passes over the quasi-Newton method's long vectors (3 values per free
// vertex), in two fixed halves from kSplitLength values on. The split, and so
// every partial sum and its rounding, does not depend on the thread count:
// one thread runs the halves in turn, two run them side by side, and the
// results are the same bit for bit. Short vectors stay in one piece.
#pragma once

#include <cstddef>
#include "worker_threads.h"

namespace arap {

// From this many free vertices the Laplacian's factor is split in two halves
// and a separator (linalg/spd_solve.h) and these vector passes run in halves:
// below it a solve or a pass is too short for a second thread.
constexpr std::ptrdiff_t kSplitRows = 20000;
constexpr std::ptrdiff_t kSplitLength = 3 * kSplitRows;  // x, y, z of each free vertex

// body(begin, end, half) for half 0 = [0, mid) and half 1 = [mid, n).
template <class Body>
void for_each_half(std::ptrdiff_t n, int threads, const Body& body) {
  if (n < kSplitLength) {
    body(std::ptrdiff_t(0), n, 0);
    return;
  }
  const std::ptrdiff_t mid = n / 2 / 12 * 12;  // whole vertices, and whole 4-wide blocks of the unrolled sums
  run_side_by_side(threads > 1, [&] { body(std::ptrdiff_t(0), mid, 0); }, [&] { body(mid, n, 1); });
}

// The sum of body(begin, end) over the halves, added in a fixed order.
template <class Body>
double sum_over_halves(std::ptrdiff_t n, int threads, const Body& body) {
  double part[2] = {0, 0};
  for_each_half(n, threads, [&](std::ptrdiff_t begin, std::ptrdiff_t end, int half) { part[half] = body(begin, end); });
  return part[0] + part[1];
}

}  // namespace arap
