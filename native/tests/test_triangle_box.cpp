// The triangle-box test that decides which lattice cubes an infill surface
// meets (volume/triangle_box.h): closed sets, each separating axis.

#include <gtest/gtest.h>

#include "volume/triangle_box.h"

using Eigen::Vector3d;

namespace {

const Vector3d kLo(0, 0, 0), kHi(1, 1, 1);

bool meets(const Vector3d& a, const Vector3d& b, const Vector3d& c) {
  return arap::triangle_meets_box(a, b, c, kLo, kHi, 0.0);
}

}  // namespace

TEST(TriangleBox, InsideCrossingAndAwayFromTheBox) {
  EXPECT_TRUE(meets({0.2, 0.2, 0.5}, {0.8, 0.2, 0.5}, {0.5, 0.8, 0.5}));     // inside
  EXPECT_TRUE(meets({-5, -5, 0.5}, {5, -5, 0.5}, {0, 5, 0.5}));              // a large one through it
  EXPECT_FALSE(meets({2, 0, 0}, {3, 0, 0}, {2, 1, 0}));                      // beside it (a box axis)
  EXPECT_FALSE(meets({-1, -1, 3}, {3, -1, 3.5}, {-1, 3, 3.2}));              // above it (the normal)
}

TEST(TriangleBox, TouchingCountsAsMeeting) {
  EXPECT_TRUE(meets({1, 0.2, 0.2}, {2, 0.2, 0.2}, {1, 0.8, 0.8}));           // a corner on the face x = 1
  EXPECT_TRUE(meets({0, 0, 1}, {1, 0, 1}, {0, 1, 1}));                       // lying in the top face
  EXPECT_FALSE(meets({1.001, 0.2, 0.2}, {2, 0.2, 0.2}, {1.001, 0.8, 0.8}));  // just off it
  EXPECT_TRUE(arap::triangle_meets_box({1.001, 0.2, 0.2}, {2, 0.2, 0.2}, {1.001, 0.8, 0.8}, kLo, kHi, 0.01));
}

TEST(TriangleBox, ASlantedTriangleBesideAnEdgeIsSeparatedByItsPlane) {
  // Every box axis overlaps; the plane x + y = 2.5 passes beside the box's edge x = y = 1.
  EXPECT_FALSE(meets({1.6, 0.9, -1}, {0.9, 1.6, -1}, {1.25, 1.25, 2}));
  // The plane x + y = 1.9 cuts that edge's corner off the box.
  EXPECT_TRUE(meets({1.2, 0.7, -1}, {0.7, 1.2, -1}, {0.95, 0.95, 2}));
}

TEST(TriangleBox, AFlatBoxIsAFace) {
  const Vector3d lo(1, 0, 0), hi(1, 1, 1);  // the face x = 1 of the unit cube
  EXPECT_TRUE(arap::triangle_meets_box({0.5, 0.5, 0.5}, {1.5, 0.5, 0.5}, {0.5, 0.6, 0.6}, lo, hi, 0.0));
  EXPECT_FALSE(arap::triangle_meets_box({0.2, 0.5, 0.5}, {0.8, 0.5, 0.5}, {0.2, 0.6, 0.6}, lo, hi, 0.0));
}
