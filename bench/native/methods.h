// The solver methods the time-to-band and settle measurements compare, by
// the labels their tables use, and the median they report.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "arap/options.h"

namespace bench {

struct MethodLabel {
  const char* label;
  arap::Method method;
};

inline const MethodLabel kLocalGlobal = {"local-global", arap::Method::LocalGlobal};
inline const MethodLabel kAnderson5 = {"anderson-5", arap::Method::Anderson};  // the default window, 5
inline const MethodLabel kQuasiNewton = {"quasi-newton", arap::Method::QuasiNewton};

// The options these benches measure the methods with: surface ARAP alone, the energy CGAL's
// Surface_mesh_deformation and the textbook minimise (the library's default adds Volume Infill).
inline arap::Options surface_options() {
  arap::Options o;
  o.volume = arap::Volume::None;
  return o;
}

inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? NAN : v[v.size() / 2];
}

}  // namespace bench
