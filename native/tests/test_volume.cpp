// The volume modes (Options::volume): Global keeps the enclosed volume of
// every closed part exactly and leaves open parts alone; Infill keeps more
// volume and cross-section than the surface alone, on open and
// self-intersecting inputs too. Every figure is measured on the positions
// with arap::measure (independently of the solver), on meshes made here.
#include <gtest/gtest.h>

#include <limits>
#include <map>
#include <string>
#include <vector>

#include "arap/errors.h"
#include "arap/io/mesh_io.h"
#include "arap/io/shape_measures.h"
#include "arap/solver.h"
#include "arap/tools/procedural.h"
#include "cli_fixture.h"

namespace {

using arap::Options;
using arap::Points;
using arap::Triangles;
using arap::Volume;
using arap::procedural::TriMesh;

// A mesh, its constraints and the targets of "hold the bottom, move the top by `shift`".
struct Pose {
  TriMesh mesh;
  std::vector<int> constrained;
  Points targets;
};

Pose bend(TriMesh mesh, const Eigen::RowVector3d& shift) {
  const auto picked = arap::procedural::pick_by_height(mesh.vertices);
  Pose p{std::move(mesh), picked.fixed, {}};
  p.constrained.insert(p.constrained.end(), picked.handle.begin(), picked.handle.end());
  p.targets.resize(static_cast<Eigen::Index>(p.constrained.size()), 3);
  for (size_t k = 0; k < p.constrained.size(); ++k) {
    p.targets.row(k) = p.mesh.vertices.row(p.constrained[k]);
    if (k >= picked.fixed.size()) p.targets.row(k) += shift;
  }
  return p;
}

// The 1 x 1 x 5 bar pulled sideways and down: surface ARAP loses about 9% of its volume.
Pose bent_bar() { return bend(arap::procedural::make_bar_with_vertices(600), Eigen::RowVector3d(2, 0, -1)); }

Points solve(const Pose& p, Volume volume, arap::Method method = arap::Method::QuasiNewton,
             arap::SolveStats* stats = nullptr, arap::MeshReport* report = nullptr) {
  arap::Solver solver;
  Options o;
  o.volume = volume;
  o.method = method;
  solver.bind(p.mesh.vertices, p.mesh.triangles, p.constrained, o);
  const arap::SolveStats s = solver.solve(p.targets);
  EXPECT_TRUE(s.converged);
  if (stats) *stats = s;
  if (report) *report = solver.mesh_report();
  EXPECT_TRUE(solver.positions().allFinite());
  return solver.positions();
}

double volume_ratio(const Pose& p, const Points& posed) {
  return arap::measure::volume_kept(p.mesh.vertices, posed, p.mesh.triangles).ratio;
}

// `a` and `b` side by side (b moved by `offset`), as one mesh of two parts.
TriMesh side_by_side(const TriMesh& a, const TriMesh& b, const Eigen::RowVector3d& offset) {
  TriMesh m;
  m.vertices.resize(a.vertices.rows() + b.vertices.rows(), 3);
  m.vertices << a.vertices, b.vertices.rowwise() + offset;
  m.triangles.resize(a.triangles.rows() + b.triangles.rows(), 3);
  m.triangles << a.triangles, b.triangles.array() + static_cast<int>(a.vertices.rows());
  return m;
}

// A capped cylinder without its caps: an open tube (the two cap centres, its last vertices, dropped).
TriMesh open_tube() {
  const TriMesh c = arap::procedural::make_cylinder(12, 20, 0.5, 5.0);
  const int n = static_cast<int>(c.vertices.rows()) - 2;
  std::vector<Eigen::RowVector3i> kept;
  for (Eigen::Index f = 0; f < c.triangles.rows(); ++f)
    if (c.triangles.row(f).maxCoeff() < n) kept.push_back(c.triangles.row(f));
  TriMesh t{c.vertices.topRows(n), Triangles(static_cast<Eigen::Index>(kept.size()), 3)};
  for (size_t f = 0; f < kept.size(); ++f) t.triangles.row(static_cast<Eigen::Index>(f)) = kept[f];
  return t;
}

// ------------------------------------------------------------------ Global

TEST(VolumeGlobal, KeepsTheEnclosedVolumeOfABentBarExactly) {
  const Pose p = bent_bar();
  const double surface = volume_ratio(p, solve(p, Volume::None));
  EXPECT_LT(surface, 0.95);  // what there is to keep
  for (arap::Method method : {arap::Method::QuasiNewton, arap::Method::LocalGlobal}) {
    SCOPED_TRACE(arap::to_string(method));
    arap::SolveStats stats;
    arap::MeshReport report;
    const Points posed = solve(p, Volume::Global, method, &stats, &report);
    EXPECT_NEAR(volume_ratio(p, posed), 1.0, 1e-9);
    EXPECT_LT(stats.volume_drift, 1e-9);
    EXPECT_EQ(report.volume_kept_components, 1);
    EXPECT_EQ(report.volume_open_components, 0);
    // The handles are still where they were sent.
    for (size_t k = 0; k < p.constrained.size(); ++k)
      EXPECT_LT((posed.row(p.constrained[k]) - p.targets.row(k)).norm(), 1e-12) << k;
  }
}

TEST(VolumeGlobal, KeepsEachClosedPartAndLeavesOpenPartsAsTheSurfaceSolvesThem) {
  const TriMesh bar = arap::procedural::make_bar_with_vertices(400);
  const TriMesh two_bars = side_by_side(bar, bar, Eigen::RowVector3d(3, 0, 0));
  const Pose bars = bend(two_bars, Eigen::RowVector3d(2, 0, -1));
  arap::MeshReport report;
  const Points posed = solve(bars, Volume::Global, arap::Method::QuasiNewton, nullptr, &report);
  EXPECT_EQ(report.volume_kept_components, 2);
  // Each part's own volume, not only their sum.
  EXPECT_NEAR(arap::measure::volume_kept(bars.mesh.vertices, posed, bars.mesh.triangles).worst_ratio, 1.0, 1e-9);

  const Pose mixed = bend(side_by_side(bar, open_tube(), Eigen::RowVector3d(3, 0, 0)), Eigen::RowVector3d(2, 0, -1));
  const Points kept = solve(mixed, Volume::Global, arap::Method::QuasiNewton, nullptr, &report);
  EXPECT_EQ(report.volume_kept_components, 1);
  EXPECT_EQ(report.volume_open_components, 1);
  const arap::measure::VolumeKept v = arap::measure::volume_kept(mixed.mesh.vertices, kept, mixed.mesh.triangles);
  EXPECT_EQ(v.closed_components, 1);
  EXPECT_NEAR(v.ratio, 1.0, 1e-9);
  // The tube is posed as surface ARAP poses it (the parts do not interact).
  const Points surface = solve(mixed, Volume::None);
  const Eigen::Index n = bar.vertices.rows();
  const Eigen::Index m = mixed.mesh.vertices.rows() - n;
  EXPECT_LT((kept.bottomRows(m) - surface.bottomRows(m)).rowwise().norm().maxCoeff(), 1e-3);
  EXPECT_GT((kept.topRows(n) - surface.topRows(n)).rowwise().norm().maxCoeff(), 1e-2);
}

TEST(VolumeGlobal, AnOpenMeshIsSolvedAsTheSurface) {
  const Pose p = bend(open_tube(), Eigen::RowVector3d(1, 0, -0.5));
  arap::MeshReport report;
  const Points kept = solve(p, Volume::Global, arap::Method::QuasiNewton, nullptr, &report);
  EXPECT_EQ(report.volume_kept_components, 0);
  EXPECT_EQ(report.volume_open_components, 1);
  EXPECT_LT((kept - solve(p, Volume::None)).rowwise().norm().maxCoeff(), 1e-9);
}

// A bake: frame after frame from the last solution, to a tolerance of 0 (stop only when stuck).
TEST(VolumeGlobal, WarmStartsKeepTheVolumeFromTheRestShapeOn) {
  const Pose bar = bent_bar();
  const Pose cylinder = bend(arap::procedural::make_cylinder(16, 10, 0.5, 4.0), Eigen::RowVector3d(1.6, 0, -0.8));
  for (double tolerance : {0.0, 1e-8})
  for (const Pose* shape : {&bar, &cylinder}) {
    const Pose& p = *shape;
    SCOPED_TRACE(tolerance);
    arap::Solver solver;
    Options o;
    o.volume = Volume::Global;
    o.weights = arap::Weights::CotanClamped;
    o.tolerance = tolerance;
    o.max_iterations = 500;
    solver.bind(p.mesh.vertices, p.mesh.triangles, p.constrained, o);
    solver.options().init = arap::InitialGuess::WarmStart;
    Points targets(p.targets.rows(), 3);
    for (size_t k = 0; k < p.constrained.size(); ++k) targets.row(k) = p.mesh.vertices.row(p.constrained[k]);
    for (int frame = 0; frame <= 4; ++frame) {
      const Points frame_targets = targets + 0.25 * frame * (p.targets - targets);
      const arap::SolveStats stats = solver.solve(frame_targets);
      EXPECT_NEAR(volume_ratio(p, solver.positions()), 1.0, 1e-9) << frame;
      EXPECT_LT(stats.volume_drift, 1e-9) << frame;
    }
  }
}

TEST(VolumeModes, AreCheckedAtBind) {
  const Pose p = bent_bar();
  arap::Solver solver;
  Options o;
  o.volume = Volume::Global;
  o.method = arap::Method::Anderson;
  EXPECT_THROW(solver.bind(p.mesh.vertices, p.mesh.triangles, p.constrained, o), arap::Error);
  for (int resolution : {1, 257}) {
    o = Options();
    o.volume = Volume::Infill;
    o.infill_resolution = resolution;
    EXPECT_THROW(solver.bind(p.mesh.vertices, p.mesh.triangles, p.constrained, o), arap::Error) << resolution;
  }
  EXPECT_THROW(arap::parse_volume("tets"), arap::Error);
  for (Volume v : {Volume::None, Volume::Global, Volume::Infill}) EXPECT_EQ(arap::parse_volume(arap::to_string(v)), v);
}

// Found by fuzz_solve: the lattice read triangle indices before the bind had checked them.
TEST(VolumeModes, BadIndicesAndPositionsAreTypedErrorsBeforeTheLatticeIsBuilt) {
  const Pose p = bent_bar();
  for (Volume v : {Volume::Global, Volume::Infill}) {
    Options o;
    o.volume = v;
    arap::Triangles bad = p.mesh.triangles;
    bad(0, 1) = -1;
    bad(1, 2) = static_cast<int>(p.mesh.vertices.rows());
    arap::Solver solver;
    try {
      solver.bind(p.mesh.vertices, bad, p.constrained, o);
      ADD_FAILURE() << "bound a mesh with bad indices, volume " << arap::to_string(v);
    } catch (const arap::Error& e) {
      EXPECT_EQ(e.code(), arap::ErrorCode::IndexOutOfRange) << e.what();
    }
    arap::Points nan = p.mesh.vertices;
    nan(3, 1) = std::numeric_limits<double>::quiet_NaN();
    try {
      solver.bind(nan, p.mesh.triangles, p.constrained, o);
      ADD_FAILURE() << "bound a NaN vertex, volume " << arap::to_string(v);
    } catch (const arap::Error& e) {
      EXPECT_EQ(e.code(), arap::ErrorCode::NonFinite) << e.what();
    }
    EXPECT_FALSE(solver.is_bound());
  }
}

// Found by fuzz_solve: faces spanning a few denormals beside a far vertex no face uses made
// the lattice spacing 0 and its cube count an infinite int. Such a mesh carries no lattice.
TEST(VolumeInfill, FacesTooSmallForALatticeAreSolvedAsTheSurface) {
  const double tiny = 2 * std::numeric_limits<double>::denorm_min();  // the bind scales to the largest, 1
  Points rest(5, 3);
  rest << 0, 0, 0, tiny, 0, 0, 0, tiny, 0, 0, 0, tiny, 1, 0, 0;
  Triangles tetrahedron(4, 3);
  tetrahedron << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  Options o;
  o.volume = Volume::Infill;
  arap::Solver solver;
  solver.bind(rest, tetrahedron, {0, 4}, o);
  Points targets(2, 3);
  targets << 0, 0, 0, 2, 0, 0;
  solver.solve(targets);
  EXPECT_TRUE(solver.positions().allFinite());
  EXPECT_EQ(solver.positions().row(4), targets.row(1));
}

// ------------------------------------------------------------------ Infill

TEST(VolumeInfill, KeepsMoreVolumeAndCrossSectionThanTheSurface) {
  const Pose p = bent_bar();
  const Points surface = solve(p, Volume::None);
  arap::MeshReport report;
  const Points filled = solve(p, Volume::Infill, arap::Method::QuasiNewton, nullptr, &report);
  EXPECT_GT(report.infill_cells, 0);
  EXPECT_GT(report.infill_nodes, report.infill_cells);
  const double surface_volume = volume_ratio(p, surface), filled_volume = volume_ratio(p, filled);
  EXPECT_GT(filled_volume, surface_volume + 0.03) << surface_volume;
  EXPECT_GT(filled_volume, 0.93);
  const auto& t = p.mesh.triangles;
  EXPECT_GT(arap::measure::cross_sections(p.mesh.vertices, filled, t).min,
            arap::measure::cross_sections(p.mesh.vertices, surface, t).min + 0.05);
}

// Past 20 000 rows the bind's factor is split in two halves and a separator
// (linalg/spd_solve.h). The lattice's nodes, each joined to the surface
// vertices of its cells, make every breadth-first level wide, and such a
// separator makes the factor several times larger (6x here, 17x and a bind of
// a minute on a 100k-vertex bar). The factor stays near the surface's.
// After a small handle step, a warm start begins at the last pose with the handles' move carried
// through it, not where a global step on the last rotations throws the stiffened lattice (tens of
// times the energy).
TEST(VolumeInfill, AWarmStartBeginsNearTheLastPose) {
  const Pose p = bent_bar();
  arap::Solver solver;
  Options o;
  o.volume = Volume::Infill;
  solver.bind(p.mesh.vertices, p.mesh.triangles, p.constrained, o);
  const arap::SolveStats cold = solver.solve(p.targets);
  ASSERT_TRUE(cold.converged);
  Points further = p.targets;
  const std::size_t fixed = arap::procedural::pick_by_height(p.mesh.vertices).fixed.size();
  for (Eigen::Index k = static_cast<Eigen::Index>(fixed); k < further.rows(); ++k) further(k, 0) += 0.25;
  solver.options().init = arap::InitialGuess::WarmStart;
  const arap::SolveStats warm = solver.solve(further);
  EXPECT_TRUE(warm.converged);
  const double settled = warm.energy.back();
  EXPECT_LT(warm.initial_energy, 2 * settled)
      << "started at " << warm.initial_energy / settled << " x the settled energy";
  EXPECT_LT(warm.iterations, cold.iterations);
}

// `p` with every triangle cut into four at its edge midpoints: the same surface, finer. The original
// vertices keep their indices; a midpoint is constrained when both ends are, with the mean of their
// targets (the handles here translate, so that is their target too).
Pose split_at_midpoints(const Pose& p) {
  const Points& v = p.mesh.vertices;
  std::map<int, int> slot;  // vertex -> row in constrained / targets
  for (size_t k = 0; k < p.constrained.size(); ++k) slot[p.constrained[k]] = static_cast<int>(k);
  std::vector<Eigen::RowVector3d> points, targets;
  Pose out{{}, p.constrained, {}};
  for (Eigen::Index r = 0; r < v.rows(); ++r) points.push_back(v.row(r));
  for (Eigen::Index r = 0; r < p.targets.rows(); ++r) targets.push_back(p.targets.row(r));
  std::map<std::pair<int, int>, int> midpoint;
  auto middle = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    const auto found = midpoint.find(key);
    if (found != midpoint.end()) return found->second;
    const int m = static_cast<int>(points.size());
    points.push_back(0.5 * (v.row(a) + v.row(b)));
    if (slot.count(a) && slot.count(b)) {
      out.constrained.push_back(m);
      targets.push_back(0.5 * (p.targets.row(slot[a]) + p.targets.row(slot[b])));
    }
    return midpoint[key] = m;
  };
  std::vector<Eigen::RowVector3i> faces;
  for (Eigen::Index f = 0; f < p.mesh.triangles.rows(); ++f) {
    const int a = p.mesh.triangles(f, 0), b = p.mesh.triangles(f, 1), c = p.mesh.triangles(f, 2);
    const int ab = middle(a, b), bc = middle(b, c), ca = middle(c, a);
    faces.insert(faces.end(), {{a, ab, ca}, {ab, b, bc}, {ca, bc, c}, {ab, bc, ca}});
  }
  out.mesh.vertices.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (size_t r = 0; r < points.size(); ++r) out.mesh.vertices.row(static_cast<Eigen::Index>(r)) = points[r];
  out.mesh.triangles.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (size_t f = 0; f < faces.size(); ++f) out.mesh.triangles.row(static_cast<Eigen::Index>(f)) = faces[f];
  out.targets.resize(static_cast<Eigen::Index>(targets.size()), 3);
  for (size_t r = 0; r < targets.size(); ++r) out.targets.row(static_cast<Eigen::Index>(r)) = targets[r];
  return out;
}

