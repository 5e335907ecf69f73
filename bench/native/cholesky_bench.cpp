// The bind's factorization, old against new on the same matrices: Eigen's
// simplicial Cholesky against ours (supernodal_cholesky.h), both inside
// BlockCholesky (same split, ordering and postorder), alternated in one
// process; CPU time of the calling thread, medians.
//   build/arap-bench-cholesky [--sizes 10000,50000] [--shapes bar,sphere] [--repeats 3] [--new-only]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench_cases.h"
#include "bound_mesh.h"
#include "cpu_clock.h"
#include "linalg/spd_solve.h"

namespace {

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');) out.push_back(item);
  return out;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> sizes = {"10000", "50000", "100000", "250000"}, shapes = {"bar", "sphere"};
  int repeats = 3;
  bool old_kernel = true;  // --new-only: skip Eigen's (for profiling)
  for (int i = 1; i < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--new-only") {
      old_kernel = false, --i;
      continue;
    }
    if (i + 1 == argc) return std::fprintf(stderr, "%s needs a value\n", argv[i]), 2;
    if (flag == "--sizes") sizes = split_list(argv[i + 1]);
    else if (flag == "--shapes") shapes = split_list(argv[i + 1]);
    else if (flag == "--repeats") repeats = std::max(1, std::stoi(argv[i + 1]));
    else return std::fprintf(stderr, "unknown flag %s\n", argv[i]), 2;
  }
  using Kernel = arap::BlockCholesky::Kernel;
  std::printf(
      "| mesh | rows | factor entries (old / new) | bind's factor() CPU ms, old / new | numeric factor ms, old / "
      "new | ratio | solve max rel. difference |\n|---|---:|---:|---:|---:|---:|---:|\n");
  for (const std::string& size : sizes)
    for (const std::string& shape : shapes) {
      const bench::Case c = bench::procedural_case(shape, std::stoi(size));
      const arap::BoundMesh mesh =
          arap::build_bound_mesh(c.rest, c.triangles, c.constrained, arap::Weights::CotanClamped, {});
      const Eigen::SparseMatrix<double>& A = mesh.laplacian_ff;
      std::vector<double> cpu[2], numeric[2];
      long entries[2] = {0, 0};
      std::vector<double> x[2], work;
      std::mt19937 rng(1);
      std::uniform_real_distribution<double> uniform(-1, 1);
      std::vector<double> b(3 * A.rows());
      for (double& v : b) v = uniform(rng);
      for (int r = 0; r < repeats; ++r)
        for (int k = !old_kernel; k < 2; ++k) {  // alternated, so that a burst of load hits both alike
          arap::BlockCholesky chol;
          const double t = bench::thread_cpu_ms();
          if (!chol.factor(A, k ? Kernel::Supernodal : Kernel::Simplicial)) return std::fprintf(stderr, "not SPD\n"), 1;
          cpu[k].push_back(bench::thread_cpu_ms() - t);
          numeric[k].push_back(chol.factor_ms());
          entries[k] = chol.nonzeros();
          x[k] = b;
          chol.solve_in_place(x[k].data(), work);
        }
      if (!old_kernel) cpu[0] = numeric[0] = cpu[1], x[0] = x[1];
      double diff = 0, scale = 0;
      for (size_t i = 0; i < b.size(); ++i)
        diff = std::max(diff, std::abs(x[0][i] - x[1][i])), scale = std::max(scale, std::abs(x[0][i]));
      const double old_cpu = median(cpu[0]), new_cpu = median(cpu[1]);
      std::printf("| %s | %ld | %.3g M / %.3g M | %.1f / %.1f | %.1f / %.1f | %.2f | %.1e |\n", c.name.c_str(),
                  static_cast<long>(A.rows()), 1e-6 * entries[0], 1e-6 * entries[1], old_cpu, new_cpu,
                  median(numeric[0]), median(numeric[1]), new_cpu / old_cpu, diff / scale);
      std::fflush(stdout);
    }
  std::printf("\n(%d repeats each; factor() = ordering + numeric factorization, CPU ms of this thread; numeric: wall "
              "ms of the factorization alone)\n",
              repeats);
  return 0;
}
