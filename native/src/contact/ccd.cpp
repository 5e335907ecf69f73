#include "contact/ccd.h"

#include <algorithm>
#include <cmath>

namespace arap::contact {
namespace {

// Both distance functions take the pair's four points in the order of x.
using Distance2 = double (*)(const Vec3&, const Vec3&, const Vec3&, const Vec3&, double*);

// Enough for any step that does not graze at a small fraction of `separation`
// from contact for a long stretch; past it the step found so far is returned (still safe).
constexpr int kMaxIterations = 1000;

double distance2_at(Distance2 distance2, const Vec3 x[4], const Vec3 dx[4], double t) {
  const Vec3 y0 = x[0] + t * dx[0], y1 = x[1] + t * dx[1], y2 = x[2] + t * dx[2], y3 = x[3] + t * dx[3];
  double w[4];
  return distance2(y0, y1, y2, y3, w);
}

// The steps less their mean: the same relative motion (distances do not change
// under a common translation), with smaller norms for the bound l_p.
void relative_steps(const Vec3 dx[4], Vec3 out[4]) {
  const Vec3 mean = 0.25 * (dx[0] + dx[1] + dx[2] + dx[3]);
  for (int k = 0; k < 4; ++k) out[k] = dx[k] - mean;
}

// Additive CCD (Li et al. 2021, section 5). The distance decreases at most at
// rate l_p, so from a distance d a further step of c (d - separation) / l_p,
// c < 1, keeps it above separation + (1 - c) (d - separation). The step is
// written (d^2 - xi^2) / ((d + xi) l_p), xi = separation, so that d^2 - xi^2 comes from the
// squared distance without the cancellation of d - xi.
double additive_ccd(Distance2 distance2, const Vec3 x[4], const Vec3 dx[4], double l_p, double separation,
                    double reduction, double up_to) {
  const double xi2 = separation * separation;
  double d2 = distance2_at(distance2, x, dx, 0.0);
  if (!(d2 > xi2)) return 0.0;  // also a NaN distance
  if (l_p == 0) return 1.0;     // no relative motion: the distance stays the same
  const double gap0 = d2 - xi2;
  const double g = reduction * gap0;
  double t = 0;
  // The first step with the factor (1 - reduction), the later ones with 0.9 (paper).
  double t_l = (1 - reduction) * gap0 / ((std::sqrt(d2) + separation) * l_p);
  for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
    if (!(t_l > 0)) return t;  // no progress (underflow, or an infinite l_p)
    const double t_next = t + t_l;
    if (t_next >= 1) return 1.0;  // [t, 1] lies within the safe step
    d2 = distance2_at(distance2, x, dx, t_next);
    const double gap = d2 - xi2;
    if (!(gap > 0)) return t;  // only by rounding: the bound says otherwise
    // Close to an impact: return the time reached, whose gap is at least g unless
    // it is the first step's (the paper takes the first step in any case).
    if (t > 0 && gap < g) return t;
    t = t_next;
    if (t >= up_to) return t;  // the whole search returns t or later
    t_l = 0.9 * gap / ((std::sqrt(d2) + separation) * l_p);
  }
  return t;
}

}  // namespace

double point_triangle_impact(const Vec3 x[4], const Vec3 dx[4], double separation, double reduction,
                             double up_to) {
  Vec3 p[4];
  relative_steps(dx, p);
  // A point of the triangle moves by a convex combination of its vertices' steps.
  const double l_p = p[0].norm() + std::max({p[1].norm(), p[2].norm(), p[3].norm()});
  return additive_ccd(point_triangle_distance2, x, dx, l_p, separation, reduction, up_to);
}

double edge_edge_impact(const Vec3 x[4], const Vec3 dx[4], double separation, double reduction, double up_to) {
  Vec3 p[4];
  relative_steps(dx, p);
  // A point of either edge moves by a convex combination of its ends' steps.
  const double l_p = std::max(p[0].norm(), p[1].norm()) + std::max(p[2].norm(), p[3].norm());
  return additive_ccd(edge_edge_distance2, x, dx, l_p, separation, reduction, up_to);
}

}  // namespace arap::contact
