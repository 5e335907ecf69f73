// The self-contact primitives (native/src/contact): distances against brute
// force and finite differences, the segment-triangle predicate on cases with
// known answers, and additive CCD never reporting a step as free when the pair
// comes within the separation (references: dense sampling of the distance, and
// the exact times at which the four points are coplanar).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "contact/ccd.h"
#include "contact/primitives.h"

namespace {

using arap::contact::edge_edge_distance2;
using arap::contact::edge_edge_separation;
using arap::contact::point_triangle_separation;
using arap::contact::point_triangle_distance2;
using arap::contact::segment_crosses_triangle;
using arap::contact::Vec3;

using Distance2 = double (*)(const Vec3&, const Vec3&, const Vec3&, const Vec3&, double*);
using Impact = double (*)(const Vec3[4], const Vec3[4], double, double, double);  // separation, reduction, up_to

struct Kind {
  const char* name;
  Distance2 distance2;
  Impact impact;
  bool point_triangle;
};
const Kind kPointTriangle{"point-triangle", point_triangle_distance2, arap::contact::point_triangle_impact, true};
const Kind kEdgeEdge{"edge-edge", edge_edge_distance2, arap::contact::edge_edge_impact, false};

double uniform(std::mt19937& rng, double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); }

Vec3 random_point(std::mt19937& rng, double half_width = 1.0) {
  const double x = uniform(rng, -half_width, half_width);
  const double y = uniform(rng, -half_width, half_width);
  const double z = uniform(rng, -half_width, half_width);
  return Vec3(x, y, z);
}

double distance(const Kind& kind, const std::array<Vec3, 4>& x) {
  double w[4];
  return std::sqrt(kind.distance2(x[0], x[1], x[2], x[3], w));
}

// The weights: in range, summing to 0, and sum w_k x_k has the length returned.
void expect_valid_weights(const Kind& kind, const std::array<Vec3, 4>& x, const double w[4], double d2) {
  ASSERT_TRUE(std::isfinite(d2));
  for (int k = 0; k < 4; ++k) ASSERT_TRUE(std::isfinite(w[k])) << "w" << k;
  if (kind.point_triangle) {
    EXPECT_EQ(w[0], 1.0);
    for (int k = 1; k < 4; ++k) {
      EXPECT_LE(w[k], 0.0);
      EXPECT_GE(w[k], -1.0);
    }
  } else {
    for (int k = 0; k < 2; ++k) {
      EXPECT_GE(w[k], 0.0);
      EXPECT_LE(w[k], 1.0);
      EXPECT_LE(w[k + 2], 0.0);
      EXPECT_GE(w[k + 2], -1.0);
    }
    EXPECT_NEAR(w[0] + w[1], 1.0, 1e-15);
  }
  EXPECT_NEAR(w[0] + w[1] + w[2] + w[3], 0.0, 1e-15);
  double scale = 1.0;
  for (const Vec3& p : x) scale = std::max(scale, p.cwiseAbs().maxCoeff());
  const Vec3 v = w[0] * x[0] + w[1] * x[1] + w[2] * x[2] + w[3] * x[3];
  EXPECT_NEAR(v.norm(), std::sqrt(d2), 1e-13 * scale);
}

double checked_distance2(const Kind& kind, const std::array<Vec3, 4>& x, double w[4]) {
  const double d2 = kind.distance2(x[0], x[1], x[2], x[3], w);
  expect_valid_weights(kind, x, w, d2);
  return d2;
}

// The smallest distance from p to a barycentric grid of n + 1 points per side
// on the triangle; every point of the triangle is within (longest edge) / n of the grid.
double brute_point_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, int n) {
  double best = HUGE_VAL;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j) {
      const double u = double(i) / n, v = double(j) / n;
      best = std::min(best, (p - (a + u * (b - a) + v * (c - a))).squaredNorm());
    }
  return std::sqrt(best);
}

// The smallest distance over an (n + 1)^2 grid of (s, t): within (|a1 - a0| + |b1 - b0|) / (2 n) of the minimum.
double brute_edge_edge(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1, int n) {
  double best = HUGE_VAL;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      const double s = double(i) / n, t = double(j) / n;
      best = std::min(best, ((a0 + s * (a1 - a0)) - (b0 + t * (b1 - b0))).squaredNorm());
    }
  return std::sqrt(best);
}

// Random configurations of several shapes: spread out, near contact, and (if
// `slivers`) thin triangles, nearly parallel edges, short edges.
std::array<Vec3, 4> random_configuration(std::mt19937& rng, bool point_triangle, bool slivers = true) {
  std::array<Vec3, 4> x;
  for (Vec3& p : x) p = random_point(rng);
  switch (rng() % (slivers ? 4 : 2)) {
    case 0:  // spread out
      break;
    case 1:  // the first point (edge) moved close to the second primitive
      if (point_triangle) {
        const double u = uniform(rng, 0, 1), v = uniform(rng, 0, 1 - u);
        x[0] = x[1] + u * (x[2] - x[1]) + v * (x[3] - x[1]) + random_point(rng, 0.05);
      } else {
        const Vec3 shift = x[2] + uniform(rng, 0, 1) * (x[3] - x[2]) + random_point(rng, 0.05) -
                           (x[0] + uniform(rng, 0, 1) * (x[1] - x[0]));
        x[0] += shift;
        x[1] += shift;
      }
      break;
    case 2:  // a thin triangle / nearly parallel edges
      if (point_triangle) {
        x[3] = x[1] + uniform(rng, -0.5, 1.5) * (x[2] - x[1]) + random_point(rng, 1e-3);
      } else {
        x[3] = x[2] + uniform(rng, 0.2, 1.5) * (x[1] - x[0]) + random_point(rng, 1e-3);
      }
      break;
    default:  // a short edge
      x[point_triangle ? 2 : 3] = x[point_triangle ? 1 : 2] + random_point(rng, 0.02);
      break;
  }
  return x;
}

