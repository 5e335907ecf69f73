// Solver::bind(): the mesh's structures, the factored Laplacian, the
// solver's state and the features' rooms, built aside so that only a
// successful bind replaces the previous one.
#include <new>
#include <string>

#include "runtime/memory_headroom.h"
#include "runtime/prefault.h"
#include "solver_impl.h"
#include "unit_scale.h"
#include "volume/infill.h"

namespace arap {

namespace {

// What a bind allocates per vertex (lattice nodes included), measured on
// spheres and bars of 100k-1M vertices (docs/robustness.md, "Memory"): the
// mesh's structures (weights, spokes, the Laplacian) at their peak, and the
// solver's state made after the factorization; the factorization's own bytes
// come from its column counts (spd_solve.h).
constexpr double kMeshBytesPerVertex = 600;
// Volume Infill's lattice and each vertex's binding to it, on top (a 200k sphere peaks 80 MB higher).
constexpr double kInfillBytesPerVertex = 400;
constexpr double kStateBytesPerVertex = 128;

// Refuses (arap::Error OutOfMemory) before a bind allocates what would not fit
// (runtime/memory_headroom.h): the previous binding is kept.
void require_bind_memory(Eigen::Index vertices, double bytes_per_vertex, const char* part, double more_bytes = 0) {
  require_headroom(static_cast<double>(vertices) * bytes_per_vertex + more_bytes,
                   "binding " + std::to_string(vertices) + " vertices (" + part + ")");
}

}  // namespace

void Solver::bind(const Eigen::Ref<const Points>& rest, const Eigen::Ref<const Triangles>& triangles,
                  const std::vector<int>& constrained, const Options& options, const std::vector<double>& stiffness) {
  check_options(options);
  check_bind_input(rest, triangles, constrained);  // before the infill lattice reads the triangles
  require_bind_memory(rest.rows(), kMeshBytesPerVertex + (options.volume == Volume::Infill ? kInfillBytesPerVertex : 0),
                      "the mesh's structures");
  // Built aside: only a successful bind replaces the previous state.
  auto make_binding = [&] {
    const auto start = Clock::now();
    auto next = std::make_unique<Impl>();
    next->options = options;
    next->bound_weights = options.weights;
    next->bound_volume = options.volume;
    next->bound_infill_resolution = options.infill_resolution;
    next->unit = unit_scale_of(rest);
    Points scaled(rest.rows(), 3);
    prefault(scaled.data(), sizeof(double) * scaled.size());
    scaled = rest / next->unit;
    InfillGraph infill;
    if (options.volume == Volume::Infill) {
      infill = build_infill(scaled, triangles, constrained, options.infill_resolution);
      require_bind_memory(rest.rows() + infill.nodes.rows(), kMeshBytesPerVertex, "the infill lattice");
    }
    next->mesh = build_bound_mesh(scaled, triangles, constrained, options.weights, stiffness,
                                  options.volume == Volume::Infill ? &infill : nullptr);
    next->bind_stats.mesh_ms = ms_since(start);
    next->triangles.resize(triangles.rows(), 3);
    prefault(next->triangles.data(), sizeof(int) * next->triangles.size());
    for (Eigen::Index f = 0; f < triangles.rows(); ++f)
      for (int k = 0; k < 3; ++k) next->triangles(f, k) = next->mesh.rank[triangles(f, k)];
    next->constrained_input = constrained;
    if (!next->laplacian.factor(next->mesh.laplacian_ff, BlockCholesky::Kernel::Supernodal, options.threads,
                                BlockCholesky::Ordering::Auto, [&](double factor_bytes) {
                                  require_bind_memory(next->mesh.n, kStateBytesPerVertex, "the factorization",
                                                      factor_bytes);
                                },
                                lattice_rows_to_order_last(next->mesh)))
      throw Error(ErrorCode::Factorization,
                  "the Laplacian could not be factored (not positive definite); with --weights cotan on a badly "
                  "triangulated mesh, try cotan-clamped");
    const int n = next->mesh.n;
    const size_t nf = next->mesh.free_vertices.size();
    next->state.resize(n, 3);
    next->positions.resize(rest.rows(), 3);
    for (Points* p : {&next->state, &next->positions}) prefault(p->data(), sizeof(double) * p->size());
    next->state = next->mesh.rest;
    next->positions = rest;
    assign_prefaulted(next->rotations, n, Eigen::Matrix3d::Identity());
    assign_prefaulted(next->cell_energy, n, 0.0);
    assign_prefaulted(next->eigenvalues, n, 0.0);
    assign_prefaulted(next->coupled, 3 * nf, 0.0);
    assign_prefaulted(next->rhs, 3 * nf, 0.0);
    assign_prefaulted(next->work, 3 * nf, 0.0);
    next->volume_term = make_volume_term(options.volume, next->mesh, next->triangles, infill);
    if (next->volume_term)
      next->pose_stop_scale = next->volume_term->pose_stop_per_tolerance() *
                              (scaled.colwise().maxCoeff() - scaled.colwise().minCoeff()).norm();
    next->bound_contact = options.contact;
    if (options.contact == Contact::Self) next->contact.bind(next->mesh, next->triangles);
    next->bound = true;
    next->bind_stats.ordering_ms = next->laplacian.ordering_ms();
    next->bind_stats.factor_ms = next->laplacian.factor_ms();
    next->bind_stats.total_ms = ms_since(start);
    return next;
  };
  try {
    impl_ = make_binding();
  } catch (const std::bad_alloc&) {
    throw Error(ErrorCode::OutOfMemory, "binding " + std::to_string(rest.rows()) +
                                            " vertices ran out of memory (the system refused an allocation); the "
                                            "previous binding is kept");
  }
}

}  // namespace arap
