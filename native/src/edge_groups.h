// The weighted edges of a triangle mesh grouped by their smaller vertex: what
// edge_weights() lists, kept in groups so that the bind can build its vertex
// graph straight from them (no edge list in between).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "arap/options.h"
#include "runtime/large_buffer.h"

namespace arap {

struct EdgeGroups {
  struct Entry {
    int j;     // the larger vertex
    double w;  // the edge's summed weight
  };
  // Vertex i's edges (i, j), j > i increasing: entries[begin[i] .. end[i]).
  std::vector<int> begin, end;
  UninitializedVector<Entry> entries;
  int degenerate_triangles = 0;  // skipped: (near) zero area
  int nonmanifold_edges = 0;     // in more than two triangles
  int edge_count() const;
};

// The weights of edge_weights() (arap/weights.h), grouped.
EdgeGroups edge_groups(const Eigen::Ref<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>& rest,
                       const Eigen::Ref<const Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>& triangles,
                       Weights kind);

}  // namespace arap
