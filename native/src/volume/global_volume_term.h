// Volume::Global (volume.h) as a volume term: the enclosed volume of every
// closed component held at its rest value. At each point steps start from it
// keeps the constraint's normal n = dV/dp and u = L^-1 n (3 per free row):
// the gradient becomes the Lagrangian's, g~ = g - lambda n, directions are
// projected on the tangent plane, and trial points return onto the constraint
// along u.
#pragma once

#include <vector>

#include "volume/volume.h"
#include "volume/volume_term.h"

namespace arap {

class GlobalVolumeTerm final : public VolumeTerm {
 public:
  // Finds the kept components.
  void bind(const BoundMesh& mesh, const Triangles& triangles);
  const VolumeConstraint& constraint() const { return volume_; }

  bool constrains() const override { return true; }
  void constrain_gradient(const double* P, double* g, const LaplacianSolve& solve, SolveStats& stats) override;
  void project_direction(double* d) override;
  bool retract(double* P, SolveStats& stats) override;
  void project(double* P, const LaplacianSolve& solve, SolveStats& stats) override;
  double drift(const double* P) const override { return volume_.drift(P); }

 private:
  // n = dV/dp and u = L^-1 n at P, taken as the current normal.
  void take_normal(const double* P, const LaplacianSolve& solve, SolveStats& stats);

  VolumeConstraint volume_;
  std::vector<double> n_, u_;
};

}  // namespace arap
