// The settle after the last step of a drag: each method binds, settles the
// case's pose with the default options, then the handles move a little further
// (`step` times the longest side of the bounding box, along their mean motion)
// and it settles again, warm-started as Live and Auto mode do. What is
// measured is that second solve: iterations and CPU time to the tolerance stop,
// and whether it lands in the band E <= E* + 1e-3 |E*| of the moved pose.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "bench_cases.h"

namespace bench {

struct SettleSettings {
  double step = 0.05;               // the further step, times the bounding box's longest side
  int repeats = 3;                  // timed settles per method (the median is kept)
  int reference_iterations = 4000;  // budget of the run that finds E* from the best settle
  double band = 1e-3;
};

// One mesh: per method the settle's median CPU ms, iterations, energy, band and the iteration that first
// entered the band; E*.
nlohmann::json settle_after_step(const Case& c, const SettleSettings& settings);

// The markdown table of a list of settle_after_step() results.
std::string settle_table(const nlohmann::json& meshes);

}  // namespace bench
