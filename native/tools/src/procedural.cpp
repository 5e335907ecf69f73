#include "arap/tools/procedural.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <unordered_map>

#include "arap/errors.h"

namespace arap::procedural {
namespace {

constexpr double kPi = 3.14159265358979323846;

void require(bool ok, const std::string& what) {
  if (!ok) throw Error(ErrorCode::InvalidInput, what);
}

// Adds quad a-b-c-d (counter-clockwise seen from outside) as two triangles,
// alternating the diagonal with `flip` so that the mesh has no preferred direction.
void add_quad(std::vector<std::array<int, 3>>& tris, int a, int b, int c, int d, bool flip) {
  if (flip) {
    tris.push_back({a, b, d});
    tris.push_back({b, c, d});
  } else {
    tris.push_back({a, b, c});
    tris.push_back({a, c, d});
  }
}

Triangles to_matrix(const std::vector<std::array<int, 3>>& tris) {
  Triangles t(static_cast<Eigen::Index>(tris.size()), 3);
  for (std::size_t i = 0; i < tris.size(); ++i)
    t.row(static_cast<Eigen::Index>(i)) << tris[i][0], tris[i][1], tris[i][2];
  return t;
}

// The surface of a cube [0, 2]^3 of about `target_vertices` lattice points
// with each point moved to the unit direction it stands for: warped by tan
// so that the cells come out of similar size on the sphere.
TriMesh unit_sphere_lattice(int target_vertices) {
  const int n = std::max(1, static_cast<int>(std::lround(std::sqrt((target_vertices - 2) / 6.0))));
  TriMesh m = make_bar(n, n, n, 2.0, 2.0, 2.0);
  for (Eigen::Index i = 0; i < m.vertices.rows(); ++i) {
    Eigen::Vector3d p;
    for (int k = 0; k < 3; ++k) p[k] = std::tan((m.vertices(i, k) - 1.0) * kPi / 4);
    m.vertices.row(i) = p.normalized().transpose();
  }
  return m;
}

}  // namespace

TriMesh make_bar(int nx, int ny, int nz, double sx, double sy, double sz) {
  require(nx >= 1 && ny >= 1 && nz >= 1, "bar: cell counts must be at least 1");
  require(sx > 0 && sy > 0 && sz > 0, "bar: sizes must be positive");
  const int n[3] = {nx, ny, nz};
  // Surface lattice point -> vertex id (a hash map: the box's volume can be
  // far larger than its surface for benchmark sizes).
  auto lattice = [&](int i, int j, int k) { return (static_cast<long long>(k) * (ny + 1) + j) * (nx + 1) + i; };
  std::unordered_map<long long, int> id;
  std::vector<std::array<double, 3>> pts;
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j) {
      const bool cap = k == 0 || k == nz || j == 0 || j == ny;
      for (int i = 0; i <= nx; i += (cap || i == nx) ? 1 : nx) {
        id[lattice(i, j, k)] = static_cast<int>(pts.size());
        pts.push_back({sx * i / nx, sy * j / ny, sz * k / nz});
      }
    }
  std::vector<std::array<int, 3>> tris;
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;  // e_b x e_c = e_a
    for (int side : {0, n[a]}) {
      for (int u = 0; u < n[b]; ++u) {
        for (int v = 0; v < n[c]; ++v) {
          auto vid = [&](int du, int dv) {
            int q[3];
            q[a] = side;
            q[b] = u + du;
            q[c] = v + dv;
            return id.at(lattice(q[0], q[1], q[2]));
          };
          const bool flip = (u + v) % 2 == 1;
          if (side == n[a])
            add_quad(tris, vid(0, 0), vid(1, 0), vid(1, 1), vid(0, 1), flip);
          else
            add_quad(tris, vid(0, 0), vid(0, 1), vid(1, 1), vid(1, 0), flip);
        }
      }
    }
  }
  TriMesh m;
  m.vertices.resize(static_cast<Eigen::Index>(pts.size()), 3);
  for (std::size_t i = 0; i < pts.size(); ++i)
    m.vertices.row(static_cast<Eigen::Index>(i)) << pts[i][0], pts[i][1], pts[i][2];
  m.triangles = to_matrix(tris);
  return m;
}

TriMesh make_bar_with_vertices(int target_vertices, double length) {
  require(target_vertices >= 26, "bar: at least 26 vertices");
  require(length >= 1, "bar: length (aspect ratio) must be at least 1");
  // #V = 2 n^2 + 4 n nz + 2 with nz = length * n.
  const int n = std::max(1, static_cast<int>(std::lround(std::sqrt((target_vertices - 2) / (2 + 4 * length)))));
  const int nz = std::max(1, static_cast<int>(std::lround(length * n)));
  return make_bar(n, n, nz, 1.0, 1.0, length);
}

TriMesh make_cylinder(int segments, int rings, double radius, double height) {
  require(segments >= 3 && rings >= 1, "cylinder: at least 3 segments and 1 ring");
  require(radius > 0 && height > 0, "cylinder: radius and height must be positive");
  TriMesh m;
  const int nv = segments * (rings + 1) + 2;
  const int bottom = nv - 2, top = nv - 1;
  m.vertices.resize(nv, 3);
  for (int r = 0; r <= rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double t = 2 * kPi * s / segments;
      m.vertices.row(r * segments + s) << radius * std::cos(t), radius * std::sin(t), height * r / rings;
    }
  m.vertices.row(bottom) << 0, 0, 0;
  m.vertices.row(top) << 0, 0, height;
  auto vid = [segments](int r, int s) { return r * segments + (s % segments); };
  std::vector<std::array<int, 3>> tris;
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s)
      add_quad(tris, vid(r, s), vid(r, s + 1), vid(r + 1, s + 1), vid(r + 1, s), (r + s) % 2 == 1);
  for (int s = 0; s < segments; ++s) {
    tris.push_back({bottom, vid(0, s + 1), vid(0, s)});
    tris.push_back({top, vid(rings, s), vid(rings, s + 1)});
  }
  m.triangles = to_matrix(tris);
  return m;
}

