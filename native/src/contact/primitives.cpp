#include "contact/primitives.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

namespace arap::contact {
namespace {

// The parameter u in [0, 1] of the point a + u (b - a) closest to p; 0 for a
// zero-length segment.
double closest_on_segment(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double length2 = ab.squaredNorm();
  if (!(length2 > 0)) return 0.0;
  return std::clamp((p - a).dot(ab) / length2, 0.0, 1.0);
}

// Point p against segment (a, b) as weights {1, -(1 - u), -u}; returns |v|^2.
double point_segment_distance2(const Vec3& p, const Vec3& a, const Vec3& b, double& u) {
  u = closest_on_segment(p, a, b);
  return ((p - a) - u * (b - a)).squaredNorm();
}

// A candidate pair of closest points, kept when nearer than the best so far.
struct Best {
  double distance2 = HUGE_VAL;
  double w[4] = {0, 0, 0, 0};
  bool any = false;
  void offer(double d2, double w0, double w1, double w2, double w3) {
    if (any && !(d2 < distance2)) return;
    any = true;
    distance2 = d2;
    w[0] = w0;
    w[1] = w1;
    w[2] = w2;
    w[3] = w3;
  }
};

}  // namespace

double point_triangle_distance2(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, double w[4]) {
  const Vec3 ab = b - a, bc = c - b, ca = a - c;
  const Vec3 n = ab.cross(-ca);
  Best best;
  if (!(n.squaredNorm() > 0)) {
    // Zero area: the three points are collinear and the longest edge holds the others.
    const double lab = ab.squaredNorm(), lbc = bc.squaredNorm(), lca = ca.squaredNorm();
    double u = 0;
    if (lab >= lbc && lab >= lca) {
      const double d2 = point_segment_distance2(p, a, b, u);
      best.offer(d2, 1, -(1 - u), -u, 0);
    } else if (lbc >= lca) {
      const double d2 = point_segment_distance2(p, b, c, u);
      best.offer(d2, 1, 0, -(1 - u), -u);
    } else {
      const double d2 = point_segment_distance2(p, c, a, u);
      best.offer(d2, 1, -u, 0, -(1 - u));
    }
  } else {
    // The projection of p onto the plane has barycentric coordinates proportional
    // to the signed areas n . ((b - p) x (c - p)) etc. (the component of p along n
    // drops out). When all three are >= 0 the projection is the closest point.
    const Vec3 pa = a - p, pb = b - p, pc = c - p;
    const double area_a = n.dot(pb.cross(pc)), area_b = n.dot(pc.cross(pa)), area_c = n.dot(pa.cross(pb));
    const double sum = area_a + area_b + area_c;  // |n|^2 up to rounding
    if (area_a >= 0 && area_b >= 0 && area_c >= 0 && sum > 0) {
      const double beta_b = area_b / sum, beta_c = area_c / sum, beta_a = 1 - beta_b - beta_c;
      best.offer((-pa - beta_b * ab + beta_c * ca).squaredNorm(), 1, -beta_a, -beta_b, -beta_c);
    }
    // Otherwise the closest point is on the boundary. The edges are also tried
    // when the projection is inside: near a degenerate triangle the signs above
    // are unreliable, and the nearest edge point bounds the error.
    double u = 0;
    double d2 = point_segment_distance2(p, a, b, u);
    best.offer(d2, 1, -(1 - u), -u, 0);
    d2 = point_segment_distance2(p, b, c, u);
    best.offer(d2, 1, 0, -(1 - u), -u);
    d2 = point_segment_distance2(p, c, a, u);
    best.offer(d2, 1, -u, 0, -(1 - u));
  }
  std::copy(best.w, best.w + 4, w);
  return best.distance2;
}

double edge_edge_distance2(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1, double w[4]) {
  const Vec3 da = a1 - a0, db = b1 - b0, r = b0 - a0;
  Best best;
  // Interior critical point of |a0 + s da - b0 - t db|^2. With n = da x db,
  // s |n|^2 = (r x db) . n and t |n|^2 = (r x da) . n: cross products of the
  // differences lose less to cancellation than the normal equations'
  // (da.da)(db.db) - (da.db)^2. Parallel lines (n = 0) have their closest
  // points at an endpoint, found below.
  const Vec3 n = da.cross(db);
  const double n2 = n.squaredNorm();
  if (n2 > 0) {
    const double s = r.cross(db).dot(n) / n2, t = r.cross(da).dot(n) / n2;
    if (s > 0 && s < 1 && t > 0 && t < 1) best.offer((s * da - t * db - r).squaredNorm(), 1 - s, s, -(1 - t), -t);
  }
  // Otherwise some closest pair has an endpoint (s or t in {0, 1}). The
  // endpoints are tried also after an interior point, so that a nearly parallel
  // pair never does worse than its endpoints.
  double u = 0;
  double d2 = point_segment_distance2(a0, b0, b1, u);
  best.offer(d2, 1, 0, -(1 - u), -u);
  d2 = point_segment_distance2(a1, b0, b1, u);
  best.offer(d2, 0, 1, -(1 - u), -u);
  d2 = point_segment_distance2(b0, a0, a1, u);
  best.offer(d2, 1 - u, u, -1, 0);
  d2 = point_segment_distance2(b1, a0, a1, u);
  best.offer(d2, 1 - u, u, 0, -1);
  std::copy(best.w, best.w + 4, w);
  return best.distance2;
}

double point_triangle_separation(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 axis = (a + b + c) / 3 - p;
  const double length = axis.norm();
  if (!(length > 0)) return 0;
  // The triangle's nearest reach toward p along the axis, over its corners.
  const double nearest = std::min({(a - p).dot(axis), (b - p).dot(axis), (c - p).dot(axis)}) / length;
  return std::max(0.0, nearest);
}

double edge_edge_separation(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1) {
  const Vec3 axis = (b0 + b1 - a0 - a1) / 2;
  const double length = axis.norm();
  if (!(length > 0)) return 0;
  // Each segment projects to its midpoint's place +- half its extent along the axis.
  const double half_extents = 0.5 * (std::abs((a1 - a0).dot(axis)) + std::abs((b1 - b0).dot(axis))) / length;
  return std::max(0.0, length - half_extents);
}

namespace {

// Whether the closed 2D segments (a, b) and (c, d) share a point, from
// orientation signs (collinear cases by bounding boxes).
double orient2(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

bool on_segment2(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& x) {
  // x is collinear with (a, b): inside the segment iff inside its bounding box.
  return std::min(a.x(), b.x()) <= x.x() && x.x() <= std::max(a.x(), b.x()) && std::min(a.y(), b.y()) <= x.y() &&
         x.y() <= std::max(a.y(), b.y());
}

int sign(double x) { return (x > 0) - (x < 0); }

bool segments_meet2(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                    const Eigen::Vector2d& d) {
  const int o1 = sign(orient2(a, b, c)), o2 = sign(orient2(a, b, d));
  const int o3 = sign(orient2(c, d, a)), o4 = sign(orient2(c, d, b));
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  return (o1 == 0 && on_segment2(a, b, c)) || (o2 == 0 && on_segment2(a, b, d)) || (o3 == 0 && on_segment2(c, d, a)) ||
         (o4 == 0 && on_segment2(c, d, b));
}

// Closed 2D point-in-triangle (either winding).
bool in_triangle2(const Eigen::Vector2d& x, const Eigen::Vector2d& p, const Eigen::Vector2d& q,
                  const Eigen::Vector2d& r) {
  const double s1 = orient2(p, q, x), s2 = orient2(q, r, x), s3 = orient2(r, p, x);
  return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
}

}  // namespace

bool segment_crosses_triangle(const Vec3& a, const Vec3& b, const Vec3& p, const Vec3& q, const Vec3& r) {
  const Vec3 n = (q - p).cross(r - p);
  // Signed volumes of (p, q, r, a) and (p, q, r, b): the sides of the plane.
  const double sa = n.dot(a - p), sb = n.dot(b - p);
  if ((sa > 0 && sb > 0) || (sa < 0 && sb < 0)) return false;
  if (sa != 0 || sb != 0) {
    // The segment meets the plane at one point: inside the closed triangle iff
    // the line through (a, b) passes on the same side of the three edges. The
    // three volumes sum to (b - a) . n = sb - sa != 0, so they are not all zero.
    const Vec3 d = b - a, pa = p - a, qa = q - a, ra = r - a;
    const double s1 = d.dot(pa.cross(qa)), s2 = d.dot(qa.cross(ra)), s3 = d.dot(ra.cross(pa));
    return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
  }
  if (!(n.squaredNorm() > 0)) {
    // A zero-area triangle (every point is "coplanar" with it): a distance test
    // against its longest edge, with a tolerance at the rounding of the coordinates.
    const double lpq = (q - p).squaredNorm(), lqr = (r - q).squaredNorm(), lrp = (p - r).squaredNorm();
    const Vec3& e0 = lpq >= lqr && lpq >= lrp ? p : (lqr >= lrp ? q : r);
    const Vec3& e1 = lpq >= lqr && lpq >= lrp ? q : (lqr >= lrp ? r : p);
    const double scale = std::max({a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff(), p.cwiseAbs().maxCoeff(),
                                   q.cwiseAbs().maxCoeff(), r.cwiseAbs().maxCoeff()});
    const double tolerance = 16 * std::numeric_limits<double>::epsilon() * scale;
    double w[4];
    return edge_edge_distance2(a, b, e0, e1, w) <= tolerance * tolerance;
  }
  // Coplanar: 2D tests after dropping the normal's dominant axis (the projected
  // triangle then has the nonzero area |n_k|).
  int k = 0;
  n.cwiseAbs().maxCoeff(&k);
  const int i = (k + 1) % 3, j = (k + 2) % 3;
  const auto project = [i, j](const Vec3& x) { return Eigen::Vector2d(x[i], x[j]); };
  const Eigen::Vector2d a2 = project(a), b2 = project(b), p2 = project(p), q2 = project(q), r2 = project(r);
  return in_triangle2(a2, p2, q2, r2) || in_triangle2(b2, p2, q2, r2) || segments_meet2(a2, b2, p2, q2) ||
         segments_meet2(a2, b2, q2, r2) || segments_meet2(a2, b2, r2, p2);
}

}  // namespace arap::contact
