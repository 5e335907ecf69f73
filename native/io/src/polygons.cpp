#include "arap/io/polygons.h"

namespace arap::io {

Triangles triangulate(const std::vector<std::vector<int>>& polygons) {
  Eigen::Index n = 0;
  for (const auto& p : polygons) n += p.size() >= 3 ? static_cast<Eigen::Index>(p.size()) - 2 : 0;
  Triangles t(n, 3);
  Eigen::Index row = 0;
  for (const auto& p : polygons)
    for (std::size_t k = 1; k + 1 < p.size(); ++k) t.row(row++) << p[0], p[k], p[k + 1];
  return t;
}

std::vector<std::vector<int>> to_polygons(const Triangles& triangles) {
  std::vector<std::vector<int>> out(triangles.rows());
  for (Eigen::Index i = 0; i < triangles.rows(); ++i) out[i] = {triangles(i, 0), triangles(i, 1), triangles(i, 2)};
  return out;
}

}  // namespace arap::io
