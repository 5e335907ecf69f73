#include "volume/volume.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include <Eigen/Geometry>

#include "union_find.h"

namespace arap {

namespace {

double triple(const double* a, const double* b, const double* c) {
  return a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
}

double polynomial(const double a[4], double x) { return ((a[3] * x + a[2]) * x + a[1]) * x + a[0]; }

// Real roots of a0 + a1 x + a2 x^2 (+ a3 x^3 when `cubic`) by closed form,
// appended to roots[count]: the cubic (Cardano / trigonometric), the quadratic
// (its cancellation-free pair), or the line they degenerate to.
void closed_form_roots(const double a[4], bool cubic, double* roots, int& count) {
  if (cubic) {
    const double b = a[2] / a[3], c = a[1] / a[3], d = a[0] / a[3];
    const double p = c - b * b / 3, q = 2 * b * b * b / 27 - b * c / 3 + d;
    const double discriminant = q * q / 4 + p * p * p / 27;
    if (discriminant > 0) {
      const double s = std::sqrt(discriminant);
      roots[count++] = std::cbrt(-q / 2 + s) + std::cbrt(-q / 2 - s) - b / 3;
    } else if (p < 0) {
      const double r = std::sqrt(-p / 3);
      const double phi = std::acos(std::clamp(3 * q / (2 * p) * std::sqrt(-3 / p), -1.0, 1.0));
      for (int k = 0; k < 3; ++k) roots[count++] = 2 * r * std::cos(phi / 3 - 2 * M_PI * k / 3) - b / 3;
    } else {
      roots[count++] = -b / 3;  // a triple root
    }
  } else if (a[2] != 0) {
    const double discriminant = a[1] * a[1] - 4 * a[2] * a[0];
    if (discriminant < 0) return;
    const double q = -0.5 * (a[1] + std::copysign(std::sqrt(discriminant), a[1]));
    roots[count++] = q / a[2];
    if (q != 0) roots[count++] = a[0] / q;
  } else if (a[1] != 0) {
    roots[count++] = -a[0] / a[1];
  }
}

// The real root of a0 + a1 x + a2 x^2 + a3 x^3 nearest 0 (NaN when there is
// none). Candidates: the cubic's closed form, and the quadratic's with a3
// dropped (a short step has a3 x^3 negligible, and then the cubic's closed form
// divides by a tiny a3 and loses the small root to cancellation); each is
// refined by Newton steps on the full polynomial and kept only when it is a
// root there to rounding.
double root_nearest_zero(const double a[4]) {
  if (a[0] == 0) return 0;
  double roots[5];
  int count = 0;
  if (a[3] != 0) closed_form_roots(a, true, roots, count);
  closed_form_roots(a, false, roots, count);
  double best = NAN;
  for (int k = 0; k < count; ++k) {
    double x = roots[k];
    for (int it = 0; it < 8; ++it) {
      const double slope = (3 * a[3] * x + 2 * a[2]) * x + a[1];
      if (slope == 0) break;
      const double next = x - polynomial(a, x) / slope;
      if (!std::isfinite(next)) break;
      if (next == x) break;
      x = next;
    }
    const double terms = std::abs(a[0]) + std::abs(a[1] * x) + std::abs(a[2] * x * x) + std::abs(a[3] * x * x * x);
    if (!std::isfinite(x) || !(std::abs(polynomial(a, x)) <= 1e-10 * terms)) continue;
    if (!(std::abs(x) >= std::abs(best))) best = x;
  }
  return best;
}

}  // namespace

void VolumeConstraint::bind(const BoundMesh& m, const Triangles& triangles) {
  free_vertices_ = m.free_vertices;
  const int n = m.n;
  // Components over shared vertices.
  UnionFind sets(n);
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    sets.join(triangles(f, 0), triangles(f, 1));
    sets.join(triangles(f, 0), triangles(f, 2));
  }
  std::vector<int> component(n, -1);
  std::vector<std::vector<int>> faces;
  for (Eigen::Index f = 0; f < triangles.rows(); ++f) {
    const int r = sets.root(triangles(f, 0));
    if (component[r] < 0) component[r] = static_cast<int>(faces.size()), faces.emplace_back();
    faces[component[r]].push_back(static_cast<int>(f));
  }
  // Size of the rest shape, for the retraction's reach.
  const Eigen::RowVector3d lo = m.rest.colwise().minCoeff(), hi = m.rest.colwise().maxCoeff();
  reach_ = 0.5 * (hi - lo).norm();
  const double diagonal = (hi - lo).norm();
  const double tiny_volume = 1e-12 * diagonal * diagonal * diagonal;  // not std::pow: see portable_math.h

