// Where the constrained vertices go in one round of a forced pose
// (Contact::Self, contact_solve.h's reach_first_guess): each part of them that
// moves as one turns and shifts as a rigid body toward its targets, the best
// fit of their move (Kabsch), plus that share of what the fit leaves over.
// Straight lines would meet where a part turns about itself (a handle turned
// half a turn: every line passes through the axis), a turn does not.
//
// A part: constrained vertices joined by edges along which the move could be
// rigid, |d_a - d_b| <= 2 |x_a - x_b| (d the move, x the position); so a
// fixed group stays apart from a handle beside it that moves away.
#pragma once

#include <vector>

#include "arap/types.h"

namespace arap::contact {

class HandleMoves {
 public:
  // `constrained`: internal vertex index of each constrained slot (the first
  // `slots` are the user's); `triangles`: internal indices.
  void bind(const std::vector<int>& constrained, int slots, const Triangles& triangles, int vertex_count);

  // goal (slots by 3): the slots' positions `share` (in [0, 1]) of the way
  // from `state` to `targets` along each part's rigid motion; share 1 gives
  // the targets exactly.
  void toward(const Points& state, const Points& targets, double share, Points& goal) const;

 private:
  std::vector<int> constrained_;  // slot -> internal vertex
  std::vector<int> edges_;        // pairs of slots joined by a mesh edge
};

}  // namespace arap::contact
