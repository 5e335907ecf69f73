// Micro-benchmark of the 3x3 rotation fit: the fast Davenport/Newton path
// against Eigen's JacobiSVD on the same covariances (docs/design.md, "How it works").
//   build/arap-bench-rotation-fit [cells]
#include <chrono>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "arap/rotation_fit.h"

int main(int argc, char** argv) {
  const int cells = argc > 1 ? std::stoi(argv[1]) : 200000;
  // Near-rotations of a flat-ish cell, as in a deforming surface.
  std::mt19937 rng(1);
  std::normal_distribution<double> noise;
  std::vector<Eigen::Matrix3d> A(cells), R(cells);
  for (auto& a : A) {
    a << 1, 0, 0, 0, 1, 0, 0, 0, 0.05;
    for (int i = 0; i < 9; ++i) a(i / 3, i % 3) += 0.2 * noise(rng);
  }
  using Clock = std::chrono::steady_clock;
  auto ns_per_cell = [&](auto&& fit) {
    double best = 1e300;
    for (int repeat = 0; repeat < 5; ++repeat) {
      const auto t = Clock::now();
      for (int i = 0; i < cells; ++i) fit(i);
      best = std::min(best, std::chrono::duration<double, std::nano>(Clock::now() - t).count() / cells);
    }
    return best;
  };
  long fallbacks = 0;
  const double fast = ns_per_cell([&](int i) { fallbacks += arap::fit_rotation(A[i], R[i]); });
  const double svd = ns_per_cell([&](int i) { R[i] = arap::fit_rotation_svd(A[i]); });
  std::printf("rotation fit: %.1f ns per cell, JacobiSVD %.1f ns (best of 5 over %d cells; %ld SVD fallbacks)\n", fast,
              svd, cells, fallbacks / 5);
  return 0;
}
