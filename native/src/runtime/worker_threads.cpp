#include "worker_threads.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include <pthread.h>
#include <sched.h>
#include <unistd.h>

namespace arap {

namespace worker_detail {

namespace {

using Clock = std::chrono::steady_clock;

// How long a helper polls for its next part, and the caller for a helper to
// finish, before sleeping: a few vector passes' worth at 100k vertices (one
// takes 0.1-0.2 ms), so that the sections of an iteration hand over without
// sleeping. ARAP_POLL_US overrides it (0: sleep at once).
int poll_microseconds() {
  static const int us = [] {
    const char* s = std::getenv("ARAP_POLL_US");
    return s ? std::atoi(s) : 300;
  }();
  return us;
}

// Polls `ready` for a while; false if it did not become true in time. Between
// looks it yields the core: on an idle machine that returns at once, and on a
// busy one the thread that shares this core (another program, or the thread
// being waited for) runs instead of the poll (polling with the processor's
// pause instruction instead made two threads slower than one on a busy
// machine: docs/engine_internals.md).
template <class Ready>
bool poll(const Ready& ready) {
  const auto deadline = Clock::now() + std::chrono::microseconds(poll_microseconds());
  while (!ready()) {
    if (Clock::now() > deadline) return ready();
    sched_yield();
  }
  return true;
}

// One helper thread: takes a part, runs it, says it is done.
class Helper {
 public:
  Helper() : thread_([this] { loop(); }) {}
  ~Helper() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      quit_ = true;
    }
    posted_cv_.notify_one();
    thread_.join();
  }
  Helper(const Helper&) = delete;
  Helper& operator=(const Helper&) = delete;

  void start(Job job, int part) {
    job_ = job, part_ = part;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      posted_.store(posted_.load(std::memory_order_relaxed) + 1, std::memory_order_release);
    }
    posted_cv_.notify_one();
  }

  void wait() {
    const std::uint64_t target = posted_.load(std::memory_order_relaxed);
    auto done = [&] { return finished_.load(std::memory_order_acquire) == target; };
    if (poll(done)) return;
    std::unique_lock<std::mutex> lock(mutex_);
    finished_cv_.wait(lock, done);
  }

 private:
  void loop() {
    std::uint64_t seen = 0;
    for (;;) {
      auto posted = [&] { return posted_.load(std::memory_order_acquire) != seen; };
      if (!poll(posted)) {
        std::unique_lock<std::mutex> lock(mutex_);
        posted_cv_.wait(lock, [&] { return quit_ || posted(); });
        if (quit_) return;
      }
      seen = posted_.load(std::memory_order_acquire);
      job_.call(job_.body, part_);
      {
        std::lock_guard<std::mutex> lock(mutex_);
        finished_.store(seen, std::memory_order_release);
      }
      finished_cv_.notify_one();
    }
  }

  Job job_{};
  int part_ = 0;
  std::atomic<std::uint64_t> posted_{0}, finished_{0};
  std::mutex mutex_;
  std::condition_variable posted_cv_, finished_cv_;
  bool quit_ = false;
  std::thread thread_;  // last: starts once the members above exist
};

struct Helpers {
  pid_t owner = getpid();
  std::vector<std::unique_ptr<Helper>> list;
};

// Each thread's helpers hang on a POSIX thread-specific key, whose destructor
// stops them when that thread ends. (Not a C++ thread_local with a destructor:
// that needs glibc 2.18, and the zip's modules need only 2.17.) The main
// thread's helpers are not stopped at exit; they are asleep or about to be.
pthread_key_t helpers_key;

void destroy_helpers(void* helpers) { delete static_cast<Helpers*>(helpers); }

Helpers& helpers_of_this_thread(int count) {
  static pthread_once_t once = PTHREAD_ONCE_INIT;
  pthread_once(&once, [] { pthread_key_create(&helpers_key, destroy_helpers); });
  auto* helpers = static_cast<Helpers*>(pthread_getspecific(helpers_key));
  // After fork() the child has this object but none of its threads: leave it
  // (destroying it would wait for threads that are not there) and start anew.
  if (helpers && helpers->owner != getpid()) helpers = nullptr;
  if (!helpers) {
    helpers = new Helpers;
    pthread_setspecific(helpers_key, helpers);
  }
  while (static_cast<int>(helpers->list.size()) < count) helpers->list.push_back(std::make_unique<Helper>());
  return *helpers;
}

}  // namespace

void run(int threads, Job job) {
  // A part that itself runs parts (none does today) runs them in turn here: its helpers are busy.
  thread_local bool running = false;
  if (running) {
    for (int t = 0; t < threads; ++t) job.call(job.body, t);
    return;
  }
  running = true;
  Helpers& helpers = helpers_of_this_thread(threads - 1);
  for (int t = 1; t < threads; ++t) helpers.list[t - 1]->start(job, t);
  job.call(job.body, 0);
  for (int t = 1; t < threads; ++t) helpers.list[t - 1]->wait();
  running = false;
}

}  // namespace worker_detail

}  // namespace arap
