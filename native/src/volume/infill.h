// Volume: Infill — a coarse lattice of cubes filling the inside of the mesh,
// posed as-rigid-as-possible together with the surface, which is bound to it
// (the lattice analogue of a 3D print's infill; cf. Rivers & James 2007,
// "FastLSM", and embedded deformation, Sumner et al. 2007).
//
// The lattice: the mesh's bounding box cut into cubes of size h, `resolution`
// along its longest side L. Per connected part of the surface, a cube belongs
// to the part when its centre is inside (generalized winding number of the
// part's triangles, |w| >= 0.6: open, non-manifold and self-intersecting
// input included, either orientation), or when the part's surface meets it
// and no inside cube is next to it (thin parts and open sheets: "surface
// cubes"). Two cubes side by side share the corners of the face between them
// when its centre is inside, or when both are surface cubes and the surface
// crosses that face. Which cubes a surface meets and which faces it crosses
// depend on the surface, not on its tessellation. Parts get lattices of their
// own: touching parts are not glued together.
//
// It enters the ARAP energy as more vertices (the cube corners, "nodes") and
// more edges, so the local step, the Laplacian and the gradient work on it
// unchanged:
//  - lattice edges, the 12 edges of every cube, each cube adding
//    kappa h / L / 4 to each of its edges: the graph Laplacian that
//    discretises (kappa / L) integral |grad f|^2 dV, the same interior
//    stiffness at every resolution (kappa = 10);
//  - coupling edges from each surface vertex v to the four corners of the
//    Kuhn tetrahedron of its cube that holds it, weighted by their barycentric
//    weights: 2 beta A_v / h^2 in all (A_v a third of the area of v's
//    triangles, beta = 4). With the rotations fixed, v's coupling energy is
//    least at the weighted mean of q_k + R (p_v - q_k)_rest: the surface
//    follows the lattice softly, continuously in where v lies, and rotates with
//    it. The fixed and handle vertices of a cube share a fixed grip on it (10
//    times its lattice edges) rather than one weighted by their area, so that
//    a handle holds the lattice the same at any tessellation (docs/volume.md).
// ARAP alone does not resist volume change more than any change of shape
// (a material of Poisson's ratio 0): the lattice also carries a bulk term,
// see infill_volume.h (gamma = kInfillBulk).
#pragma once

#include <array>
#include <vector>

#include "arap/types.h"
#include "arap/weights.h"

namespace arap {

// gamma of infill_volume.h: the lattice's resistance to volume change relative to ARAP's.
constexpr double kInfillBulk = 1.0;

struct InfillGraph {
  Points nodes;                     // #nodes by 3, rest positions of the cube corners
  std::vector<WeightedEdge> edges;  // surface vertex v is index v, node k is index #V + k
  std::vector<std::array<int, 6>> neighbors;  // per node: node along -x, +x, -y, +y, -z, +z, or -1
  int cells = 0;
  double spacing = 0;  // cube size h
  // The factored matrix carries the lattice edges this much stiffer (see bound_mesh.h): the
  // bulk term's curvature on a change of volume, 9 gamma times ARAP's, so that the
  // quasi-Newton step, which the factor preconditions, does not overshoot it.
  double preconditioner_scale = 1;
};

// Throws arap::Error(InvalidInput) when the lattice would exceed 2 million cubes.
// `constrained`: the fixed and handle vertices (input indices, checked by the caller).
InfillGraph build_infill(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
                         const std::vector<int>& constrained, int resolution);

}  // namespace arap
