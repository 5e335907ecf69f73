#include "arap/weights.h"

#include <algorithm>

#include <Eigen/Geometry>

#include "arap/mesh_check.h"
#include "default_init.h"
#include "prefault.h"

namespace arap {

namespace {

// One triangle's edge in the group of its smaller vertex: the larger one and the weight.
struct GroupEntry {
  int j;
  double w;
};

// Sorts a small group by j (a vertex has a handful of edges: insertion sort).
void sort_group(GroupEntry* first, GroupEntry* last) {
  for (GroupEntry* e = first + 1; e < last; ++e) {
    const GroupEntry moving = *e;
    GroupEntry* hole = e;
    for (; hole > first && (hole - 1)->j > moving.j; --hole) *hole = *(hole - 1);
    *hole = moving;
  }
}

}  // namespace

std::vector<WeightedEdge> edge_weights(
    const Eigen::Ref<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>& rest,
    const Eigen::Ref<const Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>& triangles, Weights kind,
    EdgeCounts* counts) {
  // Each triangle's three edges, grouped by their smaller index: a counting
  // pass over the indices (every triangle, so a group may keep unused room
  // for degenerate ones), then the weights written straight into the groups.
  const int n = static_cast<int>(rest.rows());
  std::vector<int> group_begin(n + 1, 0);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++group_begin[std::min(triangles(f, (k + 1) % 3), triangles(f, (k + 2) % 3)) + 1];
  for (int v = 0; v < n; ++v) group_begin[v + 1] += group_begin[v];
  UninitializedVector<GroupEntry> grouped(group_begin[n]);  // written before it is read
  prefault_buffer(grouped);
  std::vector<int> group_end(group_begin.begin(), group_begin.end() - 1);
  const bool cotangent = kind != Weights::Uniform, clamped = kind == Weights::CotanClamped;
  int degenerate = 0;
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const int idx[3] = {triangles(f, 0), triangles(f, 1), triangles(f, 2)};
    const Eigen::Vector3d p[3] = {rest.row(idx[0]), rest.row(idx[1]), rest.row(idx[2])};
    // |u x v| is twice the area at every corner: cot = (u . v) / |u x v| needs one square root.
    const double twice_area = twice_area_unless_degenerate(p[0], p[1], p[2]);
    if (twice_area == 0) {
      ++degenerate;
      continue;
    }
    const double inv_twice_area = 1.0 / twice_area;
    for (int k = 0; k < 3; ++k) {
      // The edge opposite corner k.
      const int a = (k + 1) % 3, b = (k + 2) % 3;
      double w = 1.0;
      if (cotangent) {
        const double c = (p[a] - p[k]).dot(p[b] - p[k]) * inv_twice_area;
        w = 0.5 * (clamped ? std::max(c, 0.0) : c);
      }
      GroupEntry& entry = grouped[group_end[std::min(idx[a], idx[b])]++];
      entry.j = std::max(idx[a], idx[b]);
      entry.w = w;
    }
  }
  // Each small group sorted by the larger index; repeated edges summed.
  std::vector<WeightedEdge> edges;
  edges.reserve(group_begin[n] / 2 + 1);
  prefault(edges.data(), sizeof(WeightedEdge) * edges.capacity());
  int nonmanifold = 0;
  for (int v = 0; v < n; ++v) {
    GroupEntry *first = grouped.data() + group_begin[v], *last = grouped.data() + group_end[v];
    sort_group(first, last);
    for (const GroupEntry* s = first; s != last;) {
      const GroupEntry* e = s;
      double w = 0;
      while (e != last && e->j == s->j) w += (e++)->w;
      if (e - s > 2) ++nonmanifold;
      // Field by field: a whole WeightedEdge built first and copied in stalls on the store.
      WeightedEdge& edge = edges.emplace_back();
      edge.i = v;
      edge.j = s->j;
      edge.w = cotangent ? w : 1.0;
      s = e;
    }
  }
  if (counts) {
    counts->degenerate_triangles = degenerate;
    counts->nonmanifold_edges = nonmanifold;
  }
  return edges;
}

}  // namespace arap
