#include <gtest/gtest.h>

#include <cmath>

#include "arap/weights.h"
#include "test_meshes.h"

namespace {

double weight_of(const std::vector<arap::WeightedEdge>& edges, int i, int j) {
  for (const auto& e : edges)
    if (e.i == std::min(i, j) && e.j == std::max(i, j)) return e.w;
  return NAN;
}

// Two triangles sharing edge (0, 1): a right isosceles one and an obtuse one.
struct Kite {
  arap::Points V{4, 3};
  arap::Triangles F{2, 3};
  Kite() {
    V << 0, 0, 0,  //
        1, 0, 0,   //
        0, 1, 0,   //
        0.5, -0.2, 0;
    F << 0, 1, 2,  //
        1, 0, 3;
  }
};

TEST(Weights, CotanMatchesHandComputedKite) {
  Kite k;
  const auto edges = arap::edge_weights(k.V, k.F, arap::Weights::Cotan);
  // Edge (0,1): opposite angle at 2 is 45 deg (cot 1); at 3 the vectors (-0.5, 0.2)
  // and (0.5, 0.2) give cot = (-0.25 + 0.04) / 0.2 = -1.05. w = (1 - 1.05) / 2.
  EXPECT_NEAR(weight_of(edges, 0, 1), 0.5 * (1.0 - 1.05), 1e-12);
  // Edge (0,2): opposite angle at 1 is 45 deg: w = 1/2.
  EXPECT_NEAR(weight_of(edges, 0, 2), 0.5, 1e-12);
  // Edge (1,2): opposite angle at 0 is 90 deg: w = 0.
  EXPECT_NEAR(weight_of(edges, 1, 2), 0.0, 1e-12);
  // Edge (1,3): opposite angle at 0 between (1,0) and (0.5,-0.2): cot = 0.5 / 0.2.
  EXPECT_NEAR(weight_of(edges, 1, 3), 0.5 * 2.5, 1e-12);
}

TEST(Weights, ClampedDropsNegativeCotangents) {
  Kite k;
  const auto edges = arap::edge_weights(k.V, k.F, arap::Weights::CotanClamped);
  EXPECT_NEAR(weight_of(edges, 0, 1), 0.5 * 1.0, 1e-12);
  for (const auto& e : edges) EXPECT_GE(e.w, 0.0);
}

TEST(Weights, UniformIsOnePerEdge) {
  Kite k;
  const auto edges = arap::edge_weights(k.V, k.F, arap::Weights::Uniform);
  EXPECT_EQ(edges.size(), 5u);
  for (const auto& e : edges) EXPECT_EQ(e.w, 1.0);
}

TEST(Weights, ZeroAreaTrianglesAreSkippedNotInfinite) {
  arap::Points V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0;  // 0,1,2 collinear
  arap::Triangles F(2, 3);
  F << 0, 1, 2, 0, 1, 3;
  arap::EdgeCounts counts;
  const auto edges = arap::edge_weights(V, F, arap::Weights::Cotan, &counts);
  EXPECT_EQ(counts.degenerate_triangles, 1);
  for (const auto& e : edges) EXPECT_TRUE(std::isfinite(e.w));
}

TEST(Weights, NonManifoldEdgeSumsAllOppositeAngles) {
  // Three triangles on edge (0,1), each with a 45-degree... right isosceles opposite corner.
  arap::Points V(5, 3);
  V << 0, 0, 0, 1, 0, 0, 0.5, 0.5, 0, 0.5, -0.5, 0, 0.5, 0, 0.5;
  arap::Triangles F(3, 3);
  F << 0, 1, 2, 1, 0, 3, 0, 1, 4;
  arap::EdgeCounts counts;
  const auto edges = arap::edge_weights(V, F, arap::Weights::Cotan, &counts);
  EXPECT_EQ(counts.nonmanifold_edges, 1);
  EXPECT_NEAR(weight_of(edges, 0, 1), 0.0, 1e-12);  // three right angles: cot 90 = 0
  EXPECT_NEAR(weight_of(edges, 0, 2), 0.5, 1e-12);
}

TEST(Weights, EveryKindGivesOneWeightPerEdgeOfATube) {
  const auto m = arap_test::tube(12, 6, 2.0);
  for (auto kind : {arap::Weights::Cotan, arap::Weights::CotanClamped, arap::Weights::Uniform}) {
    const auto edges = arap::edge_weights(m.V, m.F, kind);
    EXPECT_EQ(edges.size(), static_cast<size_t>(12 * 6 + 12 * 5 + 12 * 5));
  }
}

}  // namespace
