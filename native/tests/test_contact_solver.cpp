// Self-contact in the solver (Options::contact == Contact::Self): poses that
// cross without it do not with it, constraints stay exact, poses that come
// nowhere near are those of the solve without it, pairs that cross at rest are
// left alone, and a handle pulled through the body stops short at contact.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <set>
#include <tuple>
#include <utility>

#include "surface_options.h"
#include "arap/errors.h"
#include "arap/io/shape_measures.h"
#include "arap/solver.h"
#include "arap/tools/procedural.h"
#include "contact/primitives.h"
#include "contact/self_contact.h"
#include "gradient_check.h"
#include "sanitizer_build.h"

namespace {

using arap::Contact;
using arap::Options;
using arap::Points;
using arap::Solver;
using arap::SolveStats;
using arap::Triangles;

struct Scene {
  Points rest;
  Triangles triangles;
  std::vector<int> constrained;  // fixed first, then the handle
  int fixed_count = 0;
  Points targets;
};

// Meshes and move counts are a third under the sanitizers (10-50x slower), keeping CI's time.
int sized(int n) { return arap_test::kSanitizerBuild ? std::max(150, n / 3) : n; }
// A forced push on a coarse bar takes far longer than on a finer one: that scene keeps its size.
constexpr bool kKeepSize = true;

// A 1 x 1 x 5 bar standing on z = 0, its lowest fifth fixed and its top 5%
// moved by `shift` (in bar lengths): a large sideways and downward move folds
// the bar into itself. About `vertices` vertices (a third under the sanitizers).
Scene bent_bar(const Eigen::Vector3d& shift, int vertices = 600, bool keep_size = false) {
  Scene s;
  const arap::procedural::TriMesh bar =
      arap::procedural::make_bar_with_vertices(keep_size ? vertices : sized(vertices), 5.0);
  s.rest = bar.vertices;
  s.triangles = bar.triangles;
  const auto picked = arap::procedural::pick_by_height(s.rest, 2, 0.2, 0.05);
  s.constrained = picked.fixed;
  s.fixed_count = static_cast<int>(picked.fixed.size());
  s.constrained.insert(s.constrained.end(), picked.handle.begin(), picked.handle.end());
  s.targets.resize(static_cast<Eigen::Index>(s.constrained.size()), 3);
  for (size_t k = 0; k < s.constrained.size(); ++k) {
    s.targets.row(k) = s.rest.row(s.constrained[k]);
    if (static_cast<int>(k) >= s.fixed_count) s.targets.row(k) += 5.0 * shift.transpose();
  }
  return s;
}

Options with_contact(Contact contact) {
  Options o = arap_test::surface_options();
  o.contact = contact;
  return o;
}

struct Result {
  Points positions;
  SolveStats stats;
};

Result solve(const Scene& s, const Options& options) {
  Solver solver;
  solver.bind(s.rest, s.triangles, s.constrained, options);
  Result r;
  r.stats = solver.solve(s.targets);
  r.positions = solver.positions();
  return r;
}

std::set<std::pair<int, int>> crossing_pairs(const Points& P, const Triangles& T) {
  std::vector<std::pair<int, int>> list;
  arap::measure::self_intersecting_pairs(P, T, &list);
  std::set<std::pair<int, int>> pairs;
  for (auto [a, b] : list) pairs.insert({std::min(a, b), std::max(a, b)});
  return pairs;
}

double largest_constraint_error(const Scene& s, const Points& P) {
  double worst = 0;
  for (size_t k = 0; k < s.constrained.size(); ++k)
    worst = std::max(worst, (P.row(s.constrained[k]) - s.targets.row(k)).norm());
  return worst;
}

// The distance between triangles f and g of P (0 when they cross).
double triangle_distance(const Points& P, const Triangles& T, int f, int g) {
  using arap::contact::Vec3;
  auto at = [&](int v) -> Vec3 { return P.row(v).transpose(); };
  double w[4], d2 = std::numeric_limits<double>::infinity();
  for (int pass = 0; pass < 2; ++pass) {
    const int a = pass == 0 ? f : g, b = pass == 0 ? g : f;
    for (int i = 0; i < 3; ++i) {
      d2 = std::min(d2, arap::contact::point_triangle_distance2(at(T(a, i)), at(T(b, 0)), at(T(b, 1)), at(T(b, 2)), w));
      if (arap::contact::segment_crosses_triangle(at(T(a, i)), at(T(a, (i + 1) % 3)), at(T(b, 0)), at(T(b, 1)),
                                                  at(T(b, 2))))
        return 0;
    }
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      d2 = std::min(d2, arap::contact::edge_edge_distance2(at(T(f, i)), at(T(f, (i + 1) % 3)), at(T(g, j)),
                                                          at(T(g, (j + 1) % 3)), w));
  return std::sqrt(d2);
}

double mean_edge_length(const Points& P, const Triangles& T) {
  double sum = 0;
  for (Eigen::Index f = 0; f < T.rows(); ++f)
    for (int k = 0; k < 3; ++k) sum += (P.row(T(f, k)) - P.row(T(f, (k + 1) % 3))).norm();
  return sum / (3.0 * T.rows());
}

// The bar's top turned half a turn about the bar's own axis, the base held:
// the handle's vertices cannot go there in straight lines (those meet at the
// axis), but turning, they can. (Two ways round are equally short; either will do.)
Scene half_turned_bar(int vertices) {
  Scene s = bent_bar(Eigen::Vector3d::Zero(), vertices);
  Eigen::RowVector3d axis_point = Eigen::RowVector3d::Zero();
  for (size_t k = s.fixed_count; k < s.constrained.size(); ++k) axis_point += s.rest.row(s.constrained[k]);
  axis_point /= static_cast<double>(s.constrained.size() - s.fixed_count);
  const Eigen::Matrix3d half_turn = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (size_t k = s.fixed_count; k < s.constrained.size(); ++k) {
    Eigen::RowVector3d offset = s.rest.row(s.constrained[k]) - axis_point;
    offset(2) = 0;
    s.targets.row(k) = s.rest.row(s.constrained[k]) - offset + (half_turn * offset.transpose()).transpose();
  }
  return s;
}

// Folded into itself: the top pulled sideways and down past the fixed base.
const Eigen::Vector3d kFold(0.5, 0.0, -0.6);

TEST(ContactSolver, AHandleTurnedHalfATurnGetsThere) {
  const Scene s = half_turned_bar(600);
  for (bool warm : {false, true}) {
    Options o = with_contact(Contact::Self);
    Solver solver;
    solver.bind(s.rest, s.triangles, s.constrained, o);
    if (warm) {
      // Live: from the rest pose on screen, the whole turn in one update.
      solver.options().init = arap::InitialGuess::WarmStart;
      solver.set_positions(s.rest);
    }
    const SolveStats stats = solver.solve(s.targets);
    EXPECT_EQ(stats.contact_reached, 1.0) << (warm ? "warm" : "cold");
    EXPECT_LT(largest_constraint_error(s, solver.positions()), 1e-9) << (warm ? "warm" : "cold");
    EXPECT_EQ(crossing_pairs(solver.positions(), s.triangles).size(), 0u) << (warm ? "warm" : "cold");
  }
}

TEST(ContactSolver, ABarFoldedIntoItselfCrossesWithoutContactAndNotWithIt) {
  const Scene s = bent_bar(kFold);
  const Result plain = solve(s, with_contact(Contact::None));
  ASSERT_GT(crossing_pairs(plain.positions, s.triangles).size(), 0u) << "the scene must cross without contact";
  const Result r = solve(s, with_contact(Contact::Self));
  ASSERT_TRUE(r.positions.allFinite());
  EXPECT_EQ(crossing_pairs(r.positions, s.triangles).size(), 0u);
  EXPECT_DOUBLE_EQ(r.stats.contact_reached, 1.0);
  EXPECT_EQ(r.stats.contact_stopped_vertex, -1);
  EXPECT_LE(largest_constraint_error(s, r.positions), 1e-12 * 5.0);
  EXPECT_GT(r.stats.contact_pairs, 0) << "the pose should rest against itself somewhere";
  // The solve without the barrier came first (it crosses: the solve with contact started again from the
  // usual first guess); the energy never rises within either part.
  const size_t free_part = static_cast<size_t>(r.stats.contact_free_iterations);
  EXPECT_EQ(free_part, static_cast<size_t>(plain.stats.iterations));
  ASSERT_LT(free_part, r.stats.energy.size());
  for (size_t k = 1; k < r.stats.energy.size(); ++k) {
    if (k == free_part) continue;  // where the barrier comes in
    EXPECT_LE(r.stats.energy[k], r.stats.energy[k - 1]) << "iteration " << k;
  }
}

// The same fold in any unit (docs/robustness.md, "any unit"): the solver works in
// a power of two near the largest coordinate, so scales other than powers of two
// see the same bar times a factor in [1/2, 2) and rounded differently. This fold
// leaves sides of the bar creased against each other, corners in each other's
// plane to rounding, where the first guess is checked for crossings.
TEST(ContactSolver, ABarFoldedIntoItselfFoldsTheSameInAnyUnit) {
  const Scene s = bent_bar(kFold * 0.8, 200);
  const Result unit = solve(s, with_contact(Contact::Self));
  ASSERT_EQ(crossing_pairs(unit.positions, s.triangles).size(), 0u);
  EXPECT_GT(unit.stats.contact_pairs, 0) << "the pose should rest against itself somewhere";
  for (double scale : {1e-6, 1e6, 1e30, 1e-30}) {
    Scene scaled = s;
    scaled.rest *= scale;
    scaled.targets *= scale;
    const Result r = solve(scaled, with_contact(Contact::Self));
    ASSERT_TRUE(r.positions.allFinite()) << "scale " << scale;
    EXPECT_EQ(r.stats.contact_rounds, unit.stats.contact_rounds) << "scale " << scale;
    // Within 1e-9 of the bar's length (5) once scaled back.
    EXPECT_LT((r.positions / scale - unit.positions).rowwise().norm().maxCoeff(), 1e-9 * 5.0) << "scale " << scale;
  }
}

TEST(ContactSolver, LocalGlobalAndVolumeModesKeepTheGuaranteeToo) {
  const Scene s = bent_bar(kFold);
  for (arap::Volume volume : {arap::Volume::None, arap::Volume::Global, arap::Volume::Infill}) {
    Options o = with_contact(Contact::Self);
    o.method = arap::Method::LocalGlobal;
    o.volume = volume;
    o.infill_resolution = 6;
    const Result r = solve(s, o);
    ASSERT_TRUE(r.positions.allFinite()) << to_string(volume);
    EXPECT_EQ(crossing_pairs(r.positions, s.triangles).size(), 0u) << to_string(volume);
    EXPECT_LE(largest_constraint_error(s, r.positions), 1e-12 * 5.0) << to_string(volume);
  }
}

TEST(ContactSolver, WhereNothingComesNearThePoseIsTheSolveWithoutContact) {
  const Scene s = bent_bar(Eigen::Vector3d(0.15, 0.0, 0.0));
  const Result plain = solve(s, with_contact(Contact::None));
  const Result r = solve(s, with_contact(Contact::Self));
  EXPECT_EQ(r.stats.contact_pairs, 0);
  EXPECT_EQ(r.positions, plain.positions);  // the solve without contact, kept as it is
  EXPECT_EQ(r.stats.iterations, plain.stats.iterations);
  EXPECT_EQ(r.stats.contact_free_iterations, plain.stats.iterations);
}

// The iteration cap ends the part without contact as it ends any solve; the solve with contact that
// follows has the cap again, and what it returns crosses nothing.
TEST(ContactSolver, EachPartOfAColdSolveHasTheIterationCap) {
  const Scene s = bent_bar(kFold);
  Options o = with_contact(Contact::Self);
  o.max_iterations = 12;
  const Result r = solve(s, o);
  ASSERT_TRUE(r.positions.allFinite());
  EXPECT_EQ(r.stats.contact_free_iterations, 12);
  EXPECT_GT(r.stats.iterations, 12) << "the solve with contact should have iterated too";
  EXPECT_LE(r.stats.iterations, 24);
  EXPECT_FALSE(r.stats.converged);
  EXPECT_EQ(crossing_pairs(r.positions, s.triangles).size(), 0u);
  EXPECT_LE(largest_constraint_error(s, r.positions), 1e-12 * 5.0);
}

// A cold solve first runs without the barrier, so its iterates may cross; chunks of it (a time budget, as
// Auto mode's worker solves) return no such pose, and resumed to the end they give the unchunked result.
TEST(ContactSolver, AColdSolveInTimedChunksShowsNoCrossingAndEndsAsInOne) {
  const Scene s = bent_bar(kFold * 0.6);
  const Result whole = solve(s, with_contact(Contact::Self));
  Options o = with_contact(Contact::Self);
  o.init = arap::InitialGuess::WarmStart;  // the first chunk starts cold (no solution yet), the others resume
  o.time_budget_ms = 0.2;
  Solver solver;
  solver.bind(s.rest, s.triangles, s.constrained, o);
  int chunks = 0;
  for (bool converged = false; !converged && chunks < 100000; ++chunks) {
    converged = solver.solve(s.targets).converged;
    ASSERT_EQ(crossing_pairs(solver.positions(), s.triangles).size(), 0u) << "chunk " << chunks;
  }
  EXPECT_GT(chunks, 1) << "the budget should split the solve";
  EXPECT_EQ(solver.positions(), whole.positions);
}

// The bar of bent_bar() held as it stands, and a block (every vertex held) brought from afar to half the
// barrier's reach from its side: the solve without contact crosses nothing but leaves pairs in reach.
Scene bar_beside_a_block() {
  Scene s = bent_bar(Eigen::Vector3d::Zero());
  const Eigen::Index n = s.rest.rows();
  const arap::procedural::TriMesh block = arap::procedural::make_bar(2, 4, 4, 0.5, 2.0, 1.0);
  Points rest(n + block.vertices.rows(), 3);
  rest.topRows(n) = s.rest;
  rest.bottomRows(block.vertices.rows()) = block.vertices.rowwise() + Eigen::RowVector3d(4.0, -0.5, 2.0);
  Triangles triangles(s.triangles.rows() + block.triangles.rows(), 3);
  triangles.topRows(s.triangles.rows()) = s.triangles;
  triangles.bottomRows(block.triangles.rows()) = block.triangles.array() + static_cast<int>(n);
  const double reach = arap::contact::kActivationShare * mean_edge_length(rest, triangles);
  const double side = s.rest.col(0).maxCoeff();  // the bar's +x side
  std::vector<int> constrained(s.constrained.begin(), s.constrained.begin() + s.fixed_count);
  for (Eigen::Index v = n; v < rest.rows(); ++v) constrained.push_back(static_cast<int>(v));
  const int fixed_count = static_cast<int>(constrained.size());
  constrained.insert(constrained.end(), s.constrained.begin() + s.fixed_count, s.constrained.end());
  Points targets(static_cast<Eigen::Index>(constrained.size()), 3);
  for (size_t k = 0; k < constrained.size(); ++k) targets.row(k) = rest.row(constrained[k]);
  for (Eigen::Index v = n; v < rest.rows(); ++v)  // the block's targets: its -x side half the reach from the bar's
    targets(s.fixed_count + (v - n), 0) += side + 0.5 * reach - 4.0;
  return {rest, triangles, constrained, fixed_count, targets};
}

// Where the solve without contact crosses nothing but brings surfaces within the barrier's reach, the solve
// with contact goes on from it: no crossing, the constraints met, a pose close to it.
TEST(ContactSolver, ASolveWithoutContactThatComesNearGoesOnWithTheBarrier) {
  const Scene s = bar_beside_a_block();
  const Result plain = solve(s, with_contact(Contact::None));
  ASSERT_EQ(crossing_pairs(plain.positions, s.triangles).size(), 0u) << "the scene must not cross without contact";
  const Result r = solve(s, with_contact(Contact::Self));
  ASSERT_TRUE(r.positions.allFinite());
  EXPECT_EQ(r.stats.contact_free_iterations, plain.stats.iterations);
  EXPECT_GT(r.stats.iterations, r.stats.contact_free_iterations) << "the barrier should have had work to do";
  EXPECT_EQ(r.stats.contact_rounds, 0);
  EXPECT_EQ(crossing_pairs(r.positions, s.triangles).size(), 0u);
  EXPECT_LE(largest_constraint_error(s, r.positions), 1e-12 * 5.0);
  EXPECT_GT(r.stats.contact_pairs, 0);
  const double moved = (r.positions - plain.positions).rowwise().norm().maxCoeff();
  EXPECT_GT(moved, 0.0) << "the barrier should push the bar's side away from the block";
  EXPECT_LT(moved, arap::contact::kActivationShare * mean_edge_length(s.rest, s.triangles));
}

// Pairs nearer than the activation distance at rest (those that cross among
// them) are not watched; every pair farther apart than that never crosses.
TEST(ContactSolver, PairsThatCrossAtRestAreLeftAloneAndNoPairApartAtRestCrosses) {
  // A second bar through the first, held at both ends; the first is folded.
  Scene s = bent_bar(kFold, 400);
  const Points upright = s.rest;
  const Eigen::Index n = upright.rows();
  Points rest(2 * n, 3);
  rest.topRows(n) = upright;
  for (Eigen::Index v = 0; v < n; ++v)  // turned to lie along x, through the upright one at half height
    rest.row(n + v) << upright(v, 2) - 2.0, upright(v, 1), 3.0 - upright(v, 0);
  Triangles triangles(2 * s.triangles.rows(), 3);
  triangles.topRows(s.triangles.rows()) = s.triangles;
  triangles.bottomRows(s.triangles.rows()) = s.triangles.array() + static_cast<int>(n);
  std::vector<int> constrained(s.constrained.begin(), s.constrained.begin() + s.fixed_count);
  for (Eigen::Index v = 0; v < n; ++v)
    if (upright(v, 2) <= 0.25 || upright(v, 2) >= 4.75) constrained.push_back(static_cast<int>(n + v));
  const std::size_t extra_fixed = constrained.size() - s.fixed_count;
  constrained.insert(constrained.end(), s.constrained.begin() + s.fixed_count, s.constrained.end());
  Points targets(static_cast<Eigen::Index>(constrained.size()), 3);
  for (size_t k = 0; k < constrained.size(); ++k) targets.row(k) = rest.row(constrained[k]);
  for (Eigen::Index k = s.fixed_count; k < s.targets.rows(); ++k)
    targets.row(s.fixed_count + extra_fixed + (k - s.fixed_count)) = s.targets.row(k);
  const auto at_rest = crossing_pairs(rest, triangles);
  ASSERT_GT(at_rest.size(), 0u) << "the two bars must cross at rest";

  Solver solver;
  solver.bind(rest, triangles, constrained, with_contact(Contact::Self));
  solver.solve(targets);
  ASSERT_TRUE(solver.positions().allFinite());
  const double apart = arap::contact::kActivationShare * mean_edge_length(rest, triangles);
  const int first_bar = static_cast<int>(s.triangles.rows());
  auto within_first_bar = [&](const std::set<std::pair<int, int>>& pairs) {
    return std::count_if(pairs.begin(), pairs.end(), [&](const auto& p) { return p.second < first_bar; });
  };
  const auto posed = crossing_pairs(solver.positions(), triangles);
  for (const auto& pair : posed) {
    if (at_rest.count(pair)) continue;
    EXPECT_LT(triangle_distance(rest, triangles, pair.first, pair.second), apart)
        << "triangles " << pair.first << " and " << pair.second << " were apart at rest and crossed";
  }
  // Without contact the folded bar crosses itself, far from the other bar; with it, not.
  Solver plain;
  plain.bind(rest, triangles, constrained, with_contact(Contact::None));
  plain.solve(targets);
  EXPECT_GT(within_first_bar(crossing_pairs(plain.positions(), triangles)), 0);
  EXPECT_EQ(within_first_bar(posed), 0);
}

TEST(ContactSolver, AHandlePulledThroughTheBodyStopsShortAtContactAndSaysWhich) {
  // The top pulled straight down through the bar to below its base.
  const Scene s = bent_bar(Eigen::Vector3d(0.0, 0.0, -1.2), 400, kKeepSize);
  const Result r = solve(s, with_contact(Contact::Self));
  ASSERT_TRUE(r.positions.allFinite());
  EXPECT_EQ(crossing_pairs(r.positions, s.triangles).size(), 0u);
  EXPECT_LT(r.stats.contact_reached, 1.0);
  EXPECT_GT(r.stats.contact_reached, 0.0);
  const std::vector<int> handle(s.constrained.begin() + s.fixed_count, s.constrained.end());
  EXPECT_NE(std::find(handle.begin(), handle.end(), r.stats.contact_stopped_vertex), handle.end())
      << "stopped vertex " << r.stats.contact_stopped_vertex << " is not a handle vertex";
  // The fixed vertices stay exactly where they are.
  for (int k = 0; k < s.fixed_count; ++k) EXPECT_EQ(r.positions.row(s.constrained[k]), s.targets.row(k));
}

TEST(ContactSolver, TheBarrierIsPartOfTheEnergyAndItsGradient) {
  const Scene s = bent_bar(kFold, 400);
  Solver solver;
  solver.bind(s.rest, s.triangles, s.constrained, with_contact(Contact::Self));
  const SolveStats stats = solver.solve(s.targets);
  ASSERT_GT(stats.contact_pairs, 0);
  Solver plain;
  plain.bind(s.rest, s.triangles, s.constrained, with_contact(Contact::None));
  EXPECT_GT(solver.energy(solver.positions()), plain.energy(solver.positions()));
  // The free vertices that a barrier pushes on: where the two gradients differ.
  const Points with = solver.energy_gradient(solver.positions());
  const Points without = plain.energy_gradient(solver.positions());
  std::vector<int> touched;
  for (Eigen::Index v = 0; v < with.rows() && touched.size() < 12; ++v)
    if ((with.row(v) - without.row(v)).norm() > 1e-6 * (1 + with.row(v).norm())) touched.push_back(static_cast<int>(v));
  ASSERT_FALSE(touched.empty());
  arap_test::expect_gradient_matches_finite_differences(solver, touched);
}

TEST(ContactSolver, SolvesInShortChunksNeverShowACrossing) {
  const Scene s = bent_bar(kFold, 400);
  Options o = with_contact(Contact::Self);
  o.max_iterations = 3;
  o.init = arap::InitialGuess::WarmStart;
  Solver solver;
  solver.bind(s.rest, s.triangles, s.constrained, o);
  for (int chunk = 0; chunk < 40; ++chunk) {
    // The handle moves there over the first ten chunks, as in a drag.
    Points targets = s.targets;
    const double share = std::min(1.0, (chunk + 1) / 10.0);
    for (Eigen::Index k = s.fixed_count; k < targets.rows(); ++k)
      targets.row(k) = s.rest.row(s.constrained[k]) + share * (s.targets.row(k) - s.rest.row(s.constrained[k]));
    solver.solve(targets);
    ASSERT_TRUE(solver.positions().allFinite());
    ASSERT_EQ(crossing_pairs(solver.positions(), s.triangles).size(), 0u) << "chunk " << chunk;
  }
}

// A drag in a viewport with a frame budget: a trial step whose collision check
// runs past the budget is cut to the share already checked, so no update waits
// for the whole of a long check; no update shows a crossing, and held still the
// pose settles at the targets.
TEST(ContactSolver, ADragWithAFrameBudgetCutsLongChecksAndStillSettles) {
  const Scene s = bent_bar(kFold, 600);
  Options o = with_contact(Contact::Self);
  o.init = arap::InitialGuess::WarmStart;
  o.time_budget_ms = 0.5;
  Solver solver;
  solver.bind(s.rest, s.triangles, s.constrained, o);
  Points at_rest = s.targets;
  for (Eigen::Index k = 0; k < at_rest.rows(); ++k) at_rest.row(k) = s.rest.row(s.constrained[k]);
  for (bool done = false; !done;) done = solver.solve(at_rest).converged;  // the rest pose, solved first
  long stopped = 0;
  const int drag = 8;
  for (int update = 1; update <= drag; ++update) {
    Points targets = s.targets;
    for (Eigen::Index k = s.fixed_count; k < targets.rows(); ++k)
      targets.row(k) = s.rest.row(s.constrained[k]) +
                       (static_cast<double>(update) / drag) * (s.targets.row(k) - s.rest.row(s.constrained[k]));
    const SolveStats stats = solver.solve(targets);
    stopped += stats.contact_checks_stopped;
    ASSERT_EQ(crossing_pairs(solver.positions(), s.triangles).size(), 0u) << "update " << update;
  }
  EXPECT_GT(stopped, 0) << "no check ran past the budget: the test checks nothing";
  SolveStats stats;
  int held = 0;
  for (; held < 20000 && !stats.converged; ++held) {
    stats = solver.solve(s.targets);
    stopped += stats.contact_checks_stopped;
    ASSERT_EQ(crossing_pairs(solver.positions(), s.triangles).size(), 0u) << "held " << held;
  }
  ASSERT_TRUE(stats.converged) << "not settled after " << held << " updates held still";
  EXPECT_EQ(stats.contact_reached, 1.0);
  EXPECT_LE(largest_constraint_error(s, solver.positions()), 1e-9 * 5.0);
}

TEST(ContactSolver, OneAndTwoThreadsGiveTheSameBits) {
  const Scene s = bent_bar(kFold, 400);
  Options one = with_contact(Contact::Self), two = one;
  two.threads = 2;
  EXPECT_EQ(solve(s, one).positions, solve(s, two).positions);
}

TEST(ContactSolver, AndersonIsRefusedWithAMessage) {
  const Scene s = bent_bar(kFold, 200);
  Options o = with_contact(Contact::Self);
  o.method = arap::Method::Anderson;
  Solver solver;
  try {
    solver.bind(s.rest, s.triangles, s.constrained, o);
    FAIL() << "anderson with contact self was accepted";
  } catch (const arap::Error& e) {
    EXPECT_EQ(e.code(), arap::ErrorCode::InvalidInput);
    EXPECT_NE(std::string(e.what()).find("anderson"), std::string::npos) << e.what();
  }
}

TEST(ContactSolver, ChangingTheContactModeNeedsABind) {
  const Scene s = bent_bar(kFold, 200);
  Solver solver;
  solver.bind(s.rest, s.triangles, s.constrained, with_contact(Contact::None));
  solver.options().contact = Contact::Self;
  EXPECT_THROW(solver.solve(s.targets), arap::Error);
}

}  // namespace

namespace {

// The barrier summed over every pair of the surface by brute force: each point
// against each triangle not holding it, each edge against each edge sharing no
// vertex, pairs nearer than the activation distance at rest left out; infinite
// once a pair is within the gap (a state no step may reach).
double brute_force_barrier(const Points& rest, const Points& P, const Triangles& T, double activation, double gap) {
  using arap::contact::Vec3;
  auto at = [](const Points& X, int v) { return Vec3(X.row(v).transpose()); };
  auto barrier = [&](double d) {
    if (!(d > gap)) return std::numeric_limits<double>::infinity();
    return d < activation ? -(d - activation) * (d - activation) * std::log(d / activation) : 0.0;
  };
  std::set<std::pair<int, int>> edge_set;
  for (Eigen::Index f = 0; f < T.rows(); ++f)
    for (int k = 0; k < 3; ++k) edge_set.insert(std::minmax(T(f, k), T(f, (k + 1) % 3)));
  const std::vector<std::pair<int, int>> edges(edge_set.begin(), edge_set.end());
  std::set<int> surface;
  for (Eigen::Index f = 0; f < T.rows(); ++f)
    for (int k = 0; k < 3; ++k) surface.insert(T(f, k));
  double w[4], sum = 0;
  for (int v : surface)
    for (Eigen::Index f = 0; f < T.rows(); ++f) {
      if (v == T(f, 0) || v == T(f, 1) || v == T(f, 2)) continue;
      auto d2 = [&](const Points& X) {
        return arap::contact::point_triangle_distance2(at(X, v), at(X, T(f, 0)), at(X, T(f, 1)), at(X, T(f, 2)), w);
      };
      if (d2(rest) >= activation * activation) sum += barrier(std::sqrt(d2(P)));
    }
  for (size_t i = 0; i < edges.size(); ++i)
    for (size_t j = i + 1; j < edges.size(); ++j) {
      const int a0 = edges[i].first, a1 = edges[i].second, b0 = edges[j].first, b1 = edges[j].second;
      if (a0 == b0 || a0 == b1 || a1 == b0 || a1 == b1) continue;
      auto d2 = [&](const Points& X) {
        return arap::contact::edge_edge_distance2(at(X, a0), at(X, a1), at(X, b0), at(X, b1), w);
      };
      if (d2(rest) >= activation * activation) sum += barrier(std::sqrt(d2(P)));
    }
  return sum;
}

// The pair search (a tree over the surface, near pairs listed with a margin)
// finds every pair the barrier counts, each once: its energy is the brute-force
// sum over all pairs, on poses folded into contact with noise on top.
TEST(ContactPairList, TheSearchFindsEveryNearPairOnce) {
  const Scene s = bent_bar(kFold, 200, kKeepSize);
  const double size = 5.0;
  const Points rest = s.rest / size;
  arap::contact::SelfContact contact;
  contact.bind(rest, s.triangles, 1.0);
  std::mt19937 random(11);
  std::normal_distribution<double> noise(0.0, 1.0);
  const double edge = mean_edge_length(rest, s.triangles);
  const int poses = arap_test::kSanitizerBuild ? 4 : 12;
  int near = 0;
  for (int k = 0; k < poses; ++k) {
    // Folded sideways and down by a growing share, so that the top meets the side, plus noise of a tenth of an edge.
    Points P = rest;
    const double share = 0.3 + 0.45 * k / poses;
    for (Eigen::Index v = 0; v < P.rows(); ++v) {
      const double h = rest(v, 2);
      P.row(v) += share * h * h * Eigen::RowVector3d(0.5, 0.0, -0.6) +
                  0.1 * edge * Eigen::RowVector3d(noise(random), noise(random), noise(random));
    }
    const double expected = brute_force_barrier(rest, P, s.triangles, contact.activation(), contact.gap());
    const double found = contact.energy(P.data());
    if (!std::isfinite(expected)) {
      EXPECT_EQ(found, expected) << "pose " << k << ": a pair within the gap was missed";
      continue;
    }
    ASSERT_NEAR(found, expected, 1e-9 * (1 + std::abs(expected))) << "pose " << k;
    near += expected > 0;
  }
  EXPECT_GE(near, poses / 4) << "too few poses brought pairs within the activation distance";
}

// The list of near pairs kept between steps misses nothing: a long run of
// random moves checked by one SelfContact gives, step by step, what a fresh one
// (its list made for that step alone) gives.
TEST(ContactPairList, AKeptListSeesWhatAFreshOneSees) {
  const Scene s = bent_bar(kFold, 300);
  const double size = 5.0;
  Points P = s.rest / size;  // internal units are about 1
  arap::contact::SelfContact kept;
  kept.bind(P, s.triangles, 1.0);
  std::mt19937 random(7);
  std::normal_distribution<double> step(0.0, 1.0);
  const double edge = mean_edge_length(P, s.triangles);
  int cut = 0, touching = 0;
  for (int k = 0; k < sized(300); ++k) {
    // Smooth moves of the whole bar (a bend that grows), plus noise of a few tenths of an edge, some long.
    Points next = P;
    const double scale = (k % 17 == 0 ? 3.0 : 0.2) * edge;
    for (Eigen::Index v = 0; v < P.rows(); ++v) {
      const double h = s.rest(v, 2) / size;
      next.row(v) += Eigen::RowVector3d(0.02 * h * h, 0.0, -0.01 * h) +
                     scale * Eigen::RowVector3d(step(random), step(random), step(random));
    }
    arap::contact::SelfContact fresh;
    fresh.bind(s.rest / size, s.triangles, 1.0);
    const auto a = kept.evaluate(P.data(), next.data());
    const auto b = fresh.evaluate(P.data(), next.data());
    ASSERT_EQ(a.fraction, b.fraction) << "step " << k;
    ASSERT_NEAR(a.energy, b.energy, 1e-12 * (1 + std::abs(b.energy))) << "step " << k;
    ASSERT_EQ(kept.active_pairs(), fresh.active_pairs()) << "step " << k;
    cut += a.fraction < 1;
    touching += kept.active_pairs() > 0;
    if (a.fraction >= 1) P = next;
  }
  EXPECT_GT(cut, 0) << "no step was cut: the test moved nothing close";
  EXPECT_GT(touching, 0);
}

// Carrying the whole bar along, several edge lengths per step while it turns
// slowly, moves no pair much nearer: the motion relative to the clusters stays
// small, so one list holds for many steps (by the margin alone, each step would
// need about sixteen), and it sees what a fresh list sees.
TEST(ContactPairList, ACarriedAlongMeshKeepsItsList) {
  const Scene s = bent_bar(kFold, 300);
  const Points rest = s.rest / 5.0;
  const double edge = mean_edge_length(rest, s.triangles);
  arap::contact::SelfContact kept;
  kept.bind(rest, s.triangles, 1.0);
  Points P = rest;
  const int steps = 40;
  for (int k = 1; k <= steps; ++k) {
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.005 * k, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    const Eigen::RowVector3d shift(3.0 * edge * k, -2.0 * edge * k, edge * k);
    Points next = (rest * turn.transpose()).rowwise() + shift;
    arap::contact::SelfContact fresh;
    fresh.bind(rest, s.triangles, 1.0);
    const auto a = kept.evaluate(P.data(), next.data());
    const auto b = fresh.evaluate(P.data(), next.data());
    ASSERT_EQ(a.fraction, 1.0) << "step " << k;
    ASSERT_EQ(a.fraction, b.fraction) << "step " << k;
    ASSERT_NEAR(a.energy, b.energy, 1e-12 * (1 + std::abs(b.energy))) << "step " << k;
    ASSERT_EQ(kept.active_pairs(), fresh.active_pairs()) << "step " << k;
    P = next;
  }
  EXPECT_LT(kept.lists_made(), steps / 4) << "the list was made again for moves that carry everything along";
}

// A long move that bends the surface (a shear wave, too uneven for the
// clusters' bound) is checked in pieces of a quarter edge; a list made at a
// piece's end holds for that piece and the next, and for a short step that
// starts where the move ended.
TEST(ContactPairList, AListMadeAtTheEndOfAPieceCoversTheNextOne) {
  const Scene s = bent_bar(Eigen::Vector3d::Zero(), 600, true);
  const Points rest = s.rest / 5.0;
  const double edge = mean_edge_length(rest, s.triangles);
  arap::contact::SelfContact kept;
  kept.bind(rest, s.triangles, 1.0);
  const double amplitude = 2.0 * edge, wavelength = 16.0 * edge;
  Points waved = rest;
  for (Eigen::Index v = 0; v < rest.rows(); ++v)
    waved(v, 0) += amplitude * std::sin(2 * M_PI * rest(v, 2) / wavelength);
  Points nudged = waved;
  for (Eigen::Index v = 0; v < rest.rows(); ++v)
    nudged(v, 0) += 0.1 * edge * std::cos(2 * M_PI * rest(v, 2) / wavelength);
  const auto move = kept.evaluate(rest.data(), waved.data());
  ASSERT_EQ(move.fraction, 1.0);
  const long pieces = static_cast<long>(std::ceil(amplitude / (0.25 * edge)));
  const long lists = kept.lists_made();
  EXPECT_GE(lists, 2) << "the clusters' bound held: the move does not test what it should";
  EXPECT_LE(lists, pieces / 2 + 1);
  arap::contact::SelfContact fresh;
  fresh.bind(rest, s.triangles, 1.0);
  const auto a = kept.evaluate(waved.data(), nudged.data());
  const auto b = fresh.evaluate(waved.data(), nudged.data());
  EXPECT_EQ(kept.lists_made(), lists) << "the short step after the move made a list again";
  EXPECT_EQ(a.fraction, b.fraction);
  EXPECT_NEAR(a.energy, b.energy, 1e-12 * (1 + std::abs(b.energy)));
}

// The search of near pairs runs on the solver's threads on larger meshes; the
// list it finds, and so every result, is the same bit for bit on one or two.
TEST(ContactPairList, OneAndTwoThreadsFindTheSameList) {
  const Scene s = bent_bar(kFold, 1400, kKeepSize);
  ASSERT_GE(s.triangles.rows(), 2000) << "below the size at which the search runs on threads";
  const Points rest = s.rest / 5.0;
  std::mt19937 random(5);
  std::normal_distribution<double> noise(0.0, 1.0);
  const double edge = mean_edge_length(rest, s.triangles);
  arap::contact::SelfContact one, two;
  one.bind(rest, s.triangles, 1.0);
  two.bind(rest, s.triangles, 1.0);
  two.set_threads(2);
  Points from = rest;
  const int moves = arap_test::kSanitizerBuild ? 3 : 6;
  for (int k = 1; k <= moves; ++k) {
    Points to = rest;
    for (Eigen::Index v = 0; v < rest.rows(); ++v) {
      const double h = rest(v, 2);
      to.row(v) += (1.2 * k / moves) * h * h * Eigen::RowVector3d(0.5, 0.0, -0.6) +
                   0.05 * edge * Eigen::RowVector3d(noise(random), noise(random), noise(random));
    }
    const auto a = one.evaluate(from.data(), to.data());
    const auto b = two.evaluate(from.data(), to.data());
    ASSERT_EQ(a.fraction, b.fraction) << k;
    ASSERT_EQ(a.energy, b.energy) << k;
    ASSERT_EQ(one.active_pairs(), two.active_pairs()) << k;
    ASSERT_EQ(one.lists_made(), two.lists_made()) << k;
    if (a.fraction >= 1) from = to;
  }
  // A pose pressed into contact: many pairs within reach, their barrier summed in the list's order.
  const Points pressed = solve(s, with_contact(Contact::Self)).positions / 5.0;
  EXPECT_EQ(one.energy(pressed.data()), two.energy(pressed.data()));
  EXPECT_EQ(one.active_pairs(), two.active_pairs());
  EXPECT_GT(one.active_pairs(), 20) << "too few pairs in reach for their order to show";
}

// A line search tries shorter steps along the move it checked: a move from
// the same start to a point within the share found safe is not checked again
// (only its end is evaluated, as a fresh check evaluates it), one past that
// share or off the line is.
TEST(ContactPairList, AShorterStepAlongACheckedMoveIsNotCheckedAgain) {
  const Scene s = bent_bar(kFold, 600, kKeepSize);
  const Points rest = s.rest / 5.0;
  const double edge = mean_edge_length(rest, s.triangles);
  // The top folded sideways and down into the side, in one straight move that a pair stops.
  Points folded = rest;
  for (Eigen::Index v = 0; v < rest.rows(); ++v) {
    const double h = rest(v, 2);
    folded.row(v) += 1.2 * h * h * Eigen::RowVector3d(0.5, 0.0, -0.6);
  }
  arap::contact::SelfContact kept;
  kept.bind(rest, s.triangles, 1.0);
  const auto move = kept.evaluate(rest.data(), folded.data());
  ASSERT_LT(move.fraction, 1.0) << "the move is not stopped: the test checks nothing";
  ASSERT_GT(move.fraction, 0.1);
  const long after_move = kept.lists_made();
  ASSERT_GE(after_move, 2) << "the move needed a single list: a check again would cost nothing";
  auto along = [&](double share) {
    Points P = rest;
    for (Eigen::Index i = 0; i < P.size(); ++i) P.data()[i] += share * (folded.data()[i] - rest.data()[i]);
    return P;
  };
  auto fresh_check = [&](const Points& to) {
    arap::contact::SelfContact fresh;
    fresh.bind(rest, s.triangles, 1.0);
    const auto step = fresh.evaluate(rest.data(), to.data());
    return std::make_tuple(step, fresh.active_pairs(), fresh.lists_made());
  };
  for (double share : {0.9 * move.fraction, 0.5 * move.fraction}) {
    const Points shorter = along(share);
    const long before = kept.lists_made();
    const auto a = kept.evaluate(rest.data(), shorter.data());
    const auto [b, b_pairs, b_lists] = fresh_check(shorter);
    EXPECT_EQ(a.fraction, 1.0) << share;
    EXPECT_EQ(b.fraction, 1.0) << share;
    EXPECT_NEAR(a.energy, b.energy, 1e-12 * (1 + std::abs(b.energy))) << share;
    EXPECT_EQ(kept.active_pairs(), b_pairs) << share;
    EXPECT_LE(kept.lists_made() - before, 1) << share << ": the move was checked again";
    EXPECT_GE(b_lists, 2) << share;
  }
  // A check told it is out of time after its first piece stops there: that share is safe, as a fresh check finds.
  const std::function<bool()> out_of_time = [] { return true; };
  const auto stopped = kept.evaluate(rest.data(), folded.data(), arap::contact::SelfContact::ListAt::End, &out_of_time);
  EXPECT_TRUE(stopped.out_of_time);
  EXPECT_GT(stopped.fraction, 0.0);
  EXPECT_LT(stopped.fraction, move.fraction);
  EXPECT_EQ(std::get<0>(fresh_check(along(stopped.fraction))).fraction, 1.0);
  // Past the safe share, and off the line by a thousandth of an edge: checked in full, stopped as a fresh check stops
  // them.
  Points past = along(std::min(1.0, 1.05 * move.fraction));
  Points off = along(0.9 * move.fraction);
  off.row(s.triangles(0, 0)) += Eigen::RowVector3d(1e-3 * edge, 0, 0);
  for (const Points* to : {&past, &off}) {
    kept.evaluate(rest.data(), folded.data());  // the move checked last again
    const long before = kept.lists_made();
    const auto a = kept.evaluate(rest.data(), to->data());
    const auto [b, b_pairs, b_lists] = fresh_check(*to);
    EXPECT_EQ(a.fraction, b.fraction);
    EXPECT_NEAR(a.energy, b.energy, 1e-12 * (1 + std::abs(b.energy)));
    EXPECT_GE(kept.lists_made() - before, 2) << "not checked in full";
  }
}

}  // namespace

namespace {

// In a viewport's chunks (a time budget, the same targets again and again), a
// pose that cannot be reached still settles: the handles stop short, the solve
// says so in every chunk after, and reports converged only once it is done.
TEST(ContactSolver, ChunksTowardAnUnreachableTargetSettleShortAndSaySo) {
  const Scene s = bent_bar(Eigen::Vector3d(0.0, 0.0, -1.2), 300);
  Options o = with_contact(Contact::Self);
  o.time_budget_ms = 1;
  o.init = arap::InitialGuess::WarmStart;
  Solver solver;
  solver.bind(s.rest, s.triangles, s.constrained, o);
  SolveStats stats;
  int chunk = 0;
  for (; chunk < 3000; ++chunk) {
    stats = solver.solve(s.targets);
    ASSERT_TRUE(solver.positions().allFinite()) << "chunk " << chunk;
    ASSERT_EQ(crossing_pairs(solver.positions(), s.triangles).size(), 0u) << "chunk " << chunk;
    if (stats.converged) break;
  }
  ASSERT_TRUE(stats.converged) << "still not settled after " << chunk << " chunks";
  EXPECT_LT(stats.contact_reached, 1.0);
  EXPECT_GT(largest_constraint_error(s, solver.positions()), 1e-3);
  // Resumed with nothing left to do: still short, still said.
  const SolveStats again = solver.solve(s.targets);
  EXPECT_EQ(again.contact_reached, stats.contact_reached);
  EXPECT_EQ(again.contact_stopped_vertex, stats.contact_stopped_vertex);
}

}  // namespace
