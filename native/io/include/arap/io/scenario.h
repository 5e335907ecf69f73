// Constraint sets: the scenario JSON files of ../shared/scenarios and the
// plain index lists of the command line, turned into what Solver::bind() and
// Solver::solve() take.
//
// Scenario JSON:
//   {"name": "...", "mesh": "relative/to/this/file.off", "fixed": [0, 5],
//    "handles": [{"vertices": [7, 8], "matrix": [16 numbers, row-major 4x4 affine],
//                 "translate": [dx, dy, dz]}]}
// A handle moves its vertices to M * p_rest + translate (M identity and
// translate 0 when absent).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "arap/constraints.h"
#include "arap/types.h"

namespace arap::io {

struct Handle {
  std::vector<int> vertices;
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();  // affine: last row 0 0 0 1
  Eigen::Vector3d translate = Eigen::Vector3d::Zero();
};

struct Scenario {
  std::string name;
  std::string mesh_path;  // resolved against the JSON file's folder
  std::vector<int> fixed;
  std::vector<Handle> handles;
};

// Parses a scenario file. Throws FileError (unreadable, not JSON) or
// arap::Error(InvalidInput) for a missing/mistyped field or a non-affine matrix.
Scenario load_scenario(const std::string& json_path);

// Whitespace-separated 0-based vertex indices (a fixed.txt / handle.txt file).
// Throws FileError on an unreadable file or a token that is not a non-negative integer.
std::vector<int> read_index_file(const std::string& path);

struct Constraints : ConstraintSet {
  Points targets;  // for Solver::solve(), one row per constrained vertex
};

// The constraint set of arap/constraints.h (its rules: fixed wins, the first
// handle wins, warnings name the other group) with the fixed list named "the
// fixed list" and handle k "handle k" (0-based), and each handle's targets
// matrix * rest + translate. Throws arap::Error as make_constraint_set() and
// constraint_targets() do.
Constraints build_constraints(const Points& rest, const std::vector<int>& fixed, const std::vector<Handle>& handles);

}  // namespace arap::io
