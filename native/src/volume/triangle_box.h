// Whether a triangle meets an axis-aligned box, by the separating axis test
// (the box's 3 axes, the triangle's normal and the 9 cross products of their
// edges; cf. Akenine-Möller 2001). Closed sets, widened by `tolerance`: a
// triangle touching the box meets it, so the answer depends only on the
// surface the triangles cover, not on how it is cut into triangles. A box may
// be flat (a face of a cube: lo == hi along one axis).
#pragma once

#include <Eigen/Core>

namespace arap {

bool triangle_meets_box(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                        const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double tolerance);

}  // namespace arap
