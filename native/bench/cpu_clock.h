// CPU time of the calling thread: what a measurement costs, whatever else
// runs on a shared machine (wall time counts the waits for a core too).
#pragma once

#include <ctime>

namespace bench {

inline double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

}  // namespace bench
