// Which vertices are constrained, and by which group: the one rule that the
// command line, the Python module and the Blender add-on share (docs/design.md,
// "Constraints: the rules").
//
// The constrained vertices are listed fixed first, then each handle's own
// vertices, handle by handle:
//  - a vertex listed twice in one group counts once;
//  - a vertex both fixed and in a handle stays fixed (fixed wins);
//  - a vertex in two handles follows the first of them (the first handle wins);
//  - each time a handle loses vertices to another group, a warning names
//    that group; a handle left with no vertex of its own is ignored, with a
//    warning;
//  - an index outside [0, #V) throws Error(IndexOutOfRange), and no
//    constrained vertex at all Error(NoConstraints).
#pragma once

#include <string>
#include <vector>

#include "arap/types.h"

namespace arap {

struct ConstraintGroup {
  // How messages name the group, as its user knows it: "the fixed group 'Feet'", "handle 'Hand'", "handle 2".
  std::string label;
  std::vector<int> vertices;
};

// Rows [start, stop) of ConstraintSet::constrained follow handle number `handle` (its index in the input).
struct HandleBlock {
  int handle = 0;
  int start = 0;
  int stop = 0;
  std::string label;  // the handle's ConstraintGroup::label
};

struct ConstraintSet {
  std::vector<int> constrained;      // for Solver::bind(): distinct, fixed first, then each handle's block
  int fixed_count = 0;               // the first fixed_count entries are the fixed vertices
  std::vector<HandleBlock> handles;  // the handles that kept vertices, in input order
  std::vector<std::string> warnings;
};

// Applies the rules above to a mesh of `vertex_count` vertices.
ConstraintSet make_constraint_set(int vertex_count, const ConstraintGroup& fixed,
                                  const std::vector<ConstraintGroup>& handles);

// How messages name the group that holds `vertex` (an input index): its
// label, "the fixed group ..." or "handle ...", or "" when no group holds it.
std::string group_label_of(const ConstraintSet& set, int vertex);

// One target per constrained vertex, in set.constrained's order: the rest
// position of a fixed vertex, handle_transforms[h] (a 4x4 affine map, one per
// input handle) applied to the rest position of a vertex of handle h. Throws
// Error(NonFinite) naming the handle when a target is not finite.
Points constraint_targets(const ConstraintSet& set, const Eigen::Ref<const Points>& rest,
                          const std::vector<Eigen::Matrix4d>& handle_transforms);

}  // namespace arap