TriMesh make_sphere(int target_vertices, double radius, double bumpiness) {
  require(target_vertices >= 8, "sphere: at least 8 vertices");
  require(radius > 0 && bumpiness > -1 && bumpiness < 1, "sphere: radius > 0 and |bumpiness| < 1");
  TriMesh m = unit_sphere_lattice(target_vertices);
  for (Eigen::Index i = 0; i < m.vertices.rows(); ++i) {
    const Eigen::Vector3d d = m.vertices.row(i);
    const double bump = std::sin(3 * d.x() + 1) * std::sin(2 * d.y() + 2) * std::cos(2.5 * d.z());
    m.vertices.row(i) *= radius * (1 + bumpiness * bump);
  }
  return m;
}

TriMesh make_ellipsoid(int target_vertices, const Eigen::Vector3d& semi_axes) {
  require(target_vertices >= 8, "ellipsoid: at least 8 vertices");
  require(semi_axes.minCoeff() > 0 && semi_axes.allFinite(), "ellipsoid: semi-axes must be positive");
  TriMesh m = unit_sphere_lattice(target_vertices);
  m.vertices = m.vertices * semi_axes.asDiagonal();
  // make_bar() adds each quad as two triangles in a row, (a, b, c) + (a, c, d) or (a, b, d) + (b, c, d).
  for (Eigen::Index q = 0; q + 1 < m.triangles.rows(); q += 2) {
    const auto t0 = m.triangles.row(q), t1 = m.triangles.row(q + 1);
    const bool diagonal_ac = t0(0) == t1(0);
    const int a = t0(0), b = t0(1), c = diagonal_ac ? t0(2) : t1(1), d = t1(2);
    const auto& V = m.vertices;
    if ((V.row(b) - V.row(d)).squaredNorm() < (V.row(a) - V.row(c)).squaredNorm()) {
      m.triangles.row(q) << a, b, d;
      m.triangles.row(q + 1) << b, c, d;
    } else {
      m.triangles.row(q) << a, b, c;
      m.triangles.row(q + 1) << a, c, d;
    }
  }
  return m;
}

TriMesh make_torus(int around, int segments, double major_radius, double minor_radius) {
  require(around >= 3 && segments >= 3, "torus: at least 3 rings of 3 vertices");
  require(major_radius > minor_radius && minor_radius > 0, "torus: radii must satisfy major > minor > 0");
  TriMesh m;
  m.vertices.resize(around * segments, 3);
  auto vid = [&](int r, int s) { return (r % around) * segments + (s % segments); };
  for (int r = 0; r < around; ++r)
    for (int s = 0; s < segments; ++s) {
      const double u = 2 * kPi * r / around, v = 2 * kPi * s / segments;
      const double w = major_radius + minor_radius * std::cos(v);
      m.vertices.row(vid(r, s)) << w * std::cos(u), w * std::sin(u), minor_radius * std::sin(v);
    }
  std::vector<std::array<int, 3>> tris;
  for (int r = 0; r < around; ++r)
    for (int s = 0; s < segments; ++s)
      add_quad(tris, vid(r, s), vid(r + 1, s), vid(r + 1, s + 1), vid(r, s + 1), (r + s) % 2 == 1);
  m.triangles = to_matrix(tris);
  return m;
}

HeightConstraints pick_by_height(const Points& vertices, int axis, double fixed_fraction, double handle_fraction) {
  require(axis >= 0 && axis <= 2, "pick_by_height: axis must be 0, 1 or 2");
  require(vertices.rows() > 0, "pick_by_height: no vertices");
  const double lo = vertices.col(axis).minCoeff(), hi = vertices.col(axis).maxCoeff();
  const double extent = hi - lo, eps = 1e-9 * std::max(extent, 1.0);
  HeightConstraints c;
  for (Eigen::Index i = 0; i < vertices.rows(); ++i) {
    const double h = vertices(i, axis);
    if (h <= lo + fixed_fraction * extent + eps)
      c.fixed.push_back(static_cast<int>(i));
    else if (h >= hi - handle_fraction * extent - eps)
      c.handle.push_back(static_cast<int>(i));
  }
  return c;
}

Bend bend(const Points& vertices, double shift) {
  require(vertices.rows() > 0 && vertices.allFinite(), "bend: no vertices, or non-finite ones");
  const Eigen::RowVector3d extent = vertices.colwise().maxCoeff() - vertices.colwise().minCoeff();
  int up = 0;
  extent.maxCoeff(&up);
  const HeightConstraints picked = pick_by_height(vertices, up);
  Bend b;
  b.constrained = picked.fixed;
  b.fixed_count = static_cast<int>(picked.fixed.size());
  b.constrained.insert(b.constrained.end(), picked.handle.begin(), picked.handle.end());
  b.targets.resize(static_cast<Eigen::Index>(b.constrained.size()), 3);
  for (std::size_t k = 0; k < b.constrained.size(); ++k) {
    const Eigen::Index row = static_cast<Eigen::Index>(k);
    b.targets.row(row) = vertices.row(b.constrained[k]);
    if (static_cast<int>(k) >= b.fixed_count) b.targets(row, (up + 1) % 3) += shift * extent[up];
  }
  return b;
}

}  // namespace arap::procedural
