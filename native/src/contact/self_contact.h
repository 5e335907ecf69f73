// Self-contact of the surface (Options::contact == Contact::Self): a barrier on
// the distances of near primitive pairs and continuous collision detection of
// every step, as in Incremental Potential Contact (Li et al. 2020, eq. 6 and
// section 4). The pairs are a point against a triangle and an edge against an
// edge, taken from surface triangles that share no vertex.
//
// A pair closer than the activation distance d^ in the rest shape (touching
// layers, triangles that already cross) is excluded; every other pair adds
//   kappa b(d),  b(d) = -(d - d^)^2 ln(d / d^)  for d < d^, 0 beyond,
// to the energy (C2 at d^, infinite at 0), and a step is only ever taken as far
// as every such pair stays farther apart than the gap (< d^). So two triangles
// that are at least d^ apart at rest never cross, at any accepted step.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "arap/types.h"
#include "contact/near_list.h"
#include "contact/relative_motion.h"

namespace arap::contact {

// The gap and the activation distance as fractions of the mean edge length (docs/contact.md).
constexpr double kGapShare = 0.01;
constexpr double kActivationShare = 0.1;

class SelfContact {
 public:
  // `triangles`: the surface (#F by 3, internal vertex indices); `rest`: #n by
  // 3 (internal order and units); `stiffness`: kappa.
  void bind(const Points& rest, const Triangles& triangles, double stiffness);
  bool active() const { return triangles_.rows() > 0; }
  // Threads for the search of near pairs (Options::threads): the list found is the same for any count.
  void set_threads(int threads) { threads_ = threads < 1 ? 1 : threads; }
  double gap() const { return gap_; }
  double activation() const { return activation_; }
  long lists_made() const { return lists_made_; }
  long active_pairs() const { return static_cast<long>(active_.size()); }

  // What moving every vertex from P0 to P1 (#n by 3 each, row-major) meets:
  // `fraction` of the step that is safe (1: all of it), and, when all of it
  // is, the barrier energy at P1. The pairs active at P1 are kept for
  // add_half_gradient(); when fraction < 1, `blocking` holds the four vertices
  // of the pair that stopped the step.
  struct Step {
    double fraction = 1;
    double energy = 0;
    int blocking[4] = {-1, -1, -1, -1};
    // The check of a long move stopped between two of its pieces because
    // `out_of_time` said so: `fraction` is the share checked, no pair stopped it.
    bool out_of_time = false;
  };
  // A list of near pairs the move needs is made where the next move will likely
  // start: at the end of each piece of the move (ListAt::End), or at its start
  // for a move expected to be cut (ListAt::Start: the end lies past a contact,
  // and a list made there holds pairs that do not matter).
  enum class ListAt { End, Start };
  // `out_of_time`, when given, is asked between the pieces of a long move (never before the first).
  Step evaluate(const double* P0, const double* P1, ListAt list_at = ListAt::End,
                const std::function<bool()>* out_of_time = nullptr);
  // The barrier energy at P (no motion).
  double energy(const double* P) { return evaluate(P, P).energy; }
  // g += 1/2 dE_contact/dp on the free rows (`free_row`: vertex -> row or -1,
  // 3 entries per row), for the pairs of the last evaluate().
  void add_half_gradient(const std::vector<int>& free_row, double* g) const;
  // dE_contact/dp for every vertex (#n by 3), for the pairs of the last evaluate().
  void add_gradient(double* gradient) const;
  // Whether P is a state a step may start from: every watched pair farther
  // apart than the gap and no two triangles crossing that did not cross at rest.
  // `barrier_energy`, when given and P is clear, gets the barrier energy at P.
  bool is_clear(const double* P, double* barrier_energy = nullptr);

