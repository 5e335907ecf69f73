#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "arap/solver.h"
#include "test_meshes.h"

namespace {

using arap_test::concat;
using arap_test::ring_vertices;
using arap_test::rows_of;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

arap::ErrorCode bind_error(const arap::Points& V, const arap::Triangles& F, const std::vector<int>& c) {
  arap::Solver solver;
  try {
    solver.bind(V, F, c);
  } catch (const arap::Error& e) {
    EXPECT_GT(std::string(e.what()).size(), 10u);
    return e.code();
  }
  ADD_FAILURE() << "bind() accepted bad input";
  return arap::ErrorCode::InvalidInput;
}

struct Tube {
  arap_test::Mesh mesh = arap_test::tube(8, 6, 3.0);
  std::vector<int> constrained = concat(ring_vertices(8, 0), ring_vertices(8, 5));
};

TEST(BadInput, OutOfRangeFaceIndex) {
  Tube t;
  t.mesh.F(3, 1) = 999;
  EXPECT_EQ(bind_error(t.mesh.V, t.mesh.F, t.constrained), arap::ErrorCode::IndexOutOfRange);
  t.mesh.F(3, 1) = -1;
  EXPECT_EQ(bind_error(t.mesh.V, t.mesh.F, t.constrained), arap::ErrorCode::IndexOutOfRange);
}

TEST(BadInput, OutOfRangeConstraint) {
  Tube t;
  t.constrained.push_back(48);
  EXPECT_EQ(bind_error(t.mesh.V, t.mesh.F, t.constrained), arap::ErrorCode::IndexOutOfRange);
}

TEST(BadInput, NonFiniteRestPosition) {
  Tube t;
  t.mesh.V(10, 2) = kNaN;
  EXPECT_EQ(bind_error(t.mesh.V, t.mesh.F, t.constrained), arap::ErrorCode::NonFinite);
  t.mesh.V(10, 2) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(bind_error(t.mesh.V, t.mesh.F, t.constrained), arap::ErrorCode::NonFinite);
}

TEST(BadInput, NoTrianglesNoVerticesNoConstraints) {
  Tube t;
  EXPECT_EQ(bind_error(t.mesh.V, arap::Triangles(0, 3), t.constrained), arap::ErrorCode::NoTriangles);
  EXPECT_EQ(bind_error(arap::Points(0, 3), t.mesh.F, t.constrained), arap::ErrorCode::InvalidInput);
  EXPECT_EQ(bind_error(t.mesh.V, t.mesh.F, {}), arap::ErrorCode::NoConstraints);
}

TEST(BadInput, DuplicateConstraint) {
  Tube t;
  t.constrained.push_back(t.constrained.front());
  EXPECT_EQ(bind_error(t.mesh.V, t.mesh.F, t.constrained), arap::ErrorCode::DuplicateConstraint);
}

TEST(BadInput, NonFiniteTargetThrowsAndKeepsThePositions) {
  Tube t;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained);
  arap::Points targets = rows_of(t.mesh.V, t.constrained);
  targets(12, 0) += 1.0;
  solver.solve(targets);
  const arap::Points before = solver.positions();
  targets(3, 1) = kNaN;
  try {
    solver.solve(targets);
    FAIL() << "NaN target accepted";
  } catch (const arap::Error& e) {
    EXPECT_EQ(e.code(), arap::ErrorCode::NonFinite);
  }
  EXPECT_EQ(solver.positions(), before);
}

TEST(BadInput, WrongTargetCountAndSolveBeforeBind) {
  Tube t;
  arap::Solver solver;
  EXPECT_THROW(solver.solve(arap::Points(2, 3)), arap::Error);
  solver.bind(t.mesh.V, t.mesh.F, t.constrained);
  EXPECT_THROW(solver.solve(arap::Points(2, 3)), arap::Error);
}

