// Checks of a triangle mesh before binding, and what the solver does about
// what it finds. Hard errors throw arap::Error; everything else is a
// documented fallback counted here.
#pragma once

#include <algorithm>
#include <vector>

#include <Eigen/Geometry>

#include "arap/types.h"

namespace arap {

struct MeshReport {
  int vertices = 0;
  int triangles = 0;
  // Triangles with (near) zero area: their cotangents would be infinite, so
  // they add no weight (skipped). Counted, not an error.
  int degenerate_triangles = 0;
  // Vertices in no usable triangle: kept where they are given (rest, or target).
  int isolated_vertices = 0;
  // Connected components over usable triangles.
  int components = 0;
  // Components without any constrained vertex: the system is singular there,
  // so they are kept at their rest shape (documented fallback).
  int unconstrained_components = 0;
  int unconstrained_vertices = 0;
  // Edges shared by more than two triangles. The math does not need
  // manifoldness: they are solved as usual.
  int nonmanifold_edges = 0;
  // Volume::Global: closed components whose enclosed volume is kept, and
  // components left alone because they are open (not closed and consistently
  // oriented). Closed components with no free vertex or no volume are neither.
  int volume_kept_components = 0;
  int volume_open_components = 0;
  // Volume::Infill: lattice cubes and their corners (solved with the mesh).
  int infill_cells = 0;
  int infill_nodes = 0;
};

// Every field of MeshReport by name, in declaration order: the one list the
// command line's JSON report and the Python module's MeshReport read.
struct MeshReportField {
  const char* name;
  int MeshReport::*member;
};
inline constexpr MeshReportField kMeshReportFields[] = {
    {"vertices", &MeshReport::vertices},
    {"triangles", &MeshReport::triangles},
    {"degenerate_triangles", &MeshReport::degenerate_triangles},
    {"isolated_vertices", &MeshReport::isolated_vertices},
    {"components", &MeshReport::components},
    {"unconstrained_components", &MeshReport::unconstrained_components},
    {"unconstrained_vertices", &MeshReport::unconstrained_vertices},
    {"nonmanifold_edges", &MeshReport::nonmanifold_edges},
    {"volume_kept_components", &MeshReport::volume_kept_components},
    {"volume_open_components", &MeshReport::volume_open_components},
    {"infill_cells", &MeshReport::infill_cells},
    {"infill_nodes", &MeshReport::infill_nodes},
};

// A triangle is degenerate when twice its area is below this fraction of the
// square of its longest edge: its smallest angle is then below ~1e-12 radians
// and its cotangents would overflow the weights.
constexpr double kDegenerateRelativeArea = 1e-12;

// Component id of every vertex over non-degenerate triangles (-1 for isolated
// vertices); returns the number of components.
int label_components(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
                     std::vector<int>& component_of_vertex);

bool is_degenerate_triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);
// |(b - a) x (c - a)|, twice the triangle's area, or 0 when it is degenerate.
inline double twice_area_unless_degenerate(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                           const Eigen::Vector3d& c) {
  const double longest2 = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
  const double twice_area = (b - a).cross(c - a).norm();
  // Also catches three coincident points (longest2 == 0).
  return twice_area > kDegenerateRelativeArea * longest2 ? twice_area : 0.0;
}

}  // namespace arap
