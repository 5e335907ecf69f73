// Continuous collision detection of one primitive pair moving linearly over a
// step: each point goes from x_k to x_k + t dx_k, t in [0, 1]. Additive CCD
// (Li, Kaufman, Kim, Zorin & Jiang 2021, "Codimensional Incremental Potential
// Contact", section 5): conservative by construction, it never reports a
// fraction of the step as free when the pair comes within `separation` there.
#pragma once

#include "contact/primitives.h"

namespace arap::contact {

// The share of the starting gap d^2 - separation^2 at which the algorithm stops (the paper's 0.1).
constexpr double kImpactReduction = 0.1;

// A fraction t_safe in [0, 1] of the step such that for every t in [0, t_safe]
// the pair stays farther apart than `separation` (> 0). 0 when the pair is not
// farther apart than `separation` at t = 0, otherwise > 0 (finite steps); 1 when
// the four steps are equal. The algorithm stops once the gap d^2 - separation^2
// has shrunk to `reduction` (in (0, 1)) times its value at t = 0: before an
// impact t_safe is close to the time of impact, never past it, and a pair that
// only comes that close without touching stops short of 1 too. While the gap
// stays above that the result is 1, unless the pair stays a small fraction of
// `separation` beyond it for long: after 1000 steps of the algorithm the time
// reached is returned.
// `up_to`: a caller that only needs to know whether this pair stops the step
// before up_to (where another pair already stopped it) gets the same result
// when it is below up_to, else some fraction >= up_to, found sooner.
// Point p against triangle (a, b, c): x = {p, a, b, c}, dx their steps.
double point_triangle_impact(const Vec3 x[4], const Vec3 dx[4], double separation,
                             double reduction = kImpactReduction, double up_to = 1.0);
// Edge (a0, a1) against edge (b0, b1): x = {a0, a1, b0, b1}, dx their steps.
double edge_edge_impact(const Vec3 x[4], const Vec3 dx[4], double separation,
                        double reduction = kImpactReduction, double up_to = 1.0);

}  // namespace arap::contact
