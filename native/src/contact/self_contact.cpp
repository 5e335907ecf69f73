#include "contact/self_contact.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <numeric>
#include <utility>

#include "contact/ccd.h"
#include "contact/primitives.h"
#include "runtime/memory_headroom.h"
#include "runtime/worker_threads.h"
#include "portable_math.h"

namespace arap::contact {

namespace {

constexpr int kLeafSize = 4;
// The pairs near enough to matter are listed with a margin (in mean edge
// lengths; a Verlet list): the list holds while no vertex has moved more than
// half the margin since it was made, or while the motion relative to the
// surface around each vertex stays within the room between the pairs
// (relative_motion.h). A step longer than half the margin is checked in
// pieces, at most kMostPieces (beyond, the pieces are longer and the list is
// made for each).
constexpr double kMarginShare = 0.5;
constexpr int kMostPieces = 256;
// Triangles per cluster of the relative-motion bound, at least; the clusters are
// at most about kMostClusters (their pairs are checked on every move).
constexpr int kClusterTriangles = 16;
constexpr int kMostClusters = 512;
// The search of near pairs runs in at least kWalkParts parts, on the solver's
// threads from kParallelTriangles surface triangles (below, a list takes well
// under a millisecond: waking the helpers would cost a share of it).
constexpr int kWalkParts = 64;
constexpr int kParallelTriangles = 2000;
constexpr int kMostThreads = 64;  // Options::threads' limit (options.cpp)

std::uint64_t key(int a, int b) { return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b); }
std::uint64_t sorted_key(int a, int b) { return a < b ? key(a, b) : key(b, a); }

Vec3 row(const double* P, int v) { return Vec3(P[3 * v], P[3 * v + 1], P[3 * v + 2]); }

bool share_vertex(const int* f, const int* g) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (f[i] == g[j]) return true;
  return false;
}

void sort_unique(std::vector<std::uint64_t>& keys) {
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
}

}  // namespace

double SelfContact::vertex_triangle_distance2(const double* P, int v, int f, double w[4]) const {
  return point_triangle_distance2(row(P, v), row(P, triangles_(f, 0)), row(P, triangles_(f, 1)),
                                  row(P, triangles_(f, 2)), w);
}

double SelfContact::edges_distance2(const double* P, int a, int b, double w[4]) const {
  return edge_edge_distance2(row(P, edges_[2 * a]), row(P, edges_[2 * a + 1]), row(P, edges_[2 * b]),
                             row(P, edges_[2 * b + 1]), w);
}

bool SelfContact::excluded(const std::vector<std::uint64_t>& sorted, std::uint64_t k) const {
  return !sorted.empty() && std::binary_search(sorted.begin(), sorted.end(), k);
}

template <class B>
static bool overlap(const B& a, const B& b) {
  for (int c = 0; c < 3; ++c)
    if (a.hi[c] < b.lo[c] || b.hi[c] < a.lo[c]) return false;
  return true;
}

template <class B>
static double extent(const B& b) {
  return (b.hi[0] - b.lo[0]) + (b.hi[1] - b.lo[1]) + (b.hi[2] - b.lo[2]);
}

template <class B>
static void grow(B& into, const B& b) {
  for (int c = 0; c < 3; ++c) into.lo[c] = std::min(into.lo[c], b.lo[c]), into.hi[c] = std::max(into.hi[c], b.hi[c]);
}

double SelfContact::barrier(double d) const {
  if (d >= activation_) return 0;
  if (!(d > 0)) return std::numeric_limits<double>::infinity();
  const double e = d - activation_;
  return -e * e * natural_log(d / activation_);
}

double SelfContact::barrier_slope(double d) const {
  if (d >= activation_) return 0;
  const double e = d - activation_;
  return -2 * e * natural_log(d / activation_) - e * e / d;
}

