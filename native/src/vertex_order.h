// A vertex numbering with good memory locality for the per-vertex loops:
// reverse Cuthill-McKee (breadth-first from a far vertex, neighbours by
// ascending degree), component by component.
#pragma once

#include <vector>

#include "arap/weights.h"
#include "edge_groups.h"
#include "runtime/large_buffer.h"

namespace arap {

// Both directions of every edge, by vertex (compressed rows): vertex v's
// neighbours are adjacent[begin[v] .. begin[v + 1]), with the edge's weight:
// first the mesh's edges (`groups`, the neighbours of each vertex in
// increasing order), then the `extra` ones (a lattice's) in their order.
// vertex_count: the mesh's vertices and any others the extra edges reach.
struct EdgeGraph {
  std::vector<int> begin;
  UninitializedVector<int> adjacent;
  UninitializedVector<double> weight;
  int degree(int v) const { return begin[v + 1] - begin[v]; }
};
EdgeGraph edge_graph(int vertex_count, const EdgeGroups& groups, const std::vector<WeightedEdge>& extra);

// Returns new -> old: the vertex visited k-th is order[k]. Every vertex appears once.
// Its breadth-first passes also give each vertex's connected component over
// the graph's edges (0 .. components - 1 in the order they are reached), -1
// for a vertex in no edge.
std::vector<int> locality_order(const EdgeGraph& graph, std::vector<int>& component, int& components);

}  // namespace arap
