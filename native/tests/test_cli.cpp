// Scenario parsing and the arap-deform command line, end to end on meshes
// made here (never on ../shared).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "arap/errors.h"
#include "arap/io/mesh_io.h"
#include "arap/io/polygons.h"
#include "arap/io/scenario.h"
#include "arap/options.h"
#include "arap/tools/procedural.h"
#include "cli_fixture.h"

namespace {

namespace fs = std::filesystem;
using arap_test::TempDir;
using nlohmann::json;

// ---------------------------------------------------------------- scenarios

using Scenario = TempDir;

TEST_F(Scenario, ParsesMeshPathHandlesAndMatrices) {
  write("s.json", R"({"name": "t", "mesh": "meshes/m.off", "fixed": [0, 1],
    "handles": [{"vertices": [2], "translate": [1, 2, 3]},
                {"vertices": [3], "matrix": [0,-1,0,5, 1,0,0,0, 0,0,1,0, 0,0,0,1]},
                {"vertices": [4], "matrix": [[2,0,0,0],[0,2,0,0],[0,0,2,0],[0,0,0,1]], "translate": [0, 0, 1]}]})");
  const arap::io::Scenario s = arap::io::load_scenario(path("s.json"));
  EXPECT_EQ(s.name, "t");
  EXPECT_EQ(fs::path(s.mesh_path), dir_ / "meshes/m.off");
  EXPECT_EQ(s.fixed, (std::vector<int>{0, 1}));
  ASSERT_EQ(s.handles.size(), 3u);

