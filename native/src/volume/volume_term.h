// What keeps the volume (Options::volume), as the solver sees it: a term of the
// energy minimised with ARAP's (Infill's bulk term, infill_volume.h) or a
// constraint every iterate stays on (Global, volume.h). Both run on the
// quasi-Newton path; the solver calls these hooks at fixed points of it, so a
// new model is a new term, not a new branch in the solve. The defaults are
// those of a term that adds nothing (an energy term overrides the first three,
// a constraint the others).
#pragma once

#include <functional>
#include <memory>

#include "arap/options.h"
#include "arap/solve_stats.h"
#include "arap/types.h"
#include "bound_mesh.h"

namespace arap {

class VolumeTerm {
 public:
  // v <- L_ff^-1 v (3 per free row) with the solver's factored Laplacian.
  using LaplacianSolve = std::function<void(double*)>;

  virtual ~VolumeTerm() = default;

  // The term's energy at P (#n by 3, internal order), added to ARAP's.
  virtual double energy(const double*) const { return 0; }
  // g += 1/4 dE/dp on the free rows (3 per free row): the scale of the solver's ARAP gradient
  // g = L_ff p_f - b_f (local_step.h's half_gradient(), a quarter of dE/dp: E counts every edge in
  // the cells of both its ends, and L's weights are w_ij (s_i + s_j) / 2). At another scale the
  // iteration would follow a gradient that is not the energy's, and stall where that one vanishes.
  virtual void add_half_gradient(const double*, double*) const {}
  // gradient += dE/dp for every vertex (#n by 3, internal order).
  virtual void add_gradient(const double*, double*) const {}

  // Whether a warm start should first carry the moved handles through the mesh with one
  // global step on the last rotations. Not when the factored matrix is only the term's
  // preconditioner (Infill's stiffened lattice): that step is then no minimiser, and it
  // throws the lattice far from the last pose (tens of times the settled energy); the
  // solver carries the move by its harmonic extension instead, L_ff d_f = sum_c w_fc d_c.
  virtual bool warm_global_step() const { return true; }
  // Whether the plain step -L_ff^-1 g may raise the energy, so that the line search halves it
  // until it does not. It cannot with ARAP's Laplacian: the global step minimises the energy
  // with the rotations fixed, which bounds it from above. It can where L is only a
  // preconditioner (the bulk term's curvature is not below it) or the step returns onto a constraint.
  virtual bool plain_step_may_rise() const { return constrains(); }
  // The stop on the pose (pose_stop.h): a solve with this term stops only when its pose is
  // estimated within this share of the rest bounding box's diagonal of its limit, per unit of
  // Options::tolerance (0: the energy test alone, as the surface solves).
  virtual double pose_stop_per_tolerance() const { return 0; }

  // Whether the term holds the positions on a constraint set.
  virtual bool constrains() const { return false; }
  // At P: takes the constraint's normal there, and makes the half gradient g that of the Lagrangian.
  virtual void constrain_gradient(const double*, double*, const LaplacianSolve&, SolveStats&) {}
  // A step d (3 per free row) onto the tangent plane of the last constrain_gradient() point.
  virtual void project_direction(double*) {}
  // A trial point P brought back onto the set; false when it cannot be (the trial is refused).
  virtual bool retract(double*, SolveStats&) { return true; }
  // P (a first guess) moved onto the set.
  virtual void project(double*, const LaplacianSolve&, SolveStats&) {}
  // How far P is from the set (reported at the end of a solve).
  virtual double drift(const double*) const { return 0; }
};

// The term of `mode` for the bound `mesh` (`triangles`: internal indices; `lattice`: the infill's,
// for Volume::Infill), or null when it has nothing to keep. Volume::Global reports its components in
// mesh.report.
std::unique_ptr<VolumeTerm> make_volume_term(Volume mode, BoundMesh& mesh, const Triangles& triangles,
                                             const InfillGraph& lattice);

}  // namespace arap
