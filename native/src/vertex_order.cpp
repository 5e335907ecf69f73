#include "vertex_order.h"

#include <algorithm>

#include "runtime/prefault.h"

namespace arap {

namespace {

// Breadth-first order from `start` into `out`; marks visited. Returns the last vertex reached.
// by_degree: each vertex's newly reached neighbours in increasing degree (sorted where they were appended).
int breadth_first(const EdgeGraph& g, int start, std::vector<char>& visited, std::vector<int>& out, bool by_degree) {
  const size_t first = out.size();
  visited[start] = 1;
  out.push_back(start);
  for (size_t k = first; k < out.size(); ++k) {
    const int v = out[k];
    const size_t reached = out.size();
    for (int p = g.begin[v]; p < g.begin[v + 1]; ++p)
      if (!visited[g.adjacent[p]]) visited[g.adjacent[p]] = 1, out.push_back(g.adjacent[p]);
    if (by_degree)
      std::sort(out.begin() + static_cast<std::ptrdiff_t>(reached), out.end(),
                [&](int a, int b) { return g.degree(a) < g.degree(b); });
  }
  return out.back();
}

}  // namespace

EdgeGraph edge_graph(int n, const EdgeGroups& groups, const std::vector<WeightedEdge>& extra) {
  const int mesh_vertices = static_cast<int>(groups.end.size());
  EdgeGraph g;
  g.begin.assign(n + 1, 0);
  for (int i = 0; i < mesh_vertices; ++i) {
    g.begin[i + 1] += groups.end[i] - groups.begin[i];
    for (int k = groups.begin[i]; k < groups.end[i]; ++k) ++g.begin[groups.entries[k].j + 1];
  }
  for (const auto& e : extra) ++g.begin[e.i + 1], ++g.begin[e.j + 1];
  for (int v = 0; v < n; ++v) g.begin[v + 1] += g.begin[v];
  g.adjacent.resize(g.begin[n]);
  g.weight.resize(g.begin[n]);
  prefault_buffer(g.adjacent);
  prefault_buffer(g.weight);
  std::vector<int> fill(g.begin.begin(), g.begin.end() - 1);
  auto add = [&](int i, int j, double w) {
    const int a = fill[i]++, b = fill[j]++;
    g.adjacent[a] = j, g.weight[a] = w;
    g.adjacent[b] = i, g.weight[b] = w;
  };
  // By increasing i, then j: each vertex meets its smaller neighbours (earlier
  // groups) before its larger ones (its own group), both in increasing order.
  for (int i = 0; i < mesh_vertices; ++i)
    for (int k = groups.begin[i]; k < groups.end[i]; ++k) add(i, groups.entries[k].j, groups.entries[k].w);
  for (const auto& e : extra) add(e.i, e.j, e.w);
  return g;
}

std::vector<int> locality_order(const EdgeGraph& g, std::vector<int>& component, int& components) {
  const int n = static_cast<int>(g.begin.size()) - 1;
  std::vector<char> visited(n, 0), probe_visited(n, 0);
  std::vector<int> order, probe;
  order.reserve(n);
  probe.reserve(n);
  component.assign(n, -1);
  components = 0;
  for (int v = 0; v < n; ++v) {
    if (visited[v]) continue;
    // A far start: the last vertex of a breadth-first pass from v.
    probe.clear();
    const int far = breadth_first(g, v, probe_visited, probe, false);
    const size_t first = order.size();
    breadth_first(g, far, visited, order, true);
    std::reverse(order.begin() + first, order.end());
    if (g.degree(v) == 0) continue;  // a vertex in no edge: in no component
    for (size_t k = first; k < order.size(); ++k) component[order[k]] = components;
    ++components;
  }
  return order;
}

}  // namespace arap