// How far the original vertices of `p` move, as a fraction of its bounding box's diagonal, when the
// same surface is solved with its triangles split at their midpoints.
double moved_by_splitting(const Pose& p, Volume volume) {
  const Points coarse = solve(p, volume);
  const Points fine = solve(split_at_midpoints(p), volume).topRows(coarse.rows());
  const Points& rest = p.mesh.vertices;
  const double diagonal = (rest.colwise().maxCoeff() - rest.colwise().minCoeff()).norm();
  return (fine - coarse).rowwise().norm().maxCoeff() / diagonal;
}

// Infill poses the same surface the same way whatever its tessellation, with handles of many
// vertices or of one; the surface energy alone does not.
TEST(VolumeInfill, PosesTheSameSurfaceTheSameAtAFinerTessellation) {
  const Pose bar = bent_bar();
  EXPECT_LT(moved_by_splitting(bar, Volume::Infill), 0.005);
  EXPECT_GT(moved_by_splitting(bar, Volume::None), 0.02);
  // One vertex of the top pulled sideways, the bottom fixed.
  Pose pulled = bar;
  const auto picked = arap::procedural::pick_by_height(bar.mesh.vertices);
  pulled.constrained = picked.fixed;
  pulled.constrained.push_back(picked.handle.front());
  pulled.targets.resize(static_cast<Eigen::Index>(pulled.constrained.size()), 3);
  for (size_t k = 0; k < pulled.constrained.size(); ++k)
    pulled.targets.row(static_cast<Eigen::Index>(k)) = bar.mesh.vertices.row(pulled.constrained[k]);
  pulled.targets.bottomRows(1) += Eigen::RowVector3d(0.5, 0, 0);
  EXPECT_LT(moved_by_splitting(pulled, Volume::Infill), 0.005);
}