  triangle_begin_.assign(1, 0);
  corners_.clear();
  corner_rows_.clear();
  target_.clear();
  open_ = 0;
  row_component_.assign(m.free_vertices.size(), -1);
  std::unordered_map<std::uint64_t, int> directed;
  auto key = [](int a, int b) { return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b); };
  for (const std::vector<int>& list : faces) {
    // Closed and consistently oriented: every directed edge once, its reverse once.
    directed.clear();
    for (int f : list)
      for (int k = 0; k < 3; ++k) ++directed[key(triangles(f, k), triangles(f, (k + 1) % 3))];
    bool closed = true;
    for (const auto& [edge, count] : directed) {
      const auto reverse = directed.find(key(static_cast<int>(edge & 0xffffffffu), static_cast<int>(edge >> 32)));
      if (count != 1 || reverse == directed.end() || reverse->second != 1) {
        closed = false;
        break;
      }
    }
    if (!closed) {
      ++open_;
      continue;
    }
    double six_v = 0;
    bool has_free = false;
    for (int f : list) {
      six_v += triple(m.rest.row(triangles(f, 0)).data(), m.rest.row(triangles(f, 1)).data(),
                      m.rest.row(triangles(f, 2)).data());
      for (int k = 0; k < 3; ++k) has_free |= m.free_row[triangles(f, k)] >= 0;
    }
    if (!has_free || !(std::abs(six_v / 6) > tiny_volume)) continue;
    const int c = static_cast<int>(target_.size());
    target_.push_back(six_v / 6);
    for (int f : list)
      for (int k = 0; k < 3; ++k) {
        const int v = triangles(f, k);
        corners_.push_back(v);
        corner_rows_.push_back(m.free_row[v]);
        if (m.free_row[v] >= 0) row_component_[m.free_row[v]] = c;
      }
    triangle_begin_.push_back(static_cast<int>(corners_.size() / 3));
  }
  scratch_.assign(target_.size(), 0.0);
  normal_dot_.assign(target_.size(), 0.0);
  longest_u_.assign(target_.size(), 0.0);
}

void VolumeConstraint::gradient(const double* P, double* n) const {
  std::fill(n, n + 3 * row_component_.size(), 0.0);
  // dV/dp_a = (p_b x p_c) / 6 for the triangle (a, b, c), and cyclically (the 1/6 at the end).
  const size_t triangles = corners_.size() / 3;
  for (size_t t = 0; t < triangles; ++t) {
    const int* v = &corners_[3 * t];
    const int* rows = &corner_rows_[3 * t];
    const Eigen::Vector3d p0(P + 3 * v[0]), p1(P + 3 * v[1]), p2(P + 3 * v[2]);
    if (rows[0] >= 0) Eigen::Map<Eigen::Vector3d>(n + 3 * rows[0]) += p1.cross(p2);
    if (rows[1] >= 0) Eigen::Map<Eigen::Vector3d>(n + 3 * rows[1]) += p2.cross(p0);
    if (rows[2] >= 0) Eigen::Map<Eigen::Vector3d>(n + 3 * rows[2]) += p0.cross(p1);
  }
  for (size_t k = 0; k < 3 * row_component_.size(); ++k) n[k] *= 1.0 / 6;
}

void VolumeConstraint::component_dots(const double* a, const double* b, double* out) const {
  std::fill(out, out + target_.size(), 0.0);
  for (size_t r = 0; r < row_component_.size(); ++r) {
    const int c = row_component_[r];
    if (c >= 0) out[c] += a[3 * r] * b[3 * r] + a[3 * r + 1] * b[3 * r + 1] + a[3 * r + 2] * b[3 * r + 2];
  }
}

