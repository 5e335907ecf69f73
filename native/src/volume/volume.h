// Volume: Global — the enclosed volume of every closed component of the
// surface held at its rest value, V_c(p) = V_c(p_rest), one constraint per
// component, V_c(p) = 1/6 sum_{t in c} p_a . (p_b x p_c) (divergence theorem).
//
// The solver keeps every iterate on the constraint set and measures all
// directions in the metric of the factored Laplacian L (the plain global
// step's own metric):
//   n_c = dV_c/dp (the free rows of component c), u_c = L^-1 n_c (the metric's
//   normal: one extra triangular solve for all components at once, since L
//   couples no two components);
//   the multiplier lambda_c = (u_c . g) / (n_c . u_c) makes g~ = g - lambda n
//   the gradient of the Lagrangian, and L^-1 g~ is tangent (n . L^-1 g~ = 0):
//   x - L^-1 g~ is the minimiser of the global step's quadratic on the
//   tangent plane (a constrained global step);
//   a step d is projected on the tangent plane, d - u (n . d) / (n . u), and
//   the trial point x + d is brought back onto the constraint along u:
//   V_c(x + d + mu u) is a cubic in mu, whose root nearest 0 is taken exactly.
// Components that are open (an edge not shared by exactly two triangles of
// opposite directions), have no free vertex, or enclose (almost) no volume are
// left alone.
#pragma once

#include <vector>

#include "arap/types.h"
#include "bound_mesh.h"

namespace arap {

class VolumeConstraint {
 public:
  // triangles: internal vertex indices (see bound_mesh.h). Finds the kept components.
  void bind(const BoundMesh& m, const Triangles& triangles);
  int kept_components() const { return static_cast<int>(target_.size()); }
  // Closed components whose volume is not kept (no free vertex, or no volume) are counted as
  // such; open ones here.
  int open_components() const { return open_; }
  bool active() const { return !target_.empty(); }

  // n = dV/dp over the free rows (3 per row), 0 on rows of no kept component.
  void gradient(const double* P, double* n) const;
  // Takes n and u = L^-1 n (3 per free row) as the current normal: the
  // calls below use them, and these per-component sums of theirs.
  void set_normal(const double* n, const double* u);
  // Projects d on the tangent plane: d -= u (n . d) / (n . u), per component.
  void project_tangent(double* d, const double* n, const double* u);
  // g -= lambda n with lambda_c = (u . g) / (n . u): the Lagrangian gradient.
  void lagrangian_gradient(double* g, const double* n, const double* u);
  // Moves the free rows of each component of P (#V by 3, internal order) along u
  // so that its volume is its rest volume again (the cubic's root nearest 0).
  // Returns false, P unchanged, when some component has no root within reach
  // (a move longer than half the rest shape's size).
  bool retract(double* P, const double* u);
  // Largest |V_c(P) / V_c(rest) - 1| over the kept components.
  double drift(const double* P) const;

 private:
  // Coefficients of V_c(P + mu u) = a0 + a1 mu + a2 mu^2 + a3 mu^3.
  void cubic(const double* P, const double* u, int c, double a[4]) const;
  // out[c] = sum over the free rows of component c of a . b (a, b: 3 per free row).
  void component_dots(const double* a, const double* b, double* out) const;
  // a -= coefficient[c] b on the rows of each component c.
  void subtract(double* a, const double* coefficient, const double* b) const;

  std::vector<int> free_vertices_;   // free row -> internal vertex (as in BoundMesh)
  std::vector<int> triangle_begin_;  // component c: triangles [triangle_begin_[c], triangle_begin_[c + 1])
  std::vector<int> corners_;         // 3 internal vertex indices per triangle
  std::vector<int> corner_rows_;     // their free rows, -1 for constrained vertices
  std::vector<int> row_component_;   // free row -> kept component, -1 for none
  std::vector<double> target_;       // rest volume per kept component (internal units)
  std::vector<double> normal_dot_;   // n . u per component (set_normal)
  std::vector<double> longest_u_;    // max |u_v| per component (set_normal)
  std::vector<double> scratch_;      // per component
  double reach_ = 0;
  int open_ = 0;
};

}  // namespace arap