// A flat square sheet of n x n vertices in the xy plane, its two rows at y = 0 fixed and its two
// rows at y = 1 moved by `shift`.
Pose sheet(int n, const Eigen::RowVector3d& shift) {
  Pose p;
  p.mesh.vertices.resize(n * n, 3);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) p.mesh.vertices.row(j * n + i) << double(i) / (n - 1), double(j) / (n - 1), 0.0;
  p.mesh.triangles.resize(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int v = j * n + i;
      p.mesh.triangles.row(f++) << v, v + 1, v + n + 1;
      p.mesh.triangles.row(f++) << v, v + n + 1, v + n;
    }
  for (int i = 0; i < 2 * n; ++i) p.constrained.push_back(i);
  for (int i = 0; i < 2 * n; ++i) p.constrained.push_back((n - 2) * n + i);
  p.targets.resize(4 * n, 3);
  for (int k = 0; k < 4 * n; ++k)
    p.targets.row(k) = p.mesh.vertices.row(p.constrained[k]) + (k >= 2 * n ? shift : Eigen::RowVector3d::Zero());
  return p;
}

// An open sheet gets a lattice of the cubes its surface meets, joined where the surface crosses
// their faces: the same cubes at any tessellation, so the sheet bends the same.
TEST(VolumeInfill, BendsAnOpenSheetTheSameAtAFinerTessellation) {
  const Pose p = sheet(21, Eigen::RowVector3d(0, -0.5, -0.75));
  EXPECT_LT(moved_by_splitting(p, Volume::Infill), 0.01);
}