TEST(ContactPrimitives, PointTriangleMatchesBruteForce) {
  const int n = 150;
  for (unsigned seed : {1u, 2u, 3u, 4u}) {
    std::mt19937 rng(seed);
    for (int c = 0; c < 100; ++c) {
      SCOPED_TRACE("seed " + std::to_string(seed) + " case " + std::to_string(c));
      const std::array<Vec3, 4> x = random_configuration(rng, true);
      double w[4];
      const double d = std::sqrt(checked_distance2(kPointTriangle, x, w));
      const double brute = brute_point_triangle(x[0], x[1], x[2], x[3], n);
      const double longest = std::max({(x[2] - x[1]).norm(), (x[3] - x[2]).norm(), (x[1] - x[3]).norm()});
      EXPECT_LE(d, brute + 1e-14);
      EXPECT_GE(d, brute - longest / n - 1e-14);
      if (HasFailure()) return;
    }
  }
}

// The separations are lower bounds of the distances (they decide which pairs
// the list skips), and far apart they are not trivially 0.
TEST(ContactPrimitives, SeparationsNeverExceedTheDistance) {
  int far = 0, bounded_well = 0;
  for (unsigned seed : {1u, 2u, 3u, 4u}) {
    std::mt19937 rng(seed);
    for (int c = 0; c < 2000; ++c) {
      SCOPED_TRACE("seed " + std::to_string(seed) + " case " + std::to_string(c));
      const bool point_triangle = c % 2 == 0;
      std::array<Vec3, 4> x = random_configuration(rng, point_triangle);
      if (c % 3 == 0) {  // the first primitive carried away from the second
        const Vec3 shift = random_point(rng, 4.0);
        x[0] += shift;
        if (!point_triangle) x[1] += shift;
      }
      double w[4];
      const double d = std::sqrt(point_triangle ? point_triangle_distance2(x[0], x[1], x[2], x[3], w)
                                                : edge_edge_distance2(x[0], x[1], x[2], x[3], w));
      const double s = point_triangle ? point_triangle_separation(x[0], x[1], x[2], x[3])
                                      : edge_edge_separation(x[0], x[1], x[2], x[3]);
      EXPECT_GE(s, 0.0);
      EXPECT_LE(s, d * (1 + 1e-12) + 1e-15);
      if (d > 3) {
        ++far;
        bounded_well += s > 0.5 * d;
      }
      if (HasFailure()) return;
    }
  }
  ASSERT_GT(far, 100);
  EXPECT_GT(bounded_well, far * 3 / 4);
}

TEST(ContactPrimitives, EdgeEdgeMatchesBruteForce) {
  const int n = 150;
  for (unsigned seed : {1u, 2u, 3u, 4u}) {
    std::mt19937 rng(seed);
    for (int c = 0; c < 100; ++c) {
      SCOPED_TRACE("seed " + std::to_string(seed) + " case " + std::to_string(c));
      const std::array<Vec3, 4> x = random_configuration(rng, false);
      double w[4];
      const double d = std::sqrt(checked_distance2(kEdgeEdge, x, w));
      const double brute = brute_edge_edge(x[0], x[1], x[2], x[3], n);
      const double error = ((x[1] - x[0]).norm() + (x[3] - x[2]).norm()) / (2 * n);
      EXPECT_LE(d, brute + 1e-14);
      EXPECT_GE(d, brute - error - 1e-14);
      if (HasFailure()) return;
    }
  }
}

// d|v|/dx_k = w_k v / |v| against central differences of sqrt(distance2).
// Away from slivers: the distance is C1, but near a thin triangle or nearly
// parallel edges its second derivative is too large for the differences.
void expect_gradient_matches_finite_differences(const Kind& kind) {
  std::mt19937 rng(7);
  int checked = 0;
  for (int c = 0; c < 400; ++c) {
    SCOPED_TRACE(std::string(kind.name) + " case " + std::to_string(c));
    std::array<Vec3, 4> x = random_configuration(rng, kind.point_triangle, false);
    double w[4];
    const double d2 = checked_distance2(kind, x, w);
    if (d2 < 1e-4) continue;  // not differentiable at contact
    ++checked;
    const Vec3 v = w[0] * x[0] + w[1] * x[1] + w[2] * x[2] + w[3] * x[3];
    const Vec3 unit = v / std::sqrt(d2);
    const double h = 1e-6;
    for (int k = 0; k < 4; ++k)
      for (int i = 0; i < 3; ++i) {
        std::array<Vec3, 4> plus = x, minus = x;
        plus[k][i] += h;
        minus[k][i] -= h;
        const double numeric = (distance(kind, plus) - distance(kind, minus)) / (2 * h);
        // |gradient| >= 1 (the first point's part is the unit vector v / |v|).
        EXPECT_NEAR(w[k] * unit[i], numeric, 1e-6) << "point " << k << " axis " << i;
      }
    if (::testing::Test::HasFailure()) return;
  }
  EXPECT_GT(checked, 300);
}

TEST(ContactPrimitives, PointTriangleGradientMatchesFiniteDifferences) {
  expect_gradient_matches_finite_differences(kPointTriangle);
}

TEST(ContactPrimitives, EdgeEdgeGradientMatchesFiniteDifferences) {
  expect_gradient_matches_finite_differences(kEdgeEdge);
}

