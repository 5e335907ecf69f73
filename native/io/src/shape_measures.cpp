#include "arap/io/shape_measures.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <unordered_map>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

namespace arap::measure {

namespace {

int find_root(std::vector<int>& parent, int v) {
  while (parent[v] != v) v = parent[v] = parent[parent[v]];
  return v;
}

std::uint64_t edge_key(int a, int b) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) | static_cast<std::uint32_t>(b);
}

Eigen::Vector3d row(const Eigen::Ref<const Points>& P, int v) { return P.row(v).transpose(); }

// Six times the signed volume of the tetrahedron (a, b, c, d).
double orient(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  return (b - a).cross(c - a).dot(d - a);
}

bool same_sign_or_zero(double x, double y, double z) {
  return (x >= 0 && y >= 0 && z >= 0) || (x <= 0 && y <= 0 && z <= 0);
}

// An orientation within rounding of zero is zero: `relative` of the product of
// the lengths it is made of (below that, the sign is the rounding's).
double rounded(double orientation, double scale, double relative = 1e-12) {
  return std::abs(orientation) <= relative * scale ? 0.0 : orientation;
}

// A point within 1e-9 |p - a| of a triangle's plane is on it. A solver's output
// keeps a flat face flat to about 1e-13 of its coordinates: for small triangles
// far from the origin, more than 1e-12 of their size, so their edges would be
// taken as crossing each other's planes, and the edge tests' volumes, as small,
// round to zero, which reads as a line through a corner or along an edge.
constexpr double kOnThePlane = 1e-9;

// Whether x, in the plane of triangle abc, lies on it: its barycentric
// coordinates (signed areas over the triangle's) no lower than -1e-9.
bool on_closed_triangle(const Eigen::Vector3d& x, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                        const Eigen::Vector3d& c) {
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double whole = n.squaredNorm();
  if (!(whole > 0)) return false;
  const double u = n.dot((b - x).cross(c - x)) / whole, v = n.dot((c - x).cross(a - x)) / whole;
  return u >= -1e-9 && v >= -1e-9 && 1 - u - v >= -1e-9;
}

// Segment pq crosses triangle abc (not in its plane). Near-coplanar pairs,
// whose orientations are rounding noise, count as coplanar (not crossing).
bool segment_crosses(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& a,
                     const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const double area = (b - a).cross(c - a).norm();
  const double dp = rounded(orient(a, b, c, p), area * (p - a).norm(), kOnThePlane);
  const double dq = rounded(orient(a, b, c, q), area * (q - a).norm(), kOnThePlane);
  if ((dp > 0 && dq > 0) || (dp < 0 && dq < 0) || (dp == 0 && dq == 0)) return false;
  const double pq = (q - p).norm();
  const double s1 = rounded(orient(p, q, a, b), pq * (a - p).norm() * (b - p).norm());
  const double s2 = rounded(orient(p, q, b, c), pq * (b - p).norm() * (c - p).norm());
  const double s3 = rounded(orient(p, q, c, a), pq * (c - p).norm() * (a - p).norm());
  if (s1 == 0 && s2 == 0 && s3 == 0) return false;
  if (!same_sign_or_zero(s1, s2, s3)) return false;
  if (s1 != 0 && s2 != 0 && s3 != 0) return true;
  // The line passes within rounding of an edge's line or a corner: on the triangle,
  // or on that line beyond it (a vertex lined up with an edge), is told by where
  // the segment meets the plane.
  return on_closed_triangle(p + (dp / (dp - dq)) * (q - p), a, b, c);
}

// Two non-coplanar triangles meet iff an edge of one crosses the other.
bool triangles_intersect(const Eigen::Vector3d* t, const Eigen::Vector3d* u) {
  for (int k = 0; k < 3; ++k) {
    if (segment_crosses(t[k], t[(k + 1) % 3], u[0], u[1], u[2])) return true;
    if (segment_crosses(u[k], u[(k + 1) % 3], t[0], t[1], t[2])) return true;
  }
  return false;
}

}  // namespace

std::vector<Component> components(int vertex_count, const Eigen::Ref<const Triangles>& triangles) {
  std::vector<int> parent(vertex_count);
  std::iota(parent.begin(), parent.end(), 0);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const int r = find_root(parent, triangles(f, 0));
    parent[find_root(parent, triangles(f, 1))] = r;
    parent[find_root(parent, triangles(f, 2))] = find_root(parent, r);
  }
  std::vector<int> id(vertex_count, -1);
  std::vector<Component> out;
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const int r = find_root(parent, triangles(f, 0));
    if (id[r] < 0) id[r] = static_cast<int>(out.size()), out.emplace_back();
    out[id[r]].triangles.push_back(static_cast<int>(f));
  }
  // Closed: every directed edge once, and its reverse once.
  std::unordered_map<std::uint64_t, int> directed;
  for (Component& c : out) {
    directed.clear();
    for (int f : c.triangles)
      for (int k = 0; k < 3; ++k) ++directed[edge_key(triangles(f, k), triangles(f, (k + 1) % 3))];
    c.closed = true;
    for (const auto& [key, count] : directed) {
      const int a = static_cast<int>(key >> 32), b = static_cast<int>(key & 0xffffffffu);
      const auto reverse = directed.find(edge_key(b, a));
      if (count != 1 || reverse == directed.end() || reverse->second != 1) {
        c.closed = false;
        break;
      }
    }
  }
  return out;
}

