// A vertex numbering with good memory locality for the per-vertex loops:
// reverse Cuthill-McKee (breadth-first from a far vertex, neighbours by
// ascending degree), component by component.
#pragma once

#include <vector>

#include "arap/weights.h"

namespace arap {

// Returns new -> old: the vertex visited k-th is order[k]. Every vertex appears once.
std::vector<int> locality_order(int vertex_count, const std::vector<WeightedEdge>& edges);

}  // namespace arap
