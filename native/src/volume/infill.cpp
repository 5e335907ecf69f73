#include "volume/infill.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <utility>

#include <Eigen/Geometry>

#include "arap/errors.h"
#include "union_find.h"
#include "volume/triangle_box.h"
#include "volume/winding.h"

namespace arap {

namespace {

// kappa and beta of infill.h (how they were chosen, and what a stiffer lattice would give:
// docs/engine_internals.md).
constexpr double kLatticeStiffness = 10;
constexpr double kCoupling = 4;
// A free vertex's binding in all, relative to beta A_v / h^2, and the grip of a
// cube's constrained vertices on it, relative to its 12 lattice edges (bind_vertices).
constexpr double kBindingScale = 2;
constexpr double kHandleGrip = 10;
// A cube (or a face between two) is inside when the winding number at its centre is at least this:
// above the 1/2 that points on an open sheet take, which rounding would decide either way.
constexpr double kInsideWinding = 0.6;
// How far (times the cube size) a triangle may miss a cube or a face and still meet it: touching counts.
constexpr double kMeetTolerance = 1e-9;
// More lattice cubes than this (over all components) is refused: lower the resolution.
constexpr long kMaxCells = 2000000;

// A cell's integer coordinates packed in 21 bits each, biased so that the
// neighbours of border cells (coordinate -1) pack without sign bits: the
// lattice has at most 256 cells a side, far inside +-2^20.
using CellKey = std::uint64_t;
constexpr int kKeyBits = 21;
constexpr std::int64_t kKeyBias = std::int64_t{1} << (kKeyBits - 1);
constexpr CellKey kKeyMask = (CellKey{1} << kKeyBits) - 1;
CellKey key_of(const Eigen::Vector3i& c) {
  auto packed = [](int v) { return static_cast<CellKey>(v + kKeyBias) & kKeyMask; };
  return (packed(c.x()) << (2 * kKeyBits)) | (packed(c.y()) << kKeyBits) | packed(c.z());
}
Eigen::Vector3i cell_of_key(CellKey key) {
  auto unpacked = [](CellKey bits) { return static_cast<int>(static_cast<std::int64_t>(bits & kKeyMask) - kKeyBias); };
  return {unpacked(key >> (2 * kKeyBits)), unpacked(key >> kKeyBits), unpacked(key)};
}
std::uint64_t pair_key(int a, int b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | static_cast<std::uint32_t>(std::max(a, b));
}
Eigen::Vector3i offset(int q) { return {q % 3 - 1, (q / 3) % 3 - 1, q / 9 - 1}; }  // q in [0, 27)

// Cubes of size h over the box of the mesh's vertices, centred on it.
struct Grid {
  Eigen::Vector3d origin;
  double h = 0;
  Eigen::Vector3i dims;
  Eigen::Vector3i cell_of(const Eigen::Vector3d& p) const {
    Eigen::Vector3i c;
    for (int d = 0; d < 3; ++d) c[d] = std::clamp(static_cast<int>(std::floor((p[d] - origin[d]) / h)), 0, dims[d] - 1);
    return c;
  }
  Eigen::Vector3d corner(const Eigen::Vector3i& c) const { return origin + h * c.cast<double>(); }
};

// The mesh's connected components (over shared vertices): triangles and vertices of each.
struct Parts {
  std::vector<std::vector<int>> faces, vertices;
  std::vector<double> vertex_area;  // a third of the area of each vertex's triangles
};

Parts split_parts(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles) {
  const int n = static_cast<int>(rest.rows());
  Parts parts;
  parts.vertex_area.assign(n, 0.0);
  UnionFind sets(n);
  std::vector<char> used(n, 0);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const Eigen::Vector3d a = rest.row(triangles(f, 0)), b = rest.row(triangles(f, 1)), c = rest.row(triangles(f, 2));
    const double area = 0.5 * (b - a).cross(c - a).norm();
    for (int k = 0; k < 3; ++k) parts.vertex_area[triangles(f, k)] += area / 3, used[triangles(f, k)] = 1;
    sets.join(triangles(f, 0), triangles(f, 1));
    sets.join(triangles(f, 0), triangles(f, 2));
  }
  std::vector<int> part;
  parts.faces.resize(sets.label(used, part));
  parts.vertices.resize(parts.faces.size());
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) parts.faces[part[triangles(f, 0)]].push_back(static_cast<int>(f));
  for (int v = 0; v < n; ++v)
    if (used[v]) parts.vertices[part[v]].push_back(v);
  return parts;
}