void SelfContact::bind(const Points& rest, const Triangles& triangles, double stiffness) {
  *this = SelfContact();
  if (triangles.rows() < 2) return;
  // Edges, each once, and each triangle's three.
  std::vector<std::uint64_t> edge_keys;
  edge_keys.reserve(3 * triangles.rows());
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    for (int k = 0; k < 3; ++k) edge_keys.push_back(sorted_key(triangles(f, k), triangles(f, (k + 1) % 3)));
  sort_unique(edge_keys);
  double length = 0;
  for (std::uint64_t e : edge_keys) {
    const int a = static_cast<int>(e >> 32), b = static_cast<int>(e & 0xffffffffu);
    edges_.push_back(a), edges_.push_back(b);
    length += (rest.row(a) - rest.row(b)).norm();
  }
  length /= static_cast<double>(edge_keys.size());
  if (!(length > 0) || !std::isfinite(length)) {
    edges_.clear();
    return;
  }
  triangles_ = triangles;
  triangle_edges_.resize(3 * triangles.rows());
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const std::uint64_t e = sorted_key(triangles(f, k), triangles(f, (k + 1) % 3));
      triangle_edges_[3 * f + k] = static_cast<int>(std::lower_bound(edge_keys.begin(), edge_keys.end(), e) -
                                                    edge_keys.begin());
    }
  first_triangle_of_vertex_.assign(rest.rows(), -1);
  std::vector<int> first_triangle_of_edge(edge_keys.size(), -1);
  for (int f = static_cast<int>(triangles.rows()) - 1; f >= 0; --f)
    for (int k = 0; k < 3; ++k) {
      first_triangle_of_vertex_[triangles(f, k)] = f;
      first_triangle_of_edge[triangle_edges_[3 * f + k]] = f;
    }
  owns_.assign(triangles.rows(), 0);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      if (first_triangle_of_vertex_[triangles(f, k)] == f) owns_[f] |= 1u << k;
      if (first_triangle_of_edge[triangle_edges_[3 * f + k]] == f) owns_[f] |= 8u << k;
    }
  std::vector<char> on_surface(rest.rows(), 0);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    for (int k = 0; k < 3; ++k) on_surface[triangles(f, k)] = 1;
  for (Eigen::Index v = 0; v < rest.rows(); ++v)
    if (on_surface[v]) surface_vertices_.push_back(static_cast<int>(v));
  gap_ = kGapShare * length;
  margin_ = kMarginShare * length;
  piece_start_.assign(3 * rest.rows(), 0.0);
  listed_at_.assign(3 * rest.rows(), 0.0);
  moved_.assign(rest.rows(), 0.0);
  piece_end_.assign(3 * rest.rows(), 0.0);
  checked_start_.assign(3 * rest.rows(), 0.0);
  checked_end_.assign(3 * rest.rows(), 0.0);
  activation_ = kActivationShare * length;
  stiffness_ = stiffness;
  vertex_box_.resize(rest.rows());
  triangle_box_.resize(triangles.rows());
  edge_box_.resize(edges_.size() / 2);
  leaf_box_.resize(triangles.rows());
  build_tree(rest);
  make_clusters(static_cast<int>(rest.rows()));

  // Pairs near at rest are not watched; triangle pairs that cross at rest are remembered.
  const double* P = rest.data();
  refit(P, P, 0.5 * activation_);
  const double activation2 = activation_ * activation_;
  double w[4];
  // A mesh with triangles far smaller than its mean edge, or crossing itself
  // everywhere, can have more such pairs than memory holds.
  auto keep = [](std::vector<std::uint64_t>& pairs, std::uint64_t k) {
    push_within_headroom(pairs, k, 1, "Self Contact's pairs of surface primitives near at rest (the mesh has "
                                      "triangles far smaller than its mean edge; turn Self Contact off or remesh it)");
  };
  auto point_triangle = [&](int v, int f) {
    if (vertex_triangle_distance2(P, v, f, w) < activation2) keep(excluded_vt_, key(v, f));
  };
  auto edge_edge = [&](int a, int b) {
    if (edges_distance2(P, a, b, w) < activation2) keep(excluded_ee_, sorted_key(a, b));
  };
  for_each_triangle_pair([&](int f, int g) {
    for_each_primitive_pair(f, g, point_triangle, edge_edge);
    if (triangles_cross(P, f, g)) keep(rest_crossing_, sorted_key(f, g));
  });
  std::sort(excluded_vt_.begin(), excluded_vt_.end());
  std::sort(excluded_ee_.begin(), excluded_ee_.end());
  std::sort(rest_crossing_.begin(), rest_crossing_.end());
}

