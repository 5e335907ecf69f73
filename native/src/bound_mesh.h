// Everything bind() precomputes about a mesh and its constraint set, laid out
// for the iteration loop: per-vertex spokes in one array (CSR), the free and
// constrained numbering, and the free block of the weighted Laplacian.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "arap/mesh_check.h"
#include "arap/options.h"
#include "arap/types.h"
#include "runtime/large_buffer.h"
#include "volume/infill.h"

namespace arap {

// One directed spoke i -> j of the one-ring of i.
struct Spoke {
  double gx, gy, gz;  // g_ij = w_ij (p_i - p_j) at rest
  double w;           // w_ij
};

// A free vertex's weight to a constrained neighbour: moves L_fc p_c to the right-hand side.
struct Coupling {
  int free_row;
  int constrained_slot;
  double w;
};

// All vertex indices below are internal: vertex v of the input is rank[v]
// (a locality order, see vertex_order.h); order[k] is the input index of k.
struct BoundMesh {
  int n = 0;        // vertices solved for: the mesh's, then Volume::Infill's lattice nodes
  int input_n = 0;  // the mesh's own (input indices [0, input_n); lattice node k is input_n + k)
  std::vector<int> order, rank;
  Points rest;  // internal order
  // Spokes of vertex i: [spoke_begin[i], spoke_begin[i + 1]).
  std::vector<int> spoke_begin;
  std::vector<int> neighbor;
  LargeBuffer<Spoke> spokes;
  std::vector<double> rest_spoke_energy;  // sum_j w_ij |p_i - p_j|^2 (rest), per vertex
  std::vector<double> g_sum;              // G_i = sum_j g_ij, 3 per vertex
  std::vector<double> stiffness;          // s_i, per vertex (all 1 unless given)
  // Constrained = the user's constraints, then vertices kept at rest (components
  // without constraints and isolated vertices).
  std::vector<int> constrained;       // slot -> internal vertex
  int user_constrained = 0;           // the first slots are the user's, in their order
  std::vector<int> free_vertices;     // row -> vertex
  std::vector<int> free_row;          // vertex -> row, -1 when constrained
  std::vector<Coupling> couplings;
  // Both triangles. With Volume::Infill its lattice-lattice entries are scaled by
  // InfillGraph::preconditioner_scale: the factor then preconditions the quasi-Newton
  // path (which Infill runs on) for the bulk term; the global step it gives is only
  // used as a first guess there.
  Eigen::SparseMatrix<double> laplacian_ff;
  MeshReport report;
};

// Throws Error (no vertices or triangles, non-finite positions, indices out of
// range, nothing or something twice constrained) before anything is built
// from the input; build_bound_mesh() checks it too.
void check_bind_input(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
                      const std::vector<int>& constrained);

// Checks the input (throws arap::Error) and builds the bound mesh.
// `constrained` and `triangles` use input indices. `infill` (optional) adds
// its lattice nodes and edges (Volume::Infill).
BoundMesh build_bound_mesh(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
                           const std::vector<int>& constrained, Weights weights,
                           const std::vector<double>& stiffness, const InfillGraph* infill = nullptr);

// The free rows of Volume::Infill's lattice nodes, in increasing order, for
// the factorization to order after the surface's (BlockCholesky::factor's
// last_rows) when they are few next to the surface's (see bound_mesh.cpp).
// Empty otherwise, and without a lattice.
std::vector<int> lattice_rows_to_order_last(const BoundMesh& m);

// Rows of P moved between input and internal order. to_internal writes the
// mesh's vertices and keeps `internal`'s lattice rows (the rest shape's when
// it has not #n rows); to_input writes the mesh's vertices only.
void to_internal(const BoundMesh& m, const Eigen::Ref<const Points>& input, Points& internal);
void to_input(const BoundMesh& m, const Points& internal, Points& input);
// Volume::Infill's lattice nodes of `internal` moved with its mesh vertices (their displacement from rest
// smoothed into the lattice), for a start from a given surface (Solver::start_from).
void lattice_follows_surface(const BoundMesh& m, Points& internal);

}  // namespace arap
