// Union-find over vertex indices (path halving), for the component searches
// of the mesh checks, the bind, Volume: Global and Volume: Infill.
#pragma once

#include <numeric>
#include <vector>

namespace arap {

class UnionFind {
 public:
  explicit UnionFind(int n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0); }
  int root(int v) {
    while (parent_[v] != v) v = parent_[v] = parent_[parent_[v]];
    return v;
  }
  void join(int a, int b) { parent_[root(b)] = root(a); }
  // Component of every vertex v with used[v] (0, 1, ... in vertex order), -1 for the others; returns the count.
  int label(const std::vector<char>& used, std::vector<int>& component) {
    const int n = static_cast<int>(parent_.size());
    component.assign(n, -1);
    std::vector<int> id_of_root(n, -1);
    int count = 0;
    for (int v = 0; v < n; ++v) {
      if (!used[v]) continue;
      const int r = root(v);
      if (id_of_root[r] < 0) id_of_root[r] = count++;
      component[v] = id_of_root[r];
    }
    return count;
  }

 private:
  std::vector<int> parent_;
};

}  // namespace arap
