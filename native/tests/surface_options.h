// The options of surface ARAP alone (Sorkine & Alexa 2007), the energy most
// solver tests check: the library's default adds Volume Infill's lattice.
#pragma once

#include "arap/options.h"

namespace arap_test {

inline arap::Options surface_options() {
  arap::Options o;
  o.volume = arap::Volume::None;
  return o;
}

}  // namespace arap_test
