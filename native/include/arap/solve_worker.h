// A Solver on a thread of its own, so that a caller with a user interface
// (Blender's main thread: Live, Deform) never waits for a solve.
#pragma once

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

#include "arap/solver.h"

namespace arap {

// post() hands over the newest targets and returns at once. The worker solves
// them with the solver's options, solve after solve while one ends short of
// the tolerance (its time budget or iteration cap ran out), until the pose has
// settled or `max_iterations` iterations went into these targets; then it
// sleeps until the next post(). New targets stop the solve in progress after
// its current iteration (Solver::set_stop_requested) and the next solve starts
// from where it stopped (a warm start, when the solver's options ask for one).
// take() copies out the newest finished solve. The worker's thread runs at a
// lower priority than the caller's (a nice value 10 higher on Linux), so that
// on a busy machine the caller's user interface keeps its share of the CPU.
//
// While a SolveWorker exists its solver is busy(): nothing else may call it.
class SolveWorker {
 public:
  struct Result {
    SolveStats stats;          // of the newest finished solve
    long serial = 0;           // how many solves the worker has finished so far
    int iterations = 0;        // spent on the current targets, all solves together
    bool settled = false;      // converged, or max_iterations spent: nothing more to do until post()
  };

  // Throws arap::Error(Busy) when another SolveWorker owns `solver`, (NotBound) before bind().
  SolveWorker(Solver& solver, int max_iterations);
  ~SolveWorker();  // stop()
  SolveWorker(const SolveWorker&) = delete;
  SolveWorker& operator=(const SolveWorker&) = delete;

  // targets: #constrained by 3, as Solver::solve() takes them (checked here: rows and finiteness).
  // restart: the solve starts cold (Solver::forget_solution), so that what it settles on depends on
  // the targets alone; else it goes on from where the last one stopped.
  void post(const Eigen::Ref<const Points>& targets, bool restart = false);
  // post(targets, restart=true), the cold solve starting from `start` (Solver::start_from).
  void post_from(const Eigen::Ref<const Points>& targets, const Eigen::Ref<const Points>& start);
  // When a solve finished since the last take(): fills `result`, calls `read(positions)` with the
  // solution (#V by 3, valid only during the call) and returns true. A solve that threw is
  // rethrown here, once; the worker then waits for new targets.
  bool take(Result& result, const std::function<void(const Points&)>& read);
  // Waits at most `timeout_ms` for a finished solve not yet taken (or a failure to report):
  // true when take() has one.
  bool wait(double timeout_ms) const;
  // The solve in progress (iterations, energy).
  SolveProgress progress() const;
  int vertex_count() const { return solver_.vertex_count(); }
  // Nothing to do: every posted target set has settled (or failed), nothing new was posted.
  bool settled() const;
  // Ends the solve in progress after its current iteration and joins the thread; the solver is
  // free again. post() after stop() throws.
  void stop();

 private:
  void run();
  void post(const Eigen::Ref<const Points>& targets, bool restart, const Eigen::Ref<const Points>* start);

  Solver& solver_;
  const int max_iterations_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;               // the worker: new targets, or quit
  mutable std::condition_variable finished_;   // wait(): a solve finished or failed
  std::thread thread_;
  // Guarded by mutex_:
  Points pending_;             // the newest targets, not yet taken up by the worker
  bool fresh_ = false;         // pending_ holds targets the worker has not started on
  bool restart_ = false;       // ... to be solved from a cold start
  bool from_start_ = false;    // ... that starts from start_
  Points start_;
  bool working_ = false;       // the current targets have not settled yet
  bool quit_ = false;
  int spent_ = 0;              // iterations on the current targets
  Points published_;           // the newest finished solution
  Result result_;
  bool untaken_ = false;       // result_ not yet take()n
  std::exception_ptr error_;
  // The worker thread's own:
  Points targets_;
};

}  // namespace arap