void VolumeConstraint::subtract(double* a, const double* coefficient, const double* b) const {
  for (size_t r = 0; r < row_component_.size(); ++r) {
    const int c = row_component_[r];
    if (c < 0) continue;
    for (int d = 0; d < 3; ++d) a[3 * r + d] -= coefficient[c] * b[3 * r + d];
  }
}

void VolumeConstraint::set_normal(const double* n, const double* u) {
  component_dots(n, u, normal_dot_.data());
  std::fill(longest_u_.begin(), longest_u_.end(), 0.0);
  for (size_t r = 0; r < row_component_.size(); ++r) {
    const int c = row_component_[r];
    if (c >= 0)
      longest_u_[c] =
          std::max(longest_u_[c], u[3 * r] * u[3 * r] + u[3 * r + 1] * u[3 * r + 1] + u[3 * r + 2] * u[3 * r + 2]);
  }
  for (double& l : longest_u_) l = std::sqrt(l);
}

void VolumeConstraint::project_tangent(double* d, const double* n, const double* u) {
  component_dots(n, d, scratch_.data());
  for (size_t c = 0; c < target_.size(); ++c) scratch_[c] = normal_dot_[c] > 0 ? scratch_[c] / normal_dot_[c] : 0.0;
  subtract(d, scratch_.data(), u);
}

void VolumeConstraint::lagrangian_gradient(double* g, const double* n, const double* u) {
  component_dots(u, g, scratch_.data());
  for (size_t c = 0; c < target_.size(); ++c) scratch_[c] = normal_dot_[c] > 0 ? scratch_[c] / normal_dot_[c] : 0.0;
  subtract(g, scratch_.data(), n);
}

void VolumeConstraint::cubic(const double* P, const double* u, int c, double a[4]) const {
  static const double kZero[3] = {0, 0, 0};
  double a0 = 0, a1 = 0, a2 = 0, a3 = 0;
  for (int t = triangle_begin_[c]; t < triangle_begin_[c + 1]; ++t) {
    const Eigen::Vector3d p0(P + 3 * corners_[3 * t]), p1(P + 3 * corners_[3 * t + 1]), p2(P + 3 * corners_[3 * t + 2]);
    const int* rows = &corner_rows_[3 * t];
    const Eigen::Vector3d q0(rows[0] >= 0 ? u + 3 * rows[0] : kZero), q1(rows[1] >= 0 ? u + 3 * rows[1] : kZero),
        q2(rows[2] >= 0 ? u + 3 * rows[2] : kZero);
    // det[p0 + mu q0, p1 + mu q1, p2 + mu q2] in powers of mu, from three cross products.
    const Eigen::Vector3d pp = p1.cross(p2), mixed = q1.cross(p2) + p1.cross(q2), qq = q1.cross(q2);
    a0 += p0.dot(pp);
    a1 += q0.dot(pp) + p0.dot(mixed);
    a2 += p0.dot(qq) + q0.dot(mixed);
    a3 += q0.dot(qq);
  }
  a[0] = a0 / 6, a[1] = a1 / 6, a[2] = a2 / 6, a[3] = a3 / 6;
}

bool VolumeConstraint::retract(double* P, const double* u) {
  for (size_t c = 0; c < target_.size(); ++c) {
    double a[4];
    cubic(P, u, static_cast<int>(c), a);
    a[0] -= target_[c];
    const double mu = root_nearest_zero(a);
    if (!std::isfinite(mu) || !(std::abs(mu) * longest_u_[c] <= reach_)) return false;
    scratch_[c] = mu;
  }
  for (size_t r = 0; r < row_component_.size(); ++r) {
    const int c = row_component_[r];
    if (c < 0) continue;
    double* p = P + 3 * free_vertices_[r];
    for (int d = 0; d < 3; ++d) p[d] += scratch_[c] * u[3 * r + d];
  }
  return true;
}

double VolumeConstraint::drift(const double* P) const {
  double worst = 0;
  for (size_t c = 0; c < target_.size(); ++c) {
    double six_v = 0;
    for (int t = triangle_begin_[c]; t < triangle_begin_[c + 1]; ++t)
      six_v += triple(P + 3 * corners_[3 * t], P + 3 * corners_[3 * t + 1], P + 3 * corners_[3 * t + 2]);
    worst = std::max(worst, std::abs(six_v / 6 / target_[c] - 1));
  }
  return worst;
}

}  // namespace arap