TEST(ContactPrimitives, DegenerateTriangleIsItsLongestEdge) {
  // Collinear vertices in every order: the middle one gets no weight.
  const Vec3 ends[2] = {Vec3(0, 0, 0), Vec3(2, 0, 0)}, middle(0.5, 0, 0);
  const Vec3 points[] = {Vec3(1, 1, 0), Vec3(3, 1, 0), Vec3(-1, 0, 1), Vec3(0.5, 0, 0), Vec3(1.7, -2, 3)};
  const int orders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const Vec3& p : points)
    for (const auto& order : orders) {
      const Vec3 vertices[3] = {ends[0], ends[1], middle};
      const std::array<Vec3, 4> x = {p, vertices[order[0]], vertices[order[1]], vertices[order[2]]};
      double w[4];
      const double d2 = checked_distance2(kPointTriangle, x, w);
      const double u = std::clamp(p.x() / 2, 0.0, 1.0);
      EXPECT_NEAR(d2, (p - Vec3(2 * u, 0, 0)).squaredNorm(), 1e-14);
      for (int k = 0; k < 3; ++k)
        if (order[k] == 2) {
          EXPECT_EQ(w[k + 1], 0.0);
        }
    }
  // Two vertices at one place, and all three.
  const Vec3 p(0.3, 0.4, 1.2), a(1, 2, 3), b(-1, 0, 2);
  double w[4];
  const double u = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
  EXPECT_NEAR(checked_distance2(kPointTriangle, {p, a, a, b}, w), (p - a - u * (b - a)).squaredNorm(), 1e-14);
  EXPECT_EQ(checked_distance2(kPointTriangle, {p, a, a, a}, w), (p - a).squaredNorm());
  EXPECT_EQ(w[1] + w[2] + w[3], -1.0);
  // Nearly degenerate (the third vertex 1e-13 off the line): as brute force finds.
  const Vec3 c(1, 1e-13, 0);
  for (const Vec3& q : points) {
    const double d = std::sqrt(checked_distance2(kPointTriangle, {q, ends[0], ends[1], c}, w));
    EXPECT_NEAR(d, brute_point_triangle(q, ends[0], ends[1], c, 2000), 2.0 / 2000);
    EXPECT_NEAR(d, std::sqrt(point_triangle_distance2(q, ends[0], ends[1], middle, w)), 1e-12);
  }
}

TEST(ContactPrimitives, ParallelAndZeroLengthEdges) {
  const Vec3 a0(0, 0, 0), a1(1, 0, 0);
  struct Case {
    Vec3 b0, b1;
    double distance2;
  };
  const Case cases[] = {
      {Vec3(0.5, 1, 0), Vec3(1.5, 1, 0), 1},   // parallel, overlapping along the line
      {Vec3(1.5, 1, 0), Vec3(0.5, 1, 0), 1},   // antiparallel
      {Vec3(2, 1, 0), Vec3(3, 1, 0), 2},       // parallel, past the end
      {Vec3(0.2, 0, 3), Vec3(0.8, 0, 3), 9},   // parallel, one inside the other's span
      {Vec3(0.5, 0, 0), Vec3(2, 0, 0), 0},     // collinear, overlapping
      {Vec3(3, 0, 0), Vec3(2, 0, 0), 1},       // collinear, apart
      {Vec3(0.5, 1, 0), Vec3(0.5, 1, 0), 1},   // zero length against the side
      {Vec3(-2, 0, 0), Vec3(-2, 0, 0), 4},     // zero length on the line
      {Vec3(0.5, -1, 0), Vec3(0.5, 1, 0), 0},  // crossing
      {Vec3(1, -1, 2), Vec3(1, 1, 2), 4},      // skew, closest at an endpoint
  };
  for (const Case& c : cases) {
    SCOPED_TRACE("b0 " + std::to_string(c.b0.x()) + " b1 " + std::to_string(c.b1.x()));
    for (bool swap : {false, true}) {
      const std::array<Vec3, 4> x =
          swap ? std::array<Vec3, 4>{c.b0, c.b1, a0, a1} : std::array<Vec3, 4>{a0, a1, c.b0, c.b1};
      double w[4];
      EXPECT_NEAR(checked_distance2(kEdgeEdge, x, w), c.distance2, 1e-15);
    }
  }
  // Both of zero length.
  double w[4];
  EXPECT_EQ(checked_distance2(kEdgeEdge, {a1, a1, Vec3(1, 2, 2), Vec3(1, 2, 2)}, w), 8.0);
  EXPECT_EQ(checked_distance2(kEdgeEdge, {a1, a1, a1, a1}, w), 0.0);
  // Nearly parallel (1e-10 rad) with the lines 1e-3 apart, crossing in projection at x = 0.
  const double d2 =
      checked_distance2(kEdgeEdge, {Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(-1, -1e-10, 1e-3), Vec3(1, 1e-10, 1e-3)}, w);
  EXPECT_NEAR(std::sqrt(d2), 1e-3, 1e-15);
}

TEST(ContactPrimitives, PointOnTheTriangle) {
  std::mt19937 rng(11);
  for (int c = 0; c < 100; ++c) {
    const Vec3 a = random_point(rng), b = random_point(rng), cc = random_point(rng);
    double w[4];
    // At a vertex: exactly zero.
    EXPECT_EQ(checked_distance2(kPointTriangle, {b, a, b, cc}, w), 0.0);
    EXPECT_EQ(w[2], -1.0);
    // Inside, and on an edge: zero up to rounding, the barycentric coordinates as weights.
    const double beta[3] = {0.2, 0.3, 0.5};
    const Vec3 inside = beta[0] * a + beta[1] * b + beta[2] * cc;
    EXPECT_LE(checked_distance2(kPointTriangle, {inside, a, b, cc}, w), 1e-30);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(-w[k + 1], beta[k], 1e-9);
    const Vec3 on_edge = 0.5 * (b + cc);
    EXPECT_LE(checked_distance2(kPointTriangle, {on_edge, a, b, cc}, w), 1e-30);
    EXPECT_NEAR(w[1], 0.0, 1e-9);
    // Edges that meet: zero, finite weights.
    const Vec3 middle = 0.5 * (a + b), across = cc - inside;
    EXPECT_LE(checked_distance2(kEdgeEdge, {a, b, middle - across, middle + across}, w), 1e-30);
    EXPECT_EQ(checked_distance2(kEdgeEdge, {a, b, b, cc}, w), 0.0);
  }
}

// The known answer, for the six orders of the triangle and both of the segment.
void expect_crossing(const Vec3& a, const Vec3& b, const Vec3& p, const Vec3& q, const Vec3& r, bool expected) {
  const Vec3 t[3] = {p, q, r};
  const int orders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& o : orders) {
    EXPECT_EQ(segment_crosses_triangle(a, b, t[o[0]], t[o[1]], t[o[2]]), expected) << o[0] << o[1] << o[2];
    EXPECT_EQ(segment_crosses_triangle(b, a, t[o[0]], t[o[1]], t[o[2]]), expected)
        << o[0] << o[1] << o[2] << " reversed";
  }
}