// Clusters of the relative-motion bound: the subtrees of the BVH with at most
// `most` triangles; a vertex belongs to its first triangle's.
void SelfContact::make_clusters(int vertex_count) {
  const int triangle_count = static_cast<int>(triangles_.rows());
  const int most = std::max(kClusterTriangles, (triangle_count + kMostClusters - 1) / kMostClusters);
  std::vector<int> size(nodes_.size(), 0), cluster_of_triangle(triangle_count, -1);
  for (int n = static_cast<int>(nodes_.size()) - 1; n >= 0; --n)
    size[n] = nodes_[n].left < 0 ? nodes_[n].count : size[nodes_[n].left] + size[nodes_[n].right];
  int clusters = 0;
  std::vector<std::pair<int, int>> todo = {{0, -1}};  // node, the cluster it is in (-1: none yet)
  while (!todo.empty()) {
    auto [n, cluster] = todo.back();
    todo.pop_back();
    if (cluster < 0 && size[n] <= most) cluster = clusters++;
    const Node& node = nodes_[n];
    if (node.left < 0) {
      for (int k = 0; k < node.count; ++k) cluster_of_triangle[leaf_triangles_[node.first + k]] = cluster;
    } else {
      todo.emplace_back(node.left, cluster);
      todo.emplace_back(node.right, cluster);
    }
  }
  // Numbered again over the clusters that hold a vertex.
  std::vector<int> cluster_of(vertex_count, -1), number(clusters, -1);
  int used = 0;
  for (int v : surface_vertices_) {
    int& k = number[cluster_of_triangle[first_triangle_of_vertex_[v]]];
    if (k < 0) k = used++;
    cluster_of[v] = k;
  }
  relative_.bind(std::move(cluster_of), used, surface_vertices_);
}

void SelfContact::build_tree(const Points& rest) {
  std::vector<Eigen::Vector3d> centroid(triangles_.rows());
  for (Eigen::Index f = 0; f < triangles_.rows(); ++f)
    centroid[f] =
        (rest.row(triangles_(f, 0)) + rest.row(triangles_(f, 1)) + rest.row(triangles_(f, 2))).transpose() / 3;
  leaf_triangles_.resize(triangles_.rows());
  std::iota(leaf_triangles_.begin(), leaf_triangles_.end(), 0);
  nodes_.reserve(2 * triangles_.rows() / kLeafSize + 2);
  build_node(leaf_triangles_, 0, static_cast<int>(leaf_triangles_.size()), centroid);
}

// Median split along the longest side of the centroids' box; nodes in preorder
// (a parent before its children), so a reverse pass refits bottom-up.
int SelfContact::build_node(std::vector<int>& tris, int begin, int end, const std::vector<Eigen::Vector3d>& centroid) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.emplace_back();
  if (end - begin <= kLeafSize) {
    nodes_[index].first = begin;
    nodes_[index].count = end - begin;
    return index;
  }
  Eigen::Vector3d lo = centroid[tris[begin]], hi = lo;
  for (int k = begin; k < end; ++k) lo = lo.cwiseMin(centroid[tris[k]]), hi = hi.cwiseMax(centroid[tris[k]]);
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  const int middle = begin + (end - begin) / 2;
  std::nth_element(tris.begin() + begin, tris.begin() + middle, tris.begin() + end,
                   [&](int a, int b) { return centroid[a][axis] < centroid[b][axis]; });
  const int left = build_node(tris, begin, middle, centroid);
  const int right = build_node(tris, middle, end, centroid);
  nodes_[index].left = left;
  nodes_[index].right = right;
  return index;
}

void SelfContact::refit(const double* P0, const double* P1, double pad) {
  for (int v : surface_vertices_) {
    Box& b = vertex_box_[v];
    for (int c = 0; c < 3; ++c) {
      const double a = P0[3 * v + c], z = P1[3 * v + c];
      b.lo[c] = std::min(a, z) - pad, b.hi[c] = std::max(a, z) + pad;
    }
  }
  for (size_t e = 0; e < edge_box_.size(); ++e) {
    edge_box_[e] = vertex_box_[edges_[2 * e]];
    grow(edge_box_[e], vertex_box_[edges_[2 * e + 1]]);
  }
  for (Eigen::Index f = 0; f < triangles_.rows(); ++f) {
    Box& b = triangle_box_[f];
    b = vertex_box_[triangles_(f, 0)];
    grow(b, vertex_box_[triangles_(f, 1)]);
    grow(b, vertex_box_[triangles_(f, 2)]);
  }
  for (int n = static_cast<int>(nodes_.size()) - 1; n >= 0; --n) {
    Node& node = nodes_[n];
    if (node.left < 0) {
      for (int k = 0; k < node.count; ++k) leaf_box_[node.first + k] = triangle_box_[leaf_triangles_[node.first + k]];
      node.box = leaf_box_[node.first];
      for (int k = 1; k < node.count; ++k) grow(node.box, leaf_box_[node.first + k]);
    } else {
      node.box = nodes_[node.left].box;
      grow(node.box, nodes_[node.right].box);
    }
  }
}

template <class Visit>
void SelfContact::for_each_triangle_pair(Visit&& visit) {
  walk_from(0, 0, stack_, visit);
}

