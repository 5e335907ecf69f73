// Procedural meshes: closed, consistently oriented outwards, deterministic,
// of the requested size; height-based constraint picking.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <utility>

#include "arap/errors.h"
#include "arap/procedural.h"

namespace {

using arap::procedural::TriMesh;

// Every directed edge appears once and its reverse once: closed, 2-manifold
// along edges, consistently oriented. Returns the number of undirected edges.
long check_closed_oriented(const TriMesh& m) {
  std::map<std::pair<int, int>, int> directed;
  for (Eigen::Index f = 0; f < m.triangles.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++directed[{m.triangles(f, k), m.triangles(f, (k + 1) % 3)}];
  for (const auto& [e, count] : directed) {
    EXPECT_EQ(count, 1) << "edge " << e.first << "-" << e.second;
    auto rev = directed.find({e.second, e.first});
    EXPECT_TRUE(rev != directed.end() && rev->second == 1) << "edge " << e.first << "-" << e.second << " is a border";
  }
  return static_cast<long>(directed.size() / 2);
}

// Signed volume (divergence theorem): positive when the triangles face outwards.
double signed_volume(const TriMesh& m) {
  double v = 0;
  for (Eigen::Index f = 0; f < m.triangles.rows(); ++f) {
    const Eigen::Vector3d a = m.vertices.row(m.triangles(f, 0)), b = m.vertices.row(m.triangles(f, 1)),
                          c = m.vertices.row(m.triangles(f, 2));
    v += a.dot(b.cross(c)) / 6;
  }
  return v;
}

void check_sphere_topology(const TriMesh& m) {
  const long edges = check_closed_oriented(m);
  EXPECT_EQ(m.vertices.rows() - edges + m.triangles.rows(), 2);  // Euler characteristic of a sphere
  EXPECT_TRUE(m.vertices.allFinite());
}

TEST(Procedural, BarIsAClosedBoxSurface) {
  const TriMesh m = arap::procedural::make_bar(2, 3, 10, 1.0, 2.0, 5.0);
  EXPECT_EQ(m.vertices.rows(), 2 * (2 * 3 + 3 * 10 + 10 * 2) + 2);
  EXPECT_EQ(m.triangles.rows(), 4 * (2 * 3 + 3 * 10 + 10 * 2));
  check_sphere_topology(m);
  EXPECT_NEAR(signed_volume(m), 1.0 * 2.0 * 5.0, 1e-12);
  EXPECT_DOUBLE_EQ(m.vertices.col(2).maxCoeff(), 5.0);
}

TEST(Procedural, BarWithVertexTarget) {
  const TriMesh m = arap::procedural::make_bar_with_vertices(2000, 5.0);
  EXPECT_NEAR(static_cast<double>(m.vertices.rows()), 2000.0, 300.0);
  check_sphere_topology(m);
  EXPECT_NEAR(signed_volume(m), 5.0, 1e-9);
}

TEST(Procedural, CylinderIsClosedAndOutward) {
  const TriMesh m = arap::procedural::make_cylinder(16, 10, 0.5, 4.0);
  EXPECT_EQ(m.vertices.rows(), 16 * 11 + 2);
  check_sphere_topology(m);
  const double polygon_area = 0.5 * 16 * 0.25 * std::sin(2 * M_PI / 16);
  EXPECT_NEAR(signed_volume(m), polygon_area * 4.0, 1e-9);
}

TEST(Procedural, SphereHitsTheTargetCountAndIsSmooth) {
  for (int target : {100, 1000, 5000}) {
    SCOPED_TRACE(target);
    const TriMesh m = arap::procedural::make_sphere(target);
    EXPECT_NEAR(static_cast<double>(m.vertices.rows()), target, 0.15 * target);
    check_sphere_topology(m);
    EXPECT_GT(signed_volume(m), 3.0);  // ~4/3 pi for radius 1
    const Eigen::VectorXd r = m.vertices.rowwise().norm();
    EXPECT_GT(r.minCoeff(), 0.85);
    EXPECT_LT(r.maxCoeff(), 1.15);
  }
}

TEST(Procedural, Deterministic) {
  const TriMesh a = arap::procedural::make_sphere(777), b = arap::procedural::make_sphere(777);
  EXPECT_TRUE(a.vertices == b.vertices);
  EXPECT_TRUE(a.triangles == b.triangles);
}

TEST(Procedural, PickByHeight) {
  const TriMesh m = arap::procedural::make_bar(2, 2, 20, 1.0, 1.0, 5.0);
  const auto c = arap::procedural::pick_by_height(m.vertices, 2, 0.2, 0.05);
  ASSERT_FALSE(c.fixed.empty());
  ASSERT_FALSE(c.handle.empty());
  for (int i : c.fixed) EXPECT_LE(m.vertices(i, 2), 1.0 + 1e-9);
  for (int i : c.handle) EXPECT_GE(m.vertices(i, 2), 4.75 - 1e-9);
  // Rings at z = 0, 0.25, ..., 1.0 (5 rings) fixed; rings at 4.75 and 5 moved.
  int bottom = 0, top = 0;
  for (Eigen::Index i = 0; i < m.vertices.rows(); ++i) {
    bottom += m.vertices(i, 2) <= 1.0 + 1e-9;
    top += m.vertices(i, 2) >= 4.75 - 1e-9;
  }
  EXPECT_EQ(static_cast<int>(c.fixed.size()), bottom);
  EXPECT_EQ(static_cast<int>(c.handle.size()), top);
}

TEST(Procedural, BadArgumentsThrow) {
  EXPECT_THROW(arap::procedural::make_bar(0, 1, 1, 1, 1, 1), arap::Error);
  EXPECT_THROW(arap::procedural::make_bar(1, 1, 1, 1, -1, 1), arap::Error);
  EXPECT_THROW(arap::procedural::make_cylinder(2, 1, 1, 1), arap::Error);
  EXPECT_THROW(arap::procedural::make_sphere(3), arap::Error);
  EXPECT_THROW(arap::procedural::pick_by_height(arap::Points(0, 3)), arap::Error);
}

}  // namespace
