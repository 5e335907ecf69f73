// Test fixtures shared by the command-line suites: a temporary folder per
// test, and arap-deform run in it with the checks every bad input must pass.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "arap/io/mesh_io.h"
#include "arap/io/polygons.h"
#include "arap/tools/procedural.h"

namespace arap_test {

namespace fs = std::filesystem;

class TempDir : public ::testing::Test {
 public:
  static std::string slurp(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }

 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("arap_cli_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name), std::ios::binary) << text;
    return path(name);
  }
  // A 1 x 1 x 5 bar standing on z = 0: fixed.txt (bottom fifth) and handle.txt (top 5%).
  arap::procedural::TriMesh make_bar_files(const std::string& mesh_name = "bar.obj") {
    const auto bar = arap::procedural::make_bar(3, 3, 15, 1.0, 1.0, 5.0);
    arap::io::write_mesh(path(mesh_name), bar.vertices, arap::io::to_polygons(bar.triangles));
    const auto picked = arap::procedural::pick_by_height(bar.vertices);
    fixed_ = picked.fixed;
    handle_ = picked.handle;
    write("fixed.txt", join(fixed_));
    write("handle.txt", join(handle_));
    return bar;
  }
  static std::string join(const std::vector<int>& v) {
    std::string s;
    for (int i : v) s += std::to_string(i) + " ";
    return s + "\n";
  }
  fs::path dir_;
  std::vector<int> fixed_, handle_;
};


struct Result {
  int code = -1;
  std::string out, err;
};

class Cli : public TempDir {
 protected:
  // A hang becomes exit 124 (a failure), not a stuck test run.
  int timeout_s_ = 60;
  // `shell`: sh commands run first, in the same shell (e.g. "ulimit -v N; ").
  Result run(const std::string& args, const std::string& shell = "") {
    const std::string out = path("stdout.txt"), err = path("stderr.txt");
    const std::string cmd = "cd '" + dir_.string() + "' && " + shell + "timeout " + std::to_string(timeout_s_) + " '" +
                            ARAP_DEFORM_EXE + "' " + args + " >'" + out + "' 2>'" + err + "'";
    const int status = std::system(cmd.c_str());
    Result r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(out);
    r.err = slurp(err);
    fs::remove(out);
    fs::remove(err);
    return r;
  }
  // Exit 2, one line on stderr, no output, no report, no temporary left behind.
  void expect_bad_input(const std::string& args) {
    SCOPED_TRACE(args);
    const Result r = run(args + " --output out.off --report report.json");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(path("out.off")));
    EXPECT_FALSE(fs::exists(path("report.json")));
    for (const auto& entry : fs::directory_iterator(dir_))
      EXPECT_EQ(entry.path().filename().string().find("arap-tmp"), std::string::npos) << entry.path();
  }
};


}  // namespace arap_test
