#include "vertex_order.h"

#include <algorithm>

namespace arap {

namespace {

struct Graph {
  std::vector<int> begin, adjacent;
  int degree(int v) const { return begin[v + 1] - begin[v]; }
};

Graph make_graph(int n, const std::vector<WeightedEdge>& edges) {
  Graph g;
  g.begin.assign(n + 1, 0);
  for (const auto& e : edges) ++g.begin[e.i + 1], ++g.begin[e.j + 1];
  for (int v = 0; v < n; ++v) g.begin[v + 1] += g.begin[v];
  g.adjacent.resize(g.begin[n]);
  std::vector<int> fill(g.begin.begin(), g.begin.end() - 1);
  for (const auto& e : edges) g.adjacent[fill[e.i]++] = e.j, g.adjacent[fill[e.j]++] = e.i;
  return g;
}

// Breadth-first order from `start` into `out`; marks visited. Returns the last vertex reached.
int breadth_first(const Graph& g, int start, std::vector<char>& visited, std::vector<int>& out, bool by_degree) {
  const size_t first = out.size();
  visited[start] = 1;
  out.push_back(start);
  std::vector<int> next;
  for (size_t k = first; k < out.size(); ++k) {
    const int v = out[k];
    next.clear();
    for (int p = g.begin[v]; p < g.begin[v + 1]; ++p)
      if (!visited[g.adjacent[p]]) visited[g.adjacent[p]] = 1, next.push_back(g.adjacent[p]);
    if (by_degree) std::sort(next.begin(), next.end(), [&](int a, int b) { return g.degree(a) < g.degree(b); });
    out.insert(out.end(), next.begin(), next.end());
  }
  return out.back();
}

}  // namespace

std::vector<int> locality_order(int n, const std::vector<WeightedEdge>& edges) {
  const Graph g = make_graph(n, edges);
  std::vector<char> visited(n, 0), probe_visited(n, 0);
  std::vector<int> order, probe;
  order.reserve(n);
  for (int v = 0; v < n; ++v) {
    if (visited[v]) continue;
    // A far start: the last vertex of a breadth-first pass from v.
    probe.clear();
    const int far = breadth_first(g, v, probe_visited, probe, false);
    const size_t first = order.size();
    breadth_first(g, far, visited, order, true);
    std::reverse(order.begin() + first, order.end());
  }
  return order;
}

}  // namespace arap
