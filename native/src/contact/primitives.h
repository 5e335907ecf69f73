// Distances between the primitives of a triangle surface (a point and a
// triangle, two edges), and whether a segment crosses a triangle. Positions
// are rows of a #n by 3 row-major array (internal units).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace arap::contact {

using Vec3 = Eigen::Vector3d;

// The closest points of a pair, as weights on its four points x0..x3: the
// vector between the closest points is v = w0 x0 + w1 x1 + w2 x2 + w3 x3
// (the weights sum to 0), the distance is |v|, and by the envelope theorem
// d|v|/dx_k = w_k v / |v| wherever |v| > 0 and the closest points are unique
// (not so for parallel edges, where the distance can have a kink).

// Point p against triangle (a, b, c): w = {1, -beta_a, -beta_b, -beta_c}
// (beta the closest point's barycentric coordinates). Returns |v|^2.
// A degenerate triangle (zero area) is handled as its longest edge.
double point_triangle_distance2(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, double w[4]);

// Segment (a0, a1) against segment (b0, b1): w = {1 - s, s, -(1 - t), -t}.
// Returns |v|^2. Parallel and zero-length segments are handled (some pair of
// closest points is returned).
double edge_edge_distance2(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1, double w[4]);

// Lower bounds of those distances, cheap enough to skip most far pairs before
// the exact ones: the gap between the two shapes' projections on the axis from
// one's centre to the other's (a projection never lengthens a distance). 0
// when the projections overlap.
double point_triangle_separation(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);
double edge_edge_separation(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1);

// Whether the closed segment (a, b) and the closed triangle (p, q, r) share a
// point. Exact up to rounding of the orientation tests; coplanar overlaps count.
// A zero-area triangle is tested as its longest edge, by distance (zero up to
// the rounding of the coordinates).
bool segment_crosses_triangle(const Vec3& a, const Vec3& b, const Vec3& p, const Vec3& q, const Vec3& r);

}  // namespace arap::contact