template <class Visit>
void SelfContact::walk_from(int a0, int b0, std::vector<std::pair<int, int>>& stack, Visit&& visit) const {
  // i, j: places in leaf order (their boxes side by side in leaf_box_).
  auto test = [&](int i, int j) {
    if (overlap(leaf_box_[i], leaf_box_[j])) visit(leaf_triangles_[i], leaf_triangles_[j]);
  };
  stack.clear();
  stack.emplace_back(a0, b0);
  while (!stack.empty()) {
    const auto [a, b] = stack.back();
    stack.pop_back();
    const Node& na = nodes_[a];
    const Node& nb = nodes_[b];
    if (a == b) {
      if (na.left < 0) {
        for (int i = 0; i < na.count; ++i)
          for (int j = i + 1; j < na.count; ++j) test(na.first + i, na.first + j);
      } else {
        stack.emplace_back(na.left, na.left);
        stack.emplace_back(na.right, na.right);
        stack.emplace_back(na.left, na.right);
      }
      continue;
    }
    if (!overlap(na.box, nb.box)) continue;
    if (na.left < 0 && nb.left < 0) {
      for (int i = 0; i < na.count; ++i)
        for (int j = 0; j < nb.count; ++j) test(na.first + i, nb.first + j);
    } else if (na.left < 0 || (nb.left >= 0 && extent(nb.box) > extent(na.box))) {  // the larger one down
      stack.emplace_back(a, nb.left);
      stack.emplace_back(a, nb.right);
    } else {
      stack.emplace_back(na.left, b);
      stack.emplace_back(na.right, b);
    }
  }
}

// Level by level, each node pair replaced by the pairs walk_from() would push
// for it (a pair whose boxes do not overlap is dropped, a pair of leaves kept).
void SelfContact::split_walk(int at_least) {
  walk_parts_.assign(1, {0, 0});
  for (bool split = true; split && static_cast<int>(walk_parts_.size()) < at_least;) {
    split = false;
    walk_next_.clear();
    for (const auto& [a, b] : walk_parts_) {
      const Node& na = nodes_[a];
      const Node& nb = nodes_[b];
      if (a == b) {
        if (na.left < 0) {
          walk_next_.emplace_back(a, b);
          continue;
        }
        walk_next_.emplace_back(na.left, na.left);
        walk_next_.emplace_back(na.right, na.right);
        walk_next_.emplace_back(na.left, na.right);
      } else if (!overlap(na.box, nb.box)) {
      } else if (na.left < 0 && nb.left < 0) {
        walk_next_.emplace_back(a, b);
        continue;
      } else if (na.left < 0 || (nb.left >= 0 && extent(nb.box) > extent(na.box))) {
        walk_next_.emplace_back(a, nb.left);
        walk_next_.emplace_back(a, nb.right);
      } else {
        walk_next_.emplace_back(na.left, b);
        walk_next_.emplace_back(na.right, b);
      }
      split = true;
    }
    walk_parts_.swap(walk_next_);
  }
}

// A vertex (an edge) is taken from the first triangle that holds it, whose box
// holds the vertex's (the edge's) box. So no pair comes twice, and none is
// missed: if a vertex's box meets triangle g's, so does its first triangle's.
template <class OnVt, class OnEe>
void SelfContact::for_each_primitive_pair(int f, int g, OnVt&& on_vt, OnEe&& on_ee) const {
  const int* tf = &triangles_(f, 0);
  const int* tg = &triangles_(g, 0);
  for (int pass = 0; pass < 2; ++pass) {
    const int a = pass == 0 ? f : g, b = pass == 0 ? g : f;
    const int* ta = pass == 0 ? tf : tg;
    const int* tb = pass == 0 ? tg : tf;
    const unsigned owned = owns_[a];
    for (int i = 0; i < 3; ++i) {
      const int v = ta[i];
      if (!(owned >> i & 1u) || v == tb[0] || v == tb[1] || v == tb[2]) continue;
      if (overlap(vertex_box_[v], triangle_box_[b])) on_vt(v, b);
    }
  }
  const unsigned owned_f = owns_[f] >> 3, owned_g = owns_[g] >> 3;
  if (!owned_f || !owned_g) return;
  for (int i = 0; i < 3; ++i) {
    if (!(owned_f >> i & 1u)) continue;
    const int ea = triangle_edges_[3 * f + i];
    const int a0 = edges_[2 * ea], a1 = edges_[2 * ea + 1];
    for (int j = 0; j < 3; ++j) {
      if (!(owned_g >> j & 1u)) continue;
      const int eb = triangle_edges_[3 * g + j];
      const int b0 = edges_[2 * eb], b1 = edges_[2 * eb + 1];
      if (a0 == b0 || a0 == b1 || a1 == b0 || a1 == b1) continue;
      if (overlap(edge_box_[ea], edge_box_[eb])) on_ee(ea, eb);
    }
  }
}

