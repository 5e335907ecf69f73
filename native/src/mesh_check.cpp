#include "arap/mesh_check.h"

#include <algorithm>

#include <Eigen/Geometry>

#include "union_find.h"

namespace arap {

bool is_degenerate_triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  return twice_area_unless_degenerate(a, b, c) == 0;
}

int label_components(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
                     std::vector<int>& component_of_vertex) {
  const int n = static_cast<int>(rest.rows());
  UnionFind sets(n);
  std::vector<char> used(n, 0);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const int a = triangles(f, 0), b = triangles(f, 1), c = triangles(f, 2);
    if (is_degenerate_triangle(rest.row(a), rest.row(b), rest.row(c))) continue;
    used[a] = used[b] = used[c] = 1;
    sets.join(a, b);
    sets.join(a, c);
  }
  return sets.label(used, component_of_vertex);
}

}  // namespace arap
