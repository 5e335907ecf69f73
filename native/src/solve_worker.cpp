#include "arap/solve_worker.h"

#include <cerrno>
#include <chrono>
#include <string>
#include <utility>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace arap {

SolveWorker::SolveWorker(Solver& solver, int max_iterations) : solver_(solver), max_iterations_(max_iterations) {
  if (!solver.is_bound()) throw Error(ErrorCode::NotBound, "SolveWorker: the solver is not bound");
  if (max_iterations < 1) throw Error(ErrorCode::InvalidInput, "SolveWorker: max_iterations must be at least 1");
  if (!solver.claim())
    throw Error(ErrorCode::Busy, "the solver is already in use by another SolveWorker");
  solver.set_stop_requested(false);
  try {
    thread_ = std::thread([this] { run(); });
  } catch (...) {
    solver.release();
    throw;
  }
}

SolveWorker::~SolveWorker() { stop(); }

void SolveWorker::post_from(const Eigen::Ref<const Points>& targets, const Eigen::Ref<const Points>& start) {
  if (start.rows() != solver_.vertex_count())
    throw Error(ErrorCode::InvalidInput, "expected " + std::to_string(solver_.vertex_count()) +
                                             " start positions, got " + std::to_string(start.rows()));
  if (!start.allFinite()) throw Error(ErrorCode::NonFinite, "a start position is not finite");
  post(targets, true, &start);
}

void SolveWorker::post(const Eigen::Ref<const Points>& targets, bool restart) { post(targets, restart, nullptr); }

void SolveWorker::post(const Eigen::Ref<const Points>& targets, bool restart,
                       const Eigen::Ref<const Points>* start) {
  const int expected_rows = static_cast<int>(solver_.constrained().size());
  if (targets.rows() != expected_rows)
    throw Error(ErrorCode::InvalidInput, "expected " + std::to_string(expected_rows) +
                                             " target positions (one per constrained vertex), got " +
                                             std::to_string(targets.rows()));
  if (!targets.allFinite()) throw Error(ErrorCode::NonFinite, "a target position is not finite");
  std::lock_guard<std::mutex> lock(mutex_);
  if (quit_) throw Error(ErrorCode::InvalidInput, "SolveWorker: post() after stop()");
  pending_ = targets;
  fresh_ = true;
  restart_ = restart;
  from_start_ = start != nullptr;
  if (from_start_) start_ = *start;
  solver_.set_stop_requested(true);  // the solve in progress (old targets) ends after this iteration
  wake_.notify_one();
}

bool SolveWorker::take(Result& result, const std::function<void(const Points&)>& read) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (error_) {
    std::exception_ptr error = std::exchange(error_, nullptr);
    std::rethrow_exception(error);
  }
  if (!untaken_) return false;
  untaken_ = false;
  result = result_;
  read(published_);
  return true;
}

bool SolveWorker::wait(double timeout_ms) const {
  std::unique_lock<std::mutex> lock(mutex_);
  const auto ready = [this] { return untaken_ || error_ != nullptr; };
  if (!(timeout_ms > 0)) return ready();
  // Against the system clock: a wait_for (steady clock) needs glibc 2.30's pthread_cond_clockwait, and the
  // distributed module must load on glibc 2.17. A clock jump can only lengthen or shorten this short wait.
  const auto deadline = std::chrono::system_clock::now() +
                        std::chrono::duration_cast<std::chrono::system_clock::duration>(
                            std::chrono::duration<double, std::milli>(timeout_ms));
  return finished_.wait_until(lock, deadline, ready);
}

SolveProgress SolveWorker::progress() const { return solver_.progress(); }

bool SolveWorker::settled() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return !fresh_ && !working_;
}

void SolveWorker::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (quit_ && !thread_.joinable()) return;
    quit_ = true;
    solver_.set_stop_requested(true);
    wake_.notify_one();
  }
  if (thread_.joinable()) thread_.join();
  solver_.set_stop_requested(false);
  solver_.release();
}

namespace {

// The worker's nice value above the caller's: a user interface and its drawing (software OpenGL
// draws on the CPU) come first, the solve takes the time they leave. On an idle core nothing changes.
constexpr int kNiceAboveCaller = 10;

void lower_this_threads_priority() {
#if defined(__linux__)
  // On Linux the nice value is per thread: this leaves the caller's threads as they are.
  const id_t tid = static_cast<id_t>(syscall(SYS_gettid));
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, tid);
  if (errno == 0) setpriority(PRIO_PROCESS, tid, now + kNiceAboveCaller);
#endif
}

}  // namespace

void SolveWorker::run() {
  lower_this_threads_priority();
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return quit_ || fresh_ || working_; });
    if (quit_) return;
    if (fresh_) {
      targets_ = pending_;
      fresh_ = false;
      if (restart_ && from_start_)
        solver_.start_from(start_);  // the solver is idle: this thread owns it
      else if (restart_)
        solver_.forget_solution();
      spent_ = 0;
    }
    working_ = true;
    solver_.set_stop_requested(false);  // under the lock: a post() from now on stops this solve
    lock.unlock();
    SolveStats stats;
    std::exception_ptr error;
    try {
      stats = solver_.solve(targets_);
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    if (error) {
      error_ = error;
      working_ = false;
      finished_.notify_all();
      continue;
    }
    spent_ += stats.iterations;
    // A solve with no iteration to run would never get further: settled too.
    working_ = !(stats.converged || spent_ >= max_iterations_ || stats.iterations == 0);
    published_ = solver_.positions();
    result_.stats = std::move(stats);
    result_.serial += 1;
    result_.iterations = spent_;
    result_.settled = !working_ && !fresh_;
    untaken_ = true;
    finished_.notify_all();
  }
}

}  // namespace arap
