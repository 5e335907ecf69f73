// Command line of arap-deform.
#pragma once

#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <vector>

#include "arap/options.h"

namespace arap::cli {

// A malformed command line; the message names the offending argument.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct HandleArg {
  std::string file;  // whitespace-separated vertex indices
  Eigen::Vector3d translate = Eigen::Vector3d::Zero();
  int rotate_axis = -1;       // 0, 1, 2 for x, y, z; -1 = no rotation
  double rotate_degrees = 0;  // about the handle's rest centroid
};

struct DeformArgs {
  std::string scenario;  // --scenario S.json, or
  std::string input;     // INPUT mesh with --fixed and --handle/--translate groups
  std::string fixed_file;
  std::vector<HandleArg> handles;
  Options options;  // --max-iterations, --tolerance, --init, --weights, --threads, --anderson-window
  std::string output;
  std::string report;
  bool quiet = false;
  bool help = false;
};

// Throws UsageError naming the offending argument.
DeformArgs parse_deform_args(int argc, const char* const* argv);

// The text of --help; the defaults and choices it names are arap::option_specs()'.
std::string deform_usage();

}  // namespace arap::cli
