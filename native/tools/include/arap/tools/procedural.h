// Deterministic closed triangle meshes for tests, demos and benchmarks, of the
// kinds in ../shared/meshes (bars, cylinders, smooth blobs, a torus), and
// the "hold the bottom, move the top" constraint sets they are bent with.
// All meshes are closed 2-manifolds with outward-facing triangles.
#pragma once

#include <vector>

#include "arap/types.h"

namespace arap::procedural {

struct TriMesh {
  Points vertices;      // #V by 3
  Triangles triangles;  // #F by 3
};

// The surface of a box [0, sx] x [0, sy] x [0, sz] divided into nx x ny x nz
// cells: its lattice points on the surface, each quad split into two
// triangles. #V = 2(nx ny + ny nz + nz nx) + 2. Throws arap::Error for n < 1
// or non-positive sizes.
TriMesh make_bar(int nx, int ny, int nz, double sx, double sy, double sz);

// A bar along z with square section and aspect ratio 1:1:`length`, about
// `target_vertices` vertices (at least 26).
TriMesh make_bar_with_vertices(int target_vertices, double length = 5.0);

// A capped cylinder around the z axis from z = 0 to `height`: `segments`
// vertices per ring (>= 3), `rings` + 1 rings, one centre vertex per cap.
// #V = segments (rings + 1) + 2.
TriMesh make_cylinder(int segments, int rings, double radius, double height);

// A smooth closed blob: a cube's subdivided surface pushed onto a sphere of
// `radius`, with a gentle deterministic bumpy displacement of relative size
// `bumpiness` (0 for a sphere). #V = 6 n^2 + 2 with n chosen so that #V is
// as close as possible to `target_vertices` (at least 8).
TriMesh make_sphere(int target_vertices, double radius = 1.0, double bumpiness = 0.1);

// An ellipsoid with semi-axes `semi_axes`: a cube's surface lattice warped
// onto it so that the cells come out of similar size, each quad split along
// its shorter diagonal (no needlessly obtuse angles, whose negative cotangent
// weights make the `cotan` energy indefinite). #V = 6 n^2 + 2 nearest
// `target_vertices` (at least 8).
TriMesh make_ellipsoid(int target_vertices, const Eigen::Vector3d& semi_axes);

// A torus around the z axis: `around` rings of `segments` vertices each
// (both >= 3), ring radius `minor_radius` at distance `major_radius` from the
// axis. #V = around * segments.
TriMesh make_torus(int around, int segments, double major_radius, double minor_radius);

struct HeightConstraints {
  std::vector<int> fixed;   // vertices in the lowest `fixed_fraction` of the height range
  std::vector<int> handle;  // vertices in the highest `handle_fraction` of the height range
};

// Splits by the coordinate `axis` (0, 1, 2): fixed = coordinate <= min +
// fixed_fraction * extent, handle = coordinate >= max - handle_fraction *
// extent (small tolerance so that lattice rows on the boundary are included).
HeightConstraints pick_by_height(const Points& vertices, int axis = 2, double fixed_fraction = 0.2,
                                 double handle_fraction = 0.05);

// The bend that the benchmark and the property tests pose every mesh with:
// pick_by_height() along the longest side of the bounding box, the handle
// moved by `shift` times that side's length along the next axis.
struct Bend {
  std::vector<int> constrained;  // fixed vertices first, then the handle's
  int fixed_count = 0;
  Points targets;                // #constrained by 3, in that order
};
Bend bend(const Points& vertices, double shift = 0.3);

}  // namespace arap::procedural