TEST(ContactPrimitives, SegmentCrossesTriangleKnownCases) {
  const Vec3 p(0, 0, 0), q(1, 0, 0), r(0, 1, 0);
  {
    SCOPED_TRACE("through the plane");
    expect_crossing(Vec3(0.2, 0.2, -1), Vec3(0.2, 0.2, 1), p, q, r, true);       // through the interior
    expect_crossing(Vec3(0, 0, -1), Vec3(0.5, 0.5, 1), p, q, r, true);           // oblique, interior
    expect_crossing(Vec3(1, 1, -1), Vec3(1, 1, 1), p, q, r, false);              // past the hypotenuse
    expect_crossing(Vec3(0.2, 0.2, 0.5), Vec3(0.2, 0.2, 1), p, q, r, false);     // above
    expect_crossing(Vec3(0.5, 0, -1), Vec3(0.5, 0, 1), p, q, r, true);           // through an edge
    expect_crossing(Vec3(0.5, -1e-9, -1), Vec3(0.5, -1e-9, 1), p, q, r, false);  // just beside it
    expect_crossing(Vec3(0, 0, -1), Vec3(0, 0, 1), p, q, r, true);               // through a vertex
    expect_crossing(Vec3(-1, -1, -1), Vec3(1, 1, 1), p, q, r, true);             // obliquely through a vertex
    expect_crossing(Vec3(0.2, 0.2, 0), Vec3(0.2, 0.2, 1), p, q, r, true);        // an end on the face
    expect_crossing(Vec3(0.5, 0.5, 0), Vec3(1, 1, 1), p, q, r, true);            // an end on an edge
    expect_crossing(Vec3(2, 2, 0), Vec3(2, 2, 1), p, q, r, false);               // an end on the plane, outside
    expect_crossing(Vec3(0.2, 0.2, 0), Vec3(0.2, 0.2, 0), p, q, r, true);        // zero length, on the face
    expect_crossing(Vec3(0.2, 0.2, 1), Vec3(0.2, 0.2, 1), p, q, r, false);       // zero length, above
  }
  {
    SCOPED_TRACE("coplanar");
    expect_crossing(Vec3(0.1, 0.1, 0), Vec3(0.3, 0.2, 0), p, q, r, true);  // inside
    expect_crossing(Vec3(-1, 0.2, 0), Vec3(2, 0.2, 0), p, q, r, true);     // across, ends outside
    expect_crossing(Vec3(0.1, 0.1, 0), Vec3(2, 2, 0), p, q, r, true);      // one end inside
    expect_crossing(Vec3(-1, 0, 0), Vec3(0.5, 0, 0), p, q, r, true);       // along an edge, overlapping
    expect_crossing(Vec3(2, 0, 0), Vec3(3, 0, 0), p, q, r, false);         // along an edge's line, apart
    expect_crossing(Vec3(1, 0, 0), Vec3(2, 0, 0), p, q, r, true);          // touching a vertex
    expect_crossing(Vec3(1, -1, 0), Vec3(1, 1, 0), p, q, r, true);         // through a vertex only
    expect_crossing(Vec3(2, -1, 0), Vec3(-1, 2, 0), p, q, r, true);        // over an edge, the ends beyond it
    expect_crossing(Vec3(1.5, -1, 0), Vec3(1.5, 1, 0), p, q, r, false);    // beside a vertex
    expect_crossing(Vec3(1, 0.01, 0), Vec3(0.01, 1, 0), p, q, r, false);   // beside the hypotenuse
    expect_crossing(Vec3(1, 1, 0), Vec3(2, 0.5, 0), p, q, r, false);       // apart
    expect_crossing(Vec3(2, 2, 0), Vec3(2, 2, 0), p, q, r, false);         // zero length, outside
    // A tilted plane z = x + y (exact in binary).
    const Vec3 tp(0, 0, 0), tq(2, 0, 2), tr(0, 2, 2);
    expect_crossing(Vec3(0.5, 0.5, 1), Vec3(-1, -1, -2), tp, tq, tr, true);
    expect_crossing(Vec3(3, 3, 6), Vec3(4, 1, 5), tp, tq, tr, false);
    expect_crossing(Vec3(-1, 1, 0), Vec3(1, -1, 0), tp, tq, tr, true);  // through the vertex tp
  }
  {
    SCOPED_TRACE("zero-area triangle");
    const Vec3 dq(1, 0, 0), dr(2, 0, 0);
    expect_crossing(Vec3(1.5, -1, 0), Vec3(1.5, 1, 0), p, dq, dr, true);
    expect_crossing(Vec3(1.5, -1, 1), Vec3(1.5, 1, 1), p, dq, dr, false);
    expect_crossing(Vec3(0.5, 0, -1), Vec3(0.5, 0, 1), p, dq, dr, true);
    expect_crossing(Vec3(3, 0, 0), Vec3(4, 0, 0), p, dq, dr, false);
    expect_crossing(Vec3(1.5, 0, 0), Vec3(3, 0, 0), p, dq, dr, true);
    expect_crossing(Vec3(1, 1, 1), Vec3(1, 1, 1), p, p, p, false);
    expect_crossing(Vec3(-1, -1, -1), Vec3(1, 1, 1), p, p, p, true);
  }
}

