#include "nested_dissection.h"

#include <algorithm>

namespace arap {

namespace {

using Sparse = Eigen::SparseMatrix<double>;
using OrderUncut = std::function<std::vector<int>(const std::vector<int>&)>;

class Dissection {
 public:
  Dissection(const Sparse& A, int leaf_rows, const OrderUncut& order_uncut)
      : A_(A), leaf_rows_(leaf_rows), order_uncut_(order_uncut), row_(A.rows()) {}

  // Appends the order of `rows` to `out`. The rows of the part, and no
  // others, carry `tag`. `start`: a row of the part at one end of it, or -1
  // to find one.
  void order(const std::vector<int>& rows, int tag, int start, std::vector<int>& out) {
    const int m = static_cast<int>(rows.size());
    if (m <= leaf_rows_) return append(rows, out);
    std::vector<int> queue, level_start;
    queue.reserve(m);
    int reached = breadth_first(start >= 0 ? start : rows[0], tag, queue, level_start);
    if (static_cast<int>(queue.size()) < m) return order_components(rows, tag, reached, queue, out);
    if (start < 0) {  // a pseudo-peripheral start: the last row reached from rows[0]
      start = queue.back();
      queue.clear();
      reached = breadth_first(start, reached, queue, level_start);
    }
    // Levels are runs of the queue: level l is queue[level_start[l], level_start[l + 1]).
    const int cut = separating_level(level_start);
    if (cut < 0) return append(order_uncut_(rows), out);
    const auto level_begin = queue.begin() + level_start[cut], level_end = queue.begin() + level_start[cut + 1];
    std::vector<int> side[2], separator;
    side[0].assign(queue.begin(), level_begin);
    side[1].assign(level_end, queue.end());
    for (auto v = level_begin; v != level_end; ++v) {
      // A row of the cut with no neighbour past it joins the near side: the
      // sides stay apart, and the separator is thinner.
      bool touches_far_side = false;
      for (Sparse::InnerIterator it(A_, *v); it && !touches_far_side; ++it)
        touches_far_side = row_[it.row()].tag == reached && row_[it.row()].level > cut;
      (touches_far_side ? separator : side[0]).push_back(*v);
    }
    const int side_tag[2] = {retag(side[0]), retag(side[1])};
    // Each side is cut next across this cut: from one end of the separator.
    const int end = far_end(separator);
    const int side_start[2] = {neighbour_tagged(end, side_tag[0]), neighbour_tagged(end, side_tag[1])};
    order(side[0], side_tag[0], side_start[0], out);
    order(side[1], side_tag[1], side_start[1], out);
    append(separator, out);
  }

  int retag(const std::vector<int>& rows) {
    const int tag = ++stamp_;
    for (int v : rows) row_[v].tag = tag;
    return tag;
  }

 private:
  struct Row {
    int tag = 0;    // the part's tag, then the tag of the search that reached it
    int level = 0;  // its level in that search
  };

  static void append(const std::vector<int>& part, std::vector<int>& out) {
    out.insert(out.end(), part.begin(), part.end());
  }

  // Breadth-first search from `start` over the rows tagged `tag`, appending
  // them to `queue` level by level; returns the tag they now carry.
  int breadth_first(int start, int tag, std::vector<int>& queue, std::vector<int>& level_start) {
    const int reached = ++stamp_;
    row_[start].tag = reached;
    row_[start].level = 0;
    const int first = static_cast<int>(queue.size());
    queue.push_back(start);
    level_start.assign(1, first);
    for (int level = 1; level_start.back() < static_cast<int>(queue.size()); ++level) {
      const int end = static_cast<int>(queue.size());
      for (int k = level_start.back(); k < end; ++k)
        for (Sparse::InnerIterator it(A_, queue[k]); it; ++it) {
          Row& w = row_[it.row()];
          if (w.tag != tag) continue;
          w.tag = reached;
          w.level = level;
          queue.push_back(static_cast<int>(it.row()));
        }
      level_start.push_back(end);
    }
    for (int& s : level_start) s -= first;
    return reached;
  }

  // The smallest level that leaves at least a quarter of the rows on each
  // side (a smaller separator pays for the imbalance down to about that:
  // docs/engine_internals.md), or -1 if none does. A cut leaves at least 3 rows past it (parts above the leaf
  // size have 9 or more), so the separator is never empty.
  int separating_level(const std::vector<int>& level_start) const {
    const int levels = static_cast<int>(level_start.size()) - 1;
    const int m = level_start[levels];
    int best = -1;
    for (int l = 0; l < levels; ++l) {
      const int below = level_start[l], count = level_start[l + 1] - below, above = m - below - count;
      if (4 * std::min(below, above) < m) continue;
      if (best < 0 || count < level_start[best + 1] - level_start[best]) best = l;
    }
    return best;
  }

  // The row of the separator farthest (within it) from its first row.
  int far_end(const std::vector<int>& separator) {
    std::vector<int> queue, level_start;
    queue.reserve(separator.size());
    breadth_first(separator.front(), retag(separator), queue, level_start);
    return queue.back();
  }

  // A neighbour of v tagged `tag`; -1 if it has none.
  int neighbour_tagged(int v, int tag) const {
    for (Sparse::InnerIterator it(A_, v); it; ++it)
      if (row_[it.row()].tag == tag) return static_cast<int>(it.row());
    return -1;
  }

  // A disconnected part: each component is ordered on its own, one after the
  // other. `queue` holds the first, reached from rows[0] and tagged `reached`.
  void order_components(const std::vector<int>& rows, int tag, int reached, std::vector<int>& queue,
                        std::vector<int>& out) {
    std::vector<std::vector<int>> components;
    std::vector<int> component_tag, level_start;
    components.emplace_back(queue.begin(), queue.end());
    component_tag.push_back(reached);
    for (int v : rows) {
      if (row_[v].tag != tag) continue;
      queue.clear();
      component_tag.push_back(breadth_first(v, tag, queue, level_start));
      components.push_back(queue);
    }
    for (size_t c = 0; c < components.size(); ++c) order(components[c], component_tag[c], -1, out);
  }

  const Sparse& A_;
  const int leaf_rows_;
  const OrderUncut& order_uncut_;
  std::vector<Row> row_;
  int stamp_ = 0;
};

}  // namespace

std::vector<int> nested_dissection_order(const Sparse& A, const std::vector<int>& rows, int leaf_rows,
                                         const OrderUncut& order_uncut) {
  std::vector<int> out;
  out.reserve(rows.size());
  Dissection dissection(A, leaf_rows, order_uncut);
  dissection.order(rows, dissection.retag(rows), -1, out);
  return out;
}

}  // namespace arap