// One part's surface: its triangles' corners.
struct PartSurface {
  const Eigen::Ref<const Points>& rest;
  const Eigen::Ref<const Triangles>& triangles;
  const std::vector<int>& faces;
  Eigen::Vector3d corner(int f, int k) const { return rest.row(triangles(faces[f], k)).transpose(); }
};

// The cubes of one part: those of its vertices' box whose centre is inside
// (|winding number| >= kInsideWinding), then the cubes its triangles meet with
// no inside cube among their 27 neighbours (thin parts and open sheets get a
// lattice of their own surface cubes), each with the part's triangles that
// meet it. Which cubes the surface meets depends on the surface, not on how it
// is cut into triangles. Sorted: the same lattice on every run.
struct PartCells {
  std::vector<Eigen::Vector3i> cells;
  std::unordered_map<CellKey, std::vector<int>> surface;  // surface cube -> triangles (in PartSurface) meeting it
};

PartCells part_cells(const Grid& grid, const WindingNumber& winding, const PartSurface& part,
                     const std::vector<Eigen::Vector3i>& vertex_cells, long& budget) {
  Eigen::Vector3i lo = grid.dims, hi = Eigen::Vector3i::Constant(-1);
  for (const Eigen::Vector3i& c : vertex_cells) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
  budget -= static_cast<long>(hi.x() - lo.x() + 1) * (hi.y() - lo.y() + 1) * (hi.z() - lo.z() + 1);
  if (budget < 0)
    throw Error(ErrorCode::InvalidInput, "the infill lattice would have more than " + std::to_string(kMaxCells) +
                                             " cubes: lower the infill resolution");
  std::unordered_map<CellKey, bool> inside;
  for (int i = lo.x(); i <= hi.x(); ++i)
    for (int j = lo.y(); j <= hi.y(); ++j)
      for (int k = lo.z(); k <= hi.z(); ++k) {
        const Eigen::Vector3i c(i, j, k);
        if (std::abs(winding(grid.corner(c) + Eigen::Vector3d::Constant(0.5 * grid.h))) >= kInsideWinding)
          inside.emplace(key_of(c), true);
      }
  PartCells out;
  std::vector<CellKey> keys;
  for (const auto& [key, unused] : inside) keys.push_back(key);
  std::unordered_map<CellKey, bool> near_inside;  // memo
  auto is_near_inside = [&](const Eigen::Vector3i& c) {
    const auto [it, fresh] = near_inside.emplace(key_of(c), false);
    for (int q = 0; q < 27 && fresh && !it->second; ++q) it->second = inside.count(key_of(c + offset(q))) > 0;
    return it->second;
  };
  for (int f = 0; f < static_cast<int>(part.faces.size()); ++f) {
    const Eigen::Vector3d a = part.corner(f, 0), b = part.corner(f, 1), c = part.corner(f, 2);
    const Eigen::Vector3i from = grid.cell_of(a.cwiseMin(b).cwiseMin(c)), to = grid.cell_of(a.cwiseMax(b).cwiseMax(c));
    for (int i = from.x(); i <= to.x(); ++i)
      for (int j = from.y(); j <= to.y(); ++j)
        for (int k = from.z(); k <= to.z(); ++k) {
          const Eigen::Vector3i cell(i, j, k);
          const Eigen::Vector3d box = grid.corner(cell);
          if (is_near_inside(cell) ||
              !triangle_meets_box(a, b, c, box, box + Eigen::Vector3d::Constant(grid.h), kMeetTolerance * grid.h))
            continue;
          std::vector<int>& met = out.surface[key_of(cell)];
          if (met.empty()) keys.push_back(key_of(cell));
          met.push_back(f);
        }
  }
  std::sort(keys.begin(), keys.end());
  for (CellKey key : keys) out.cells.push_back(cell_of_key(key));
  return out;
}

