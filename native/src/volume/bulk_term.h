// Volume::Infill's bulk term (infill_volume.h) as a volume term: an energy on
// the lattice nodes' volume change, added to ARAP's.
#pragma once

#include "volume/infill_volume.h"
#include "volume/volume_term.h"

namespace arap {

// With the default tolerance (1e-6) a solve stops 1e-4 of the diagonal from its limit, by
// the estimate: ten times within the 1e-3 the add-on's "settled" promises (docs/engine_internals.md).
constexpr double kInfillPoseStop = 100;

class BulkTerm final : public VolumeTerm {
 public:
  LatticeBulk& bulk() { return bulk_; }
  double energy(const double* P) const override { return bulk_.energy(P); }
  void add_half_gradient(const double* P, double* g) const override { bulk_.add_half_gradient(P, g); }
  void add_gradient(const double* P, double* gradient) const override { bulk_.add_gradient(P, gradient); }
  bool warm_global_step() const override { return false; }
  bool plain_step_may_rise() const override { return true; }
  double pose_stop_per_tolerance() const override { return kInfillPoseStop; }

 private:
  LatticeBulk bulk_;
};

}  // namespace arap