// Random segments against random triangles, where the answer is clear (the
// crossing point at least 1e-9 inside or outside): the predicate agrees.
TEST(ContactPrimitives, SegmentCrossesTriangleAgreesWithThePlaneCrossing) {
  std::mt19937 rng(5);
  int crossing = 0, clear = 0;
  for (int c = 0; c < 20000; ++c) {
    const Vec3 a = random_point(rng), b = random_point(rng), p = random_point(rng), q = random_point(rng),
               r = random_point(rng);
    const Vec3 n = (q - p).cross(r - p);
    const double sa = n.dot(a - p), sb = n.dot(b - p);
    bool expected = false;
    if (sa * sb < 0) {
      const Vec3 x = a + sa / (sa - sb) * (b - a);
      // Barycentric coordinates of x, scaled by |n| so that they compare with a distance.
      const double lp = n.dot((q - x).cross(r - x)), lq = n.dot((r - x).cross(p - x)), lr = n.dot((p - x).cross(q - x));
      const double margin = std::min({lp, lq, lr}) / n.norm();
      if (std::abs(margin) < 1e-9) continue;
      expected = margin > 0;
    } else if (std::min(std::abs(sa), std::abs(sb)) / n.norm() < 1e-9) {
      continue;
    }
    ++clear;
    crossing += expected;
    EXPECT_EQ(segment_crosses_triangle(a, b, p, q, r), expected) << "case " << c;
    if (HasFailure()) return;
  }
  EXPECT_GT(crossing, 500);
  EXPECT_GT(clear - crossing, 5000);
}

// ---------------------------------------------------------------------------
// CCD

using Points = std::array<Vec3, 4>;

Points positions_at(const Points& x, const Points& dx, double t) {
  Points y;
  for (int k = 0; k < 4; ++k) y[k] = x[k] + t * dx[k];
  return y;
}

double distance_at(const Kind& kind, const Points& x, const Points& dx, double t) {
  return distance(kind, positions_at(x, dx, t));
}

// The times in [0, 1] at which the four points are coplanar: the roots of the
// cubic det(y1 - y0, y2 - y0, y3 - y0), y_k = x_k + t dx_k, each found by
// bisection on an interval where the cubic is monotone; a double root where
// the cubic only touches zero counts. `identically_zero` when every time is.
std::vector<double> coplanar_times(const Points& x, const Points& dx, bool& identically_zero) {
  const Vec3 u = x[1] - x[0], v = x[2] - x[0], w = x[3] - x[0];
  const Vec3 du = dx[1] - dx[0], dv = dx[2] - dx[0], dw = dx[3] - dx[0];
  const double c0 = u.dot(v.cross(w));
  const double c1 = du.dot(v.cross(w)) + u.dot(dv.cross(w) + v.cross(dw));
  const double c2 = du.dot(dv.cross(w) + v.cross(dw)) + u.dot(dv.cross(dw));
  const double c3 = du.dot(dv.cross(dw));
  const double size = std::max({std::abs(c0), std::abs(c1), std::abs(c2), std::abs(c3)});
  identically_zero = size == 0;
  std::vector<double> roots;
  if (identically_zero) return roots;
  const auto f = [&](double t) { return ((c3 * t + c2) * t + c1) * t + c0; };
  std::vector<double> knots = {0.0};
  // Critical points: 3 c3 t^2 + 2 c2 t + c1 = 0.
  if (c3 != 0) {
    const double disc = 4 * c2 * c2 - 12 * c3 * c1;
    if (disc >= 0) {
      const double s = std::sqrt(disc);
      for (double t : {(-2 * c2 - s) / (6 * c3), (-2 * c2 + s) / (6 * c3)})
        if (t > 0 && t < 1) knots.push_back(t);
    }
  } else if (c2 != 0) {
    const double t = -c1 / (2 * c2);
    if (t > 0 && t < 1) knots.push_back(t);
  }
  knots.push_back(1.0);
  std::sort(knots.begin(), knots.end());
  for (size_t i = 0; i < knots.size(); ++i)
    if (std::abs(f(knots[i])) <= 1e-12 * size) roots.push_back(knots[i]);
  for (size_t i = 0; i + 1 < knots.size(); ++i) {
    double lo = knots[i], hi = knots[i + 1];
    double flo = f(lo);
    if (!((flo < 0 && f(hi) > 0) || (flo > 0 && f(hi) < 0))) continue;
    for (int it = 0; it < 200; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (mid <= lo || mid >= hi) break;
      const double fm = f(mid);
      if ((fm < 0) == (flo < 0)) {
        lo = mid;
        flo = fm;
      } else {
        hi = mid;
      }
    }
    roots.push_back(0.5 * (lo + hi));
  }
  std::sort(roots.begin(), roots.end());
  return roots;
}

// The first time in [0, 1] at which the point passes through the triangle (the
// edges through each other), from the coplanarity roots; -1 if none, or if the
// motion keeps the points coplanar throughout (then only sampling tells).
double first_crossing(const Kind& kind, const Points& x, const Points& dx) {
  bool identically_zero = false;
  double scale = 1;
  for (int k = 0; k < 4; ++k) scale = std::max({scale, x[k].cwiseAbs().maxCoeff(), dx[k].cwiseAbs().maxCoeff()});
  for (double t : coplanar_times(x, dx, identically_zero))
    if (distance_at(kind, x, dx, t) <= 1e-9 * scale) return t;
  return -1;
}

// The smallest distance over [t0, t1]: n + 1 samples and the extra times
// inside, then a golden-section search around the three lowest sampled local minima.
double min_distance(const Kind& kind, const Points& x, const Points& dx, double t0, double t1, int n,
                    const std::vector<double>& extra) {
  std::vector<double> times(n + 1), d(n + 1);
  for (int i = 0; i <= n; ++i) {
    times[i] = i == n ? t1 : t0 + (t1 - t0) * i / n;
    d[i] = distance_at(kind, x, dx, times[i]);
  }
  double best = *std::min_element(d.begin(), d.end());
  for (double t : extra)
    if (t >= t0 && t <= t1) best = std::min(best, distance_at(kind, x, dx, t));
  std::vector<int> minima;
  for (int i = 0; i <= n; ++i)
    if ((i == 0 || d[i] < d[i - 1]) && (i == n || d[i] <= d[i + 1])) minima.push_back(i);
  std::sort(minima.begin(), minima.end(), [&](int i, int j) { return d[i] < d[j]; });
  if (minima.size() > 3) minima.resize(3);
  const double phi = 0.5 * (std::sqrt(5.0) - 1);
  for (int i : minima) {
    double lo = times[std::max(i - 1, 0)], hi = times[std::min(i + 1, n)];
    double m1 = hi - phi * (hi - lo), m2 = lo + phi * (hi - lo);
    double f1 = distance_at(kind, x, dx, m1), f2 = distance_at(kind, x, dx, m2);
    for (int it = 0; it < 60; ++it) {
      if (f1 < f2) {
        hi = m2;
        m2 = m1;
        f2 = f1;
        m1 = hi - phi * (hi - lo);
        f1 = distance_at(kind, x, dx, m1);
      } else {
        lo = m1;
        m1 = m2;
        f1 = f2;
        m2 = lo + phi * (hi - lo);
        f2 = distance_at(kind, x, dx, m2);
      }
      best = std::min({best, f1, f2});
    }
  }
  return best;
}