TEST(VolumeInfill, ALargeMeshBindsWithAFactorNearTheSurfaces) {
  const Pose p = bend(arap::procedural::make_bar_with_vertices(30000), Eigen::RowVector3d(2, 0, -1));
  long nonzeros[2] = {};
  int k = 0;
  for (Volume volume : {Volume::None, Volume::Infill}) {
    arap::Solver solver;
    Options o;
    o.volume = volume;
    o.max_iterations = 5;
    solver.bind(p.mesh.vertices, p.mesh.triangles, p.constrained, o);
    solver.solve(p.targets);
    EXPECT_TRUE(solver.positions().allFinite());
    nonzeros[k++] = solver.factor_nonzeros();
  }
  ASSERT_GT(nonzeros[0], 0);
  EXPECT_LT(nonzeros[1], 1.5 * nonzeros[0]) << nonzeros[0];
}

TEST(VolumeInfill, PosesOpenAndSelfIntersectingInputs) {
  const TriMesh bar = arap::procedural::make_bar_with_vertices(400);
  // Two bars through each other (the second one moved half a bar sideways), and an open tube.
  const TriMesh crossed = side_by_side(bar, bar, Eigen::RowVector3d(0.5, 0.5, 0));
  ASSERT_GT(arap::measure::self_intersecting_pairs(crossed.vertices, crossed.triangles), 0);
  for (const TriMesh& mesh : {crossed, open_tube()}) {
    const Pose p = bend(mesh, Eigen::RowVector3d(1, 0, -0.5));
    arap::MeshReport report;
    const Points posed = solve(p, Volume::Infill, arap::Method::QuasiNewton, nullptr, &report);
    EXPECT_GT(report.infill_cells, 0);
    EXPECT_GT((posed - p.mesh.vertices).rowwise().norm().maxCoeff(), 0.5);
  }
}

