// What a pose did to a shape, measured from the meshes alone (rest and posed
// positions with the same triangles), independently of the solver: enclosed
// volume, material cross-sections, self-intersections. arap-mesh-measure and
// the volume tests use these to check the solver's results.
#pragma once

#include <utility>
#include <vector>

#include "arap/types.h"

namespace arap::measure {

// One connected component (over shared vertices) of a triangle mesh.
struct Component {
  std::vector<int> triangles;
  // Every edge has exactly two triangles, one in each direction: a closed,
  // consistently oriented surface, whose enclosed volume is defined.
  bool closed = false;
};

std::vector<Component> components(int vertex_count, const Eigen::Ref<const Triangles>& triangles);

// Signed volume enclosed by the triangles `which` of `triangles` (divergence
// theorem: sum over triangles of a . (b x c) / 6); positive for outward-facing
// triangles of a closed surface.
double signed_volume(const Eigen::Ref<const Points>& positions, const Eigen::Ref<const Triangles>& triangles,
                     const std::vector<int>& which);

struct VolumeKept {
  int closed_components = 0;
  int open_components = 0;
  double rest = 0, posed = 0;  // summed over the closed components
  double ratio = 1;            // posed / rest (1 when there is no closed component)
  double worst_ratio = 1;      // the closed component furthest from 1
};
VolumeKept volume_kept(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Points>& posed,
                       const Eigen::Ref<const Triangles>& triangles);

// Pairs of triangles that share no vertex and intersect (a crossing of edge
// and triangle, either way round; coplanar overlaps are not counted). A grid
// over the bounding box keeps it near-linear. `list` (optional) receives the pairs.
long self_intersecting_pairs(const Eigen::Ref<const Points>& positions, const Eigen::Ref<const Triangles>& triangles,
                             std::vector<std::pair<int, int>>* list = nullptr);

// Material cross-sections: the rest mesh is cut by `planes` planes
// perpendicular to its principal axis (largest variance of the vertices),
// evenly spaced inside its extent; each closed loop of the cut is a curve on
// the surface (points on edges at fixed edge parameters), followed into the
// posed mesh, and its area there (the norm of the loop's vector area) is
// compared with its area at rest. A bar that keeps its section keeps ratio 1;
// one flattened to a strip goes towards 0.
struct CrossSections {
  int loops = 0;
  std::vector<double> ratios;  // posed area / rest area, one per loop, in plane order
  double median = 1, min = 1;
};
CrossSections cross_sections(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Points>& posed,
                             const Eigen::Ref<const Triangles>& triangles, int planes = 9);

}  // namespace arap::measure