  arap::Points rest(5, 3);
  rest << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 1, 2, 3, 4;
  const arap::io::Constraints c = arap::io::build_constraints(rest, s.fixed, s.handles);
  EXPECT_EQ(c.constrained, (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(c.fixed_count, 2);
  EXPECT_TRUE(c.warnings.empty());
  EXPECT_EQ(c.targets.row(1), rest.row(1));                       // fixed: at rest
  EXPECT_EQ(c.targets.row(2), Eigen::RowVector3d(1, 3, 3));       // translate
  EXPECT_EQ(c.targets.row(3), Eigen::RowVector3d(-1 + 5, 1, 1));  // rotate z by 90 deg, then +5 x
  EXPECT_EQ(c.targets.row(4), Eigen::RowVector3d(4, 6, 9));       // scale 2 then +1 z
}

TEST_F(Scenario, FixedWinsOverHandleWithAWarning) {
  arap::Points rest = arap::Points::Random(4, 3);
  arap::io::Handle h;
  h.vertices = {1, 2, 3};
  h.translate = Eigen::Vector3d(1, 0, 0);
  const arap::io::Constraints c = arap::io::build_constraints(rest, {1, 1, 0}, {h});
  EXPECT_EQ(c.constrained, (std::vector<int>{1, 0, 2, 3}));  // repeats ignored, vertex 1 stays fixed
  EXPECT_EQ(c.targets.row(0), rest.row(1));
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_NE(c.warnings[0].find("fixed"), std::string::npos);
}

// The rule of arap/constraints.h through the scenario layer: the first handle
// keeps a shared vertex (its target), the later one is ignored once it has
// none of its own, and the warnings name handle 0.
TEST_F(Scenario, AVertexInTwoHandlesFollowsTheFirst) {
  arap::Points rest(4, 3);
  rest << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0;
  arap::io::Handle first, second;
  first.vertices = {1, 2};
  first.translate = Eigen::Vector3d(0, 0, 1);
  second.vertices = {2, 3};
  second.translate = Eigen::Vector3d(0, 0, -1);
  const arap::io::Constraints c = arap::io::build_constraints(rest, {0}, {first, second});
  EXPECT_EQ(c.constrained, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(c.targets(2, 2), 1.0);   // vertex 2 follows handle 0
  EXPECT_EQ(c.targets(3, 2), -1.0);  // vertex 3 is handle 1's own
  ASSERT_EQ(c.warnings.size(), 1u);
  EXPECT_EQ(c.warnings[0], "Handle 1: 1 of its vertices are also in handle 0 and follow that one");
}

TEST_F(Scenario, ErrorsAreTyped) {
  const arap::Points rest = arap::Points::Zero(3, 3);
  arap::io::Handle h;
  h.vertices = {3};
  try {
    arap::io::build_constraints(rest, {0}, {h});
    FAIL();
  } catch (const arap::Error& e) {
    EXPECT_EQ(e.code(), arap::ErrorCode::IndexOutOfRange);
  }
  h.vertices = {1};
  h.matrix(0, 0) = std::numeric_limits<double>::infinity();
  try {
    arap::io::build_constraints(rest, {}, {h});
    FAIL();
  } catch (const arap::Error& e) {
    EXPECT_EQ(e.code(), arap::ErrorCode::NonFinite);
  }
  EXPECT_THROW(arap::io::build_constraints(rest, {}, {}), arap::Error);
  EXPECT_THROW(arap::io::build_constraints(rest, {-1}, {}), arap::Error);
}

// A "fixed" nested 200 000 deep is refused while parsing, without recursion (dump() recursing on it overflowed
// the stack).
TEST_F(Scenario, DeepNestingIsRefusedWithoutRecursion) {
  const std::string deep = std::string(200000, '[') + std::string(200000, ']');
  for (const std::string& json : {R"({"mesh": "m.off", "fixed": )" + deep + "}", deep,
                                  R"({"mesh": "m.off", "handles": [{"vertices": )" + deep + "}]}"}) {
    try {
      arap::io::load_scenario(write("deep.json", json));
      ADD_FAILURE() << "accepted";
    } catch (const arap::io::FileError& e) {
      EXPECT_NE(std::string(e.what()).find("nested deeper than"), std::string::npos) << e.what();
    }
  }
  // The 5 levels a scenario needs are fine; unsigned indices do not wrap around.
  EXPECT_NO_THROW(arap::io::load_scenario(write("ok.json", R"({"mesh": "m.off", "handles": [{"vertices": [1],
                    "matrix": [[1,0,0,0], [0,1,0,0], [0,0,1,0], [0,0,0,1]]}]})")));
  try {
    arap::io::load_scenario(write("u.json", R"({"mesh": "m.off", "fixed": [18446744073709551615]})"));
    ADD_FAILURE() << "accepted 2^64-1";
  } catch (const arap::Error& e) {
    EXPECT_EQ(e.code(), arap::ErrorCode::IndexOutOfRange);
    EXPECT_NE(std::string(e.what()).find("18446744073709551615"), std::string::npos) << e.what();
  }
}

TEST_F(Scenario, MalformedFilesAreRefused) {
  EXPECT_THROW(arap::io::load_scenario(path("missing.json")), arap::io::FileError);
  EXPECT_THROW(arap::io::load_scenario(write("a.json", "{not json")), arap::io::FileError);
  EXPECT_THROW(arap::io::load_scenario(write("b.json", R"({"fixed": [0]})")), arap::Error);  // no mesh
  EXPECT_THROW(arap::io::load_scenario(write("c.json", R"({"mesh": "m.off", "fixed": [0.5]})")), arap::Error);
  EXPECT_THROW(arap::io::load_scenario(write("d.json", R"({"mesh": "m.off", "handles": [{"vertices": [0],
                 "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 1,0,0,1]}]})")),
               arap::Error);  // not affine
  EXPECT_THROW(arap::io::load_scenario(write("e.json", R"({"mesh": "m.off", "handles": [{"vertices": [0],
                 "translate": [1, 2]}]})")),
               arap::Error);
  EXPECT_THROW(arap::io::read_index_file(write("i.txt", "1 2 x")), arap::io::FileError);
  EXPECT_THROW(arap::io::read_index_file(write("j.txt", "1 -2")), arap::io::FileError);
  EXPECT_EQ(arap::io::read_index_file(write("k.txt", " 3\n4\t5 \n")), (std::vector<int>{3, 4, 5}));
}