// The lattice as it grows, part after part: its nodes, its edges (summed over
// the cubes that share them) and each node's neighbours along the axes.
struct Lattice {
  Grid grid;
  double edge_weight = 0;  // per cube, to each of its 12 edges
  double coupling = 0;     // a surface vertex's edge to its corner, per unit of the vertex's area
  std::vector<Eigen::Vector3d> nodes;
  std::unordered_map<std::uint64_t, double> edges;  // pair_key(node a, node b) -> weight
};

// The grid over the box of the parts' vertices, `resolution` cubes along its
// longest side; false when it has no normal cube size (no lattice).
bool make_lattice(const Eigen::Ref<const Points>& rest, const Parts& parts, int resolution, Lattice& lattice) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (const auto& list : parts.vertices)
    for (int v : list) lo = lo.cwiseMin(rest.row(v).transpose()), hi = hi.cwiseMax(rest.row(v).transpose());
  const double longest = parts.vertices.empty() ? 0.0 : (hi - lo).maxCoeff();
  Grid& grid = lattice.grid;
  grid.h = longest / resolution;
  // A flat mesh, or one whose faces span less than a normal double's worth of cubes next to a far
  // vertex no face uses (coordinates arrive scaled to the largest), carries no lattice: it is
  // solved as the surface, as an open mesh is.
  if (!std::isnormal(grid.h)) return false;
  for (int d = 0; d < 3; ++d) grid.dims[d] = std::max(1, static_cast<int>(std::ceil((hi[d] - lo[d]) / grid.h - 1e-9)));
  grid.origin = 0.5 * (lo + hi) - 0.5 * grid.h * grid.dims.cast<double>();
  lattice.edge_weight = kLatticeStiffness * grid.h / longest / 4;
  lattice.coupling = kCoupling / (grid.h * grid.h);
  return true;
}

// One part's cubes and the lattice nodes at their corners. Two cubes side by
// side share their corners only when the centre of the face between them is
// inside: the lattice follows the inside of the part, and two limbs closer
// than a cube (each in cubes of its own) stay apart (cf. Rivers & James, who
// split voxels so). Corner q of cube i is 8 i + q; shared corners are merged
// (union-find) into nodes.
struct PartCubes {
  std::vector<Eigen::Vector3i> cells;
  std::unordered_map<CellKey, int> active;  // cell -> index in `cells`
  UnionFind corners;
  std::vector<int> node_of;  // corner slot -> node

  PartCubes(const Grid& grid, const WindingNumber& winding, const PartSurface& surface, PartCells part)
      : cells(std::move(part.cells)), corners(8 * static_cast<int>(cells.size())), node_of(8 * cells.size(), -1) {
    for (size_t i = 0; i < cells.size(); ++i) active.emplace(key_of(cells[i]), static_cast<int>(i));
    for (size_t i = 0; i < cells.size(); ++i)
      for (int axis = 0; axis < 3; ++axis) {
        Eigen::Vector3i next = cells[i];
        ++next[axis];
        const auto it = active.find(key_of(next));
        if (it == active.end()) continue;
        if (!joined(grid, winding, surface, part.surface, cells[i], axis)) continue;
        const int bit = 1 << axis;
        for (int q = 0; q < 8; ++q)
          if (q & bit) corners.join(8 * it->second + (q ^ bit), 8 * static_cast<int>(i) + q);
      }
  }

  // Whether `cell` and its neighbour along +axis share their face's corners: when the face's centre is
  // inside, or, for two surface cubes (a thin part, a sheet), when the surface passes through the face.
  static bool joined(const Grid& grid, const WindingNumber& winding, const PartSurface& surface,
                     const std::unordered_map<CellKey, std::vector<int>>& met, const Eigen::Vector3i& cell, int axis) {
    Eigen::Vector3i next = cell;
    ++next[axis];
    Eigen::Vector3d lo = grid.corner(next), hi = lo + Eigen::Vector3d::Constant(grid.h);
    hi[axis] = lo[axis];
    if (std::abs(winding(0.5 * (lo + hi))) >= kInsideWinding) return true;
    const auto here = met.find(key_of(cell));
    if (here == met.end() || !met.count(key_of(next))) return false;
    for (int f : here->second)
      if (triangle_meets_box(surface.corner(f, 0), surface.corner(f, 1), surface.corner(f, 2), lo, hi,
                             kMeetTolerance * grid.h))
        return true;
    return false;
  }