double signed_volume(const Eigen::Ref<const Points>& positions, const Eigen::Ref<const Triangles>& triangles,
                     const std::vector<int>& which) {
  double six_v = 0;
  for (int f : which)
    six_v +=
        row(positions, triangles(f, 0)).dot(row(positions, triangles(f, 1)).cross(row(positions, triangles(f, 2))));
  return six_v / 6.0;
}

VolumeKept volume_kept(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Points>& posed,
                       const Eigen::Ref<const Triangles>& triangles) {
  VolumeKept v;
  double worst_gap = -1;
  for (const Component& c : components(static_cast<int>(rest.rows()), triangles)) {
    if (!c.closed) {
      ++v.open_components;
      continue;
    }
    ++v.closed_components;
    const double r = signed_volume(rest, triangles, c.triangles), p = signed_volume(posed, triangles, c.triangles);
    v.rest += r, v.posed += p;
    const double ratio = r != 0 ? p / r : 1.0;
    if (std::abs(ratio - 1) > worst_gap) worst_gap = std::abs(ratio - 1), v.worst_ratio = ratio;
  }
  if (v.closed_components > 0 && v.rest != 0) v.ratio = v.posed / v.rest;
  return v;
}

long self_intersecting_pairs(const Eigen::Ref<const Points>& positions, const Eigen::Ref<const Triangles>& triangles,
                             std::vector<std::pair<int, int>>* list) {
  const Eigen::Index m = triangles.rows();
  if (m < 2) return 0;
  std::vector<Eigen::Vector3d> lo(m), hi(m);
  Eigen::Vector3d box_lo = Eigen::Vector3d::Constant(INFINITY), box_hi = -box_lo;
  double extent_sum = 0;
  for (Eigen::Index f = 0; f < m; ++f) {
    lo[f] = hi[f] = row(positions, triangles(f, 0));
    for (int k = 1; k < 3; ++k) {
      lo[f] = lo[f].cwiseMin(row(positions, triangles(f, k)));
      hi[f] = hi[f].cwiseMax(row(positions, triangles(f, k)));
    }
    box_lo = box_lo.cwiseMin(lo[f]), box_hi = box_hi.cwiseMax(hi[f]);
    extent_sum += (hi[f] - lo[f]).maxCoeff();
  }
  // Cells about the size of a triangle, at most ~128 along the box's longest side.
  const double cell = std::max(extent_sum / m, (box_hi - box_lo).maxCoeff() / 128) + 1e-300;
  auto cell_of = [&](const Eigen::Vector3d& p) {
    return ((p - box_lo) / cell).array().floor().cast<long>().min(1L << 20).eval();
  };
  auto cell_key = [](long i, long j, long k) { return (i << 42) | (j << 21) | k; };
  std::unordered_map<long, std::vector<int>> grid;
  for (Eigen::Index f = 0; f < m; ++f) {
    const auto a = cell_of(lo[f]), b = cell_of(hi[f]);
    for (long i = a[0]; i <= b[0]; ++i)
      for (long j = a[1]; j <= b[1]; ++j)
        for (long k = a[2]; k <= b[2]; ++k) grid[cell_key(i, j, k)].push_back(static_cast<int>(f));
  }
  long pairs = 0;
  for (const auto& [key, bucket] : grid) {
    const long ci = key >> 42, cj = (key >> 21) & ((1L << 21) - 1), ck = key & ((1L << 21) - 1);
    for (size_t x = 0; x < bucket.size(); ++x)
      for (size_t y = x + 1; y < bucket.size(); ++y) {
        const int f = bucket[x], g = bucket[y];
        const Eigen::Vector3d overlap_lo = lo[f].cwiseMax(lo[g]), overlap_hi = hi[f].cwiseMin(hi[g]);
        if ((overlap_lo.array() > overlap_hi.array()).any()) continue;
        // Test each pair once: in the cell holding the low corner of the boxes' overlap.
        const auto owner = cell_of(overlap_lo);
        if (owner[0] != ci || owner[1] != cj || owner[2] != ck) continue;
        bool shared = false;
        for (int s = 0; s < 3; ++s)
          for (int t = 0; t < 3; ++t) shared |= triangles(f, s) == triangles(g, t);
        if (shared) continue;
        const Eigen::Vector3d tf[3] = {row(positions, triangles(f, 0)), row(positions, triangles(f, 1)),
                                       row(positions, triangles(f, 2))};
        const Eigen::Vector3d tg[3] = {row(positions, triangles(g, 0)), row(positions, triangles(g, 1)),
                                       row(positions, triangles(g, 2))};
        if (!triangles_intersect(tf, tg)) continue;
        ++pairs;
        if (list) list->emplace_back(std::min(f, g), std::max(f, g));
      }
  }
  return pairs;
}

