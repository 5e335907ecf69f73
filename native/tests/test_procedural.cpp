// Procedural meshes: closed, consistently oriented outwards, deterministic,
// of the requested size; height-based constraint picking.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <utility>

#include "arap/errors.h"
#include "arap/tools/procedural.h"

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

// Every quad's diagonal is its shorter one: no needlessly obtuse angles.
TEST(Procedural, EllipsoidHasItsSemiAxesAndShortDiagonals) {
  const TriMesh m = arap::procedural::make_ellipsoid(3000, Eigen::Vector3d(1, 1, 2));
  EXPECT_NEAR(static_cast<double>(m.vertices.rows()), 3000, 450);
  check_sphere_topology(m);
  EXPECT_NEAR(signed_volume(m), 4.0 / 3.0 * M_PI * 2, 0.05);
  EXPECT_NEAR(m.vertices.col(2).maxCoeff(), 2.0, 1e-12);
  EXPECT_NEAR(m.vertices.col(0).minCoeff(), -1.0, 1e-12);
  for (Eigen::Index q = 0; q < m.triangles.rows(); q += 2) {
    // The two triangles of a quad share their diagonal; the quad's other two corners are farther apart.
    const auto t0 = m.triangles.row(q), t1 = m.triangles.row(q + 1);
    std::vector<int> shared, other;
    for (int k = 0; k < 3; ++k) ((t1.array() == t0(k)).any() ? shared : other).push_back(t0(k));
    for (int k = 0; k < 3; ++k)
      if (!(t0.array() == t1(k)).any()) other.push_back(t1(k));
    ASSERT_EQ(shared.size(), 2u);
    ASSERT_EQ(other.size(), 2u);
    const double diagonal = (m.vertices.row(shared[0]) - m.vertices.row(shared[1])).squaredNorm();
    EXPECT_LE(diagonal, (m.vertices.row(other[0]) - m.vertices.row(other[1])).squaredNorm() * (1 + 1e-12));
  }
}

TEST(Procedural, TorusIsClosedWithGenusOne) {
  const TriMesh m = arap::procedural::make_torus(24, 12, 2.0, 0.5);
  EXPECT_EQ(m.vertices.rows(), 24 * 12);
  const long edges = check_closed_oriented(m);
  EXPECT_EQ(m.vertices.rows() - edges + m.triangles.rows(), 0);  // Euler characteristic of a torus
  // Outward (positive), a little under the smooth torus's 2 pi^2 R r^2 (polygonal sections).
  const double smooth = 2 * M_PI * M_PI * 2.0 * 0.25;
  EXPECT_GT(signed_volume(m), 0.9 * smooth);
  EXPECT_LT(signed_volume(m), smooth);
}

TEST(Procedural, BendHoldsTheBottomAndMovesTheTopAlongTheLongestSide) {
  // Longest side along x: the bend picks by x and shifts along y.
  const TriMesh m = arap::procedural::make_bar(20, 2, 2, 5.0, 1.0, 1.0);
  const auto b = arap::procedural::bend(m.vertices, 0.3);
  ASSERT_GT(b.fixed_count, 0);
  ASSERT_GT(static_cast<int>(b.constrained.size()), b.fixed_count);
  ASSERT_EQ(b.targets.rows(), static_cast<Eigen::Index>(b.constrained.size()));
  for (int k = 0; k < static_cast<int>(b.constrained.size()); ++k) {
    const int v = b.constrained[k];
    Eigen::RowVector3d expected = m.vertices.row(v);
    if (k < b.fixed_count) {
      EXPECT_LE(m.vertices(v, 0), 1.0 + 1e-9);
    } else {
      EXPECT_GE(m.vertices(v, 0), 4.75 - 1e-9);
      expected.y() += 0.3 * 5.0;
    }
    EXPECT_TRUE(b.targets.row(k).isApprox(expected)) << "vertex " << v;
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
  EXPECT_THROW(arap::procedural::make_ellipsoid(100, Eigen::Vector3d(1, 0, 1)), arap::Error);
  EXPECT_THROW(arap::procedural::make_torus(3, 3, 1.0, 1.0), arap::Error);
  EXPECT_THROW(arap::procedural::bend(arap::Points(0, 3)), arap::Error);
}

}  // namespace
