// Where a forced pose's rounds take the constrained vertices
// (contact/handle_moves.h): a part that turns keeps its shape on the way,
// each part moves on its own (a fixed group beside a handle too), and the
// whole share lands on the targets.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <vector>

#include "contact/handle_moves.h"

namespace {

using arap::Points;
using arap::Triangles;

// Two separate squares (two triangles each): vertices 0-3 at z = 0, 4-7 at z = 5.
struct TwoSquares {
  Points rest{8, 3};
  Triangles triangles{4, 3};
  std::vector<int> constrained{0, 1, 2, 3, 4, 5, 6, 7};
  TwoSquares() {
    for (int k = 0; k < 8; ++k) rest.row(k) << (k % 4 == 1 || k % 4 == 2), (k % 4 >= 2), k < 4 ? 0.0 : 5.0;
    triangles << 0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7;
  }
};

TEST(ContactHandleMoves, APartTurnsAsARigidBodyAndLandsOnItsTargets) {
  const TwoSquares s;
  arap::contact::HandleMoves moves;
  moves.bind(s.constrained, 8, s.triangles, 8);
  // The first square turned half a turn about its centre's vertical axis and lifted; the second shifted.
  const Eigen::RowVector3d centre(0.5, 0.5, 0.0);
  const Eigen::Matrix3d half = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Points targets = s.rest;
  for (int k = 0; k < 4; ++k)
    targets.row(k) = ((half * (s.rest.row(k) - centre).transpose()).transpose() + centre) + Eigen::RowVector3d(0, 0, 1);
  for (int k = 4; k < 8; ++k) targets.row(k) += Eigen::RowVector3d(2, 0, 0);
  Points goal(8, 3);
  for (double share : {0.25, 0.5, 0.75}) {
    moves.toward(s.rest, targets, share, goal);
    // The turning square keeps its shape (a straight line would shrink it to a point at 0.5) ...
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        EXPECT_NEAR((goal.row(a) - goal.row(b)).norm(), (s.rest.row(a) - s.rest.row(b)).norm(), 1e-12) << share;
    // ... its centre moves along the straight line, and it has turned share of the half turn.
    Eigen::RowVector3d mid = Eigen::RowVector3d::Zero();
    for (int k = 0; k < 4; ++k) mid += goal.row(k) / 4;
    EXPECT_LT((mid - (centre + Eigen::RowVector3d(0, 0, share))).norm(), 1e-12) << share;
    const Eigen::RowVector3d edge = goal.row(1) - goal.row(0);
    EXPECT_NEAR(std::abs(std::atan2(edge(1), edge(0))), share * M_PI, 1e-9) << share;
    // The other square only shifts, on its own.
    for (int k = 4; k < 8; ++k)
      EXPECT_LT((goal.row(k) - (s.rest.row(k) + share * Eigen::RowVector3d(2, 0, 0))).norm(), 1e-12) << share;
  }
  moves.toward(s.rest, targets, 1.0, goal);
  EXPECT_EQ(goal, targets);
}

TEST(ContactHandleMoves, WhatARigidFitLeavesOverArrivesWithTheLastShare) {
  const TwoSquares s;
  arap::contact::HandleMoves moves;
  moves.bind(s.constrained, 8, s.triangles, 8);
  Points targets = s.rest;
  targets.row(2) += Eigen::RowVector3d(0.3, 0.3, 0.0);  // the first square stretched at one corner
  Points goal(8, 3), almost(8, 3);
  moves.toward(s.rest, targets, 0.0, goal);
  EXPECT_LT((goal - s.rest).norm(), 1e-12);
  moves.toward(s.rest, targets, 1.0 - 1e-9, almost);
  EXPECT_LT((almost - targets).norm(), 1e-8);
}

TEST(ContactHandleMoves, AFixedGroupStaysWhileTheHandleBesideItMovesAway) {
  // One strip of triangles: vertices 0-3 fixed (targets where they are), 4-7 beside them moved far.
  Points rest(8, 3);
  for (int k = 0; k < 8; ++k) rest.row(k) << k / 2, k % 2, 0.0;
  Triangles triangles(6, 3);
  for (int t = 0; t < 6; ++t) triangles.row(t) << t, t + 1, t + 2;
  std::vector<int> constrained{0, 1, 2, 3, 4, 5, 6, 7};
  arap::contact::HandleMoves moves;
  moves.bind(constrained, 8, triangles, 8);
  Points targets = rest;
  for (int k = 4; k < 8; ++k) targets.row(k) += Eigen::RowVector3d(0.0, 0.0, 10.0);
  Points goal(8, 3);
  moves.toward(rest, targets, 0.5, goal);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(goal.row(k), rest.row(k)) << k;
  for (int k = 4; k < 8; ++k) EXPECT_LT((goal.row(k) - (rest.row(k) + Eigen::RowVector3d(0, 0, 5))).norm(), 1e-12) << k;
}

// A part with no move to make (a fixed group) stays bit for bit where it is, whatever
// its coordinates: its best rigid fit is the identity only to rounding. The group
// is the fixed end of a coarse, irregular torus, beside a handle that moves.
TEST(ContactHandleMoves, APartAlreadyAtItsTargetsStaysExactly) {
  Points rest(10, 3);
  rest << -1.99574, 0.029095, -0.116822, -1.55547, -0.367919, 0.980246, -1.67009, 0.417455, 0.601747,
      -1.29795, -0.460373, 0.134728, -1.36124, -0.408793, -1.15915, -1.65803, 0.343761, -0.849705,
      -1.25982, 0.25443, -1.46267,  // the fixed group, 0-6
      1.97579, -0.0194596, -0.307824, 1.38284, -0.148845, 1.41336, 1.0147, -0.428859, 0.717839;  // a handle
  Triangles triangles(6, 3);
  triangles << 0, 1, 2, 1, 0, 3, 6, 4, 5, 4, 3, 0, 5, 4, 0, 7, 8, 9;
  const std::vector<int> constrained{0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
  arap::contact::HandleMoves moves;
  moves.bind(constrained, 10, triangles, 10);
  Points targets = rest;
  for (int k = 7; k < 10; ++k) targets.row(k) += Eigen::RowVector3d(-3.0, 0.0, 0.3);
  Points goal(10, 3);
  for (double share : {0.125, 0.3, 0.5, 0.9}) {
    moves.toward(rest, targets, share, goal);
    for (int k = 0; k < 7; ++k) EXPECT_EQ(goal.row(k), rest.row(k)) << "share " << share << ", vertex " << k;
  }
}

}  // namespace