CrossSections cross_sections(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Points>& posed,
                             const Eigen::Ref<const Triangles>& triangles, int planes) {
  CrossSections out;
  const Eigen::Index n = rest.rows();
  if (n == 0 || triangles.rows() == 0) return out;
  const Eigen::RowVector3d centroid = rest.colwise().mean();
  const Eigen::MatrixXd centered = rest.rowwise() - centroid;
  const Eigen::Matrix3d covariance = centered.transpose() * centered;
  const Eigen::Vector3d axis = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance).eigenvectors().col(2);
  const Eigen::VectorXd t = centered * axis;
  const double t_min = t.minCoeff(), t_max = t.maxCoeff(), extent = t_max - t_min;
  if (!(extent > 0)) return out;
  for (int k = 1; k <= planes; ++k) {
    double level = t_min + extent * k / (planes + 1.0);
    // Keep every vertex off the plane, so that each crossed triangle has exactly two crossed edges.
    for (int tries = 0; tries < 8 && ((t.array() - level).abs() < 1e-9 * extent).any(); ++tries)
      level += 1e-6 * extent * (tries + 1);
    // Crossed edges (one node each) and, per crossed triangle, the link between its two.
    std::unordered_map<std::uint64_t, int> node_of;
    std::vector<std::pair<int, int>> node_edge;
    std::vector<std::vector<int>> links;
    auto node = [&](int a, int b) {
      const std::uint64_t key = edge_key(std::min(a, b), std::max(a, b));
      const auto [it, inserted] = node_of.emplace(key, static_cast<int>(node_edge.size()));
      if (inserted) node_edge.emplace_back(std::min(a, b), std::max(a, b)), links.emplace_back();
      return it->second;
    };
    for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
      int crossed[2], found = 0;
      for (int e = 0; e < 3 && found < 2; ++e) {
        const int a = triangles(f, e), b = triangles(f, (e + 1) % 3);
        if ((t[a] < level) != (t[b] < level)) crossed[found++] = node(a, b);
      }
      if (found == 2 && crossed[0] != crossed[1]) {
        links[crossed[0]].push_back(crossed[1]);
        links[crossed[1]].push_back(crossed[0]);
      }
    }
    auto point = [&](const Eigen::Ref<const Points>& P, int node_id) {
      const auto [a, b] = node_edge[node_id];
      const double s = (level - t[a]) / (t[b] - t[a]);
      return Eigen::Vector3d((1 - s) * row(P, a) + s * row(P, b));
    };
    // Closed loops through nodes of exactly two links (boundaries and non-manifold edges are skipped).
    std::vector<char> seen(node_edge.size(), 0);
    for (size_t start = 0; start < node_edge.size(); ++start) {
      if (seen[start] || links[start].size() != 2) continue;
      std::vector<int> loop{static_cast<int>(start)};
      seen[start] = 1;
      int previous = static_cast<int>(start), current = links[start][0];
      bool closed = false;
      while (!seen[current] && links[current].size() == 2) {
        seen[current] = 1;
        loop.push_back(current);
        const int next = links[current][0] == previous ? links[current][1] : links[current][0];
        previous = current, current = next;
      }
      closed = current == static_cast<int>(start) && loop.size() >= 3;
      if (!closed) continue;
      Eigen::Vector3d area_rest = Eigen::Vector3d::Zero(), area_posed = Eigen::Vector3d::Zero();
      for (size_t i = 0; i < loop.size(); ++i) {
        const int a = loop[i], b = loop[(i + 1) % loop.size()];
        area_rest += 0.5 * point(rest, a).cross(point(rest, b));
        area_posed += 0.5 * point(posed, a).cross(point(posed, b));
      }
      if (!(area_rest.norm() > 1e-12 * extent * extent)) continue;
      out.ratios.push_back(area_posed.norm() / area_rest.norm());
    }
  }
  out.loops = static_cast<int>(out.ratios.size());
  if (out.loops > 0) {
    std::vector<double> sorted = out.ratios;
    std::sort(sorted.begin(), sorted.end());
    out.min = sorted.front();
    out.median = sorted.size() % 2 ? sorted[sorted.size() / 2]
                                   : 0.5 * (sorted[sorted.size() / 2 - 1] + sorted[sorted.size() / 2]);
  }
  return out;
}

}  // namespace arap::measure
