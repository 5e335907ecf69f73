// libFuzzer target: arap::io::load_scenario() on arbitrary bytes, then
// build_constraints() against a small mesh. Either throws arap::Error /
// FileError, or gives finite targets for in-range, distinct vertices.
#include <cstdint>
#include <set>

#include "arap/errors.h"
#include "arap/io/mesh_io.h"
#include "arap/io/scenario.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = arap_fuzz::scratch_file("scenario.json", data, size);
  arap::Points rest(6, 3);
  rest << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1;
  try {
    const arap::io::Scenario s = arap::io::load_scenario(path);
    const arap::io::Constraints c = arap::io::build_constraints(rest, s.fixed, s.handles);
    if (!c.targets.allFinite()) arap_fuzz::broken("non-finite target returned");
    if (c.targets.rows() != static_cast<Eigen::Index>(c.constrained.size())) arap_fuzz::broken("target count");
    std::set<int> seen;
    for (int i : c.constrained)
      if (i < 0 || i >= rest.rows() || !seen.insert(i).second) arap_fuzz::broken("bad constrained index returned");
  } catch (const arap::Error&) {
  } catch (const arap::io::FileError&) {
  }
  return 0;
}
