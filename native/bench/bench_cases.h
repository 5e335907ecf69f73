// The meshes and constraints the benchmark measures: procedural surfaces at
// chosen sizes, mesh files with a default "bend" scenario, and the shared
// scenario JSON files.
#pragma once

#include <string>
#include <vector>

#include "arap/solver.h"

namespace bench {

using arap::Points;
using arap::Triangles;

struct Case {
  std::string name;          // "sphere-4k", "dino", ...
  std::string source;        // "procedural", the mesh file or the scenario file
  Points rest;               // #V by 3
  Triangles triangles;       // #F by 3
  std::vector<int> constrained;  // fixed vertices first, then handle vertices
  Points targets;            // #constrained by 3, in that order
  int fixed_count = 0;       // the first fixed_count of `constrained` stay at rest
};

// A closed, smooth surface: a cube's surface lattice (n segments per edge)
// projected onto the ellipsoid with semi-axes 1, 1, 2. About `vertices` vertices.
void make_ellipsoid(int vertices, Points& V, Triangles& F);
// A closed 1 x 1 x 6 bar (cubic cells) with about `vertices` vertices.
void make_bar(int vertices, Points& V, Triangles& F);

// The default scenario: the height axis is the longest side of the bounding
// box; the bottom fifth is fixed, the top 5 % moves sideways by 0.3 * height.
void bend_scenario(Case& c);

// "sphere" or "bar" at about `vertices` vertices, with the bend scenario.
Case procedural_case(const std::string& shape, int vertices);

// A mesh file (.off, .obj, .ply, .stl) with the bend scenario, or a scenario
// .json as described in shared/README.md; both read through arap_io.
Case file_case(const std::string& path);

}  // namespace bench
