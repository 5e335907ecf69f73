// Wall time for the solve's statistics (the *_ms of SolveStats).
#pragma once

#include <chrono>

namespace arap {

using Clock = std::chrono::steady_clock;

inline double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace arap
