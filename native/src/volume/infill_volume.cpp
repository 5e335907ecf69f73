#include "volume/infill_volume.h"

#include <Eigen/Geometry>

namespace arap {

namespace {

Eigen::Vector3d at(const double* P, int v) { return Eigen::Vector3d(P[3 * v], P[3 * v + 1], P[3 * v + 2]); }

}  // namespace

void LatticeBulk::bind(const BoundMesh& m, const InfillGraph& lattice, double gamma) {
  nodes_.clear();
  free_row_ = m.free_row;
  if (!(gamma > 0)) return;
  for (size_t k = 0; k < lattice.neighbors.size(); ++k) {
    const int v = m.rank[m.input_n + static_cast<int>(k)];
    Node node{};
    bool spans = true;
    for (int axis = 0; axis < 3; ++axis) {
      const int below = lattice.neighbors[k][2 * axis], above = lattice.neighbors[k][2 * axis + 1];
      node.minus[axis] = below >= 0 ? m.rank[m.input_n + below] : v;
      node.plus[axis] = above >= 0 ? m.rank[m.input_n + above] : v;
      spans &= below >= 0 || above >= 0;
    }
    if (!spans) continue;
    const double* P = m.rest.data();
    const Eigen::Vector3d x = at(P, node.plus[0]) - at(P, node.minus[0]),
                          y = at(P, node.plus[1]) - at(P, node.minus[1]),
                          z = at(P, node.plus[2]) - at(P, node.minus[2]);
    node.rest = x.dot(y.cross(z));
    if (!(node.rest > 0)) continue;
    double spoke_energy = 0;
    for (int s = m.spoke_begin[v]; s < m.spoke_begin[v + 1]; ++s) {
      if (m.order[m.neighbor[s]] < m.input_n) continue;  // a coupling to the surface
      const Spoke& spoke = m.spokes[s];
      spoke_energy += (spoke.gx * spoke.gx + spoke.gy * spoke.gy + spoke.gz * spoke.gz) / spoke.w;
    }
    node.weight = gamma * spoke_energy;
    nodes_.push_back(node);
  }
}

double LatticeBulk::slope(const Node& node, const double* P, Eigen::Vector3d& x, Eigen::Vector3d& y,
                          Eigen::Vector3d& z) const {
  x = at(P, node.plus[0]) - at(P, node.minus[0]);
  y = at(P, node.plus[1]) - at(P, node.minus[1]);
  z = at(P, node.plus[2]) - at(P, node.minus[2]);
  return 2 * node.weight * (x.dot(y.cross(z)) / node.rest - 1) / node.rest;
}

double LatticeBulk::energy(const double* P) const {
  double e = 0;
  for (const Node& node : nodes_) {
    const Eigen::Vector3d x = at(P, node.plus[0]) - at(P, node.minus[0]),
                          y = at(P, node.plus[1]) - at(P, node.minus[1]),
                          z = at(P, node.plus[2]) - at(P, node.minus[2]);
    const double change = x.dot(y.cross(z)) / node.rest - 1;
    e += node.weight * change * change;
  }
  return e;
}

// dD/d(plus_x) = y x z = -dD/d(minus_x), and cyclically.
template <class Add>
void LatticeBulk::scatter(const double* P, const Add& add) const {
  for (const Node& node : nodes_) {
    Eigen::Vector3d x, y, z;
    const double s = slope(node, P, x, y, z);
    if (s == 0) continue;
    const Eigen::Vector3d dx = s * y.cross(z), dy = s * z.cross(x), dz = s * x.cross(y);
    add(node.plus[0], dx), add(node.minus[0], -dx);
    add(node.plus[1], dy), add(node.minus[1], -dy);
    add(node.plus[2], dz), add(node.minus[2], -dz);
  }
}

void LatticeBulk::add_half_gradient(const double* P, double* g) const {
  scatter(P, [&](int v, const Eigen::Vector3d& d) {
    const int r = free_row_[v];
    if (r >= 0)
      for (int c = 0; c < 3; ++c) g[3 * r + c] += 0.25 * d[c];
  });
}

void LatticeBulk::add_gradient(const double* P, double* gradient) const {
  scatter(P, [&](int v, const Eigen::Vector3d& d) {
    for (int c = 0; c < 3; ++c) gradient[3 * v + c] += d[c];
  });
}

}  // namespace arap
