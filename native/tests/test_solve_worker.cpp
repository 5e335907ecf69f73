#include <gtest/gtest.h>

#include <chrono>
#include <dirent.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "arap/solve_worker.h"
#include "arap/solver.h"
#include "test_meshes.h"

namespace {

using arap_test::BentTube;

arap::Options quasi_newton(int iterations, double tolerance, arap::InitialGuess init = arap::InitialGuess::Naive) {
  arap::Options o;
  o.max_iterations = iterations;
  o.tolerance = tolerance;
  o.init = init;
  return o;
}

// take() until a settled result arrives (every result read into `positions`); the number of results.
int take_until_settled(arap::SolveWorker& worker, arap::SolveWorker::Result& result, arap::Points& positions) {
  int taken = 0;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  for (;;) {
    if (worker.take(result, [&](const arap::Points& p) { positions = p; })) {
      ++taken;
      if (result.settled) return taken;
    }
    if (std::chrono::steady_clock::now() > give_up) {
      ADD_FAILURE() << "the worker never settled";
      return taken;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

TEST(SolveWorker, OneSolveOnItsThreadGivesTheSameBitsAsSolveOnTheCaller) {
  const BentTube t;
  arap::Solver here, there;
  here.bind(t.mesh.V, t.mesh.F, t.constrained, quasi_newton(300, 1e-8));
  there.bind(t.mesh.V, t.mesh.F, t.constrained, quasi_newton(300, 1e-8));
  const arap::SolveStats direct = here.solve(t.targets);
  arap::SolveWorker::Result result;
  arap::Points positions;
  {
    arap::SolveWorker worker(there, 300);
    EXPECT_TRUE(there.busy());
    worker.post(t.targets);
    EXPECT_EQ(take_until_settled(worker, result, positions), 1);
    EXPECT_TRUE(worker.settled());
  }
  EXPECT_FALSE(there.busy());
  EXPECT_EQ(positions, here.positions());
  EXPECT_EQ(there.positions(), here.positions());
  EXPECT_EQ(result.stats.iterations, direct.iterations);
  EXPECT_TRUE(result.stats.converged);
  EXPECT_EQ(result.iterations, direct.iterations);
  EXPECT_EQ(result.serial, 1);
}

TEST(SolveWorker, WaitReturnsWhenASolveIsReadyOrTheTimeIsUp) {
  const BentTube t;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained, quasi_newton(300, 1e-8));
  arap::SolveWorker worker(solver, 300);
  EXPECT_FALSE(worker.wait(0.0));      // nothing posted: nothing to take
  EXPECT_FALSE(worker.wait(5.0));
  worker.post(t.targets);
  ASSERT_TRUE(worker.wait(60000.0));
  EXPECT_TRUE(worker.wait(0.0));       // still there until taken
  arap::SolveWorker::Result result;
  EXPECT_TRUE(worker.take(result, [](const arap::Points&) {}));
  EXPECT_FALSE(worker.wait(0.0));
}

TEST(SolveWorker, ChunksOfIterationsGoOnUntilThePoseSettles) {
  // Warm chunks of 3 iterations resume the quasi-Newton history: the same arithmetic as one solve.
  const BentTube t;
  arap::Solver once, chunked;
  once.bind(t.mesh.V, t.mesh.F, t.constrained, quasi_newton(300, 1e-8));
  const arap::SolveStats whole = once.solve(t.targets);
  ASSERT_TRUE(whole.converged);
  arap::Options o = quasi_newton(3, 1e-8, arap::InitialGuess::WarmStart);
  o.cold_start = arap::InitialGuess::Naive;
  chunked.bind(t.mesh.V, t.mesh.F, t.constrained, o);
  arap::SolveWorker worker(chunked, 300);
  worker.post(t.targets);
  arap::SolveWorker::Result result;
  arap::Points positions;
  take_until_settled(worker, result, positions);
  EXPECT_EQ(result.iterations, whole.iterations);
  EXPECT_EQ(result.serial, (whole.iterations + 2) / 3);
  EXPECT_TRUE(result.stats.converged);
  EXPECT_EQ(positions, once.positions());
}

TEST(SolveWorker, ARestartedSolveInChunksGivesTheBitsOfOneColdSolve) {
  // What the worker settles on after post(targets, restart) depends on the targets alone.
  const BentTube t, far(2.6), near(1.3);
  arap::Solver once, chunked;
  arap::Options o = quasi_newton(300, 1e-8, arap::InitialGuess::WarmStart);
  o.cold_start = arap::InitialGuess::Differential;
  once.bind(t.mesh.V, t.mesh.F, t.constrained, o);
  const arap::SolveStats whole = once.solve(near.targets);
  ASSERT_TRUE(whole.converged);
  o.max_iterations = 3;
  chunked.bind(t.mesh.V, t.mesh.F, t.constrained, o);
  arap::SolveWorker worker(chunked, 300);
  arap::SolveWorker::Result result;
  arap::Points positions;
  worker.post(far.targets);
  take_until_settled(worker, result, positions);
  worker.post(near.targets, /*restart=*/true);
  take_until_settled(worker, result, positions);
  EXPECT_EQ(result.iterations, whole.iterations);
  EXPECT_EQ(positions, once.positions());
  // Posted without a restart, the same targets settle from the last pose: other bits.
  worker.post(far.targets, true);
  take_until_settled(worker, result, positions);
  worker.post(near.targets);
  take_until_settled(worker, result, positions);
  EXPECT_NE(positions, once.positions());
}

TEST(SolveWorker, APostFromAStartGivesTheBitsOfTheSolverStartingThere) {
  const BentTube t, far(2.6), near(1.3);
  arap::Solver once, chunked, guess;
  arap::Options o = quasi_newton(300, 1e-8, arap::InitialGuess::WarmStart);
  guess.bind(t.mesh.V, t.mesh.F, t.constrained, o);
  guess.solve(near.targets);
  once.bind(t.mesh.V, t.mesh.F, t.constrained, o);
  once.start_from(guess.positions());
  once.solve(near.targets);
  o.max_iterations = 3;
  chunked.bind(t.mesh.V, t.mesh.F, t.constrained, o);
  arap::SolveWorker worker(chunked, 300);
  arap::SolveWorker::Result result;
  arap::Points positions;
  worker.post(far.targets);
  take_until_settled(worker, result, positions);
  worker.post_from(near.targets, guess.positions());
  take_until_settled(worker, result, positions);
  EXPECT_EQ(positions, once.positions());
  EXPECT_THROW(worker.post_from(near.targets, guess.positions().topRows(2)), arap::Error);
}

TEST(SolveWorker, StopsAtItsIterationCapWhenThePoseDoesNotSettle) {
  const BentTube t;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained, quasi_newton(4, 0.0, arap::InitialGuess::WarmStart));
  arap::SolveWorker worker(solver, 10);
  worker.post(t.targets);
  arap::SolveWorker::Result result;
  arap::Points positions;
  take_until_settled(worker, result, positions);
  EXPECT_FALSE(result.stats.converged);
  EXPECT_EQ(result.iterations, 12);  // 4 + 4 + 4: the solve that passes the cap ends it
}

TEST(SolveWorker, NewTargetsReplaceTheOldOnesAndSettleInTheBandOfADirectSolve) {
  const BentTube first(1.0), second(2.5);
  arap::Solver direct, solver;
  direct.bind(first.mesh.V, first.mesh.F, first.constrained, quasi_newton(1000, 1e-10));
  const double e_min = direct.solve(second.targets).energy.back();
  arap::Options o = quasi_newton(2, 1e-10, arap::InitialGuess::WarmStart);
  o.cold_start = arap::InitialGuess::Naive;
  solver.bind(first.mesh.V, first.mesh.F, first.constrained, o);
  arap::SolveWorker worker(solver, 1000);
  worker.post(first.targets);
  worker.post(second.targets);  // at once: the first targets may never be solved to the end
  arap::SolveWorker::Result result;
  arap::Points positions;
  auto at_second = [&] {
    for (size_t k = 0; k < second.constrained.size(); ++k)
      if (!((positions.row(second.constrained[k]) - second.targets.row(k)).norm() < 1e-12)) return false;
    return true;
  };
  // On a busy machine the worker can settle the first targets before the second
  // post reaches it: that settled result comes first, the second's after it.
  take_until_settled(worker, result, positions);
  if (!at_second()) take_until_settled(worker, result, positions);
  EXPECT_TRUE(result.stats.converged);
  EXPECT_LE(result.stats.energy.back(), e_min * (1 + 1e-4));
  for (size_t k = 0; k < second.constrained.size(); ++k)
    EXPECT_LT((positions.row(second.constrained[k]) - second.targets.row(k)).norm(), 1e-12);
}

TEST(SolveWorker, StopEndsALongSolveAndGivesTheSolverBack) {
  const BentTube t;
  arap::Solver solver;
  // Tolerance 0: it goes on until the energy stops falling to rounding (on a busy machine that
  // can come before this thread looks again; stop() must give the solver back either way).
  solver.bind(t.mesh.V, t.mesh.F, t.constrained, quasi_newton(1000000, 0.0));
  auto worker = std::make_unique<arap::SolveWorker>(solver, 1000000);
  worker->post(t.targets);
  while (worker->progress().iterations < 3) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  EXPECT_GT(worker->progress().energy, 0.0);
  worker->stop();
  EXPECT_FALSE(solver.busy());
  EXPECT_THROW(worker->post(t.targets), arap::Error);
  worker.reset();
  solver.options().max_iterations = 5;
  const int iterations = solver.solve(t.targets).iterations;  // usable on the caller's thread again
  EXPECT_GE(iterations, 1);
  EXPECT_LE(iterations, 5);
}

TEST(SolveWorker, RefusesASecondWorkerAndBadTargets) {
  const BentTube t;
  arap::Solver solver, unbound;
  EXPECT_THROW(arap::SolveWorker(unbound, 10), arap::Error);
  solver.bind(t.mesh.V, t.mesh.F, t.constrained, quasi_newton(10, 1e-6));
  arap::SolveWorker worker(solver, 10);
  try {
    arap::SolveWorker second(solver, 10);
    ADD_FAILURE() << "a second worker on a busy solver";
  } catch (const arap::Error& e) {
    EXPECT_EQ(e.code(), arap::ErrorCode::Busy);
  }
  arap::Points short_targets = t.targets.topRows(3);
  EXPECT_THROW(worker.post(short_targets), arap::Error);
  arap::Points nan_targets = t.targets;
  nan_targets(0, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(worker.post(nan_targets), arap::Error);
  EXPECT_TRUE(worker.settled());  // nothing was taken up
}

TEST(SolveWorker, ASolveThatFailsIsReportedByTake) {
  const BentTube t;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained, quasi_newton(10, 1e-6));
  solver.options().weights = arap::Weights::Uniform;  // solve() refuses: the weights are fixed at bind
  arap::SolveWorker worker(solver, 10);
  worker.post(t.targets);
  arap::SolveWorker::Result result;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  bool thrown = false;
  while (!thrown && std::chrono::steady_clock::now() < give_up) {
    try {
      worker.take(result, [](const arap::Points&) {});
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    } catch (const arap::Error& e) {
      thrown = true;
      EXPECT_EQ(e.code(), arap::ErrorCode::InvalidInput);
    }
  }
  EXPECT_TRUE(thrown);
  EXPECT_TRUE(worker.settled());
  EXPECT_FALSE(worker.take(result, [](const arap::Points&) {}));  // reported once
}

#if defined(__linux__)
// The nice values of this process's threads, from /proc/self/task/<tid>/stat (field 19).
std::vector<int> thread_nice_values() {
  std::vector<int> out;
  DIR* dir = opendir("/proc/self/task");
  if (dir == nullptr) return out;
  while (dirent* e = readdir(dir)) {
    if (e->d_name[0] == '.') continue;
    std::ifstream stat(std::string("/proc/self/task/") + e->d_name + "/stat");
    std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    const size_t close = text.rfind(')');   // the command name may hold spaces
    if (close == std::string::npos) continue;
    std::istringstream fields(text.substr(close + 2));
    std::string field;
    for (int k = 3; k <= 19 && fields >> field; ++k)
      if (k == 19) out.push_back(std::stoi(field));
  }
  closedir(dir);
  return out;
}

TEST(SolveWorker, ItsThreadRunsBelowTheCallersPriority) {
  const BentTube t;
  arap::Solver solver;
  solver.bind(t.mesh.V, t.mesh.F, t.constrained, quasi_newton(1000000, 0.0));
  const int caller = getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
  arap::SolveWorker worker(solver, 1000000);
  worker.post(t.targets);
  while (worker.progress().iterations < 1) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  int lowered = 0;
  for (int nice : thread_nice_values()) lowered += nice == std::min(caller + 10, 19);
  EXPECT_EQ(lowered, 1);
  worker.stop();
}
#endif

}  // namespace
