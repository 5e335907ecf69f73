// The two halves of a local/global iteration that do not involve the factor.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "bound_mesh.h"

namespace arap {

// Local step: for every cell, A_i = sum_j w_ij (p'_i - p'_j)(p_i - p_j)^T and the
// rotation R_i maximising <R_i, A_i> (reflections fixed). Writes each cell's
// energy s_i sum_j w_ij |e'_ij - R_i e_ij|^2 = s_i (sum_j w_ij |e'_ij|^2 + sum_j w_ij |e_ij|^2
// - 2 <R_i, A_i>), and returns the total ARAP energy (summed in vertex order, so
// it does not depend on the thread count). P: #V by 3 row-major. `lambda`
// (optional, #V) carries each cell's eigenvalue from one local step to the next
// to start the rotation fit close to its answer (see rotation_fit.h).
double local_step(const BoundMesh& m, const double* P, Eigen::Matrix3d* R, double* cell_energy, int threads,
                  long* fallbacks, double* lambda = nullptr);

// Right-hand side of the global step for the free rows (Sorkine & Alexa eq. 9,
// with stiffness): b_i = 1/2 sum_j w_ij (s_i R_i + s_j R_j)(p_i - p_j)
// = 1/2 (s_i R_i G_i + sum_j s_j R_j g_ij),
// plus `coupled` (sum of w_ij p_j over constrained neighbours j). Writes #free by 3.
void assemble_rhs(const BoundMesh& m, const Eigen::Matrix3d* R, const double* coupled, double* rhs, int threads);

// Half the ARAP gradient of every free vertex for positions P (#V by 3, the
// constrained rows at their targets) and optimal rotations R:
// g_i = sum_j w~_ij (p'_i - p'_j) - b_i, w~_ij = w_ij (s_i + s_j) / 2, b_i as in
// assemble_rhs without `coupled`; this is L_ff p_f - b_f - coupled in one pass
// over the spokes. Writes #free by 3.
void half_gradient(const BoundMesh& m, const double* P, const Eigen::Matrix3d* R, double* g, int threads);

// The ARAP gradient of every vertex for given positions and optimal rotations:
// dE/dp'_i = 2 sum_j w_ij (s_i + s_j)(p'_i - p'_j) - 2 sum_j w_ij (s_i R_i + s_j R_j)(p_i - p_j).
void energy_gradient(const BoundMesh& m, const double* P, const Eigen::Matrix3d* R, double* gradient);

}  // namespace arap
