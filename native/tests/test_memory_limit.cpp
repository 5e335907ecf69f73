// A bind that would not fit in memory is refused before it allocates, with a
// typed error that gives both figures, and the previous binding stays usable:
// on Linux the alternative is the OOM killer ending the process (in Blender,
// every unsaved change). Each case runs in a child process whose address space
// is limited (RLIMIT_AS), as `ulimit -v` does; the command-line cases, with a
// memory cgroup too, are in test_cli_memory.cpp.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "surface_options.h"
#include "arap/errors.h"
#include "arap/solver.h"
#include "arap/tools/procedural.h"
#include "runtime/memory_headroom.h"
#include "sanitizer_build.h"

namespace {

size_t address_space_bytes() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmSize:", 0) == 0) return std::stoull(line.substr(7)) * 1024;
  return 0;
}

// This process may grow by about `headroom` more bytes of address space.
void limit_address_space(size_t headroom) {
  rlimit limit{};
  getrlimit(RLIMIT_AS, &limit);
  limit.rlim_cur = address_space_bytes() + headroom;
  if (setrlimit(RLIMIT_AS, &limit) != 0) std::exit(3);
}

// Whether `call` throws arap::Error(OutOfMemory) with `named` in its message (printed for the log).
template <class Call>
bool refused_for_memory(const Call& call, const std::string& named) {
  try {
    call();
  } catch (const arap::Error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return e.code() == arap::ErrorCode::OutOfMemory && std::string(e.what()).find(named) != std::string::npos;
  }
  return false;
}

arap::Solver bound_to(const arap::procedural::TriMesh& mesh) {
  const arap::procedural::Bend bend = arap::procedural::bend(mesh.vertices);
  arap::Solver solver;
  solver.bind(mesh.vertices, mesh.triangles, bend.constrained, arap_test::surface_options());
  return solver;
}

