#include "local_step.h"

#include <algorithm>
#include <atomic>

#include "arap/rotation_fit.h"
#include "runtime/worker_threads.h"

namespace arap {

namespace {

// Runs body(i) for i in [0, n) and returns the sum of the results. With more
// than one thread, runs of kChunk vertices are handed out in turn to the
// calling thread and its helpers (worker_threads.h, which poll only briefly
// after a section: an OpenMP pool's longer-spinning workers slowed the serial
// triangular solve that follows on 2 busy cores). body(i) writes only vertex i's outputs
// and the results are integers, so which thread ran which chunk changes nothing.
template <class Body>
long for_each_vertex(int n, int threads, const Body& body) {
  auto run = [&](int begin, int end) {
    long sum = 0;
    for (int i = begin; i < end; ++i) sum += body(i);
    return sum;
  };
  // Not fixed halves: a rotation fit's cost varies from vertex to vertex, and one core of a
  // virtual or busy machine can run slower than the other; either left a thread waiting.
  constexpr int kChunk = 1024;
  constexpr int kMaxThreads = 64;  // Options::threads' limit (options.cpp)
  // A chunk per thread at least: small meshes run on one.
  threads = std::max(1, std::min({threads, n / kChunk, kMaxThreads}));
  if (threads == 1) return run(0, n);
  std::atomic<int> next{0};
  long sums[kMaxThreads] = {};  // on the stack: the iteration allocates nothing
  run_on_threads(threads, [&](int t) {
    for (int begin = next.fetch_add(kChunk); begin < n; begin = next.fetch_add(kChunk))
      sums[t] += run(begin, std::min(n, begin + kChunk));
  });
  long total = 0;
  for (int t = 0; t < threads; ++t) total += sums[t];
  return total;
}

}  // namespace

double local_step(const BoundMesh& m, const double* P, Eigen::Matrix3d* R, double* cell_energy, int threads,
                  long* fallbacks, double* lambda) {
  const int* begin = m.spoke_begin.data();
  const int* neighbor = m.neighbor.data();
  const Spoke* spokes = m.spokes.data();
  const long fallback_count = for_each_vertex(m.n, threads, [&](int i) -> long {
    const double px = P[3 * i], py = P[3 * i + 1], pz = P[3 * i + 2];
    double a00 = 0, a01 = 0, a02 = 0, a10 = 0, a11 = 0, a12 = 0, a20 = 0, a21 = 0, a22 = 0, deformed = 0;
    for (int k = begin[i]; k < begin[i + 1]; ++k) {
      const double* q = P + 3 * neighbor[k];
      const double ex = px - q[0], ey = py - q[1], ez = pz - q[2];
      const Spoke& s = spokes[k];
      a00 += ex * s.gx, a01 += ex * s.gy, a02 += ex * s.gz;
      a10 += ey * s.gx, a11 += ey * s.gy, a12 += ey * s.gz;
      a20 += ez * s.gx, a21 += ez * s.gy, a22 += ez * s.gz;
      deformed += s.w * (ex * ex + ey * ey + ez * ez);
    }
    Eigen::Matrix3d A;
    A << a00, a01, a02, a10, a11, a12, a20, a21, a22;
    const bool fell_back = fit_rotation(A, R[i], lambda ? lambda + i : nullptr);
    cell_energy[i] = m.stiffness[i] * (deformed + m.rest_spoke_energy[i] - 2.0 * R[i].cwiseProduct(A).sum());
    return fell_back ? 1 : 0;
  });
  if (fallbacks) *fallbacks += fallback_count;
  double total = 0;
  for (int i = 0; i < m.n; ++i) total += cell_energy[i];
  return total;
}

void assemble_rhs(const BoundMesh& m, const Eigen::Matrix3d* R, const double* coupled, double* rhs, int threads) {
  const int nf = static_cast<int>(m.free_vertices.size());
  for_each_vertex(nf, threads, [&](int r) -> long {
    const int i = m.free_vertices[r];
    Eigen::Vector3d b =
        m.stiffness[i] * (R[i] * Eigen::Vector3d(m.g_sum[3 * i], m.g_sum[3 * i + 1], m.g_sum[3 * i + 2]));
    for (int k = m.spoke_begin[i]; k < m.spoke_begin[i + 1]; ++k) {
      const Spoke& s = m.spokes[k];
      const int j = m.neighbor[k];
      b += m.stiffness[j] * (R[j] * Eigen::Vector3d(s.gx, s.gy, s.gz));
    }
    rhs[3 * r] = 0.5 * b.x() + coupled[3 * r];
    rhs[3 * r + 1] = 0.5 * b.y() + coupled[3 * r + 1];
    rhs[3 * r + 2] = 0.5 * b.z() + coupled[3 * r + 2];
    return 0;
  });
}

void half_gradient(const BoundMesh& m, const double* P, const Eigen::Matrix3d* R, double* g, int threads) {
  const int nf = static_cast<int>(m.free_vertices.size());
  for_each_vertex(nf, threads, [&](int r) -> long {
    const int i = m.free_vertices[r];
    const double si = m.stiffness[i];
    const Eigen::Vector3d pi(P[3 * i], P[3 * i + 1], P[3 * i + 2]);
    Eigen::Vector3d b = si * (R[i] * Eigen::Vector3d(m.g_sum[3 * i], m.g_sum[3 * i + 1], m.g_sum[3 * i + 2]));
    Eigen::Vector3d l = Eigen::Vector3d::Zero();
    for (int k = m.spoke_begin[i]; k < m.spoke_begin[i + 1]; ++k) {
      const Spoke& s = m.spokes[k];
      const int j = m.neighbor[k];
      const double sj = m.stiffness[j];
      b += sj * (R[j] * Eigen::Vector3d(s.gx, s.gy, s.gz));
      l += (s.w * 0.5 * (si + sj)) * (pi - Eigen::Vector3d(P[3 * j], P[3 * j + 1], P[3 * j + 2]));
    }
    const Eigen::Vector3d gi = l - 0.5 * b;
    g[3 * r] = gi.x(), g[3 * r + 1] = gi.y(), g[3 * r + 2] = gi.z();
    return 0;
  });
}

void energy_gradient(const BoundMesh& m, const double* P, const Eigen::Matrix3d* R, double* gradient) {
  for (int i = 0; i < m.n; ++i) {
    const Eigen::Vector3d pi(P[3 * i], P[3 * i + 1], P[3 * i + 2]);
    const double si = m.stiffness[i];
    Eigen::Vector3d g =
        -2.0 * si * (R[i] * Eigen::Vector3d(m.g_sum[3 * i], m.g_sum[3 * i + 1], m.g_sum[3 * i + 2]));
    for (int k = m.spoke_begin[i]; k < m.spoke_begin[i + 1]; ++k) {
      const int j = m.neighbor[k];
      const Spoke& s = m.spokes[k];
      const double sj = m.stiffness[j];
      g += 2.0 * s.w * (si + sj) * (pi - Eigen::Vector3d(P[3 * j], P[3 * j + 1], P[3 * j + 2]));
      g -= 2.0 * sj * (R[j] * Eigen::Vector3d(s.gx, s.gy, s.gz));
    }
    gradient[3 * i] = g.x(), gradient[3 * i + 1] = g.y(), gradient[3 * i + 2] = g.z();
  }
}

}  // namespace arap