// ---------------------------------------------------------------- arap-deform


using arap_test::Cli;
using arap_test::Result;

TEST_F(Cli, BendsABarAndReports) {
  const auto bar = make_bar_files();
  const Result r =
      run("bar.obj --fixed fixed.txt --handle handle.txt --translate 2,0,-1 --max-iterations 15 --tolerance 0 "
          "--init naive --weights cotan --volume none --output bent.obj --report report.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  EXPECT_NE(r.out.find("energy"), std::string::npos);

  const json rep = json::parse(slurp(path("report.json")));
  for (const char* key : {"vertices", "faces", "iterations", "energy", "initial_energy", "precompute_ms",
                          "iteration_ms", "init_ms", "rotation_ms", "rhs_ms", "solve_ms", "converged",
                          "degenerate_triangles", "isolated_vertices", "unconstrained_components", "nonmanifold_edges"})
    EXPECT_TRUE(rep.contains(key)) << key;
  EXPECT_EQ(rep["vertices"].get<int>(), bar.vertices.rows());
  EXPECT_EQ(rep["faces"].get<int>(), bar.triangles.rows());
  const int iterations = rep["iterations"].get<int>();
  EXPECT_EQ(iterations, 15);
  const auto energy = rep["energy"].get<std::vector<double>>();
  ASSERT_EQ(static_cast<int>(energy.size()), iterations);
  EXPECT_EQ(rep["iteration_ms"].size(), energy.size());
  EXPECT_LT(energy.front(), rep["initial_energy"].get<double>());
  for (std::size_t k = 1; k < energy.size(); ++k) EXPECT_LE(energy[k], energy[k - 1] * (1 + 1e-9)) << k;
  EXPECT_LT(energy.back(), 0.9 * energy.front());
  EXPECT_FALSE(rep["converged"].get<bool>());
  EXPECT_EQ(rep["degenerate_triangles"].get<int>(), 0);
  EXPECT_EQ(rep["nonmanifold_edges"].get<int>(), 0);
  EXPECT_EQ(rep["unconstrained_components"].get<int>(), 0);

  // Constraints met in the written file; same faces.
  const arap::io::PolygonMesh out = arap::io::read_mesh(path("bent.obj"));
  EXPECT_EQ(out.polygons, arap::io::to_polygons(bar.triangles));
  const double tol = 1e-5;  // OpenMesh reads coordinates as float
  for (int i : fixed_) EXPECT_LT((out.vertices.row(i) - bar.vertices.row(i)).norm(), tol) << i;
  for (int i : handle_)
    EXPECT_LT((out.vertices.row(i) - bar.vertices.row(i) - Eigen::RowVector3d(2, 0, -1)).norm(), tol) << i;
  // The free middle moved.
  EXPECT_GT((out.vertices - bar.vertices).rowwise().norm().maxCoeff(), 2.0 - 1e-6);
}

TEST_F(Cli, DefaultsSolveUntilSettledAndReportAHitCap) {
  make_bar_files();
  const std::string setup = "bar.obj --fixed fixed.txt --handle handle.txt --translate 2,0,-1 ";
  Result r = run(setup + "--output d.obj --report d.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  EXPECT_NE(r.out.find("method quasi-newton"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("converged after"), std::string::npos) << r.out;
  const json settled = json::parse(slurp(path("d.json")));
  EXPECT_TRUE(settled["converged"].get<bool>());
  EXPECT_EQ(settled["method"], "quasi-newton");
  EXPECT_LT(settled["iterations"].get<int>(), settled["max_iterations"].get<int>());

  // The textbook iteration on request: exactly N plain iterations, a higher energy after them.
  r = run(setup + "--method local-global --max-iterations 10 --tolerance 0 --output p.obj --report p.json -q");
  ASSERT_EQ(r.code, 0) << r.err;
  const json plain = json::parse(slurp(path("p.json")));
  EXPECT_EQ(plain["method"], "local-global");
  EXPECT_EQ(plain["iterations"].get<int>(), 10);
  EXPECT_GT(plain["energy"].back().get<double>(), settled["energy"].back().get<double>());

  // A cap below what the tolerance needs: the result is written and the cap is named.
  r = run(setup + "--max-iterations 2 --output c.obj -q");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("cap of 2 iterations"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(path("c.obj")));
}

TEST_F(Cli, MethodsAreListedAndChecked) {
  make_bar_files();
  const Result help = run("--help");
  for (const char* name : {"quasi-newton", "local-global", "anderson"})
    EXPECT_NE(help.out.find(name), std::string::npos) << name;
  const std::string ok = "bar.obj --fixed fixed.txt --handle handle.txt --translate 1,0,0";
  expect_bad_input(ok + " --method newton");
  // The Anderson window alone keeps meaning the accelerated alternation, in both spellings of its flag.
  for (const std::string flag : {"--anderson-window", "--anderson"}) {
    const Result refused = run(ok + " --method quasi-newton " + flag + " 3 --output a.off");
    EXPECT_EQ(refused.code, 2);
    EXPECT_EQ(refused.err, "arap-deform: " + flag + " applies to --method anderson only (see --help)\n");
    const Result r = run(ok + " " + flag + " 3 --output a.off --report a.json -q");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(json::parse(slurp(path("a.json")))["method"], "anderson");
  }
}

// The default model is Volume Infill; Anderson, which cannot carry the volume terms, solves Surface Only unless
// --volume names a mode (then it is refused, naming the conflict).
TEST_F(Cli, TheDefaultIsInfillAndAndersonAloneSolvesTheSurface) {
  make_bar_files();
  const std::string ok = "bar.obj --fixed fixed.txt --handle handle.txt --translate 1,0,0 -q";
  ASSERT_EQ(run(ok + " --output d.off --report d.json").code, 0);
  ASSERT_EQ(run(ok + " --volume infill --output i.off").code, 0);
  ASSERT_EQ(run(ok + " --volume none --output n.off").code, 0);
  EXPECT_EQ(json::parse(slurp(path("d.json")))["volume"], "infill");
  EXPECT_EQ(slurp(path("d.off")), slurp(path("i.off")));
  EXPECT_NE(slurp(path("d.off")), slurp(path("n.off")));
  ASSERT_EQ(run(ok + " --method anderson --output a.off --report a.json").code, 0);
  ASSERT_EQ(run(ok + " --method anderson --volume none --output an.off").code, 0);
  EXPECT_EQ(json::parse(slurp(path("a.json")))["volume"], "none");
  EXPECT_EQ(slurp(path("a.off")), slurp(path("an.off")));
  const Result refused = run(ok + " --method anderson --volume infill --output r.off");
  EXPECT_EQ(refused.code, 2);
  EXPECT_NE(refused.err.find("--volume infill works with --method quasi-newton or local-global, not anderson"),
            std::string::npos)
      << refused.err;
}

// The flags are the option table's names; --iterations and --anderson, the short forms older scripts use,
// set the same options, and --help says so.
TEST_F(Cli, FlagsAreTheOptionNamesWithTheShortFormsAccepted) {
  make_bar_files();
  const std::string help = run("--help").out;
  for (const char* flag : {"\n  --max-iterations N ", "\n  --anderson-window M ", "\n  --contact MODE "})
    EXPECT_NE(help.find(flag), std::string::npos) << flag;
  EXPECT_NE(help.find("--iterations and --anderson\n  are accepted as the short forms"), std::string::npos) << help;
  const std::string ok = "bar.obj --fixed fixed.txt --handle handle.txt --translate 1,0,0 -q --tolerance 0";
  for (const std::string flags : {"--max-iterations 3 --anderson-window 4", "--iterations 3 --anderson 4"}) {
    SCOPED_TRACE(flags);
    const Result r = run(ok + " --method anderson " + flags + " --output a.off --report a.json");
    ASSERT_EQ(r.code, 0) << r.err;
    const json report = json::parse(slurp(path("a.json")));
    EXPECT_EQ(report["max_iterations"].get<int>(), 3);
    EXPECT_EQ(report["anderson_window"].get<int>(), 4);
    EXPECT_LE(report["iterations"].get<int>(), 3);
  }
  EXPECT_EQ(run(ok + " --iterations 0 --output a.off").code, 0);
  const Result r = run(ok + " --iterations 1000001 --output a.off");
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err.rfind("arap-deform: --iterations expects ", 0), 0u) << r.err;
}

TEST_F(Cli, ScenarioWithMatrixHandleAndOverlapWarning) {
  const auto bar = make_bar_files("bar.off");
  // Rotate the top 90 degrees about z through the bar's axis (0.5, 0.5), and
  // list one fixed vertex in the handle too: it must stay fixed.
  json s = {{"mesh", "bar.off"},
            {"fixed", fixed_},
            {"handles", {{{"vertices", handle_}, {"matrix", {0, -1, 0, 1, 1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}}}}}};
  s["handles"][0]["vertices"].push_back(fixed_[0]);
  write("s.json", s.dump());
  const Result r = run("--scenario s.json --max-iterations 5 --output twisted.off --quiet");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(r.out.empty());
  EXPECT_NE(r.err.find("fixed"), std::string::npos);
  const arap::io::PolygonMesh out = arap::io::read_mesh(path("twisted.off"));
  for (int i : handle_) {
    const Eigen::RowVector3d p = bar.vertices.row(i);
    EXPECT_LT((out.vertices.row(i) - Eigen::RowVector3d(1 - p.y(), p.x(), p.z())).norm(), 1e-5) << i;
  }
  EXPECT_LT((out.vertices.row(fixed_[0]) - bar.vertices.row(fixed_[0])).norm(), 1e-9);
}

// A vertex in two handles follows the first:
// the run succeeds, the warning names handle 0, the vertex lands on handle 0's target.
TEST_F(Cli, AVertexInTwoHandlesFollowsTheFirstWithAWarning) {
  const auto bar = make_bar_files("bar.off");
  write("second.txt", join({handle_[0], handle_[1]}));
  const Result r =
      run("bar.off --fixed fixed.txt --handle handle.txt --translate 0,0,1 --handle second.txt "
          "--translate 0,0,-1 --max-iterations 3 --tolerance 0 --output out.off --quiet");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err,
            "arap-deform: warning: Handle 1: 2 of its vertices are also in handle 0 and follow that one\n"
            "arap-deform: warning: Handle 1 has no vertices of its own: ignored\n");
  const arap::io::PolygonMesh out = arap::io::read_mesh(path("out.off"));
  EXPECT_NEAR(out.vertices(handle_[0], 2), bar.vertices(handle_[0], 2) + 1, 1e-9);
}

