// Time to a settled pose: how much CPU time each method needs, from a cold
// start, to bring the energy into the band E <= E* + 1e-3 |E*|, where E* is
// the lowest energy any of them reaches within a budget of iterations.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench_cases.h"

namespace bench {

struct BandSettings {
  int reference_iterations = 2000;  // budget of the runs that find E*
  int repeats = 3;                  // timed solves per method (the median is kept)
  double band = 1e-3;               // relative width of the band
  bool cgal = true;                 // also CGAL (when built in), up to cgal_max_vertices
  int cgal_max_vertices = 300000;
  // local-global and quasi-newton runs not in the band within the budget go on
  // (resumed by warm starts, which continue them exactly) up to this many
  // iterations to find when they enter it; E* stays the budget's. 0: off.
  int extend_iterations = 0;
  // The other methods (and CGAL) stop once their CPU time passes this many times what the
  // default method took to the band: "> t" then still bounds the ratio (below 1 / cap_ratio),
  // without hours of plain iterations on the largest meshes. 0: off.
  double cap_ratio = 0;
};

// One mesh: every method's energies over the budget, E*, iterations and
// median CPU ms to the band, and what the default settings (the tolerance
// stop) give: iterations, CPU ms, final energy, in the band or not.
nlohmann::json time_to_band(const Case& c, const BandSettings& settings);

// The markdown table of a list of time_to_band() results.
std::string band_table(const nlohmann::json& meshes);

}  // namespace bench