SelfContact::Step SelfContact::evaluate(const double* P0, const double* P1, ListAt list_at,
                                        const std::function<bool()>* out_of_time) {
  Step step;
  active_.clear();
  if (!active()) return step;
  if (P0 == P1) {
    sweep(P0, P1, false, list_at, step);
    return step;
  }
  if (on_checked_move(P0, P1)) {
    // A shorter trial along the move checked last: only its end is evaluated.
    sweep(P1, P1, false, list_at, step);
    if (step.fraction >= 1) return step;
    step = Step();  // a pair within the gap at the end (rounding): checked in full below
    active_.clear();
  }
  // A long move is checked in pieces no vertex moves more than half the margin
  // in: the list of near pairs made at a piece's start then holds for all of it
  // (and, when the piece moves whole regions along together, often for more).
  double longest = 0;
  for (int v : surface_vertices_) longest = std::max(longest, (row(P1, v) - row(P0, v)).squaredNorm());
  longest = std::sqrt(longest);
  const double reach = 0.5 * margin_;
  const int pieces =
      !(longest > reach) ? 1 : static_cast<int>(std::min<double>(kMostPieces, std::ceil(longest / reach)));
  if (pieces == 1) {
    sweep(P0, P1, true, list_at, step);
    remember_checked_move(P0, P1, step.fraction);
    return step;
  }
  auto along = [&](int k, std::vector<double>& into) -> const double* {
    if (k == 0) return P0;
    if (k == pieces) return P1;
    const double t = static_cast<double>(k) / pieces;
    for (int v : surface_vertices_)
      for (int c = 0; c < 3; ++c) into[3 * v + c] = P0[3 * v + c] + t * (P1[3 * v + c] - P0[3 * v + c]);
    return into.data();
  };
  for (int k = 0; k < pieces; ++k) {
    Step piece;
    active_.clear();
    sweep(along(k, piece_start_), along(k + 1, piece_end_), true, list_at, piece);
    if (piece.fraction < 1) {
      step.fraction = (k + piece.fraction) / pieces;
      std::copy(piece.blocking, piece.blocking + 4, step.blocking);
      remember_checked_move(P0, P1, step.fraction);
      return step;
    }
    step.energy = piece.energy;  // the last piece's: the barrier at P1
    if (out_of_time && k + 1 < pieces && (*out_of_time)()) {
      step = Step();
      step.fraction = static_cast<double>(k + 1) / pieces;
      step.out_of_time = true;
      active_.clear();
      remember_checked_move(P0, P1, step.fraction);
      return step;
    }
  }
  remember_checked_move(P0, P1, 1);
  return step;
}

// A line search tries shorter steps along the same straight move. The move
// checked last went from S to E, and up to the share found safe every watched
// pair stayed farther apart than the gap. A move from S to a point within
// `tolerance` of S + s (E - S), s within that share, is at every moment within
// `tolerance` of that checked part, so its pairs stay farther apart than the gap
// less 2 sqrt(3) tolerance: it crosses nothing, and only its end needs evaluating.
bool SelfContact::on_checked_move(const double* P0, const double* P1) const {
  if (!(checked_share_ > 0)) return false;
  double along = 0, length2 = 0;
  for (int v : surface_vertices_)
    for (int c = 0; c < 3; ++c) {
      const int i = 3 * v + c;
      if (P0[i] != checked_start_[i]) return false;
      const double checked = checked_end_[i] - checked_start_[i];
      along += (P1[i] - P0[i]) * checked;
      length2 += checked * checked;
    }
  if (!(length2 > 0)) return false;
  const double s = along / length2;
  if (!(s >= 0 && s <= checked_share_)) return false;
  const double tolerance = 1e-9 * gap_;
  for (int v : surface_vertices_)
    for (int c = 0; c < 3; ++c) {
      const int i = 3 * v + c;
      if (!(std::abs(P1[i] - P0[i] - s * (checked_end_[i] - checked_start_[i])) <= tolerance)) return false;
    }
  return true;
}

void SelfContact::remember_checked_move(const double* P0, const double* P1, double share) {
  for (int v : surface_vertices_)
    for (int c = 0; c < 3; ++c) checked_start_[3 * v + c] = P0[3 * v + c], checked_end_[3 * v + c] = P1[3 * v + c];
  checked_share_ = share;
}

