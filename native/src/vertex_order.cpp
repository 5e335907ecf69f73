#include "vertex_order.h"

#include <algorithm>

#include "prefault.h"

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

EdgeGraph edge_graph(int n, const std::vector<WeightedEdge>& edges) {
  EdgeGraph g;
  g.begin.assign(n + 1, 0);
  for (const auto& e : edges) ++g.begin[e.i + 1], ++g.begin[e.j + 1];
  for (int v = 0; v < n; ++v) g.begin[v + 1] += g.begin[v];
  g.adjacent.resize(g.begin[n]);
  g.weight.resize(g.begin[n]);
  prefault_buffer(g.adjacent);
  prefault_buffer(g.weight);
  std::vector<int> fill(g.begin.begin(), g.begin.end() - 1);
  for (const auto& e : edges) {
    const int a = fill[e.i]++, b = fill[e.j]++;
    g.adjacent[a] = e.j, g.weight[a] = e.w;
    g.adjacent[b] = e.i, g.weight[b] = e.w;
  }
  return g;
}

std::vector<int> locality_order(const EdgeGraph& g, std::vector<int>* component, int* components) {
  const int n = static_cast<int>(g.begin.size()) - 1;
  std::vector<char> visited(n, 0), probe_visited(n, 0);
  std::vector<int> order, probe;
  order.reserve(n);
  probe.reserve(n);
  if (component) component->assign(n, -1);
  int count = 0;
  for (int v = 0; v < n; ++v) {
    if (visited[v]) continue;
    // A far start: the last vertex of a breadth-first pass from v.
    probe.clear();
    const int far = breadth_first(g, v, probe_visited, probe, false);
    const size_t first = order.size();
    breadth_first(g, far, visited, order, true);
    std::reverse(order.begin() + first, order.end());
    if (component && g.degree(v) > 0) {
      for (size_t k = first; k < order.size(); ++k) (*component)[order[k]] = count;
      ++count;
    }
  }
  if (components) *components = count;
  return order;
}

}  // namespace arap
