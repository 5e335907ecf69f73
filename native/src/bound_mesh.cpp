#include "bound_mesh.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "arap/errors.h"
#include "arap/weights.h"
#include "edge_groups.h"
#include "linalg/spd_solve.h"
#include "runtime/prefault.h"
#include "vertex_order.h"

namespace arap {

namespace {

bool all_finite(const Eigen::Ref<const Points>& p) {
  bool bad = false;
  for (Eigen::Index r = 0; r < p.rows(); ++r)
    for (int d = 0; d < 3; ++d) bad |= !(std::abs(p(r, d)) <= std::numeric_limits<double>::max());  // NaN too
  return !bad;
}

// Every index in [0, n).
bool all_below(const Eigen::Ref<const Triangles>& t, int n) {
  bool bad = false;
  for (Eigen::Index f = 0; f < t.rows(); ++f)
    for (int k = 0; k < 3; ++k) bad |= static_cast<unsigned>(t(f, k)) >= static_cast<unsigned>(n);  // negative too
  return !bad;
}

}  // namespace

void check_bind_input(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
                      const std::vector<int>& constrained) {
  const Eigen::Index n = rest.rows();
  if (n == 0) throw Error(ErrorCode::InvalidInput, "the mesh has no vertices");
  if (n > 100000000) throw Error(ErrorCode::InvalidInput, "more than 100 million vertices are not supported");
  if (triangles.rows() == 0) throw Error(ErrorCode::NoTriangles, "the mesh has no triangles");
  // Whole-array tests first (branch-free, vectorisable loops); the offender is looked for only when one fails.
  if (!all_finite(rest))
    for (Eigen::Index v = 0; v < n; ++v)
      if (!rest.row(v).allFinite())
        throw Error(ErrorCode::NonFinite,
                    "rest position of vertex " + std::to_string(v) + " is not finite (NaN or Inf)");
  if (!all_below(triangles, static_cast<int>(n)))
    for (Eigen::Index f = 0; f < triangles.rows(); ++f)
      for (int k = 0; k < 3; ++k) {
        const int v = triangles(f, k);
        if (v < 0 || v >= n)
          throw Error(ErrorCode::IndexOutOfRange, "triangle " + std::to_string(f) + " refers to vertex " +
                                                      std::to_string(v) + ", but the mesh has " + std::to_string(n) +
                                                      " vertices");
      }
  if (constrained.empty())
    throw Error(ErrorCode::NoConstraints, "no constrained vertices: give at least one fixed or handle vertex");
  std::vector<char> seen(n, 0);
  for (int v : constrained) {
    if (v < 0 || v >= n)
      throw Error(ErrorCode::IndexOutOfRange, "constrained vertex " + std::to_string(v) +
                                                  " is out of range (the mesh has " + std::to_string(n) + " vertices)");
    if (seen[v]) throw Error(ErrorCode::DuplicateConstraint, "vertex " + std::to_string(v) + " is constrained twice");
    seen[v] = 1;
  }
}

namespace {

void check_stiffness(const std::vector<double>& stiffness, Eigen::Index vertices) {
  if (!stiffness.empty() && stiffness.size() != static_cast<size_t>(vertices))
    throw Error(ErrorCode::InvalidInput, "expected one stiffness per vertex (" + std::to_string(vertices) + "), got " +
                                             std::to_string(stiffness.size()));
  for (size_t v = 0; v < stiffness.size(); ++v)
    if (!(stiffness[v] > 0) || !std::isfinite(stiffness[v]))
      throw Error(ErrorCode::InvalidInput,
                  "the stiffness of vertex " + std::to_string(v) + " must be a finite number > 0");
}

// The vertices' components over the edges: component[v] = -1 for a vertex in no edge.
struct Components {
  std::vector<int> of_vertex;
  int count = 0;
};

// Internal numbering for locality of the per-vertex loops (order, rank) and
// the rest positions and stiffness in that order. Its breadth-first passes
// also find the components over the edges (the non-degenerate triangles and
// the lattice).
Components number_vertices(BoundMesh& m, const EdgeGraph& graph, const Eigen::Ref<const Points>& rest,
                           const std::vector<double>& stiffness, const InfillGraph* infill) {
  Components components;
  m.order = locality_order(graph, components.of_vertex, components.count);
  m.rank.assign(m.n, 0);
  for (int k = 0; k < m.n; ++k) m.rank[m.order[k]] = k;
  m.rest.resize(m.n, 3);
  prefault(m.rest.data(), sizeof(double) * m.rest.size());
  for (int k = 0; k < m.n; ++k) {
    const int v = m.order[k];
    if (v < m.input_n)
      m.rest.row(k) = rest.row(v);
    else
      m.rest.row(k) = infill->nodes.row(v - m.input_n);
  }
  m.stiffness.assign(m.n, 1.0);  // lattice nodes: 1
  if (!stiffness.empty())
    for (int k = 0; k < m.n; ++k)
      if (m.order[k] < m.input_n) m.stiffness[k] = stiffness[m.order[k]];
  return components;
}

// The constrained slots (the user's, then the vertices kept at rest:
// components without a constraint and isolated vertices, counted by the
// mesh's own vertices) and the free rows. Returns each vertex's slot, -1 when free.
std::vector<int> split_free_and_constrained(BoundMesh& m, const std::vector<int>& constrained,
                                            const Components& components) {
  const std::vector<int>& component = components.of_vertex;
  std::vector<char> component_constrained(components.count, 0), component_counted(components.count, 0);
  for (int v : constrained)
    if (component[v] >= 0) component_constrained[component[v]] = 1;
  for (int v = 0; v < m.input_n; ++v) {
    const int c = component[v];
    if (c < 0 || component_counted[c]) continue;
    component_counted[c] = 1;
    ++m.report.components;
    m.report.unconstrained_components += !component_constrained[c];
  }
  m.user_constrained = static_cast<int>(constrained.size());
  std::vector<char> is_constrained(m.n, 0);  // internal index
  for (int v : constrained) {
    m.constrained.push_back(m.rank[v]);
    is_constrained[m.rank[v]] = 1;
  }
  for (int k = 0; k < m.n; ++k) {
    if (is_constrained[k]) continue;
    const int c = component[m.order[k]];
    const bool counted = m.order[k] < m.input_n;  // lattice nodes are not the mesh's vertices
    if (c < 0) {
      m.report.isolated_vertices += counted;
    } else if (component_constrained[c]) {
      continue;
    } else {
      m.report.unconstrained_vertices += counted;
    }
    is_constrained[k] = 1;
    m.constrained.push_back(k);
  }
  m.free_row.assign(m.n, -1);
  for (int v = 0; v < m.n; ++v)
    if (!is_constrained[v]) {
      m.free_row[v] = static_cast<int>(m.free_vertices.size());
      m.free_vertices.push_back(v);
    }
  std::vector<int> slot_of(m.n, -1);
  for (size_t s = 0; s < m.constrained.size(); ++s) slot_of[m.constrained[s]] = static_cast<int>(s);
  return slot_of;
}

// Spokes in CSR order: both directions of every edge with a nonzero weight,
// vertex by vertex in the graph's order of neighbours; with each vertex's rest
// spoke energy and G_i.
void build_spokes(BoundMesh& m, const EdgeGraph& graph) {
  std::vector<int> spoke_count(m.n, 0);  // input index: one pass in the graph's own order
  for (int v = 0; v < m.n; ++v)
    for (int q = graph.begin[v]; q < graph.begin[v + 1]; ++q) spoke_count[v] += graph.weight[q] != 0;
  m.spoke_begin.assign(m.n + 1, 0);
  for (int k = 0; k < m.n; ++k) m.spoke_begin[k + 1] = m.spoke_begin[k] + spoke_count[m.order[k]];
  resize_prefaulted(m.neighbor, m.spoke_begin[m.n]);
  m.spokes.resize(m.spoke_begin[m.n]);
  prefault_buffer(m.spokes);
  resize_prefaulted(m.rest_spoke_energy, m.n);
  resize_prefaulted(m.g_sum, 3 * static_cast<size_t>(m.n));
  for (int i = 0; i < m.n; ++i) {
    const int v = m.order[i];
    const Eigen::RowVector3d pi = m.rest.row(i);
    double energy = 0;
    Eigen::RowVector3d g_sum = Eigen::RowVector3d::Zero();
    int k = m.spoke_begin[i];
    for (int q = graph.begin[v]; q < graph.begin[v + 1]; ++q) {
      const double w = graph.weight[q];
      if (w == 0) continue;
      const int j = m.rank[graph.adjacent[q]];
      const Eigen::RowVector3d e = pi - m.rest.row(j);
      const Eigen::RowVector3d g = w * e;
      m.neighbor[k] = j;
      m.spokes[k++] = {g.x(), g.y(), g.z(), w};
      energy += w * e.squaredNorm();
      g_sum += g;
    }
    m.rest_spoke_energy[i] = energy;
    for (int d = 0; d < 3; ++d) m.g_sum[3 * i + d] = g_sum[d];
  }
}

// Free block of L (L_ii = sum_j w~_ij, L_ij = -w~_ij with w~_ij = w_ij (s_i + s_j) / 2,
// the stiffness-weighted edge), assembled column by column (it is symmetric),
// and its coupling to constrained vertices. `stiff`: a stiffness was given.
void assemble_free_laplacian(BoundMesh& m, const std::vector<int>& slot_of, bool stiff, const InfillGraph* infill) {
  const int nf = static_cast<int>(m.free_vertices.size());
  const double lattice_scale = infill ? infill->preconditioner_scale : 1.0;
  // Written straight into the matrix's storage, sized for at most one entry per spoke plus the diagonal.
  m.laplacian_ff.resize(nf, nf);
  const size_t capacity = m.spokes.size() + nf;
  m.laplacian_ff.resizeNonZeros(static_cast<Eigen::Index>(capacity));
  int* outer = m.laplacian_ff.outerIndexPtr();
  int* inner = m.laplacian_ff.innerIndexPtr();
  double* values = m.laplacian_ff.valuePtr();
  prefault(inner, sizeof(int) * capacity);
  prefault(values, sizeof(double) * capacity);
  // Without stiffness (all 1) the factor (s_i + s_j) / 2 is exactly 1, and
  // only a lattice has lattice edges: both are skipped when they cannot apply.
  int p = 0;
  outer[0] = 0;
  std::vector<std::pair<int, double>> scratch;
  for (int r = 0; r < nf; ++r) {
    const int i = m.free_vertices[r];
    double diagonal = 0;
    const int column_begin = p;
    const bool long_column = m.spoke_begin[i + 1] - m.spoke_begin[i] >= kInsertionColumn;
    auto put = [&](int row, double value) {
      if (long_column)
        inner[p] = row, values[p++] = value;
      else
        insert_sorted(inner, values, column_begin, p, row, value);
    };
    for (int k = m.spoke_begin[i]; k < m.spoke_begin[i + 1]; ++k) {
      const int j = m.neighbor[k];
      double w = stiff ? m.spokes[k].w * 0.5 * (m.stiffness[i] + m.stiffness[j]) : m.spokes[k].w;
      if (infill && m.order[i] >= m.input_n && m.order[j] >= m.input_n) w *= lattice_scale;
      diagonal += w;
      if (m.free_row[j] >= 0)
        put(m.free_row[j], -w);
      else
        m.couplings.push_back({r, slot_of[j], w});
    }
    put(r, diagonal);
    if (long_column) sort_column(inner, values, column_begin, p, scratch);
    outer[r + 1] = p;
  }
  m.laplacian_ff.resizeNonZeros(p);  // no reallocation: only the count shrinks
}

}  // namespace

BoundMesh build_bound_mesh(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
                           const std::vector<int>& constrained, Weights weights, const std::vector<double>& stiffness,
                           const InfillGraph* infill) {
  check_bind_input(rest, triangles, constrained);
  check_stiffness(stiffness, rest.rows());
  BoundMesh m;
  m.input_n = static_cast<int>(rest.rows());
  m.n = m.input_n + (infill ? static_cast<int>(infill->nodes.rows()) : 0);
  m.report.vertices = m.input_n;
  m.report.triangles = static_cast<int>(triangles.rows());

  const EdgeGroups groups = edge_groups(rest, triangles, weights);
  m.report.degenerate_triangles = groups.degenerate_triangles;
  m.report.nonmanifold_edges = groups.nonmanifold_edges;
  // Volume::Infill: the lattice nodes follow the mesh's vertices (input index #V + k), with their edges.
  if (infill) {
    m.report.infill_nodes = static_cast<int>(infill->nodes.rows());
    m.report.infill_cells = infill->cells;
  }
  const std::vector<WeightedEdge> no_lattice;
  const EdgeGraph graph = edge_graph(m.n, groups, infill ? infill->edges : no_lattice);
  const Components components = number_vertices(m, graph, rest, stiffness, infill);
  const std::vector<int> slot_of = split_free_and_constrained(m, constrained, components);
  build_spokes(m, graph);
  assemble_free_laplacian(m, slot_of, !stiffness.empty(), infill);
  return m;
}

// Minimum degree spends most of its time on the lattice nodes, each joined to
// the thousands of surface vertices of its cubes; ordered after the surface
// they cost nothing to order. But eliminating the surface first joins every
// node bound to it, and each surface column takes the nodes its subtree
// reaches (about nodes x sqrt(rows) entries in all): with many nodes the
// factor holds more than minimum degree's, and every iteration's solve pays
// for it. Hence at most kLastLatticeRows sqrt(the surface's free rows) nodes
// (the figures: docs/engine_internals.md).
constexpr double kLastLatticeRows = 0.5;

std::vector<int> lattice_rows_to_order_last(const BoundMesh& m) {
  std::vector<int> rows;
  for (size_t r = 0; r < m.free_vertices.size(); ++r)
    if (m.order[m.free_vertices[r]] >= m.input_n) rows.push_back(static_cast<int>(r));
  const double surface_rows = static_cast<double>(m.free_vertices.size() - rows.size());
  if (static_cast<double>(rows.size()) > kLastLatticeRows * std::sqrt(surface_rows)) rows.clear();
  return rows;
}

void to_internal(const BoundMesh& m, const Eigen::Ref<const Points>& input, Points& internal) {
  if (internal.rows() != m.n) internal = m.rest;  // lattice nodes at rest when there is nothing else
  for (int k = 0; k < m.n; ++k)
    if (m.order[k] < m.input_n) internal.row(k) = input.row(m.order[k]);
}

// Volume::Infill's lattice nodes (internal rows of input index >= input_n) moved with the surface given in
// `P`: each node's displacement from rest becomes the |w|-weighted mean of its neighbours' (Gauss-Seidel
// sweeps of the graph Laplacian, the mesh's vertices held), so a start from a posed surface does not pull
// against a lattice left at rest.
void lattice_follows_surface(const BoundMesh& m, Points& P) {
  if (m.n == m.input_n) return;
  constexpr int kSweeps = 60;
  for (int sweep = 0; sweep < kSweeps; ++sweep)
    for (int i = 0; i < m.n; ++i) {
      if (m.order[i] < m.input_n) continue;
      Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
      double total = 0;
      for (int k = m.spoke_begin[i]; k < m.spoke_begin[i + 1]; ++k) {
        const int j = m.neighbor[k];
        const double w = std::abs(m.spokes[k].w);
        sum += w * (P.row(j) - m.rest.row(j));
        total += w;
      }
      if (total > 0) P.row(i) = m.rest.row(i) + sum / total;
    }
}

void to_input(const BoundMesh& m, const Points& internal, Points& input) {
  input.resize(m.input_n, 3);
  for (int k = 0; k < m.n; ++k)
    if (m.order[k] < m.input_n) input.row(m.order[k]) = internal.row(k);
}

}  // namespace arap
