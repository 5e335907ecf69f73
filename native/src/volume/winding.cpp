#include "volume/winding.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace arap {

namespace {

constexpr int kLeafTriangles = 8;
// A cluster farther than this many of its radii is replaced by its dipole.
constexpr double kFarRatio = 2.0;

// Signed solid angle of triangle abc seen from q (Van Oosterom & Strackee 1983).
double solid_angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                   const Eigen::Vector3d& q) {
  const Eigen::Vector3d x = a - q, y = b - q, z = c - q;
  const double lx = x.norm(), ly = y.norm(), lz = z.norm();
  const double numerator = x.dot(y.cross(z));
  const double denominator = lx * ly * lz + x.dot(y) * lz + y.dot(z) * lx + z.dot(x) * ly;
  return 2 * std::atan2(numerator, denominator);
}

}  // namespace

WindingNumber::WindingNumber(const Eigen::Ref<const Points>& positions, const Eigen::Ref<const Triangles>& triangles,
                             const std::vector<int>& which)
    : positions_(positions), triangles_(triangles) {
  // The tree is built over the triangles' centroids (median splits), each
  // with its triangle, then its leaves read the triangles in that order. The
  // triangles' corners are read from `positions` where needed, not copied.
  struct Entry {
    Eigen::Vector3d centroid;
    int face;
  };
  const int count = static_cast<int>(which.size());
  std::vector<Entry> entries(which.size());
  for (int t = 0; t < count; ++t) {
    const int f = which[t];
    const Eigen::Vector3d a = positions.row(triangles(f, 0)), b = positions.row(triangles(f, 1)),
                          c = positions.row(triangles(f, 2));
    entries[t] = {(a + b + c) / 3, f};
  }
  struct Range {
    int node, first, count, depth;
  };
  nodes_.reserve(2 * which.size() / (kLeafTriangles / 2) + 2);  // leaves hold at least half of kLeafTriangles
  nodes_.emplace_back();
  std::vector<Range> stack{{0, 0, count, 0}};
  while (!stack.empty()) {
    const Range r = stack.back();
    stack.pop_back();
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
    for (int k = r.first; k < r.first + r.count; ++k)
      lo = lo.cwiseMin(entries[k].centroid), hi = hi.cwiseMax(entries[k].centroid);
    if (r.count <= kLeafTriangles || r.depth > 48) {
      nodes_[r.node].first = r.first;
      nodes_[r.node].count = r.count;
      continue;
    }
    int axis = 0;
    (hi - lo).maxCoeff(&axis);
    const int half = r.count / 2;
    std::nth_element(entries.begin() + r.first, entries.begin() + r.first + half, entries.begin() + r.first + r.count,
                     [axis](const Entry& s, const Entry& t) { return s.centroid[axis] < t.centroid[axis]; });
    const int child = static_cast<int>(nodes_.size());
    nodes_[r.node].child = child;
    nodes_.emplace_back();
    nodes_.emplace_back();
    stack.push_back({child, r.first, half, r.depth + 1});
    stack.push_back({child + 1, r.first + half, r.count - half, r.depth + 1});
  }
  faces_.resize(which.size());
  for (int t = 0; t < count; ++t) faces_[t] = entries[t].face;
  // Boxes, vector areas and centres bottom-up (children come after their parent).
  for (int i = static_cast<int>(nodes_.size()) - 1; i >= 0; --i) {
    Node& node = nodes_[i];
    node.lo = Eigen::Vector3d::Constant(INFINITY), node.hi = -node.lo;
    node.area.setZero();
    Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
    double total = 0;
    if (node.child < 0) {
      for (int k = node.first; k < node.first + node.count; ++k) {
        const Eigen::Vector3d a = corner(k, 0), b = corner(k, 1), c = corner(k, 2);
        node.lo = node.lo.cwiseMin(a).cwiseMin(b).cwiseMin(c);
        node.hi = node.hi.cwiseMax(a).cwiseMax(b).cwiseMax(c);
        const Eigen::Vector3d vector_area = 0.5 * (b - a).cross(c - a);
        node.area += vector_area;
        const double area = vector_area.norm();
        weighted += area * (a + b + c) / 3, total += area;
      }
      node.total_area = total;
    } else {
      for (int c = node.child; c <= node.child + 1; ++c) {
        const Node& k = nodes_[c];
        node.lo = node.lo.cwiseMin(k.lo), node.hi = node.hi.cwiseMax(k.hi);
        node.area += k.area;
        weighted += k.total_area * k.centre, total += k.total_area;
      }
      node.total_area = total;
    }
    node.centre = total > 0 ? Eigen::Vector3d(weighted / total) : Eigen::Vector3d(0.5 * (node.lo + node.hi));
    node.radius = 0;
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d p((corner & 1) ? node.hi.x() : node.lo.x(), (corner & 2) ? node.hi.y() : node.lo.y(),
                              (corner & 4) ? node.hi.z() : node.lo.z());
      node.radius = std::max(node.radius, (p - node.centre).norm());
    }
  }
}

double WindingNumber::solid_angles(int i, const Eigen::Vector3d& q) const {
  const Node& node = nodes_[i];
  const Eigen::Vector3d r = node.centre - q;
  const double distance = r.norm();
  if (distance > kFarRatio * node.radius) return node.area.dot(r) / (distance * distance * distance);
  if (node.child >= 0) return solid_angles(node.child, q) + solid_angles(node.child + 1, q);
  double sum = 0;
  for (int k = node.first; k < node.first + node.count; ++k)
    sum += solid_angle(corner(k, 0), corner(k, 1), corner(k, 2), q);
  return sum;
}

double WindingNumber::operator()(const Eigen::Vector3d& q) const {
  if (faces_.empty()) return 0;
  return solid_angles(0, q) / (4 * M_PI);
}

}  // namespace arap