// A bar of bar1's proportions (shared scenario, 1:1:5) held at its bottom 4% and its top
// pulled three times bar1's scenario's pull (3 x (2.5, 0, -3) sides): folded back on itself,
// the surface alone crosses itself in hundreds of triangle pairs. The coupling of the surface
// to the lattice keeps most of the fold's inner side out of itself: at the energy's minimum
// about a fifth of the surface's crossings remain.
TEST(VolumeInfill, KeepsABarFoldedBackFromCrossingItself) {
  const TriMesh bar = arap::procedural::make_bar_with_vertices(722);
  const auto picked = arap::procedural::pick_by_height(bar.vertices, 2, 0.04, 0.04);
  Pose p{bar, picked.fixed, {}};
  p.constrained.insert(p.constrained.end(), picked.handle.begin(), picked.handle.end());
  p.targets.resize(static_cast<Eigen::Index>(p.constrained.size()), 3);
  for (size_t k = 0; k < p.constrained.size(); ++k) {
    p.targets.row(k) = bar.vertices.row(p.constrained[k]);
    if (k >= picked.fixed.size()) p.targets.row(k) += Eigen::RowVector3d(7.5, 0, -9);
  }
  const int surface = arap::measure::self_intersecting_pairs(solve(p, Volume::None), bar.triangles);
  const Points filled = solve(p, Volume::Infill);
  const int infill = arap::measure::self_intersecting_pairs(filled, bar.triangles);
  EXPECT_GT(surface, 200);
  EXPECT_LE(infill, 0.25 * surface) << infill << " against the surface's " << surface;
  EXPECT_GT(volume_ratio(p, filled), 0.9);
}

