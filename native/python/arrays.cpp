#include "arrays.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "arap/errors.h"

namespace arap_python {

namespace {

Eigen::Index rows_of_xyz(const py::array& a, const char* what) {
  if (a.ndim() == 2 && a.shape(1) == 3) return a.shape(0);
  if (a.ndim() == 1 && a.shape(0) % 3 == 0) return a.shape(0) / 3;
  std::string shape;
  for (py::ssize_t i = 0; i < a.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(a.shape(i));
  throw py::value_error(std::string(what) + ": expected an (n, 3) or flat (3n,) array, got shape (" + shape + ")");
}

void require_c_contiguous(const py::array& a, const char* what) {
  if (!(a.flags() & py::array::c_style))
    throw py::value_error(std::string(what) + ": the array must be C-contiguous (use numpy.ascontiguousarray)");
}

[[noreturn]] void refuse_dtype(const py::array& a, const char* what) {
  throw py::type_error(std::string(what) + ": expected a float32 or float64 array, got dtype " +
                       std::string(py::str(a.dtype())));
}

}  // namespace

PointsView view_points(const py::array& a, const char* what) {
  PointsView v;
  v.rows = rows_of_xyz(a, what);
  require_c_contiguous(a, what);
  if (py::isinstance<py::array_t<double>>(a)) {
    v.data = static_cast<const double*>(a.data());
  } else if (py::isinstance<py::array_t<float>>(a)) {
    v.storage = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>>(
                    static_cast<const float*>(a.data()), v.rows, 3)
                    .cast<double>();
    v.data = v.storage.data();
  } else {
    refuse_dtype(a, what);
  }
  return v;
}

OutBuffer check_out(py::array& out, Eigen::Index rows, const char* what) {
  if (rows_of_xyz(out, what) != rows)
    throw py::value_error(std::string(what) + ": has " + std::to_string(rows_of_xyz(out, what)) +
                          " rows, the mesh has " + std::to_string(rows) + " vertices");
  require_c_contiguous(out, what);
  if (!out.writeable()) throw py::value_error(std::string(what) + ": the array is read-only");
  OutBuffer b;
  if (py::isinstance<py::array_t<double>>(out)) {
    b.is_double = true;
  } else if (py::isinstance<py::array_t<float>>(out)) {
    b.is_double = false;
  } else {
    refuse_dtype(out, what);
  }
  b.data = out.mutable_data();
  return b;
}

// A finite double beyond 3.4e38 would become +-inf in the caller's mesh (and
// the cast is undefined behaviour): nothing is written then.
void copy_out(const arap::Points& src, const OutBuffer& b) {
  const Eigen::Index n = src.size();
  if (b.is_double) {
    std::memcpy(b.data, src.data(), sizeof(double) * static_cast<size_t>(n));
    return;
  }
  const double* s = src.data();
  constexpr double kFloatMax = std::numeric_limits<float>::max();
  for (Eigen::Index i = 0; i < n; ++i)
    if (!(std::abs(s[i]) <= kFloatMax))
      throw arap::Error(arap::ErrorCode::NonFinite,
                        "vertex " + std::to_string(i / 3) + " lands at " + std::to_string(s[i]) +
                            ", beyond the float32 range (3.4e38) of the output buffer; nothing was written");
  float* dst = static_cast<float*>(b.data);
  for (Eigen::Index i = 0; i < n; ++i) dst[i] = static_cast<float>(s[i]);
}

py::array_t<double> new_points_array(const arap::Points& p) {
  py::array_t<double> a({static_cast<py::ssize_t>(p.rows()), py::ssize_t(3)});
  std::memcpy(a.mutable_data(), p.data(), sizeof(double) * p.size());
  return a;
}

arap::Triangles to_triangles(const py::array& a) {
  const Eigen::Index rows = rows_of_xyz(a, "triangles");
  // int32 and int64 (numpy's default) are both accepted; the copy is small
  // next to the factorization that follows.
  py::array_t<int64_t, py::array::c_style | py::array::forcecast> t(a);
  arap::Triangles tri(rows, 3);
  const int64_t* s = t.data();
  for (Eigen::Index i = 0; i < rows * 3; ++i) {
    if (s[i] < 0 || s[i] > INT32_MAX)
      throw py::value_error("triangles: index " + std::to_string(s[i]) + " is negative or too large");
    tri.data()[i] = static_cast<int>(s[i]);
  }
  return tri;
}

std::vector<int> to_indices(const py::handle& a, const std::string& what) {
  py::array_t<int64_t, py::array::c_style | py::array::forcecast> t =
      py::array_t<int64_t, py::array::c_style | py::array::forcecast>::ensure(a);
  if (!t || t.ndim() != 1) throw py::value_error(what + ": expected a 1-D array of vertex indices");
  std::vector<int> out(static_cast<size_t>(t.shape(0)));
  for (size_t i = 0; i < out.size(); ++i) {
    const int64_t v = t.data()[i];
    if (v < 0 || v > INT32_MAX)
      throw py::value_error(what + ": index " + std::to_string(v) + " is negative or too large");
    out[i] = static_cast<int>(v);
  }
  return out;
}

}  // namespace arap_python
