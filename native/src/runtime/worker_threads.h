// Helper threads kept from one parallel section to the next.
//
// A quasi-Newton iteration has about twenty short parallel sections (vector
// passes, the two halves of each triangular solve, the per-vertex passes).
// Starting a std::thread for each, or waking a sleeping one, costs tens of
// microseconds, a share of the iteration worth saving (docs/engine_internals.md).
// Here each calling thread keeps its helpers: after a section a helper polls
// for the next one for a short while (worker_threads.cpp's poll_microseconds(),
// ARAP_POLL_US) and only then sleeps, so back-to-back sections hand over
// in a few microseconds, while nothing polls once a solve has returned (Live
// sleeping, a batch between meshes) and a busy machine loses at most that
// short while to a helper with nothing to do.
//
// The helpers belong to the thread that calls run_on_threads (one set per
// thread, stopped when it ends): solvers on two Python threads neither share
// nor wait on each other's. A child process made by fork() starts its own
// (the parent's do not exist there). Which thread runs which part never changes a result: callers split
// their work the same way whatever the thread count.
#pragma once

namespace arap {

namespace worker_detail {
struct Job {
  void (*call)(const void* body, int part);
  const void* body;
};
// Runs job.call(job.body, t) for t in [1, threads) on the helpers and t = 0 here; returns when all have.
void run(int threads, Job job);
}  // namespace worker_detail

// body(t) for every t in [0, threads): t = 0 on the calling thread, the others
// on its helpers (started the first time they are needed). Returns when all
// have returned. threads <= 1 runs body(0) alone, here. body must not throw.
template <class Body>
void run_on_threads(int threads, const Body& body) {
  if (threads <= 1) {
    body(0);
    return;
  }
  worker_detail::run(threads, {[](const void* b, int t) { (*static_cast<const Body*>(b))(t); }, &body});
}

// first() and second(), side by side on two threads when `parallel`, else in that order here.
template <class First, class Second>
void run_side_by_side(bool parallel, const First& first, const Second& second) {
  if (!parallel) {
    first();
    second();
    return;
  }
  run_on_threads(2, [&](int t) {
    if (t == 0) first();
    else second();
  });
}

}  // namespace arap
