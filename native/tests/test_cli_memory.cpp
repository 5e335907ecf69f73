// arap-deform under a memory limit it cannot bind in: exit status 2, one line
// that says "out of memory" with what the bind needs and what is left, nothing
// written. Under `ulimit -v` (the address space) and, where this machine lets
// a test make one, in a memory cgroup (what containers and Slurm jobs set;
// there the kernel kills instead of refusing an allocation).
#include <sys/stat.h>

#include "cli_fixture.h"
#include "sanitizer_build.h"

namespace {

using arap_test::Cli;
using arap_test::Result;

class CliMemory : public Cli {
 protected:
  // A 200k-vertex bumpy sphere, bottom fifth fixed, top 5% the handle.
  void make_sphere_files() {
    const auto sphere = arap::procedural::make_sphere(200000);
    arap::io::write_mesh(path("sphere.obj"), sphere.vertices, arap::io::to_polygons(sphere.triangles));
    const auto picked = arap::procedural::pick_by_height(sphere.vertices);
    write("fixed.txt", join(picked.fixed));
    write("handle.txt", join(picked.handle));
  }
  static constexpr const char* kArgs =
      " sphere.obj --fixed fixed.txt --handle handle.txt --translate 0.3,0,0 --output out.obj";
  void expect_refused(const Result& r, const std::string& limit) {
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("out of memory: binding"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("needs about"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("is left under " + limit), std::string::npos) << r.err;
    EXPECT_FALSE(arap_test::fs::exists(path("out.obj")));
  }
};

TEST_F(CliMemory, UnderAnAddressSpaceLimitTheBindIsRefused) {
  if (arap_test::kSanitizerBuild) GTEST_SKIP() << "the address space is not limited under a sanitizer";
  make_sphere_files();
  // 150 MB: arap-deform starts and reads the mesh, the bind would not fit.
  const Result r = run(kArgs, "ulimit -v 150000; ");
  expect_refused(r, "the address-space limit");
}

TEST_F(CliMemory, InAMemoryCgroupTheBindIsRefusedNotKilled) {
  // cgroup v1's memory controller, as root (v2 needs a delegated subtree: not tried).
  if (arap_test::kSanitizerBuild) GTEST_SKIP() << "a sanitizer's memory would not fit the limit";
  const std::string group = "/sys/fs/cgroup/memory/arap_test_" + std::to_string(::getpid());
  if (::mkdir(group.c_str(), 0755) != 0) GTEST_SKIP() << "no memory cgroup can be made here (" << group << ")";
  make_sphere_files();
  std::ofstream(group + "/memory.limit_in_bytes") << (200 << 20);
  const Result r = run(kArgs, "echo $$ > " + group + "/cgroup.procs && exec ");
  ::rmdir(group.c_str());
  expect_refused(r, "the memory limit of cgroup");
}

}  // namespace
