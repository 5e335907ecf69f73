// Volume: Infill's bulk term. ARAP alone is a material with no resistance to
// volume change beyond its resistance to any change of shape (Poisson's ratio
// 0): a thick bar pushed together shortens instead of bulging. The lattice
// therefore carries, per node i, a penalty on the change of the volume its
// axis neighbours span,
//   E_bulk = sum_i c_i (D_i / D_i,rest - 1)^2,
//   D_i = det[x+ - x-, y+ - y-, z+ - z-]
// (central differences of the deformation along the three lattice axes; a
// missing neighbour is replaced by the node itself), c_i = gamma times the
// node's rest lattice spoke energy sum_j w_ij |e_ij|^2, so that gamma is the
// bulk stiffness relative to ARAP's. It is not quadratic, so it is minimised
// on the quasi-Newton path (with the Laplacian as preconditioner and a line
// search), which keeps the energy monotone.
#pragma once

#include <vector>

#include "bound_mesh.h"
#include "volume/infill.h"

namespace arap {

class LatticeBulk {
 public:
  void bind(const BoundMesh& m, const InfillGraph& lattice, double gamma);
  bool active() const { return !nodes_.empty(); }
  double energy(const double* P) const;
  // g += 1/4 dE_bulk/dp on the free rows (3 per free row), the scale of the solver's g (volume_term.h).
  void add_half_gradient(const double* P, double* g) const;
  // gradient += dE_bulk/dp for every vertex (#n by 3, internal order).
  void add_gradient(const double* P, double* gradient) const;

 private:
  struct Node {
    int minus[3], plus[3];  // internal vertex indices
    double rest;            // D_i at rest
    double weight;          // c_i
  };
  // dE/dD_i and the three columns X, Y, Z of D_i's matrix.
  double slope(const Node& node, const double* P, Eigen::Vector3d& x, Eigen::Vector3d& y, Eigen::Vector3d& z) const;
  template <class Add>
  void scatter(const double* P, const Add& add) const;

  std::vector<Node> nodes_;
  std::vector<int> free_row_;  // as in BoundMesh
};

}  // namespace arap
