// The crossing count that arap-mesh-measure reports (and the contact tests use).
#include <gtest/gtest.h>

#include "arap/io/shape_measures.h"

namespace {

using arap::Points;
using arap::Triangles;

// Two triangles sharing no vertex: abc and def.
long crossings(const Points& P) {
  Triangles T(2, 3);
  T << 0, 1, 2, 3, 4, 5;
  return arap::measure::self_intersecting_pairs(P, T);
}

TEST(SelfIntersectingPairs, AnEdgeThroughATriangleCrosses) {
  Points P(6, 3);
  P << 0, 0, 0, 1, 0, 0, 0, 1, 0,          // in z = 0
      0.2, 0.2, -0.5, 0.3, 0.2, 0.5, 0.2, 0.9, 0.5;  // one edge pierces it
  EXPECT_EQ(crossings(P), 1);
}

TEST(SelfIntersectingPairs, AShallowCrossingStillCounts) {
  // The edge dips 1e-6 of the triangles' size below the plane: far above rounding.
  Points P(6, 3);
  P << 0, 0, 0, 1, 0, 0, 0, 1, 0,
      0.2, 0.2, -1e-6, 0.3, 0.2, 0.5, 0.2, 0.9, 0.5;
  EXPECT_EQ(crossings(P), 1);
}

TEST(SelfIntersectingPairs, NeighboursOnAFlatFaceFarFromTheOriginDoNotCross) {
  // Two small triangles of one flat face (x = 0), apart in it, far from the
  // origin along z, the face flat only to 1e-13, as a solver leaves it (taken
  // from a bar compressed along its axis): not a crossing.
  Points P(6, 3);
  P << 1.3e-13, 1.2e-13, 1.0533, -2.1e-13, -2.2e-13, 1.0799, -6.9e-14, 0.25, 1.0799,
      -7.9e-14, 0.25, 1.0266, -1.3e-14, 0.25, 1.0533, -3.0e-14, 0.5, 1.0533;
  EXPECT_EQ(crossings(P), 0);
}

TEST(SelfIntersectingPairs, AVertexLinedUpWithAnEdgeBeyondTheTriangleDoesNotCross) {
  // From a bar folded by Live: d (a corner of its handle face) lies on the line
  // of the edge bc, past b, in abc's plane; the edges from d leave the plane
  // there, outside abc.
  Points P(6, 3);
  P << 0.56946643989257173, -0.10058138844730674, -0.22118772678389678,  // a
      0.59999999999999998, -0.033333399999999999, -0.099999999999999978,  // b
      0.59999999999999998, -0.10000000000000001, -0.099999999999999978,   // c
      0.55952356215383503, -0.033671604475135689, -0.21518796241947985,
      0.55952356232121891, 0.033671607137614315, -0.21518796218846031,
      0.59999999999999998, 0.033333399999999999, -0.099999999999999978;  // d
  EXPECT_EQ(crossings(P), 0);
}

TEST(SelfIntersectingPairs, AVertexOnAnEdgeTouches) {
  // d in abc's plane on the edge ab itself, the edges from d leaving the plane
  // there: the triangles touch, which counts as crossing.
  Points P(6, 3);
  P << 0, 0, 0, 1, 0, 0, 0, 1, 0,
      0.5, 0, 0, 0.7, 0.3, 1, 1.0, -0.5, 0.5;
  EXPECT_EQ(crossings(P), 1);
}

TEST(SelfIntersectingPairs, TrianglesApartDoNotCross) {
  Points P(6, 3);
  P << 0, 0, 0, 1, 0, 0, 0, 1, 0,
      0.2, 0.2, 0.1, 0.3, 0.2, 0.5, 0.2, 0.9, 0.5;
  EXPECT_EQ(crossings(P), 0);
}

}  // namespace