TEST_F(Cli, KeepsPolygonsAndRotatesHandles) {
  // A 1 x 4 strip of quads (a flat ribbon), fixed at x = 0, turned at x = 4.
  std::string off = "OFF\n10 4 0\n";
  for (int i = 0; i <= 4; ++i) off += std::to_string(i) + " 0 0\n" + std::to_string(i) + " 1 0\n";
  for (int i = 0; i < 4; ++i)
    off += "4 " + std::to_string(2 * i) + " " + std::to_string(2 * i + 2) + " " + std::to_string(2 * i + 3) + " " +
           std::to_string(2 * i + 1) + "\n";
  write("ribbon.off", off);
  write("f.txt", "0 1");
  write("h.txt", "8 9");
  const Result r = run("ribbon.off --fixed f.txt --handle h.txt --rotate x,90 --translate 0,0,0.5 --output r.ply -q");
  ASSERT_EQ(r.code, 0) << r.err;
  const arap::io::PolygonMesh out = arap::io::read_mesh(path("r.ply"));
  ASSERT_EQ(out.polygons.size(), 4u);
  EXPECT_EQ(out.polygons[0], (std::vector<int>{0, 2, 3, 1}));
  // Centroid of the handle (4, 0.5, 0); (4, 1, 0) turns to (4, 0.5, 0.5), then +0.5 z.
  EXPECT_LT((out.vertices.row(9) - Eigen::RowVector3d(4, 0.5, 1.0)).norm(), 1e-5);
  EXPECT_LT((out.vertices.row(8) - Eigen::RowVector3d(4, 0.5, 0.0)).norm(), 1e-5);
}

