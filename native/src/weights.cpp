#include "arap/weights.h"

#include <algorithm>

#include <Eigen/Geometry>

#include "arap/mesh_check.h"
#include "edge_groups.h"
#include "runtime/large_buffer.h"
#include "runtime/prefault.h"

namespace arap {

namespace {

using Entry = EdgeGroups::Entry;

// Sorts a small group by j (a vertex has a handful of edges: insertion sort).
void sort_group(Entry* first, Entry* last) {
  for (Entry* e = first + 1; e < last; ++e) {
    const Entry moving = *e;
    Entry* hole = e;
    for (; hole > first && (hole - 1)->j > moving.j; --hole) *hole = *(hole - 1);
    *hole = moving;
  }
}

}  // namespace

int EdgeGroups::edge_count() const {
  int count = 0;
  for (size_t v = 0; v < end.size(); ++v) count += end[v] - begin[v];
  return count;
}

EdgeGroups edge_groups(const Eigen::Ref<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>& rest,
                       const Eigen::Ref<const Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>& triangles,
                       Weights kind) {
  // Each triangle's three edges, grouped by their smaller index: a counting
  // pass over the indices (every triangle, so a group may keep unused room
  // for degenerate ones), then the weights written straight into the groups.
  const int n = static_cast<int>(rest.rows());
  EdgeGroups g;
  g.begin.assign(n + 1, 0);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    for (int k = 0; k < 3; ++k) ++g.begin[std::min(triangles(f, (k + 1) % 3), triangles(f, (k + 2) % 3)) + 1];
  for (int v = 0; v < n; ++v) g.begin[v + 1] += g.begin[v];
  g.entries.resize(g.begin[n]);  // written before it is read
  prefault_buffer(g.entries);
  g.end.assign(g.begin.begin(), g.begin.end() - 1);
  const bool cotangent = kind != Weights::Uniform, clamped = kind == Weights::CotanClamped;
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const int idx[3] = {triangles(f, 0), triangles(f, 1), triangles(f, 2)};
    const Eigen::Vector3d p[3] = {rest.row(idx[0]), rest.row(idx[1]), rest.row(idx[2])};
    // |u x v| is twice the area at every corner: cot = (u . v) / |u x v| needs one square root.
    const double twice_area = twice_area_unless_degenerate(p[0], p[1], p[2]);
    if (twice_area == 0) {
      ++g.degenerate_triangles;
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
      Entry& entry = g.entries[g.end[std::min(idx[a], idx[b])]++];
      entry.j = std::max(idx[a], idx[b]);
      entry.w = w;
    }
  }
  // Each small group sorted by the larger index, its repeated edges summed in place.
  for (int v = 0; v < n; ++v) {
    Entry *first = g.entries.data() + g.begin[v], *last = g.entries.data() + g.end[v];
    sort_group(first, last);
    Entry* out = first;
    for (const Entry* s = first; s != last;) {
      const Entry* e = s;
      double w = 0;
      while (e != last && e->j == s->j) w += (e++)->w;
      if (e - s > 2) ++g.nonmanifold_edges;
      out->j = s->j;
      out->w = cotangent ? w : 1.0;
      ++out;
      s = e;
    }
    g.end[v] = static_cast<int>(out - g.entries.data());
  }
  return g;
}

std::vector<WeightedEdge> edge_weights(
    const Eigen::Ref<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>& rest,
    const Eigen::Ref<const Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>& triangles, Weights kind,
    EdgeCounts* counts) {
  const EdgeGroups g = edge_groups(rest, triangles, kind);
  std::vector<WeightedEdge> edges;
  edges.reserve(g.edge_count());
  for (int v = 0; v + 1 < static_cast<int>(g.begin.size()); ++v)
    for (int k = g.begin[v]; k < g.end[v]; ++k) {
      // Field by field: a whole WeightedEdge built first and copied in stalls on the store.
      WeightedEdge& edge = edges.emplace_back();
      edge.i = v;
      edge.j = g.entries[k].j;
      edge.w = g.entries[k].w;
    }
  if (counts) {
    counts->degenerate_triangles = g.degenerate_triangles;
    counts->nonmanifold_edges = g.nonmanifold_edges;
  }
  return edges;
}

}  // namespace arap