// ------------------------------------------------------------------ the measures themselves

TEST(ShapeMeasures, VolumeSectionsAndIntersectionsOfKnownShapes) {
  const TriMesh bar = arap::procedural::make_bar(2, 2, 6, 1.0, 2.0, 3.0);
  const auto all = arap::measure::components(static_cast<int>(bar.vertices.rows()), bar.triangles);
  ASSERT_EQ(all.size(), 1u);
  EXPECT_TRUE(all[0].closed);
  EXPECT_NEAR(arap::measure::signed_volume(bar.vertices, bar.triangles, all[0].triangles), 6.0, 1e-12);
  // Scaled by 2 about the origin: 8 times the volume, 4 times every cross-section's area.
  const Points doubled = 2 * bar.vertices;
  EXPECT_NEAR(arap::measure::volume_kept(bar.vertices, doubled, bar.triangles).ratio, 8.0, 1e-12);
  const arap::measure::CrossSections sections = arap::measure::cross_sections(bar.vertices, doubled, bar.triangles);
  EXPECT_GT(sections.loops, 0);
  for (double r : sections.ratios) EXPECT_NEAR(r, 4.0, 1e-9);
  EXPECT_EQ(arap::measure::self_intersecting_pairs(bar.vertices, bar.triangles), 0);
  const TriMesh open = open_tube();
  const auto tube = arap::measure::components(static_cast<int>(open.vertices.rows()), open.triangles);
  ASSERT_EQ(tube.size(), 1u);
  EXPECT_FALSE(tube[0].closed);
  EXPECT_EQ(arap::measure::volume_kept(open.vertices, open.vertices, open.triangles).open_components, 1);
}

