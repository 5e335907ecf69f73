#include "cgal_arap.h"

#include <chrono>

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_deformation.h>

#include "cpu_clock.h"

namespace bench {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
using Deformation = CGAL::Surface_mesh_deformation<Mesh, CGAL::Default, CGAL::Default, CGAL::ORIGINAL_ARAP>;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

}  // namespace

CgalResult run_cgal_arap(const arap::Points& rest, const arap::Triangles& triangles,
                         const std::vector<int>& constrained, const arap::Points& targets, int iterations,
                         const std::function<void(const arap::Points&)>& after_iteration, double cpu_ms_limit) {
  CgalResult result;
  auto t = Clock::now();
  Mesh mesh;
  std::vector<Mesh::Vertex_index> vertex;
  vertex.reserve(rest.rows());
  for (Eigen::Index i = 0; i < rest.rows(); ++i)
    vertex.push_back(mesh.add_vertex(Kernel::Point_3(rest(i, 0), rest(i, 1), rest(i, 2))));
  for (Eigen::Index f = 0; f < triangles.rows(); ++f)
    if (mesh.add_face(vertex[triangles(f, 0)], vertex[triangles(f, 1)], vertex[triangles(f, 2)]) ==
        Mesh::null_face()) {
      result.error = "not a manifold mesh (Surface_mesh refused face " + std::to_string(f) + ")";
      return result;
    }
  result.build_ms = ms_since(t);

  t = Clock::now();
  const double preprocess_cpu = thread_cpu_ms();
  Deformation deformation(mesh);
  deformation.insert_roi_vertices(mesh.vertices().begin(), mesh.vertices().end());
  for (int v : constrained) deformation.insert_control_vertex(vertex[v]);
  if (!deformation.preprocess()) {
    result.error = "preprocess (factorization) failed";
    return result;
  }
  result.preprocess_ms = ms_since(t);
  result.preprocess_cpu_ms = thread_cpu_ms() - preprocess_cpu;

  for (size_t s = 0; s < constrained.size(); ++s) {
    const auto row = targets.row(static_cast<Eigen::Index>(s));
    deformation.set_target_position(vertex[constrained[s]], Kernel::Point_3(row[0], row[1], row[2]));
  }
  arap::Points positions(rest.rows(), 3);
  double iterations_cpu_ms = 0;
  for (int k = 0; k < iterations && iterations_cpu_ms <= cpu_ms_limit; ++k) {
    t = Clock::now();
    const double cpu = thread_cpu_ms();
    deformation.deform(1, 0.0);
    result.iteration_cpu_ms.push_back(thread_cpu_ms() - cpu);
    iterations_cpu_ms += result.iteration_cpu_ms.back();
    result.iteration_ms.push_back(ms_since(t));
    if (after_iteration) {
      for (Eigen::Index i = 0; i < rest.rows(); ++i) {
        const auto& p = mesh.point(vertex[i]);
        positions.row(i) << p.x(), p.y(), p.z();
      }
      after_iteration(positions);
    }
  }
  result.ok = true;
  return result;
}

}  // namespace bench
