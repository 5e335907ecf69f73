// Small meshes made in code for the core tests.
#pragma once

#include <cmath>
#include <vector>

#include "arap/types.h"

namespace arap_test {

struct Mesh {
  arap::Points V;
  arap::Triangles F;
};

// An open tube along z: `rings` rings of `around` vertices, radius 1, height h.
inline Mesh tube(int around, int rings, double height) {
  Mesh m;
  m.V.resize(around * rings, 3);
  for (int r = 0; r < rings; ++r)
    for (int a = 0; a < around; ++a) {
      const double t = 2 * M_PI * a / around;
      m.V.row(r * around + a) << std::cos(t), std::sin(t), height * r / (rings - 1);
    }
  m.F.resize(2 * around * (rings - 1), 3);
  int f = 0;
  for (int r = 0; r + 1 < rings; ++r)
    for (int a = 0; a < around; ++a) {
      const int v00 = r * around + a, v01 = r * around + (a + 1) % around;
      const int v10 = v00 + around, v11 = v01 + around;
      m.F.row(f++) << v00, v01, v11;
      m.F.row(f++) << v00, v11, v10;
    }
  return m;
}

inline std::vector<int> ring_vertices(int around, int ring) {
  std::vector<int> out;
  for (int a = 0; a < around; ++a) out.push_back(ring * around + a);
  return out;
}

inline std::vector<int> concat(std::vector<int> a, const std::vector<int>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

inline arap::Points rows_of(const arap::Points& P, const std::vector<int>& idx) {
  arap::Points out(idx.size(), 3);
  for (size_t k = 0; k < idx.size(); ++k) out.row(k) = P.row(idx[k]);
  return out;
}

constexpr int kBentAround = 16, kBentRings = 21;

// A tube with its bottom ring fixed and its top ring moved sideways by `shift` (the bar bend).
struct BentTube {
  Mesh mesh = tube(kBentAround, kBentRings, 6.0);
  std::vector<int> constrained = concat(ring_vertices(kBentAround, 0), ring_vertices(kBentAround, kBentRings - 1));
  arap::Points targets;
  explicit BentTube(double shift = 2.5) {
    targets = rows_of(mesh.V, constrained);
    for (int k = kBentAround; k < 2 * kBentAround; ++k) targets(k, 0) += shift;
  }
};

}  // namespace arap_test