  // The node at corner q of cube i, made on first use.
  int node(Lattice& lattice, InfillGraph& out, int i, int q) {
    const int root = corners.root(8 * i + q);
    if (node_of[root] < 0) {
      node_of[root] = static_cast<int>(lattice.nodes.size());
      lattice.nodes.push_back(lattice.grid.corner(cells[i] + Eigen::Vector3i(q & 1, (q >> 1) & 1, (q >> 2) & 1)));
      out.neighbors.push_back({-1, -1, -1, -1, -1, -1});
    }
    return node_of[root];
  }

  // The 12 edges of every cube (corners one bit apart), and each node's neighbours along the axes.
  void add_edges(Lattice& lattice, InfillGraph& out) {
    for (size_t i = 0; i < cells.size(); ++i) {
      int corner[8];
      for (int q = 0; q < 8; ++q) corner[q] = node(lattice, out, static_cast<int>(i), q);
      for (int q = 0; q < 8; ++q)
        for (int axis = 0; axis < 3; ++axis)
          if (!(q & (1 << axis))) {
            const int a = corner[q], b = corner[q | (1 << axis)];
            lattice.edges[pair_key(a, b)] += lattice.edge_weight;
            out.neighbors[a][2 * axis + 1] = b;
            out.neighbors[b][2 * axis] = a;
          }
      ++out.cells;
    }
  }

  // The cube a vertex at p in `cell` binds to: its own, or when that is not in
  // the lattice the nearest lattice cube next to it.
  int cube_of(const Grid& grid, const Eigen::Vector3d& p, const Eigen::Vector3i& cell) const {
    auto found = active.find(key_of(cell));
    if (found == active.end()) {
      double best = INFINITY;
      for (int q = 0; q < 27; ++q) {
        const auto it = active.find(key_of(cell + offset(q)));
        if (it == active.end()) continue;
        const Eigen::Vector3d box = grid.corner(cells[it->second]);
        const double d = (p - p.cwiseMax(box).cwiseMin(box + Eigen::Vector3d::Constant(grid.h))).squaredNorm();
        if (d < best) best = d, found = it;
      }
    }
    return found->second;
  }
};

// The Kuhn tetrahedron holding local coordinates t in [0, 1]^3 (the cube split
// along its main diagonal, by the order of the coordinates): its corners (bits
// x, y, z) on the path 000 -> a -> ab -> abc and their barycentric weights,
// which sum to 1 and vary continuously with t.
struct KuhnTetrahedron {
  int corner[4];
  double weight[4];
};

KuhnTetrahedron kuhn_tetrahedron(const Eigen::Vector3d& t) {
  int axis[3] = {0, 1, 2};
  std::sort(axis, axis + 3, [&](int x, int y) { return t[x] > t[y]; });
  KuhnTetrahedron k{{0, 1 << axis[0], (1 << axis[0]) | (1 << axis[1]), 7},
                    {1 - t[axis[0]], t[axis[0]] - t[axis[1]], t[axis[1]] - t[axis[2]], t[axis[2]]}};
  return k;
}

