// The meshes and constraints the benchmark measures: procedural surfaces at
// chosen sizes, mesh files with a default "bend" scenario, and the shared
// scenario JSON files.
#pragma once

#include <string>
#include <vector>

#include "arap/types.h"

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

// "sphere" (arap::procedural::make_ellipsoid, semi-axes 1, 1, 2) or "bar"
// (a 1 x 1 x 6 make_bar_with_vertices) at about `vertices` vertices, bent
// with arap::procedural::bend(): the bottom fifth by the longest side of the
// bounding box fixed, the top 5 % moved sideways by 0.3 times that length.
Case procedural_case(const std::string& shape, int vertices);

// A mesh file (.off, .obj, .ply, .stl) bent the same way, or a scenario
// .json as described in shared/README.md; both read through arap_io.
Case file_case(const std::string& path);

}  // namespace bench