TEST(MemoryLimit, HeadroomNamesTheAddressSpaceLimit) {
  if (arap_test::kSanitizerBuild) GTEST_SKIP() << "the address space is not limited under a sanitizer";
  EXPECT_EXIT(
      {
        limit_address_space(size_t(64) << 20);
        const arap::MemoryHeadroom h = arap::memory_headroom();
        const bool named = h.limit.find("address-space limit") != std::string::npos;
        const bool near = h.bytes > (size_t(48) << 20) && h.bytes <= (size_t(64) << 20);
        std::fprintf(stderr, "%zu bytes under %s\n", h.bytes, h.limit.c_str());
        std::exit(named && near ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

TEST(MemoryLimit, ABindTooLargeIsRefusedAndThePreviousBindingKept) {
  if (arap_test::kSanitizerBuild) GTEST_SKIP() << "the address space is not limited under a sanitizer";
  EXPECT_EXIT(
      {
        const auto small = arap::procedural::make_bar(3, 3, 15, 1, 1, 5);
        const auto large = arap::procedural::make_sphere(200000);
        const arap::procedural::Bend small_bend = arap::procedural::bend(small.vertices);
        const arap::procedural::Bend large_bend = arap::procedural::bend(large.vertices);
        arap::Solver solver = bound_to(small);
        limit_address_space(size_t(40) << 20);
        bool refused = false;
        try {
          solver.bind(large.vertices, large.triangles, large_bend.constrained, arap_test::surface_options());
        } catch (const arap::Error& e) {
          const std::string m = e.what();
          std::fprintf(stderr, "%s\n", e.what());
          refused = e.code() == arap::ErrorCode::OutOfMemory && m.find("needs about") != std::string::npos &&
                    m.find("is left under the address-space limit") != std::string::npos &&
                    m.find(std::to_string(large.vertices.rows()) + " vertices") != std::string::npos;
        }
        // The small binding still solves, to finite positions.
        const arap::SolveStats stats = solver.solve(small_bend.targets);
        const bool kept =
            solver.vertex_count() == small.vertices.rows() && solver.positions().allFinite() && stats.iterations > 0;
        std::exit(refused && kept ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

TEST(MemoryLimit, TheFactorizationIsCheckedFromItsColumnCounts) {
  if (arap_test::kSanitizerBuild) GTEST_SKIP() << "the address space is not limited under a sanitizer";
  // Room for the mesh's structures but not for the factor: refused after the
  // ordering, before the numeric factorization allocates.
  EXPECT_EXIT(
      {
        const auto large = arap::procedural::make_sphere(200000);
        const arap::procedural::Bend bend = arap::procedural::bend(large.vertices);
        limit_address_space(size_t(170) << 20);
        arap::Solver solver;
        const bool refused =
            refused_for_memory([&] { solver.bind(large.vertices, large.triangles, bend.constrained, arap_test::surface_options()); },
                               "(the factorization)");
        std::exit(refused && !solver.is_bound() ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

TEST(MemoryLimit, WithRoomEnoughTheBindGoesAhead) {
  if (arap_test::kSanitizerBuild) GTEST_SKIP() << "the address space is not limited under a sanitizer";
  EXPECT_EXIT(
      {
        const auto mesh = arap::procedural::make_sphere(20000);
        limit_address_space(size_t(400) << 20);
        arap::Solver solver = bound_to(mesh);
        std::exit(solver.is_bound() ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

// A fan of n slivers around one vertex, ringed by a band of n quads out to
// twice its radius: the mean edge is about 0.6 of the radius, the slivers
// 1/n of a turn wide, so each rim vertex has thousands of triangles within
// Self Contact's reach (docs/contact.md, Limits). Every other rim vertex is
// held; Options has Self Contact on.
struct SliverFan {
  arap::procedural::TriMesh mesh;
  std::vector<int> rim;
  arap::Options options = arap_test::surface_options();
};

SliverFan sliver_fan(int n) {
  SliverFan fan;
  arap::procedural::TriMesh& m = fan.mesh;
  m.vertices.resize(1 + 2 * n, 3);
  m.vertices.row(0) << 0, 0, 0;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * EIGEN_PI * i / n;
    m.vertices.row(1 + i) << std::cos(a), std::sin(a), 0;
    m.vertices.row(1 + n + i) << 2 * std::cos(a), 2 * std::sin(a), 0;
  }
  m.triangles.resize(3 * n, 3);
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    m.triangles.row(i) << 0, 1 + i, 1 + j;
    m.triangles.row(n + 2 * i) << 1 + i, 1 + n + i, 1 + j;
    m.triangles.row(n + 2 * i + 1) << 1 + j, 1 + n + i, 1 + n + j;
  }
  for (int i = 0; i < n; i += 2) fan.rim.push_back(1 + n + i);
  fan.options.contact = arap::Contact::Self;
  return fan;
}

// Self Contact's list of near pairs grows only while it fits: on the sliver
// fan it would need hundreds of MB. A cold solve whose pose without contact is
// clear needs no list; the warm solve after it checks its move with one, and
// with 64 MB left it is refused with the typed error, the positions as they were.
TEST(MemoryLimit, SelfContactRefusesAListThatDoesNotFit) {
  if (arap_test::kSanitizerBuild) GTEST_SKIP() << "the address space is not limited under a sanitizer";
  EXPECT_EXIT(
      {
        SliverFan fan = sliver_fan(3000);
        auto lifted = [&](double height) {
          arap::Points targets(static_cast<Eigen::Index>(fan.rim.size()), 3);
          for (size_t k = 0; k < fan.rim.size(); ++k)
            targets.row(static_cast<Eigen::Index>(k)) =
                fan.mesh.vertices.row(fan.rim[k]) + Eigen::RowVector3d(0, 0, height);
          return targets;
        };
        fan.options.max_iterations = 5;
        fan.options.init = arap::InitialGuess::WarmStart;
        arap::Solver solver;
        solver.bind(fan.mesh.vertices, fan.mesh.triangles, fan.rim, fan.options);
        solver.solve(lifted(0.3));
        const arap::Points before = solver.positions();
        limit_address_space(size_t(64) << 20);
        const bool refused = refused_for_memory([&] { solver.solve(lifted(0.6)); }, "Self Contact");
        const bool unchanged = solver.positions() == before;
        std::exit(refused && unchanged ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

// The pairs near at rest, which Self Contact's bind sets aside, grow only
// while they fit too: the sliver fan's need about 100 MB.
TEST(MemoryLimit, SelfContactRefusesABindWhoseRestPairsDoNotFit) {
  if (arap_test::kSanitizerBuild) GTEST_SKIP() << "the address space is not limited under a sanitizer";
  EXPECT_EXIT(
      {
        const SliverFan fan = sliver_fan(6000);
        limit_address_space(size_t(48) << 20);
        arap::Solver solver;
        const bool refused = refused_for_memory(
            [&] { solver.bind(fan.mesh.vertices, fan.mesh.triangles, fan.rim, fan.options); }, "Self Contact");
        std::exit(refused && !solver.is_bound() ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

}  // namespace