// Each vertex of a part to the corners of the Kuhn tetrahedron of its cube that
// holds it, one edge per corner weighted by the corner's barycentric weight:
// the binding moves continuously with the vertex, so a finer tessellation of
// the same surface binds it the same way. A free vertex binds with
// kBindingScale beta A_v / h^2 in all (the binding is an integral over the
// surface). The constrained vertices of a cube share a grip of kHandleGrip
// times the cube's lattice edge weights instead: a handle of one vertex holds
// the lattice as firmly as a handle of many at any tessellation, where a grip
// weighted by area would let go of the lattice as the mesh is refined. A vertex
// whose own cube is not in the lattice uses the nearest lattice cube next to
// it, its coordinates clamped: its offset, rotated with the lattice, is kept.
void bind_vertices(const Eigen::Ref<const Points>& rest, const Parts& parts, const std::vector<int>& members,
                   const std::vector<Eigen::Vector3i>& vertex_cells, const std::vector<char>& constrained,
                   PartCubes& cubes, Lattice& lattice, InfillGraph& out) {
  const Grid& grid = lattice.grid;
  const int n = static_cast<int>(rest.rows());
  std::vector<int> cube_of(members.size(), -1);
  std::unordered_map<int, int> constrained_in_cube;
  for (size_t index = 0; index < members.size(); ++index) {
    const int v = members[index];
    if (!(parts.vertex_area[v] > 0)) continue;
    cube_of[index] = cubes.cube_of(grid, rest.row(v).transpose(), vertex_cells[index]);
    if (constrained[v]) ++constrained_in_cube[cube_of[index]];
  }
  for (size_t index = 0; index < members.size(); ++index) {
    const int v = members[index], cube = cube_of[index];
    if (cube < 0) continue;
    const double total = constrained[v] ? kHandleGrip * 12 * lattice.edge_weight / constrained_in_cube[cube]
                                        : kBindingScale * lattice.coupling * parts.vertex_area[v];
    const Eigen::Vector3d t = ((rest.row(v).transpose() - grid.origin) / grid.h - cubes.cells[cube].cast<double>())
                                  .cwiseMax(0.0)
                                  .cwiseMin(1.0);
    const KuhnTetrahedron k = kuhn_tetrahedron(t);
    for (int c = 0; c < 4; ++c) {
      if (!(k.weight[c] > 0)) continue;
      out.edges.push_back({v, n + cubes.node(lattice, out, cube, k.corner[c]), total * k.weight[c]});
    }
  }
}

// The lattice's edges (sorted: the same graph on every run) and nodes into `out`.
void write_lattice(const Lattice& lattice, int n, InfillGraph& out) {
  std::vector<std::pair<std::uint64_t, double>> sorted(lattice.edges.begin(), lattice.edges.end());
  std::sort(sorted.begin(), sorted.end());
  out.edges.reserve(out.edges.size() + sorted.size());
  for (const auto& [key, w] : sorted)
    out.edges.push_back({n + static_cast<int>(key >> 32), n + static_cast<int>(key & 0xffffffffu), w});
  out.nodes.resize(static_cast<Eigen::Index>(lattice.nodes.size()), 3);
  for (size_t k = 0; k < lattice.nodes.size(); ++k)
    out.nodes.row(static_cast<Eigen::Index>(k)) = lattice.nodes[k].transpose();
}

}  // namespace

InfillGraph build_infill(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
                         const std::vector<int>& constrained, int resolution) {
  InfillGraph out;
  std::vector<char> is_constrained(static_cast<size_t>(rest.rows()), 0);
  for (int v : constrained) is_constrained[v] = 1;
  const Parts parts = split_parts(rest, triangles);
  Lattice lattice;
  if (!make_lattice(rest, parts, resolution, lattice)) return out;
  out.spacing = lattice.grid.h;
  out.preconditioner_scale = 1 + 9 * kInfillBulk;
  long budget = kMaxCells;
  out.edges.reserve(4 * static_cast<size_t>(rest.rows()));  // a vertex's binding: up to four edges
  for (size_t part = 0; part < parts.faces.size(); ++part) {
    const std::vector<int>& members = parts.vertices[part];
    std::vector<Eigen::Vector3i> vertex_cells;
    vertex_cells.reserve(members.size());
    for (int v : members) vertex_cells.push_back(lattice.grid.cell_of(rest.row(v).transpose()));
    const WindingNumber winding(rest, triangles, parts.faces[part]);
    const PartSurface surface{rest, triangles, parts.faces[part]};
    PartCubes cubes(lattice.grid, winding, surface, part_cells(lattice.grid, winding, surface, vertex_cells, budget));
    cubes.add_edges(lattice, out);
    bind_vertices(rest, parts, members, vertex_cells, is_constrained, cubes, lattice, out);
  }
  write_lattice(lattice, static_cast<int>(rest.rows()), out);
  return out;
}

}  // namespace arap