// One straight move from P0 to P1 checked in one pass (`moving`; else P0 == P1
// is a state): step.fraction and step.blocking, the energy and pairs at P1.
void SelfContact::sweep(const double* P0, const double* P1, bool moving, ListAt list_at, Step& step) {
  // Made at the move's end, it covers the move all the same (the criteria look at
  // both ends), and the next move starts there (a long move's next piece, the next step).
  if (!listed(P0, P1)) list_at == ListAt::End ? make_list(P1, P0) : make_list(P0, P1);
  Vec3 x[4], dx[4];
  double w[4];
  auto consider = [&](const int v[4], bool point_triangle) {
    for (int k = 0; k < 4; ++k) x[k] = row(P0, v[k]), dx[k] = row(P1, v[k]) - x[k];
    if (moving) {
      const bool still = dx[0].isZero(0) && dx[1].isZero(0) && dx[2].isZero(0) && dx[3].isZero(0);
      const double t = still ? 1.0
                             : point_triangle ? point_triangle_impact(x, dx, gap_, kImpactReduction, step.fraction)
                                            : edge_edge_impact(x, dx, gap_, kImpactReduction, step.fraction);
      if (t < step.fraction) {
        step.fraction = t;
        std::copy(v, v + 4, step.blocking);
      }
    }
    if (step.fraction < 1) return;
    for (int k = 0; k < 4; ++k) x[k] += dx[k];
    const double d2 = point_triangle ? point_triangle_distance2(x[0], x[1], x[2], x[3], w)
                                     : edge_edge_distance2(x[0], x[1], x[2], x[3], w);
    if (!(d2 < activation_ * activation_)) return;
    const double d = std::sqrt(d2);
    if (!(d > gap_) && !moving) {
      step.fraction = 0;  // a state no step may start from (see is_clear)
      std::copy(v, v + 4, step.blocking);
      return;
    }
    step.energy += stiffness_ * barrier(d);
    ActivePair p;
    std::copy(v, v + 4, p.v);
    std::copy(w, w + 4, p.w);
    const Vec3 diff = w[0] * x[0] + w[1] * x[1] + w[2] * x[2] + w[3] * x[3];
    for (int c = 0; c < 3; ++c) p.dir[c] = diff[c] / d;
    p.slope = stiffness_ * barrier_slope(d);
    active_.push_back(p);
  };
  // How far vertices a and b can have come nearer each other since the list was made.
  auto closer = [&](int a, int b) { return relative_list_ ? relative_.bound(a, b) : moved_[a] + moved_[b]; };
  // A pair whose distance where the list was made, less that for any of its
  // vertex pairs, stays beyond the activation distance is skipped.
  auto far = [&](double listed_distance, const int v[4], int sides) {
    double most = 0;
    for (int i = 0; i < sides; ++i)
      for (int j = sides; j < 4; ++j) most = std::max(most, closer(v[i], v[j]));
    return listed_distance - most >= activation_;
  };
  const double within = activation_ + (relative_list_ ? relative_.largest_bound() : 2 * most_moved_);
  const std::vector<NearPair>& near_vt = near_vt_.pairs();
  for (size_t i = 0, end = near_vt_.count_below(within); i < end; ++i) {
    const NearPair& n = near_vt[i];
    if (n.distance >= within) continue;
    const int f = static_cast<int>(n.key & 0xffffffffu);
    const int v[4] = {static_cast<int>(n.key >> 32), triangles_(f, 0), triangles_(f, 1), triangles_(f, 2)};
    if (far(n.distance, v, 1)) continue;
    consider(v, true);
  }
  const std::vector<NearPair>& near_ee = near_ee_.pairs();
  for (size_t i = 0, end = near_ee_.count_below(within); i < end; ++i) {
    const NearPair& n = near_ee[i];
    if (n.distance >= within) continue;
    const int a = static_cast<int>(n.key >> 32), b = static_cast<int>(n.key & 0xffffffffu);
    const int v[4] = {edges_[2 * a], edges_[2 * a + 1], edges_[2 * b], edges_[2 * b + 1]};
    if (far(n.distance, v, 2)) continue;
    consider(v, false);
  }
  if (step.fraction < 1) {
    // Moving: the step is refused, its end is not evaluated. Still: a state closer than the gap.
    step.energy = moving ? 0 : std::numeric_limits<double>::infinity();
    active_.clear();
  }
}

void SelfContact::add_half_gradient(const std::vector<int>& free_row, double* g) const {
  for (const ActivePair& p : active_)
    for (int k = 0; k < 4; ++k) {
      const int r = free_row[p.v[k]];
      if (r < 0) continue;
      for (int c = 0; c < 3; ++c) g[3 * r + c] += 0.5 * p.slope * p.w[k] * p.dir[c];
    }
}

