// The relative-motion bound that lets a near-pair list outlive long moves
// (contact/relative_motion.h): the bound it gives holds anywhere on a straight
// move, a move that carries everything along holds, and one that brings two
// clusters nearer than their room (their gap less the activation distance) does not.
#include <gtest/gtest.h>

#include <Eigen/Core>

#include <cmath>
#include <random>
#include <vector>

#include "contact/relative_motion.h"

namespace {

using arap::contact::RelativeMotion;
using Rows = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

// n vertices on a line of triangles (0,1,2), (1,2,3), ...; cluster k holds vertices with v / size == k.
struct Strip {
  int n;
  std::vector<int> triangles, cluster_of, surface;
  Strip(int count, int size) : n(count) {
    for (int v = 0; v + 2 < n; ++v) triangles.insert(triangles.end(), {v, v + 1, v + 2});
    for (int v = 0; v < n; ++v) cluster_of.push_back(v / size), surface.push_back(v);
  }
  int clusters() const { return cluster_of.back() + 1; }
};

TEST(ContactRelativeMotion, TheBoundHoldsAnywhereOnTheMove) {
  const Strip strip(60, 7);
  RelativeMotion motion;
  motion.bind(strip.cluster_of, strip.clusters(), strip.surface);
  const long triangle_count = static_cast<long>(strip.triangles.size() / 3);
  std::mt19937 random(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Rows reference(strip.n, 3), P0(strip.n, 3), P1(strip.n, 3);
    const Eigen::RowVector3d drift0(normal(random), normal(random), normal(random));
    const Eigen::RowVector3d drift1(normal(random), normal(random), normal(random));
    const double noise = trial % 3 == 0 ? 1.0 : 0.05;
    for (int v = 0; v < strip.n; ++v) {
      reference.row(v) << v * 0.1, std::sin(v * 0.3), 0.0;
      P0.row(v) = reference.row(v) + drift0 * (1 + 0.01 * v) +
                  noise * Eigen::RowVector3d(normal(random), normal(random), normal(random));
      P1.row(v) = reference.row(v) + drift1 * (1 - 0.02 * v) +
                  noise * Eigen::RowVector3d(normal(random), normal(random), normal(random));
    }
    // Room enough: the bound itself is under test.
    motion.set_reference(reference.data(), strip.triangles.data(), triangle_count, 1e6, 0.0);
    ASSERT_TRUE(motion.holds(reference.data(), P0.data(), P1.data()));
    for (double t : {0.0, 0.2, 0.5, 0.8, 1.0}) {
      const Rows D = (1 - t) * P0 + t * P1 - reference;
      for (int a = 0; a < strip.n; ++a)
        for (int b = a + 1; b < strip.n; ++b) {
          const double apart = (D.row(a) - D.row(b)).norm();
          ASSERT_LE(apart, motion.bound(a, b) * (1 + 1e-12) + 1e-12) << "trial " << trial << " t " << t;
          ASSERT_LE(motion.bound(a, b), motion.largest_bound() * (1 + 1e-12));
          ++checked;
        }
    }
  }
  EXPECT_GT(checked, 100000);
}

TEST(ContactRelativeMotion, TheRoomIsTheGapBetweenClusters) {
  // Two strips of 20 vertices, one cluster each, 1.0 apart (z = 0 and z = 1).
  const int n = 40;
  std::vector<int> triangles, cluster_of, surface;
  for (int v = 0; v + 2 < n; ++v)
    if (v / 20 == (v + 2) / 20) triangles.insert(triangles.end(), {v, v + 1, v + 2});
  for (int v = 0; v < n; ++v) cluster_of.push_back(v / 20), surface.push_back(v);
  RelativeMotion motion;
  motion.bind(cluster_of, 2, surface);
  Rows reference(n, 3);
  for (int v = 0; v < n; ++v) reference.row(v) << (v % 20) * 0.1, (v % 2) * 0.1, v < 20 ? 0.0 : 1.0;
  const double margin = 0.05, activation = 0.01;
  motion.set_reference(reference.data(), triangles.data(), static_cast<long>(triangles.size() / 3), margin, activation);
  // Everything carried 100 margins along: nothing comes nearer.
  const Rows carried = reference.rowwise() + Eigen::RowVector3d(5.0, -3.0, 2.0);
  EXPECT_TRUE(motion.holds(reference.data(), reference.data(), carried.data()));
  EXPECT_TRUE(motion.holds(reference.data(), carried.data(), carried.data()));
  // The upper strip lowered by half the gap: ten margins, but within the room of 1.0 less the activation.
  Rows lowered = reference;
  for (int v = 20; v < n; ++v) lowered(v, 2) -= 0.5;
  EXPECT_TRUE(motion.holds(reference.data(), reference.data(), lowered.data()));
  // Lowered to within the activation distance: refused.
  for (int v = 20; v < n; ++v) lowered(v, 2) = 0.005;
  EXPECT_FALSE(motion.holds(reference.data(), reference.data(), lowered.data()));
  // One vertex squeezed towards its neighbours by more than the margin: refused.
  Rows squeezed = reference;
  squeezed(3, 0) += 2 * margin;
  EXPECT_FALSE(motion.holds(reference.data(), reference.data(), squeezed.data()));
}

}  // namespace
