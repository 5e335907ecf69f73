// The matrix types of the library's interface.
#pragma once

#include <Eigen/Core>

namespace arap {

// #V by 3 positions, row-major so that numpy (n, 3) buffers map without copies.
using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
// #F by 3 vertex indices of triangles.
using Triangles = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

}  // namespace arap
