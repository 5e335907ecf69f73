#include "arap/tools/quality.h"

#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "arap/mesh_check.h"

namespace arap {

double rigidity_distortion(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Points>& deformed,
                           const Eigen::Ref<const Triangles>& triangles, int* flipped) {
  double weighted = 0, area = 0;
  int flips = 0;
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const Eigen::Vector3d a = rest.row(triangles(f, 0)), b = rest.row(triangles(f, 1)), c = rest.row(triangles(f, 2));
    if (is_degenerate_triangle(a, b, c)) continue;
    // Rest edges in an orthonormal frame of the triangle's plane (2x2), deformed edges in 3D (3x2).
    const Eigen::Vector3d u = b - a, v = c - a, n = u.cross(v);
    const Eigen::Vector3d x = u.normalized(), y = n.cross(u).normalized();
    Eigen::Matrix2d rest_edges;
    rest_edges << u.dot(x), v.dot(x), u.dot(y), v.dot(y);
    const Eigen::Vector3d a2 = deformed.row(triangles(f, 0)), b2 = deformed.row(triangles(f, 1)),
                          c2 = deformed.row(triangles(f, 2));
    Eigen::Matrix<double, 3, 2> deformed_edges;
    deformed_edges << b2 - a2, c2 - a2;
    const Eigen::Matrix<double, 3, 2> gradient = deformed_edges * rest_edges.inverse();
    const Eigen::Vector2d s = Eigen::JacobiSVD<Eigen::Matrix<double, 3, 2>>(gradient).singularValues();
    const double t = 0.5 * n.norm();
    weighted += t * ((s[0] - 1) * (s[0] - 1) + (s[1] - 1) * (s[1] - 1));
    area += t;
    if ((b2 - a2).cross(c2 - a2).dot(n) < 0) ++flips;
  }
  if (flipped) *flipped = flips;
  return area > 0 ? std::sqrt(weighted / area) : 0.0;
}

}  // namespace arap