struct CcdCounts {
  int cases = 0, crossings = 0, whole = 0, stopped = 0;
};

// Additive CCD on one case: t_safe in [0, 1]; 0 iff the pair starts within the
// separation; > 0 from more than twice the separation; the distance over
// [0, t_safe] stays above the separation; t_safe before the first crossing.
// `expect_whole`: t_safe is 1 when the whole step stays beyond twice the
// separation and the gap d^2 - separation^2 above twice the `reduction` of its
// start (nearer, the algorithm stops by design, not for a collision).
double check_ccd(const Kind& kind, const Points& x, const Points& dx, double separation, double reduction,
                 bool expect_whole, CcdCounts* counts = nullptr) {
  const double t = kind.impact(x.data(), dx.data(), separation, reduction, 1.0);
  EXPECT_TRUE(t >= 0 && t <= 1) << t;
  const double d0 = distance_at(kind, x, dx, 0);
  if (counts) ++counts->cases;
  if (d0 <= separation) {
    EXPECT_EQ(t, 0.0);
    return t;
  }
  if (d0 > 2 * separation) {
    EXPECT_GT(t, 0.0);
  }
  bool coplanar = false;
  const std::vector<double> roots = coplanar_times(x, dx, coplanar);
  const double reached = min_distance(kind, x, dx, 0, t, 2000, roots);
  EXPECT_GT(reached, separation * (1 - 1e-9)) << "t_safe " << t;
  const double crossing = first_crossing(kind, x, dx);
  if (crossing >= 0) {
    EXPECT_LT(t, crossing);
  }
  if (counts) {
    counts->crossings += crossing >= 0;
    counts->whole += t == 1;
  }
  if (expect_whole && t < 1) {
    const double whole = min_distance(kind, x, dx, 0, 1, 2000, roots);
    const double gap = whole * whole - separation * separation, gap0 = d0 * d0 - separation * separation;
    const bool free = whole > 2 * separation && gap > 2 * reduction * gap0;
    EXPECT_FALSE(free) << "t_safe " << t << " though the distance stays above " << whole;
    if (counts) counts->stopped += !free;
  }
  return t;
}

// A random step; half of them aimed so that the pair meets at a random time in [0.05, 1.2].
void random_motion(std::mt19937& rng, const Kind& kind, double step, Points& x, Points& dx) {
  for (Vec3& p : x) p = random_point(rng);
  for (Vec3& d : dx) d = step * random_point(rng);
  if (rng() % 4 == 0) dx[rng() % 4].setZero();
  if (rng() % 2 == 0) return;
  const double tm = uniform(rng, 0.05, 1.2);
  const Points y = positions_at(x, dx, tm);
  if (kind.point_triangle) {
    const double u = uniform(rng, 0, 1), v = uniform(rng, 0, 1 - u);
    const Vec3 target = y[1] + u * (y[2] - y[1]) + v * (y[3] - y[1]);
    dx[0] = (target - x[0]) / tm;
  } else {
    const double s = uniform(rng, 0, 0.9), u = uniform(rng, 0, 1);
    const Vec3 target = y[2] + u * (y[3] - y[2]);
    const Vec3 a0 = (target - s * y[1]) / (1 - s);  // (1 - s) a0 + s a1 = target at tm
    dx[0] = (a0 - x[0]) / tm;
  }
}

void random_ccd_cases(const Kind& kind, const std::vector<double>& separations, int per_seed) {
  const double reductions[] = {0.1, 0.1, 0.5, 0.01};
  CcdCounts counts;
  for (unsigned seed : {21u, 22u, 23u, 24u}) {
    std::mt19937 rng(seed);
    for (int c = 0; c < per_seed; ++c) {
      SCOPED_TRACE(std::string(kind.name) + " seed " + std::to_string(seed) + " case " + std::to_string(c));
      Points x, dx;
      random_motion(rng, kind, uniform(rng, 0, 1.5), x, dx);
      const double separation = separations[rng() % separations.size()];
      check_ccd(kind, x, dx, separation, reductions[rng() % 4], true, &counts);
      if (::testing::Test::HasFailure()) return;
    }
  }
  // The cases exercise both outcomes.
  EXPECT_GT(counts.crossings, counts.cases / 5);
  EXPECT_GT(counts.whole, counts.cases / 10);
}

TEST(ContactCcd, RandomPointTriangleMotionsNeverMiss) {
  random_ccd_cases(kPointTriangle, {0.1, 0.03, 1e-2, 1e-3}, 600);
}

TEST(ContactCcd, RandomEdgeEdgeMotionsNeverMiss) { random_ccd_cases(kEdgeEdge, {0.1, 0.03, 1e-2, 1e-3}, 600); }

TEST(ContactCcd, TinySeparations) {
  random_ccd_cases(kPointTriangle, {1e-6}, 150);
  random_ccd_cases(kEdgeEdge, {1e-6}, 150);
}

