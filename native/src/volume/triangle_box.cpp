#include "volume/triangle_box.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace arap {

namespace {

// Whether the triangle (corners relative to the box's centre) and the box of half sizes `half`
// overlap, widened by `tolerance`, along `axis` (a zero axis separates nothing).
bool overlap_along(const Eigen::Vector3d& axis, const Eigen::Vector3d v[3], const Eigen::Vector3d& half,
                   double tolerance) {
  const double p0 = axis.dot(v[0]), p1 = axis.dot(v[1]), p2 = axis.dot(v[2]);
  const double radius = half.dot(axis.cwiseAbs()) + tolerance * axis.norm();
  return std::min({p0, p1, p2}) <= radius && std::max({p0, p1, p2}) >= -radius;
}

}  // namespace

bool triangle_meets_box(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                        const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double tolerance) {
  const Eigen::Vector3d centre = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
  const Eigen::Vector3d v[3] = {a - centre, b - centre, c - centre};
  const Eigen::Vector3d edge[3] = {v[1] - v[0], v[2] - v[1], v[0] - v[2]};
  for (int d = 0; d < 3; ++d)
    if (!overlap_along(Eigen::Vector3d::Unit(d), v, half, tolerance)) return false;
  if (!overlap_along(edge[0].cross(edge[1]), v, half, tolerance)) return false;
  for (int d = 0; d < 3; ++d)
    for (const Eigen::Vector3d& e : edge)
      if (!overlap_along(Eigen::Vector3d::Unit(d).cross(e), v, half, tolerance)) return false;
  return true;
}

}  // namespace arap