TEST_F(Cli, HelpExitsZero) {
  const Result r = run("--help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("fixed wins"), std::string::npos);
  EXPECT_NE(r.out.find("the first handle wins"), std::string::npos);
}

// --help names every solver option's default and choices as arap::option_specs() has them:
// "(default X)" in each flag's paragraph, or "(default)" on the default's line of a list.
TEST_F(Cli, HelpTakesDefaultsAndChoicesFromTheOptionTable) {
  const std::string help = run("--help").out;
  // The lines from the flag's own to the next flag's.
  auto paragraph = [&](const std::string& flag) {
    const std::size_t begin = help.find("\n  " + flag + " ");
    if (begin == std::string::npos) return std::string();
    return help.substr(begin + 1, help.find("\n  --", begin + 1) - begin - 1);
  };
  const arap::Options defaults;
  const std::pair<const char*, const char*> flags[] = {{"--method", "method"},
                                                       {"--max-iterations", "max_iterations"},
                                                       {"--tolerance", "tolerance"},
                                                       {"--init", "init"},
                                                       {"--weights", "weights"},
                                                       {"--threads", "threads"},
                                                       {"--anderson-window", "anderson_window"},
                                                       {"--volume", "volume"},
                                                       {"--infill-resolution", "infill_resolution"}};
  for (const auto& [flag, name] : flags) {
    const std::string key = name;
    const arap::OptionSpec& spec = arap::option_spec(key);
    const std::string text = paragraph(flag);
    ASSERT_FALSE(text.empty()) << flag;
    if (spec.kind != arap::OptionKind::Choice) {
      const std::size_t at = text.find("(default ");
      ASSERT_NE(at, std::string::npos) << text;
      EXPECT_EQ(std::stod(text.substr(at + 9)), spec.get_number(defaults)) << text;
      continue;
    }
    const std::string chosen = spec.get_choice(defaults);
    for (const std::string& choice : spec.choices) {
      if (std::string(spec.name) == "init" && choice == "warm") continue;  // refused: one solve has no last one
      EXPECT_NE(text.find(choice), std::string::npos) << flag << ' ' << choice;
    }
    if (text.find("(default)") == std::string::npos) {
      EXPECT_NE(text.find("(default " + chosen + ")"), std::string::npos) << text;
      continue;
    }
    // A list, a choice's name at column 26 of its first line: "(default)" ends the default's note.
    std::istringstream lines(text);
    std::string line, listed, marked;
    while (std::getline(lines, line)) {
      if (line.size() > 26 && line[25] == ' ' && line[26] != ' ') listed = line.substr(26, line.find(' ', 26) - 26);
      if (line.find("(default)") != std::string::npos) marked = listed;
    }
    EXPECT_EQ(marked, chosen) << text;
  }
}

// The flags take their limits and messages from arap::option_specs(), the
// limits the library and the add-on use: the bounds themselves are accepted.
TEST_F(Cli, OptionLimitsAreTheLibrarys) {
  const auto bar = make_bar_files();
  const std::string ok = "bar.obj --fixed fixed.txt --handle handle.txt --translate 1,0,0 -q --output out.obj";
  Result r = run(ok + " --method anderson --anderson-window 20 --threads 64 --tolerance 1 --max-iterations 1");
  EXPECT_EQ(r.code, 0) << r.err;
  // No iteration: the first guess (the rest shape with the handle moved) is written.
  r = run(ok + " --max-iterations 0");
  ASSERT_EQ(r.code, 0) << r.err;
  const arap::io::PolygonMesh out = arap::io::read_mesh(path("out.obj"));
  for (int v : {handle_[0], fixed_[0]})
    EXPECT_NEAR(out.vertices(v, 0), bar.vertices(v, 0) + (v == handle_[0] ? 1 : 0), 1e-6);
  r = run(ok + " --anderson-window 21");
  EXPECT_EQ(r.code, 2);
  const std::string limits = arap::option_limits(arap::option_spec("anderson_window"));
  EXPECT_EQ(r.err, "arap-deform: --anderson-window expects " + limits + ", got '21' (see --help)\n");
  EXPECT_NE(r.err.find("between 0 and 20"), std::string::npos);
}

TEST_F(Cli, BadArgumentsExitTwo) {
  make_bar_files();
  write("out_of_range.txt", "0 1 100000");
  write("empty.txt", "");
  write("nan.json", R"({"mesh": "bar.obj", "fixed": [0],
    "handles": [{"vertices": [1], "matrix": [1e999,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]})");
  write("range.json", R"({"mesh": "bar.obj", "fixed": [0, 99999]})");
  write("nomesh.json", R"({"mesh": "nothere.obj", "fixed": [0]})");
  const std::string ok = "--fixed fixed.txt --handle handle.txt --translate 1,0,0";
  expect_bad_input("missing.obj " + ok);
  expect_bad_input("bar.obj --fixed nothere.txt");
  expect_bad_input("bar.obj " + ok + " --bogus");
  expect_bad_input("bar.obj " + ok + " --iterations abc");
  expect_bad_input("bar.obj " + ok + " --iterations 1000001");
  expect_bad_input("bar.obj " + ok + " --tolerance 2");
  expect_bad_input("bar.obj " + ok + " --method anderson --anderson 21");
  expect_bad_input("bar.obj " + ok + " --weights nonsense");
  expect_bad_input("bar.obj " + ok + " --init sideways");
  expect_bad_input("bar.obj " + ok + " --tolerance nan");
  expect_bad_input("bar.obj --fixed fixed.txt --translate 1,0,0");
  expect_bad_input("bar.obj --fixed fixed.txt --handle handle.txt --translate 1,0");
  expect_bad_input("bar.obj --fixed fixed.txt --handle handle.txt --rotate w,3");
  expect_bad_input("bar.obj --fixed out_of_range.txt");
  expect_bad_input("bar.obj --fixed fixed.txt --handle empty.txt");
  expect_bad_input("bar.obj");
  expect_bad_input("--scenario nan.json");
  expect_bad_input("--scenario range.json");
  expect_bad_input("--scenario nomesh.json");
  expect_bad_input("--scenario missing.json");
  expect_bad_input("--scenario nan.json bar.obj");
  // Output format that cannot be written.
  const Result r = run("bar.obj " + ok + " --output out.stl");
  EXPECT_EQ(r.code, 2);
  EXPECT_FALSE(fs::exists(path("out.stl")));
}

// Every numeric flag takes a finite decimal number in its range and nothing else: NaN, Inf, overflow,
// hex (0x10, and 0x1p3, which strtod would read as 8), an empty value, spaces around it, digit
// separators, control characters. Each refusal is exit 2 and one line naming the flag and quoting at most
// 40 characters of the value; -0 is 0, accepted where 0 is in range.
TEST_F(Cli, NumericFlagsTakeFiniteNumbersInRangeOnly) {
  make_bar_files();
  struct Flag {
    std::string name, before, after;  // the value V is passed as before + V + after
    bool zero_ok;
  };
  const std::string base = "bar.obj --fixed fixed.txt --handle handle.txt";
  const std::vector<Flag> flags = {
      {"--translate", base + " --translate '", ",0,0'", true},
      {"--translate", base + " --translate '0,0,", "'", true},
      {"--rotate", base + " --rotate 'x,", "'", true},
      {"--max-iterations", base + " --translate 1,0,0 --max-iterations '", "'", true},
      {"--iterations", base + " --translate 1,0,0 --iterations '", "'", true},
      {"--tolerance", base + " --translate 1,0,0 --tolerance '", "'", true},
      {"--threads", base + " --translate 1,0,0 --threads '", "'", false},
      {"--anderson-window", base + " --translate 1,0,0 --method anderson --anderson-window '", "'", true},
      {"--anderson", base + " --translate 1,0,0 --method anderson --anderson '", "'", true},
      {"--infill-resolution", base + " --translate 1,0,0 --volume infill --infill-resolution '", "'", false},
  };
  const std::string long_value(5000, '7');
  const std::vector<std::string> refused = {"nan", "inf", "-inf", "1e999", "-1e999", "", "0x10", "0x1p3", " 1",
                                            "1 ", "1\t", "1\n", "1_0", "+-1", "--1", "1e", long_value};
  for (const Flag& f : flags) {
    for (const std::string& v : refused) {
      SCOPED_TRACE(f.before + v.substr(0, 50) + f.after);
      const Result r = run(f.before + v + f.after + " -q --output out.off --report report.json");
      EXPECT_EQ(r.code, 2) << r.err;
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
      EXPECT_EQ(r.err.rfind("arap-deform: " + f.name + " expects ", 0), 0u) << r.err;
      EXPECT_LT(r.err.size(), 200u) << r.err;
      EXPECT_FALSE(fs::exists(path("out.off")));
      EXPECT_FALSE(fs::exists(path("report.json")));
    }
    const Result r = run(f.before + "-0" + f.after + " -q --output out.obj");
    EXPECT_EQ(r.code, f.zero_ok ? 0 : 2) << f.name << ": " << r.err;
    if (!f.zero_ok) {
      EXPECT_NE(r.err.find(f.name + " expects "), std::string::npos) << r.err;
    }
    fs::remove(path("out.obj"));
  }
  // What the refusals quote: 40 characters of the value at most, control characters escaped.
  Result r = run(base + " --translate 1,0,0 --tolerance " + long_value + " --output out.off");
  EXPECT_NE(r.err.find("got '" + std::string(40, '7') + "'..."), std::string::npos) << r.err;
  r = run(base + " --translate 1,0,0 --iterations '1\n' --output out.off");
  EXPECT_NE(r.err.find("got '1\\x0a'"), std::string::npos) << r.err;
  // -0 is 0: the tolerance of the report is 0, not -0.
  r = run(base + " --translate 1,0,0 --tolerance -0 -q --output out.obj --report report.json");
  ASSERT_EQ(r.code, 0) << r.err;
  const json report = json::parse(slurp(path("report.json")));
  EXPECT_EQ(report.at("tolerance").get<double>(), 0.0);
  EXPECT_FALSE(std::signbit(report.at("tolerance").get<double>()));
}

TEST_F(Cli, HostileMeshFilesExitTwo) {
  write("f.txt", "0");
  write("h.txt", "1");
  std::string junk;
  for (int i = 0; i < 2000; ++i) junk.push_back(static_cast<char>((i * 31 + 7) % 256));
  const std::vector<std::pair<std::string, std::string>> files = {
      {"empty.off", ""},
      {"junk.off", junk},
      {"junk.ply", "ply\n" + junk},
      {"junk.stl", junk},
      {"huge.off", "OFF\n1000000000000 1 0\n0 0 0\n"},
      {"truncated.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1"},
      {"nan.off", "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n"},
      {"range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n"},
      {"nofaces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"},
  };
  for (const auto& [name, bytes] : files) {
    write(name, bytes);
    expect_bad_input(name + " --fixed f.txt --handle h.txt --translate 0,0,1");
  }
}


}  // namespace