// Searching only up to `up_to` (the fraction another pair already stopped the
// move at) gives the whole search's answer below it, and something not below it otherwise.
TEST(ContactCcd, UpToOnlyTellsWhetherThePairStopsTheStepEarlier) {
  std::mt19937 rng(43);
  int beyond = 0, before = 0;
  for (const Kind* kind : {&kPointTriangle, &kEdgeEdge})
    for (int c = 0; c < 400; ++c) {
      SCOPED_TRACE(std::string(kind->name) + " case " + std::to_string(c));
      Points x, dx;
      random_motion(rng, *kind, uniform(rng, 0, 1.5), x, dx);
      const double separation = 1e-2, up_to = uniform(rng, 0.05, 1);
      const double whole = kind->impact(x.data(), dx.data(), separation, 0.1, 1.0);
      const double t = kind->impact(x.data(), dx.data(), separation, 0.1, up_to);
      if (whole < up_to) {
        EXPECT_EQ(t, whole);
      } else {
        EXPECT_GE(t, up_to);
        EXPECT_LE(t, whole);
      }
      beyond += whole >= up_to && whole < 1;
      before += whole < up_to && whole > 0;
      if (HasFailure()) return;
    }
  // Both outcomes occur, with the whole search stopping short of 1.
  EXPECT_GT(beyond, 50);
  EXPECT_GT(before, 50);
}

const double kSeparations[] = {0.1, 1e-3, 1e-6};

TEST(ContactCcd, ParallelEdgesSlidingIntoEachOther) {
  const Vec3 a0(0, 0, 0), a1(1, 0, 0), zero(0, 0, 0);
  for (double xi : kSeparations) {
    SCOPED_TRACE("separation " + std::to_string(xi));
    // Along their common line: b0 reaches a1 at t = 1/3.
    double t = check_ccd(kEdgeEdge, {a0, a1, Vec3(2, 0, 0), Vec3(3, 0, 0)},
                         {zero, zero, Vec3(-3, 0, 0), Vec3(-3, 0, 0)}, xi, 0.1, true);
    EXPECT_LT(t, (1 - xi) / 3);
    // Side by side in a plane, closing to an overlap at t = 1/2.
    t = check_ccd(kEdgeEdge, {a0, a1, Vec3(0.5, 1, 0), Vec3(1.5, 1, 0)}, {zero, zero, Vec3(0, -2, 0), Vec3(0, -2, 0)},
                  xi, 0.1, true);
    EXPECT_LT(t, 0.5);
    // Sliding along and closing, the ends meeting exactly at t = 1.
    t = check_ccd(kEdgeEdge, {a0, a1, Vec3(2, 0, 1), Vec3(3, 0, 1)}, {zero, zero, Vec3(-3, 0, -1), Vec3(-3, 0, -1)}, xi,
                  0.1, true);
    EXPECT_LT(t, 1.0);
    // Sliding past at 1.5 separations, from overlapping: never closer, the whole step
    // (each step of the algorithm slides 0.45 separations: 667 at 1e-3, within its 1000).
    t = check_ccd(kEdgeEdge, {a0, a1, Vec3(0.2, 1.5 * xi, 0), Vec3(1.2, 1.5 * xi, 0)},
                  {zero, zero, Vec3(0.3, 0, 0), Vec3(0.3, 0, 0)}, xi, 0.1, true);
    if (xi >= 1e-3) {
      EXPECT_EQ(t, 1.0);
    }
    // Sliding past at 1.5 separations, arriving from afar: stops early (the gap shrinks), but safe.
    check_ccd(kEdgeEdge, {a0, a1, Vec3(-2, 1.5 * xi, 0), Vec3(-1, 1.5 * xi, 0)},
              {zero, zero, Vec3(4, 0, 0), Vec3(4, 0, 0)}, xi, 0.1, true);
    // Crossing at a right angle through each other's middle at t = 1/2.
    t = check_ccd(kEdgeEdge, {a0, a1, Vec3(0.5, -1, 1), Vec3(0.5, 1, 1)}, {zero, zero, Vec3(0, 0, -2), Vec3(0, 0, -2)},
                  xi, 0.1, true);
    EXPECT_LT(t, 0.5);
    EXPECT_NEAR(first_crossing(kEdgeEdge, {a0, a1, Vec3(0.5, -1, 1), Vec3(0.5, 1, 1)},
                               {zero, zero, Vec3(0, 0, -2), Vec3(0, 0, -2)}),
                0.5, 1e-12);
    // An end through the other's middle at t = 1/2.
    t = check_ccd(kEdgeEdge, {a0, a1, Vec3(0.5, 0, 1), Vec3(0.5, 1, 1)}, {zero, zero, Vec3(0, 0, -2), Vec3(0, 0, -2)},
                  xi, 0.1, true);
    EXPECT_LT(t, 0.5);
  }
}

TEST(ContactCcd, PointGrazingTheTrianglePlane) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), zero(0, 0, 0);
  for (double xi : kSeparations) {
    SCOPED_TRACE("separation " + std::to_string(xi));
    // The triangle turns about its edge ab (c from z = -1 to 1) while the point
    // rises: the point touches the plane at t = 1/2 inside the triangle without
    // crossing it (the height is -0.8 (t - 1/2)^2 over the normal's length).
    const Points x = {Vec3(0.2, 0.1, -0.3), a, b, Vec3(0, 1, -1)};
    const Points dx = {Vec3(0, 0.4, 0.6), zero, zero, Vec3(0, 0, 2)};
    EXPECT_NEAR(first_crossing(kPointTriangle, x, dx), 0.5, 1e-6);
    EXPECT_LT(check_ccd(kPointTriangle, x, dx, xi, 0.1, true), 0.5);
    // The same 3 separations short of touching.
    Points lowered = x;
    lowered[0].z() -= 3 * xi;
    check_ccd(kPointTriangle, lowered, dx, xi, 0.1, true);
    // Parallel to the plane just above the separation, across the triangle (may stop short, safe).
    check_ccd(kPointTriangle, {Vec3(-1, 0.25, xi * (1 + 1e-3)), a, b, Vec3(0, 1, 0)}, {Vec3(3, 0, 0), zero, zero, zero},
              xi, 0.1, true);
    // In the plane, into the edge ca at t = 1/2 (coplanar throughout: sampling is the reference).
    double t = check_ccd(kPointTriangle, {Vec3(-1, 0.25, 0), a, b, Vec3(0, 1, 0)}, {Vec3(2, 0, 0), zero, zero, zero},
                         xi, 0.1, true);
    EXPECT_LT(t, 0.5);
    // In the plane, passing beside the triangle at 3 separations.
    check_ccd(kPointTriangle, {Vec3(-1, -3 * xi, 0), a, b, Vec3(0, 1, 0)}, {Vec3(4, 0, 0), zero, zero, zero}, xi, 0.1,
              true);
  }
}