// ------------------------------------------------------------------ the command line

#ifdef ARAP_DEFORM_EXE

using arap_test::Cli;

TEST_F(Cli, VolumeGlobalKeepsTheVolumeInTheWrittenFile) {
  const TriMesh bar = make_bar_files();
  const std::string setup = "bar.obj --fixed fixed.txt --handle handle.txt --translate 2,0,-1 -q ";
  for (const std::string mode : {"none", "global", "infill"}) {
    const arap_test::Result r =
        run(setup + "--volume " + mode + " --output " + mode + ".off --report " + mode + ".json");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << r.err;
    EXPECT_NE(slurp(path(mode + ".json")).find("\"volume\": \"" + mode + "\""), std::string::npos);
  }
  auto kept = [&](const std::string& mode) {
    const arap::io::PolygonMesh out = arap::io::read_mesh(path(mode + ".off"));
    return arap::measure::volume_kept(bar.vertices, out.vertices, bar.triangles).ratio;
  };
  EXPECT_NEAR(kept("global"), 1.0, 1e-5);  // the file holds floats
  EXPECT_LT(kept("none"), 0.97);
  EXPECT_GT(kept("infill"), kept("none"));
}

TEST_F(Cli, VolumeGlobalSaysWhichPartsItLeaves) {
  // The bar and an open sheet (two triangles) beside it.
  const TriMesh bar = make_bar_files();
  std::string obj = slurp(path("bar.obj"));
  const int n = static_cast<int>(bar.vertices.rows());
  obj += "v 3 0 0\nv 4 0 0\nv 4 0 1\nv 3 0 1\nf " + std::to_string(n + 1) + " " + std::to_string(n + 2) + " " +
         std::to_string(n + 3) + "\nf " + std::to_string(n + 1) + " " + std::to_string(n + 3) + " " +
         std::to_string(n + 4) + "\n";
  write("mixed.obj", obj);
  const arap_test::Result r = run("mixed.obj --fixed fixed.txt --handle handle.txt --translate 2,0,-1 -q "
                                  "--volume global --output m.off --report m.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("1 open part(s) are left as they are"), std::string::npos) << r.err;
  EXPECT_NE(slurp(path("m.json")).find("\"volume_open_components\": 1"), std::string::npos);
}

TEST_F(Cli, BadVolumeOptionsExitTwo) {
  make_bar_files();
  const std::string ok = "bar.obj --fixed fixed.txt --handle handle.txt --translate 1,0,0";
  expect_bad_input(ok + " --volume tets");
  expect_bad_input(ok + " --volume global --method anderson");
  expect_bad_input(ok + " --volume infill --infill-resolution 1");
  expect_bad_input(ok + " --volume infill --infill-resolution many");
  const arap_test::Result help = run("--help");
  for (const char* name : {"--volume", "global", "infill", "--infill-resolution"})
    EXPECT_NE(help.out.find(name), std::string::npos) << name;
}

#endif  // ARAP_DEFORM_EXE

}  // namespace
