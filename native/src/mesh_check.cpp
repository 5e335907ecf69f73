#include "arap/mesh_check.h"

#include <algorithm>
#include <numeric>

#include <Eigen/Geometry>

namespace arap {

bool is_degenerate_triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const double longest2 = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
  const double twice_area = (b - a).cross(c - a).norm();
  // Also catches three coincident points (longest2 == 0).
  return !(twice_area > kDegenerateRelativeArea * longest2);
}

namespace {

// Union-find with path halving.
int find_root(std::vector<int>& parent, int v) {
  while (parent[v] != v) {
    parent[v] = parent[parent[v]];
    v = parent[v];
  }
  return v;
}

}  // namespace

int label_components(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
                     std::vector<int>& component_of_vertex) {
  const int n = static_cast<int>(rest.rows());
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<char> used(n, 0);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const int a = triangles(f, 0), b = triangles(f, 1), c = triangles(f, 2);
    if (is_degenerate_triangle(rest.row(a), rest.row(b), rest.row(c))) continue;
    used[a] = used[b] = used[c] = 1;
    const int ra = find_root(parent, a);
    parent[find_root(parent, b)] = ra;
    parent[find_root(parent, c)] = ra;
  }
  component_of_vertex.assign(n, -1);
  std::vector<int> id_of_root(n, -1);
  int count = 0;
  for (int v = 0; v < n; ++v) {
    if (!used[v]) continue;
    const int r = find_root(parent, v);
    if (id_of_root[r] < 0) id_of_root[r] = count++;
    component_of_vertex[v] = id_of_root[r];
  }
  return count;
}

}  // namespace arap