void SelfContact::add_gradient(double* gradient) const {
  for (const ActivePair& p : active_)
    for (int k = 0; k < 4; ++k)
      for (int c = 0; c < 3; ++c) gradient[3 * p.v[k] + c] += p.slope * p.w[k] * p.dir[c];
}

// Whether the list holds for the move P0 -> P1: every vertex within half the
// margin of where the list was made (moved_ then bounds how far, anywhere on
// the move), or else the motion relative to the clusters' within their room.
bool SelfContact::listed(const double* P0, const double* P1) {
  if (!list_made_) return false;
  const double reach2 = 0.25 * list_margin_ * list_margin_;
  most_moved_ = 0;
  bool near = true;
  for (int v : surface_vertices_) {
    const Vec3 at = row(listed_at_.data(), v);
    const double m2 = std::max((row(P0, v) - at).squaredNorm(), (row(P1, v) - at).squaredNorm());
    if (m2 > reach2) {
      near = false;
      break;
    }
    moved_[v] = std::sqrt(m2);
    most_moved_ = std::max(most_moved_, moved_[v]);
  }
  relative_list_ = !near;
  return near || relative_.holds(listed_at_.data(), P0, P1);
}

// The watched pairs closer than `reach` at `at`, into near_vt_ and near_ee_ (not yet grouped).
// The walk runs in parts that the threads take in turn; what each part finds is
// joined in the parts' order, so the list is the same for any thread count.
void SelfContact::find_near_pairs(const double* at, double reach) {
  const double reach2 = reach * reach;
  split_walk(kWalkParts);
  const int parts = static_cast<int>(walk_parts_.size());
  part_range_.resize(parts);
  const int threads = triangles_.rows() >= kParallelTriangles ? std::min({threads_, parts, kMostThreads}) : 1;
  if (static_cast<int>(thread_found_.size()) < threads) thread_found_.resize(threads);
  std::atomic<int> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error[kMostThreads];
  run_on_threads(threads, [&](int t) {
    try {
      double w[4];
      Found& found = thread_found_[t];
      found.vt.clear();
      found.ee.clear();
      for (int part = next++; part < parts && !failed; part = next++) {
        PartRange& range = part_range_[part];
        range.thread = t;
        range.vt_begin = found.vt.size(), range.ee_begin = found.ee.size();
        auto point_triangle = [&](int v, int f) {
          const Vec3 p = row(at, v), a = row(at, triangles_(f, 0)), b = row(at, triangles_(f, 1)),
                     c = row(at, triangles_(f, 2));
          if (point_triangle_separation(p, a, b, c) >= reach) return;
          const double d2 = point_triangle_distance2(p, a, b, c, w);
          const std::uint64_t k = key(v, f);
          if (d2 < reach2 && !excluded(excluded_vt_, k)) keep_near_pair(found.vt, std::sqrt(d2), k);
        };
        auto edge_edge = [&](int e, int g) {
          const Vec3 a0 = row(at, edges_[2 * e]), a1 = row(at, edges_[2 * e + 1]);
          const Vec3 b0 = row(at, edges_[2 * g]), b1 = row(at, edges_[2 * g + 1]);
          if (edge_edge_separation(a0, a1, b0, b1) >= reach) return;
          const double d2 = edge_edge_distance2(a0, a1, b0, b1, w);
          const std::uint64_t k = sorted_key(e, g);
          if (d2 < reach2 && !excluded(excluded_ee_, k)) keep_near_pair(found.ee, std::sqrt(d2), k);
        };
        walk_from(walk_parts_[part].first, walk_parts_[part].second, found.stack,
                  [&](int f, int g) { for_each_primitive_pair(f, g, point_triangle, edge_edge); });
        range.vt_end = found.vt.size(), range.ee_end = found.ee.size();
      }
    } catch (...) {  // more pairs than the memory left holds: thrown below, on the calling thread
      error[t] = std::current_exception();
      failed = true;
    }
  });
  for (int t = 0; t < threads; ++t)
    if (error[t]) std::rethrow_exception(error[t]);
  near_vt_.start(reach);
  near_ee_.start(reach);
  for (const PartRange& range : part_range_) {
    const Found& found = thread_found_[range.thread];
    for (size_t i = range.vt_begin; i < range.vt_end; ++i) near_vt_.add(found.vt[i].distance, found.vt[i].key);
    for (size_t i = range.ee_begin; i < range.ee_end; ++i) near_ee_.add(found.ee[i].distance, found.ee[i].key);
  }
}

