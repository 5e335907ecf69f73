// The helper threads kept between parallel sections (native/src/runtime/worker_threads.h):
// every part runs once, on its own thread; idle helpers sleep; a forked child
// and a thread that exits are handled.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <dirent.h>
#include <fstream>
#include <set>
#include <string>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

#include "runtime/worker_threads.h"

namespace {

// Threads of this process (Linux: /proc/self/task).
std::vector<std::string> task_ids() {
  std::vector<std::string> ids;
  if (DIR* dir = opendir("/proc/self/task")) {
    while (const dirent* entry = readdir(dir))
      if (entry->d_name[0] != '.') ids.push_back(entry->d_name);
    closedir(dir);
  }
  return ids;
}

// The state letter of a thread (R running, S sleeping, ...), from /proc/self/task/<id>/stat.
char task_state(const std::string& id) {
  std::ifstream stat("/proc/self/task/" + id + "/stat");
  std::string line;
  std::getline(stat, line);
  const size_t paren = line.rfind(')');
  return paren == std::string::npos || paren + 2 >= line.size() ? '?' : line[paren + 2];
}

// Runs `threads` parts and checks each ran once, part 0 here and every part on its own thread.
void expect_each_part_once(int threads) {
  std::vector<std::atomic<int>> runs(threads);
  std::vector<std::thread::id> ran_on(threads);
  arap::run_on_threads(threads, [&](int t) {
    ++runs[t];
    ran_on[t] = std::this_thread::get_id();
  });
  for (int t = 0; t < threads; ++t) EXPECT_EQ(runs[t].load(), 1) << "part " << t;
  EXPECT_EQ(ran_on[0], std::this_thread::get_id());
  EXPECT_EQ(std::set<std::thread::id>(ran_on.begin(), ran_on.end()).size(), static_cast<size_t>(threads));
}

TEST(WorkerThreads, EveryPartRunsOnceOnItsOwnThread) {
  for (int threads : {1, 2, 4, 3}) expect_each_part_once(threads);
}

TEST(WorkerThreads, ManySectionsBackToBackSeeEachOthersWrites) {
  // Each section reads what the previous one wrote, on both threads, and
  // writes a second buffer: the hand-over must order memory both ways.
  std::vector<long> a(1000, 1), b(1000, 0), expected(1000, 1), next(1000);
  for (int round = 0; round < 2000; ++round) {
    arap::run_on_threads(2, [&](int t) {
      for (size_t i = t; i < a.size(); i += 2) b[i] = (a[i] + a[a.size() - 1 - i]) % 1000003;
    });
    for (size_t i = 0; i < a.size(); ++i) next[i] = (expected[i] + expected[a.size() - 1 - i]) % 1000003;
    a.swap(b);
    expected.swap(next);
  }
  EXPECT_EQ(a, expected);
}

TEST(WorkerThreads, APartThatRunsPartsRunsThemInTurn) {
  std::atomic<int> inner{0};
  arap::run_on_threads(2, [&](int t) {
    if (t == 0) arap::run_on_threads(3, [&](int) { ++inner; });
  });
  EXPECT_EQ(inner.load(), 3);
}

TEST(WorkerThreads, IdleHelpersSleep) {
  arap::run_on_threads(3, [](int) {});
  const std::string self = std::to_string(gettid());
  // They poll for well under a millisecond, then sleep; allow a loaded machine seconds to schedule them.
  std::string polling;
  for (int wait = 0; wait < 400; ++wait) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    polling.clear();
    for (const std::string& id : task_ids())
      if (id != self && task_state(id) == 'R') polling = id;
    if (polling.empty()) break;
  }
  EXPECT_TRUE(polling.empty()) << "thread " << polling << " still running with nothing to do";
}

TEST(WorkerThreads, AThreadThatExitsTakesItsHelpersWithIt) {
  std::thread([] {}).join();  // a runtime that starts a thread of its own with the first one (ThreadSanitizer) has now
  const size_t before = task_ids().size();
  std::thread user([] { expect_each_part_once(3); });
  user.join();
  EXPECT_EQ(task_ids().size(), before);
}

TEST(WorkerThreads, AForkedChildStartsItsOwnHelpers) {
  expect_each_part_once(2);  // this thread has helpers now; the child will not
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    alarm(60);  // a hang ends the child with SIGALRM instead of stalling the test
    int ok = 1;
    for (int round = 0; round < 50 && ok; ++round) {
      std::atomic<int> parts{0};
      arap::run_on_threads(2, [&](int) { ++parts; });
      ok = parts.load() == 2;
    }
    _exit(ok ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status)) << "the child did not exit normally (signal " << WTERMSIG(status) << ")";
  EXPECT_EQ(WEXITSTATUS(status), 0);
  expect_each_part_once(2);  // and the parent's still work
}

}  // namespace