TEST(ContactCcd, PointThroughAnEdgeOrAVertex) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0), zero(0, 0, 0);
  struct Case {
    const char* name;
    Points x, dx;
  };
  const Case cases[] = {
      {"edge ab head-on", {Vec3(0.5, 0, 1), a, b, c}, {Vec3(0, 0, -2), zero, zero, zero}},
      {"vertex a head-on", {Vec3(0, 0, 1), a, b, c}, {Vec3(0, 0, -2), zero, zero, zero}},
      {"vertex b obliquely", {Vec3(1.5, 0.5, 1), a, b, c}, {Vec3(-1, -1, -2), zero, zero, zero}},
      {"the triangle up through the point at its edge bc",
       {Vec3(0.5, 0.5, 0.3), a, b, c},
       {zero, Vec3(0, 0, 0.6), Vec3(0, 0, 0.6), Vec3(0, 0, 0.6)}},
      {"both moving, through vertex c",
       {Vec3(0, 1.5, 0.5), a, b, c},
       {Vec3(0.2, -1, -1), Vec3(0.2, 0, 0), Vec3(0.2, 0, 0), Vec3(0.2, 0, 0)}},
  };
  for (const Case& k : cases)
    for (double xi : kSeparations) {
      SCOPED_TRACE(std::string(k.name) + ", separation " + std::to_string(xi));
      EXPECT_NEAR(first_crossing(kPointTriangle, k.x, k.dx), 0.5, 1e-12);
      const double t = check_ccd(kPointTriangle, k.x, k.dx, xi, 0.1, true);
      EXPECT_LT(t, 0.5);
      EXPECT_GT(t, 0.1);  // and not needlessly short
    }
}

TEST(ContactCcd, ZeroAndRigidStepsAreWhole) {
  std::mt19937 rng(31);
  for (const Kind* kind : {&kPointTriangle, &kEdgeEdge})
    for (int c = 0; c < 200; ++c) {
      SCOPED_TRACE(std::string(kind->name) + " case " + std::to_string(c));
      Points x;
      for (Vec3& p : x) p = random_point(rng);
      const double d = distance(*kind, x);
      const Points still = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
      const Vec3 shift = random_point(rng, 5);
      const Points rigid = {shift, shift, shift, shift};
      for (const Points* dx : {&still, &rigid}) {
        EXPECT_EQ(kind->impact(x.data(), dx->data(), 0.5 * d, 0.1, 1.0), 1.0);
        EXPECT_EQ(kind->impact(x.data(), dx->data(), d * (1 + 1e-14), 0.1, 1.0), 0.0);  // within the separation
      }
    }
}

TEST(ContactCcd, HugeSteps) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0), zero(0, 0, 0);
  for (double xi : kSeparations) {
    SCOPED_TRACE("separation " + std::to_string(xi));
    // Through the face at t = 1e-6.
    double t =
        check_ccd(kPointTriangle, {Vec3(0.2, 0.2, 1), a, b, c}, {Vec3(0, 0, -1e6), zero, zero, zero}, xi, 0.1, true);
    EXPECT_LT(t, 1e-6);
    // Away along the plane: the whole step.
    t = check_ccd(kPointTriangle, {Vec3(0.2, 0.2, 1), a, b, c}, {Vec3(1e6, 0, 0), zero, zero, zero}, xi, 0.1, true);
    EXPECT_EQ(t, 1.0);
    t = check_ccd(kEdgeEdge, {a, b, Vec3(0.5, -1, 1), Vec3(0.5, 1, 1)},
                  {zero, zero, Vec3(0, 0, -1e6), Vec3(0, 0, -1e6)}, xi, 0.1, true);
    EXPECT_LT(t, 1e-6);
  }
  std::mt19937 rng(41);
  for (const Kind* kind : {&kPointTriangle, &kEdgeEdge})
    for (int c = 0; c < 100; ++c) {
      SCOPED_TRACE(std::string(kind->name) + " case " + std::to_string(c));
      Points x, dx;
      random_motion(rng, *kind, 1e5, x, dx);
      check_ccd(*kind, x, dx, 1e-3, 0.1, true);
      if (HasFailure()) return;
    }
}

TEST(ContactCcd, StartingAtTheSeparation) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0), zero(0, 0, 0), up(0, 0, 1), down(0, 0, -1);
  // Exactly 0.5 above the face (0.25 = 0.5^2 in binary): 0 whether it moves away, towards or not at all.
  const Points x = {Vec3(0.25, 0.25, 0.5), a, b, c};
  for (const Vec3& step : {up, down, zero}) {
    const Points dx = {step, zero, zero, zero};
    EXPECT_EQ(arap::contact::point_triangle_impact(x.data(), dx.data(), 0.5), 0.0);
    EXPECT_EQ(arap::contact::point_triangle_impact(x.data(), dx.data(), 1.0), 0.0);  // within it
    // Just beyond it, moving towards: a small safe fraction.
    const double t = check_ccd(kPointTriangle, x, dx, 0.5 * (1 - 1e-12), 0.1, false);
    if (step == down) {
      EXPECT_LT(t, 1e-10);
    }
  }
  // Edges 0.25 apart at separation 0.25.
  const Points e = {a, b, Vec3(0.5, -1, 0.25), Vec3(0.5, 1, 0.25)};
  for (const Vec3& step : {up, down, zero}) {
    const Points dx = {zero, zero, step, step};
    EXPECT_EQ(arap::contact::edge_edge_impact(e.data(), dx.data(), 0.25), 0.0);
  }
}

}  // namespace
