// The solver's properties as specifications, over meshes of the kinds the
// solver is measured on (../shared/meshes: bars, cylinders, bumpy blobs,
// ellipsoids, a torus), made by arap::procedural and bent by procedural::bend:
// the energy never increases, the solve ends at a stationary point, and the
// gradient is the derivative of the energy.
#include <gtest/gtest.h>

#include <cmath>
#include <ostream>
#include <string>
#include <vector>

#include "surface_options.h"
#include "arap/solver.h"
#include "arap/tools/procedural.h"
#include "gradient_check.h"

namespace {

namespace procedural = arap::procedural;

struct Case {
  std::string name;
  procedural::TriMesh (*make)();
};

const Case kCases[] = {
    {"Bar", [] { return procedural::make_bar_with_vertices(600); }},
    {"Cylinder", [] { return procedural::make_cylinder(16, 24, 0.5, 4.0); }},
    {"BumpySphere", [] { return procedural::make_sphere(600, 1.0, 0.15); }},
    {"Ellipsoid", [] { return procedural::make_ellipsoid(600, Eigen::Vector3d(2.0, 0.6, 0.4)); }},
    {"Torus", [] { return procedural::make_torus(24, 12, 1.0, 0.3); }},
};

// Test names and failure messages name the mesh, not the bytes of the Case.
void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

class SolverProperties : public ::testing::TestWithParam<Case> {
 protected:
  void SetUp() override {
    mesh = GetParam().make();
    bend = procedural::bend(mesh.vertices);
    start = mesh.vertices;
    for (size_t k = 0; k < bend.constrained.size(); ++k) start.row(bend.constrained[k]) = bend.targets.row(k);
    free.assign(mesh.vertices.rows(), true);
    for (int v : bend.constrained) free[v] = false;
  }

  arap::Solver bound(arap::Method method, int iterations, double tolerance) const {
    arap::Options o = arap_test::surface_options();
    o.method = method;
    o.max_iterations = iterations;
    o.tolerance = tolerance;
    arap::Solver solver;
    solver.bind(mesh.vertices, mesh.triangles, bend.constrained, o);
    return solver;
  }

  // |dE/dp| over the free vertices.
  double free_gradient(const arap::Solver& solver, const arap::Points& p) const {
    const arap::Points g = solver.energy_gradient(p);
    double sum = 0;
    for (int v = 0; v < g.rows(); ++v)
      if (free[v]) sum += g.row(v).squaredNorm();
    return std::sqrt(sum);
  }

  procedural::TriMesh mesh;
  procedural::Bend bend;
  arap::Points start;  // the rest shape with the constrained vertices at their targets
  std::vector<bool> free;
};

TEST_P(SolverProperties, EnergyNeverIncreases) {
  for (auto method : {arap::Method::QuasiNewton, arap::Method::LocalGlobal, arap::Method::Anderson}) {
    arap::Solver solver = bound(method, 40, 0);
    const auto stats = solver.solve(bend.targets);
    ASSERT_FALSE(stats.energy.empty()) << arap::to_string(method);
    EXPECT_LE(stats.energy[0], stats.initial_energy * (1 + 1e-12)) << arap::to_string(method);
    // Only the quasi-Newton method refuses any rise; the plain step may rise by rounding at the minimum.
    const double slack = method == arap::Method::QuasiNewton ? 0.0 : 1e-10 * std::abs(stats.energy[0]);
    for (size_t k = 1; k < stats.energy.size(); ++k)
      EXPECT_LE(stats.energy[k], stats.energy[k - 1] + slack) << arap::to_string(method) << " iteration " << k;
  }
}

TEST_P(SolverProperties, EndsAtAStationaryPointThatMeetsTheConstraints) {
  arap::Solver solver = bound(arap::Method::QuasiNewton, 3000, 1e-12);
  const double initial = free_gradient(solver, start);
  ASSERT_GT(initial, 0);
  const auto stats = solver.solve(bend.targets);
  EXPECT_TRUE(stats.converged) << stats.iterations << " iterations";
  const arap::Points& p = solver.positions();
  EXPECT_TRUE(p.allFinite());
  EXPECT_LT(free_gradient(solver, p), 1e-4 * initial);
  for (size_t k = 0; k < bend.constrained.size(); ++k)
    EXPECT_LT((p.row(bend.constrained[k]) - bend.targets.row(k)).norm(), 1e-12);
}

TEST_P(SolverProperties, GradientIsTheDerivativeOfTheEnergy) {
  arap::Solver solver = bound(arap::Method::QuasiNewton, 5, 0);
  solver.solve(bend.targets);  // a pose away from the rest shape and from the minimum
  std::vector<int> vertices;  // four free vertices spread over the mesh
  for (int v = 0; v < mesh.vertices.rows() && vertices.size() < 4; v += static_cast<int>(mesh.vertices.rows()) / 7)
    if (free[v]) vertices.push_back(v);
  ASSERT_FALSE(vertices.empty());
  arap_test::expect_gradient_matches_finite_differences(solver, vertices);
}

INSTANTIATE_TEST_SUITE_P(ProceduralMeshes, SolverProperties, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& info) { return info.param.name; });

}  // namespace
