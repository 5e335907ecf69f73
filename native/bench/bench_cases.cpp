#include "bench_cases.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <unordered_map>

#ifdef ARAP_BENCH_HAVE_IO
#include "arap/mesh_io.h"
#include "arap/scenario.h"
#endif

namespace bench {
namespace {

// The surface of the lattice box [0,nx] x [0,ny] x [0,nz]: its boundary
// lattice points (as integer coordinates) and two outward-facing triangles
// per boundary cell.
void box_lattice(int nx, int ny, int nz, std::vector<Eigen::Vector3i>& points, Triangles& F) {
  const int size[3] = {nx, ny, nz};
  std::unordered_map<std::int64_t, int> id;
  auto vertex = [&](const Eigen::Vector3i& p) {
    const std::int64_t key = (std::int64_t(p[0]) * (ny + 1) + p[1]) * (nz + 1) + p[2];
    auto [it, inserted] = id.emplace(key, static_cast<int>(points.size()));
    if (inserted) points.push_back(p);
    return it->second;
  };
  std::vector<Eigen::Vector3i> tris;
  for (int d = 0; d < 3; ++d) {
    const int u = (d + 1) % 3, v = (d + 2) % 3;  // e_u x e_v = e_d
    for (int side = 0; side < 2; ++side)
      for (int a = 0; a < size[u]; ++a)
        for (int b = 0; b < size[v]; ++b) {
          int corner[4];
          for (int c = 0; c < 4; ++c) {
            Eigen::Vector3i p;
            p[d] = side * size[d];
            p[u] = a + (c == 1 || c == 2);
            p[v] = b + (c >= 2);
            corner[c] = vertex(p);
          }
          // corners 0, 1, 2, 3 go counter-clockwise seen from +d; each quad
          // (a, b, c, d) outward becomes the pair (a, b, c), (a, c, d)
          if (side == 1) {
            tris.emplace_back(corner[0], corner[1], corner[2]);
            tris.emplace_back(corner[0], corner[2], corner[3]);
          } else {
            tris.emplace_back(corner[0], corner[3], corner[2]);
            tris.emplace_back(corner[0], corner[2], corner[1]);
          }
        }
  }
  F.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (size_t t = 0; t < tris.size(); ++t) F.row(static_cast<Eigen::Index>(t)) = tris[t].transpose();
}

// Splits every quad of box_lattice() along its shorter diagonal once the
// points are placed, so that curved quads give no needlessly obtuse angles
// (whose negative cotangent weights would make the `cotan` energy indefinite).
void split_along_shorter_diagonal(const Points& V, Triangles& F) {
  for (Eigen::Index q = 0; q + 1 < F.rows(); q += 2) {
    const int a = F(q, 0), b = F(q, 1), c = F(q, 2), d = F(q + 1, 2);
    if ((V.row(b) - V.row(d)).squaredNorm() < (V.row(a) - V.row(c)).squaredNorm()) {
      F.row(q) << a, b, d;
      F.row(q + 1) << b, c, d;
    }
  }
}

}  // namespace

void make_ellipsoid(int vertices, Points& V, Triangles& F) {
  // 6 n^2 + 2 lattice points on the surface of an n-cube.
  const int n = std::max(2, static_cast<int>(std::lround(std::sqrt((vertices - 2) / 6.0))));
  std::vector<Eigen::Vector3i> lattice;
  box_lattice(n, n, n, lattice, F);
  V.resize(static_cast<Eigen::Index>(lattice.size()), 3);
  const double quarter_pi = std::atan(1.0);
  for (size_t i = 0; i < lattice.size(); ++i) {
    Eigen::Vector3d p;
    // tan warp: equal angles instead of equal cube steps, for rounder triangles
    for (int d = 0; d < 3; ++d) p[d] = std::tan(quarter_pi * (2.0 * lattice[i][d] / n - 1.0));
    p.normalize();
    p.z() *= 2.0;
    V.row(static_cast<Eigen::Index>(i)) = p.transpose();
  }
  split_along_shorter_diagonal(V, F);
}

void make_bar(int vertices, Points& V, Triangles& F) {
  // 26 s^2 + 2 lattice points on an s x s x 6s box.
  const int s = std::max(1, static_cast<int>(std::lround(std::sqrt((vertices - 2) / 26.0))));
  std::vector<Eigen::Vector3i> lattice;
  box_lattice(s, s, 6 * s, lattice, F);
  V.resize(static_cast<Eigen::Index>(lattice.size()), 3);
  for (size_t i = 0; i < lattice.size(); ++i) V.row(static_cast<Eigen::Index>(i)) = lattice[i].cast<double>().transpose() / s;
}

void bend_scenario(Case& c) {
  const Eigen::RowVector3d lo = c.rest.colwise().minCoeff(), hi = c.rest.colwise().maxCoeff();
  int up = 0;
  (hi - lo).maxCoeff(&up);
  const int side = (up + 1) % 3;
  const double h = hi[up] - lo[up];
  std::vector<int> handles;
  c.constrained.clear();
  for (int v = 0; v < c.rest.rows(); ++v) {
    const double z = c.rest(v, up);
    if (z <= lo[up] + 0.2 * h)
      c.constrained.push_back(v);
    else if (z >= hi[up] - 0.05 * h)
      handles.push_back(v);
  }
  c.fixed_count = static_cast<int>(c.constrained.size());
  c.constrained.insert(c.constrained.end(), handles.begin(), handles.end());
  c.targets.resize(static_cast<Eigen::Index>(c.constrained.size()), 3);
  for (size_t s = 0; s < c.constrained.size(); ++s) {
    c.targets.row(static_cast<Eigen::Index>(s)) = c.rest.row(c.constrained[s]);
    if (static_cast<int>(s) >= c.fixed_count) c.targets(static_cast<Eigen::Index>(s), side) += 0.3 * h;
  }
}

Case procedural_case(const std::string& shape, int vertices) {
  Case c;
  if (shape == "sphere")
    make_ellipsoid(vertices, c.rest, c.triangles);
  else if (shape == "bar")
    make_bar(vertices, c.rest, c.triangles);
  else
    throw std::runtime_error("unknown shape '" + shape + "' (sphere or bar)");
  const long n = static_cast<long>(c.rest.rows());
  c.name = shape + "-" + (n >= 1000000 ? std::to_string((n + 500000) / 1000000) + "M"
                         : n >= 1000  ? std::to_string((n + 500) / 1000) + "k"
                                      : std::to_string(n));
  c.source = "procedural";
  bend_scenario(c);
  return c;
}

Case file_case(const std::string& path) {
#ifdef ARAP_BENCH_HAVE_IO
  Case c;
  c.source = path;
  c.name = std::filesystem::path(path).stem().string();
  auto read = [&c](const std::string& mesh_path) {
    arap::io::PolygonMesh mesh = arap::io::read_mesh(mesh_path);
    c.rest = std::move(mesh.vertices);
    c.triangles = arap::io::triangulate(mesh.polygons);
  };
  if (arap::io::extension_of(path) != "json") {
    read(path);
    bend_scenario(c);
    return c;
  }
  const arap::io::Scenario scenario = arap::io::load_scenario(path);
  if (!scenario.name.empty()) c.name = scenario.name;
  read(scenario.mesh_path);
  arap::io::Constraints constraints = arap::io::build_constraints(c.rest, scenario.fixed, scenario.handles);
  c.constrained = std::move(constraints.indices);
  c.targets = std::move(constraints.targets);
  c.fixed_count = constraints.fixed_count;
  return c;
#else
  throw std::runtime_error(path + ": this arap-bench was built without arap_io, so it reads no files");
#endif
}

}  // namespace bench
