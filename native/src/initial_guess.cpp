#include "initial_guess.h"

#include "arap/errors.h"
#include "arap/weights.h"

namespace arap {

void laplacian_guess(const BoundMesh& m, const BlockCholesky& laplacian, const double* coupled, Points& P,
                     std::vector<double>& rhs, std::vector<double>& work) {
  const size_t nf = m.free_vertices.size();
  rhs.resize(3 * nf);
  for (size_t r = 0; r < nf; ++r) {
    const int i = m.free_vertices[r];
    double b[3] = {m.stiffness[i] * m.g_sum[3 * i], m.stiffness[i] * m.g_sum[3 * i + 1],
                   m.stiffness[i] * m.g_sum[3 * i + 2]};
    for (int k = m.spoke_begin[i]; k < m.spoke_begin[i + 1]; ++k) {
      const double sj = m.stiffness[m.neighbor[k]];
      b[0] += sj * m.spokes[k].gx, b[1] += sj * m.spokes[k].gy, b[2] += sj * m.spokes[k].gz;
    }
    for (int d = 0; d < 3; ++d) rhs[3 * r + d] = 0.5 * b[d] + coupled[3 * r + d];
  }
  laplacian.solve_in_place(rhs.data(), work);
  for (size_t r = 0; r < nf; ++r) P.row(m.free_vertices[r]) << rhs[3 * r], rhs[3 * r + 1], rhs[3 * r + 2];
}

void DifferentialGuess::prepare(const BoundMesh& m, const Triangles& triangles) {
  const std::vector<WeightedEdge> edges = edge_weights(m.rest, triangles, Weights::Uniform);
  std::vector<int> degree(m.n, 0);
  for (const auto& e : edges) ++degree[e.i], ++degree[e.j];
  std::vector<int> slot_of(m.n, -1);
  for (size_t s = 0; s < m.constrained.size(); ++s) slot_of[m.constrained[s]] = static_cast<int>(s);

  // M = I - D^-1 A (uniform Laplacian), split by column into free and constrained parts.
  std::vector<Eigen::Triplet<double>> free_entries, constrained_entries;
  auto put = [&](int row, int col, double value) {
    if (m.free_row[col] >= 0)
      free_entries.emplace_back(row, m.free_row[col], value);
    else
      constrained_entries.emplace_back(row, slot_of[col], value);
  };
  for (int v = 0; v < m.n; ++v) put(v, v, 1.0);
  for (const auto& e : edges) {
    put(e.i, e.j, -1.0 / degree[e.i]);
    put(e.j, e.i, -1.0 / degree[e.j]);
  }
  m_free_.resize(m.n, static_cast<Eigen::Index>(m.free_vertices.size()));
  m_free_.setFromTriplets(free_entries.begin(), free_entries.end());
  m_constrained_.resize(m.n, static_cast<Eigen::Index>(m.constrained.size()));
  m_constrained_.setFromTriplets(constrained_entries.begin(), constrained_entries.end());

  Eigen::Matrix<double, Eigen::Dynamic, 3> rest_free(m.free_vertices.size(), 3),
      rest_constrained(m.constrained.size(), 3);
  for (size_t r = 0; r < m.free_vertices.size(); ++r) rest_free.row(r) = m.rest.row(m.free_vertices[r]);
  for (size_t s = 0; s < m.constrained.size(); ++s) rest_constrained.row(s) = m.rest.row(m.constrained[s]);
  delta_ = m_free_ * rest_free + m_constrained_ * rest_constrained;

  const Eigen::SparseMatrix<double> normal = Eigen::SparseMatrix<double>(m_free_.transpose()) * m_free_;
  if (!normal_.factor(normal))
    throw Error(ErrorCode::Factorization, "the differential-coordinates system could not be factored");
  prepared_ = true;
}

void DifferentialGuess::solve(const BoundMesh& m, Points& P, std::vector<double>& work) const {
  Eigen::Matrix<double, Eigen::Dynamic, 3> targets(m.constrained.size(), 3);
  for (size_t s = 0; s < m.constrained.size(); ++s) targets.row(s) = P.row(m.constrained[s]);
  const Eigen::Matrix<double, Eigen::Dynamic, 3> residual = delta_ - m_constrained_ * targets;
  Points rhs = m_free_.transpose() * residual;  // row-major, #free by 3
  normal_.solve_in_place(rhs.data(), work);
  for (size_t r = 0; r < m.free_vertices.size(); ++r) P.row(m.free_vertices[r]) = rhs.row(r);
}

}  // namespace arap