TEST(BadInput, BadOptions) {
  Tube t;
  arap::Solver solver;
  arap::Options o;
  o.threads = 0;
  EXPECT_THROW(solver.bind(t.mesh.V, t.mesh.F, t.constrained, o), arap::Error);
  o.threads = 1;
  o.tolerance = kNaN;
  EXPECT_THROW(solver.bind(t.mesh.V, t.mesh.F, t.constrained, o), arap::Error);
  o.tolerance = 0;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained, o);
  solver.options().weights = arap::Weights::Uniform;  // needs a new bind
  EXPECT_THROW(solver.solve(rows_of(t.mesh.V, t.constrained)), arap::Error);
}

TEST(BadInput, ZeroAreaTrianglesAreSkipped) {
  Tube t;
  // Collapse one vertex onto its neighbour: two triangles become degenerate.
  t.mesh.V.row(20) = t.mesh.V.row(21);
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained);
  EXPECT_GE(solver.mesh_report().degenerate_triangles, 2);
  arap::Points targets = rows_of(t.mesh.V, t.constrained);
  for (int k = 8; k < 16; ++k) targets(k, 0) += 1.0;
  const auto stats = solver.solve(targets);
  EXPECT_TRUE(solver.positions().allFinite());
  EXPECT_TRUE(std::isfinite(stats.energy.back()));
}

TEST(BadInput, ComponentWithoutConstraintStaysAtRest) {
  Tube t;
  // Add a separate triangle and an isolated vertex that no constraint reaches.
  const Eigen::Index n = t.mesh.V.rows();
  t.mesh.V.conservativeResize(n + 4, 3);
  t.mesh.V.row(n) << 5, 5, 5;
  t.mesh.V.row(n + 1) << 6, 5, 5;
  t.mesh.V.row(n + 2) << 5, 6, 5;
  t.mesh.V.row(n + 3) << 9, 9, 9;  // isolated
  t.mesh.F.conservativeResize(t.mesh.F.rows() + 1, 3);
  t.mesh.F.row(t.mesh.F.rows() - 1) << n, n + 1, n + 2;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained);
  EXPECT_EQ(solver.mesh_report().components, 2);  // the tube and the triangle; not the isolated vertex
  EXPECT_EQ(solver.mesh_report().unconstrained_components, 1);
  EXPECT_EQ(solver.mesh_report().unconstrained_vertices, 3);
  EXPECT_EQ(solver.mesh_report().isolated_vertices, 1);
  arap::Points targets = rows_of(t.mesh.V, t.constrained);
  for (int k = 8; k < 16; ++k) targets(k, 0) += 1.0;
  solver.solve(targets);
  const arap::Points& P = solver.positions();
  EXPECT_TRUE(P.allFinite());
  for (Eigen::Index v = n; v < n + 4; ++v) EXPECT_EQ(P.row(v), t.mesh.V.row(v));
  EXPECT_GT((P.row(30) - t.mesh.V.row(30)).norm(), 0.1);  // the tube itself did move
}

TEST(BadInput, NonManifoldEdgeIsSolved) {
  Tube t;
  // A fin: a triangle on an existing edge of the tube (that edge now has three triangles).
  const Eigen::Index n = t.mesh.V.rows();
  t.mesh.V.conservativeResize(n + 1, 3);
  t.mesh.V.row(n) << 2.0, 0.0, 1.0;
  t.mesh.F.conservativeResize(t.mesh.F.rows() + 1, 3);
  t.mesh.F.row(t.mesh.F.rows() - 1) << 16, 24, n;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained);
  EXPECT_EQ(solver.mesh_report().nonmanifold_edges, 1);
  arap::Points targets = rows_of(t.mesh.V, t.constrained);
  for (int k = 8; k < 16; ++k) targets(k, 0) += 1.0;
  const auto stats = solver.solve(targets);
  EXPECT_TRUE(solver.positions().allFinite());
  EXPECT_LE(stats.energy.back(), stats.initial_energy);
}

TEST(BadInput, FailedBindKeepsThePreviousBinding) {
  Tube t;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained);
  EXPECT_THROW(solver.bind(t.mesh.V, t.mesh.F, {1, 1}), arap::Error);
  EXPECT_TRUE(solver.is_bound());
  EXPECT_NO_THROW(solver.solve(rows_of(t.mesh.V, t.constrained)));
}

}  // namespace
