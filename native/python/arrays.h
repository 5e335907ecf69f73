// Numpy arrays in and out of the module: positions, triangles, vertex indices.
//
// Positions are (n, 3) or flat (3n,) C-contiguous float64 (mapped without a
// copy) or float32 (converted to double once). Results are written into a
// buffer the caller owns (float32 or float64, (n, 3) or flat).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "arap/types.h"

namespace arap_python {

namespace py = pybind11;

// A read-only (rows x 3) view of a numpy array: mapped in place when it is
// C-contiguous float64, otherwise converted once into `storage`.
struct PointsView {
  arap::Points storage;
  const double* data = nullptr;
  Eigen::Index rows = 0;
  Eigen::Map<const arap::Points> map() const { return Eigen::Map<const arap::Points>(data, rows, 3); }
};
PointsView view_points(const py::array& a, const char* what);

// The caller's buffer for a result (#V by 3). Checks happen with the GIL held;
// the copy itself may run without it.
struct OutBuffer {
  void* data = nullptr;
  bool is_double = true;
};
// `out` as a buffer for `rows` vertices: float32/float64, (n, 3) or flat, C-contiguous, writeable.
OutBuffer check_out(py::array& out, Eigen::Index rows, const char* what);
// Copies `src` into the buffer; a float32 buffer receives nothing unless every value fits.
void copy_out(const arap::Points& src, const OutBuffer& b);

// A new (rows, 3) float64 array holding `p`.
py::array_t<double> new_points_array(const arap::Points& p);

// Triangles from an (m, 3) or flat array of int32 or int64 indices.
arap::Triangles to_triangles(const py::array& a);
// Vertex indices from a 1-D array or sequence of integers (int32 and int64,
// numpy's default, are both accepted). Indices beyond the mesh are the core's
// to refuse (its messages name the group).
std::vector<int> to_indices(const py::handle& a, const std::string& what);

}  // namespace arap_python