// The watched pairs closer than activation + margin at `at`; the margin grows
// for a move between `at` and `other` longer than half of it (one cut into the most pieces).
void SelfContact::make_list(const double* at, const double* other) {
  list_made_ = false;  // until it is done: the walk can throw (more pairs than the memory left holds)
  double longest = 0;
  for (int v : surface_vertices_) longest = std::max(longest, (row(other, v) - row(at, v)).squaredNorm());
  list_margin_ = std::max(margin_, 2.001 * std::sqrt(longest));
  relative_.set_reference(at, triangles_.data(), static_cast<long>(triangles_.rows()), list_margin_, activation_);
  refit(at, at, 0.5 * (activation_ + list_margin_));
  find_near_pairs(at, activation_ + list_margin_);
  // Grouped by distance: a move checks only the pairs that its largest motion can bring within reach.
  near_vt_.finish();
  near_ee_.finish();
  for (int v : surface_vertices_)
    for (int c = 0; c < 3; ++c) listed_at_[3 * v + c] = at[3 * v + c];
  list_made_ = true;
  listed(at, other);  // sets moved_ (the margin covers the move)
  ++lists_made_;
}


// One walk with the boxes padded by half the activation distance (no list of
// near pairs: the state is checked once, not moved from), for both the pairs
// within the gap and the triangles that cross.
bool SelfContact::is_clear(const double* P, double* barrier_energy) {
  if (barrier_energy) *barrier_energy = 0;
  if (!active()) return true;
  refit(P, P, 0.5 * activation_);
  const double activation2 = activation_ * activation_;
  bool clear = true;
  double energy = 0, w[4];
  auto near = [&](double d2) {
    if (!(d2 < activation2)) return;
    const double d = std::sqrt(d2);
    if (!(d > gap_)) clear = false;
    else energy += stiffness_ * barrier(d);
  };
  auto point_triangle = [&](int v, int f) {
    if (clear && !excluded(excluded_vt_, key(v, f))) near(vertex_triangle_distance2(P, v, f, w));
  };
  auto edge_edge = [&](int a, int b) {
    if (clear && !excluded(excluded_ee_, sorted_key(a, b))) near(edges_distance2(P, a, b, w));
  };
  for_each_triangle_pair([&](int f, int g) {
    if (!clear) return;
    for_each_primitive_pair(f, g, point_triangle, edge_edge);
    if (triangles_cross(P, f, g) && !excluded(rest_crossing_, sorted_key(f, g))) clear = false;
  });
  if (clear && barrier_energy) *barrier_energy = energy;
  return clear;
}

// Whether triangles f and g (sharing no vertex) cross: an edge of one through
// the other. Crossing triangles each have corners strictly on both sides of the
// other's plane; one that only touches the other's plane (corners in it and on
// one side, or all in it: an overlap there is not a crossing) is passed without
// the edge tests. A corner within a tolerance of the plane, far above the
// rounding of the signed volumes, counts as in it: a side folded at a crease
// leaves corners in each other's plane, which measure a few ulps to either side
// depending on the unit's rounding, and an edge test of an edge lying in the
// plane is decided by that rounding.
bool SelfContact::triangles_cross(const double* P, int f, int g) const {
  if (share_vertex(&triangles_(f, 0), &triangles_(g, 0))) return false;
  auto straddles = [&](int a, int b) {
    const Vec3 p = row(P, triangles_(b, 0));
    const Vec3 n = (row(P, triangles_(b, 1)) - p).cross(row(P, triangles_(b, 2)) - p);
    // Signed volumes n.(x - p) scale as L^3 and |n| as L^2: a distance of 1e-12 sqrt|n| from the plane.
    const double tolerance = 1e-12 * n.norm() * std::sqrt(n.norm());
    int above = 0, below = 0;
    for (int i = 0; i < 3; ++i) {
      const double side = n.dot(row(P, triangles_(a, i)) - p);
      above += side > tolerance;
      below += side < -tolerance;
    }
    return above > 0 && below > 0;
  };
  if (!straddles(f, g) || !straddles(g, f)) return false;
  for (int pass = 0; pass < 2; ++pass) {
    const int a = pass == 0 ? f : g, b = pass == 0 ? g : f;
    for (int e = 0; e < 3; ++e)
      if (segment_crosses_triangle(row(P, triangles_(a, e)), row(P, triangles_(a, (e + 1) % 3)),
                                   row(P, triangles_(b, 0)), row(P, triangles_(b, 1)), row(P, triangles_(b, 2))))
        return true;
  }
  return false;
}

}  // namespace arap::contact