 private:
  struct Box {
    double lo[3], hi[3];
  };
  struct Node {
    Box box;
    int left = -1, right = -1;  // children, or -1 for a leaf
    int first = 0, count = 0;   // a leaf's triangles: leaf_triangles_[first, first + count)
  };
  struct ActivePair {
    int v[4];
    double w[4];
    double dir[3];  // (closest-point difference) / d
    double slope;   // kappa b'(d)
  };
  void build_tree(const Points& rest);
  void make_clusters(int vertex_count);
  int build_node(std::vector<int>& tris, int begin, int end, const std::vector<Eigen::Vector3d>& centroid);
  void refit(const double* P0, const double* P1, double pad);
  // visit(f, g) for each pair of triangles whose boxes overlap.
  template <class Visit>
  void for_each_triangle_pair(Visit&& visit);
  // The same for the pairs below tree nodes a and b (a == b: within one subtree), on `stack`.
  template <class Visit>
  void walk_from(int a, int b, std::vector<std::pair<int, int>>& stack, Visit&& visit) const;
  // The walk from the root cut into at least `at_least` parts (node pairs, in an order
  // that only the tree and its boxes decide), into walk_parts_.
  void split_walk(int at_least);
  // The point-triangle (on_vt(v, f)) and edge-edge (on_ee(e, g)) pairs that triangles f and g
  // hold, their boxes overlapping; each pair comes from one triangle pair only.
  template <class OnVt, class OnEe>
  void for_each_primitive_pair(int f, int g, OnVt&& on_vt, OnEe&& on_ee) const;
  bool excluded(const std::vector<std::uint64_t>& sorted, std::uint64_t key) const;
  // The squared distance of vertex v and triangle f, of edges a and b, at positions P (weights: primitives.h).
  double vertex_triangle_distance2(const double* P, int v, int f, double w[4]) const;
  double edges_distance2(const double* P, int a, int b, double w[4]) const;
  void sweep(const double* P0, const double* P1, bool moving, ListAt list_at, Step& step);
  bool listed(const double* P0, const double* P1);
  bool on_checked_move(const double* P0, const double* P1) const;
  void remember_checked_move(const double* P0, const double* P1, double share);
  void make_list(const double* at, const double* other);
  void find_near_pairs(const double* at, double reach);
  bool triangles_cross(const double* P, int f, int g) const;
  double barrier(double d) const;
  double barrier_slope(double d) const;

  Triangles triangles_;
  std::vector<int> edges_;           // 2 per edge
  std::vector<int> triangle_edges_;  // 3 per triangle
  std::vector<int> surface_vertices_;
  std::vector<int> first_triangle_of_vertex_;
  // Per triangle: bit k (k < 3) when it is its vertex k's first triangle, bit 3 + k its edge k's.
  std::vector<std::uint8_t> owns_;
  std::vector<Node> nodes_;
  std::vector<int> leaf_triangles_;
  double gap_ = 0, activation_ = 0, margin_ = 0, stiffness_ = 0;
  std::vector<std::uint64_t> excluded_vt_, excluded_ee_;  // sorted keys (vertex, triangle), (edge, edge)
  std::vector<std::uint64_t> rest_crossing_;              // triangle pairs that cross at rest, sorted

  // Scratch of evaluate(), kept between calls (no allocation once grown).
  std::vector<Box> vertex_box_;  // per vertex (swept, padded); only surface vertices are set
  std::vector<Box> triangle_box_;
  std::vector<Box> edge_box_;
  std::vector<Box> leaf_box_;    // triangle_box_ in the order of leaf_triangles_
  std::vector<std::pair<int, int>> stack_;
  // make_list()'s parts of the walk; per thread, what it found and a stack; per part, which
  // thread took it and where its pairs lie in that thread's (joined in the parts' order).
  std::vector<std::pair<int, int>> walk_parts_, walk_next_;
  struct Found {
    std::vector<NearPair> vt, ee;
    std::vector<std::pair<int, int>> stack;
  };
  std::vector<Found> thread_found_;
  struct PartRange {
    int thread;
    size_t vt_begin, vt_end, ee_begin, ee_end;
  };
  std::vector<PartRange> part_range_;
  int threads_ = 1;
  std::vector<ActivePair> active_;
  NearList near_vt_, near_ee_;  // the watched pairs within activation + margin
  std::vector<double> listed_at_;                 // 3 per vertex: where the list was made
  std::vector<double> moved_;                     // per vertex: how far from there, on the move checked
  double most_moved_ = 0;
  RelativeMotion relative_;     // the list's other criterion (relative_motion.h)
  bool relative_list_ = false;  // the move checked last is covered by it (moved_ is not set then)
  double list_margin_ = 0;
  bool list_made_ = false;
  long lists_made_ = 0;
  std::vector<double> piece_start_, piece_end_;  // 3 per vertex: the ends of one piece of a long step
  // The last move checked and the share of it found safe (on_checked_move()).
  std::vector<double> checked_start_, checked_end_;  // 3 per vertex
  double checked_share_ = 0;
};

}  // namespace arap::contact
