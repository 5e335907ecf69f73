// The hostile-input catalogue of the command line: generated mesh
// files, scenarios and arguments, each run through arap-deform. Every one
// must end in exit 2 with one line on stderr, write nothing, leave every
// input file byte for byte as it was, and finish (a hang is killed by
// `timeout` and fails as exit 124). The sanitizer build (ARAP_SANITIZE) runs
// the same cases against an ASan + UBSan arap-deform.
#include <sys/stat.h>

#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "cli_fixture.h"


namespace {

namespace fs = std::filesystem;

struct Case {
  std::string name;
  std::map<std::string, std::string> files;  // written before the run
  std::string args;                          // arap-deform's arguments (output options added)
};

const std::string kTriangleOff = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
const std::string kIndices = " --fixed f.txt --handle h.txt --translate 0,0,1";

std::string ply(const std::string& format, const std::string& vertex_type, const std::string& body,
                const std::string& count = "3") {
  return "ply\nformat " + format + "\nelement vertex " + count + "\nproperty " + vertex_type + " x\nproperty " +
         vertex_type + " y\nproperty " + vertex_type +
         " z\nelement face 1\nproperty list uchar int vertex_indices\n"
         "end_header\n" +
         body;
}

std::string stl(const std::string& second_vertex) {
  return "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex " + second_vertex +
         "\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
}

std::string nested(int depth, const std::string& inner = "0") {
  return std::string(depth, '[') + inner + std::string(depth, ']');
}

std::vector<Case> catalogue() {
  std::vector<Case> cases;
  auto mesh = [&](const std::string& name, const std::string& bytes) {
    cases.push_back({"mesh " + name, {{name, bytes}, {"f.txt", "0"}, {"h.txt", "2"}}, name + kIndices});
  };
  // Numbers in every OFF field that do not fit what they count or hold.
  const std::string off_body = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  for (const std::string counts : {"999999999999999999 1 0", "9999999999999999999 1 0", "3 999999999999999999 0",
                                   "-3 1 0", "3 -1 0", "1e3 1 0", "0x3 1 0", "3 1", "3.0 1 0"})
    mesh("counts_" + std::to_string(cases.size()) + ".off", "OFF\n" + counts + "\n" + off_body);
  for (const std::string x : {"nan", "inf", "-inf", "1e999", "-1e400", "0x", "1,5", ""})
    mesh("coordinate_" + std::to_string(cases.size()) + ".off", "OFF\n3 1 0\n0 0 0\n" + x + " 0 0\n0 1 0\n3 0 1 2\n");
  for (const std::string face : {"-3 0 1 2", "4000000000 0 1 2", "3 0 1 3", "3 0 1 -1", "3 0 1 1.0", "3 0 1 2 1 0 0",
                                 "2 0 1", "3 0 1 99999999999999999999"})
    mesh("face_" + std::to_string(cases.size()) + ".off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n" + face + "\n");
  mesh("empty.off", "");
  mesh("binary.off", "OFF BINARY\n\x03\0\0\0");
  mesh("nd.off", "4OFF\n3 1 0\n0 0 0 0\n1 0 0 0\n0 1 0 0\n3 0 1 2\n");
  mesh("truncated.off", "OFF\n3 1 0\n0 0 0\n1 0");
  mesh("only_comments.off", "# OFF\n# 3 1 0\n");
  // PLY: every header number, then the body's numbers as OpenMesh parses them.
  const std::string ply_body = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  for (const std::string version :
       {"ascii 1e40", "ascii 1e300", "ascii nan", "ascii -1", "ascii 2.0", "ascii x1.0", "binary_middle_endian 1.0"})
    mesh("header_" + std::to_string(cases.size()) + ".ply", ply(version, "float", ply_body));
  for (const std::string count : {"1000000000000", "999999999999999999", "-3", "3e0", "4294967296"})
    mesh("element_count_" + std::to_string(cases.size()) + ".ply", ply("ascii 1.0", "float", ply_body, count));
  mesh("property_type.ply", ply("ascii 1.0", "quad", ply_body));
  for (const std::string x : {"1e39", "-1e300", "nan", "inf", "3.5e38"})
    mesh("ply_coordinate_" + std::to_string(cases.size()) + ".ply",
         ply("ascii 1.0", "double", "0 0 0\n" + x + " 0 0\n0 1 0\n3 0 1 2\n"));
  for (const std::string face : {"3 0 1.5 2", "3 0 1 99999999999", "300 0 1 2", "-3 0 1 2", "3 0 1"})
    mesh("ply_face_" + std::to_string(cases.size()) + ".ply",
         ply("ascii 1.0", "float", "0 0 0\n1 0 0\n0 1 0\n" + face));
  {
    const double big[9] = {0, 0, 0, 1e39, 0, 0, 0, 1, 0};
    std::string body(reinterpret_cast<const char*>(big), sizeof(big));
    body += std::string("\x03\0\0\0\0\x01\0\0\0\x02\0\0\0", 13);
    mesh("binary_1e39.ply", ply("binary_little_endian 1.0", "double", body));
    mesh("binary_truncated.ply", ply("binary_little_endian 1.0", "double", body.substr(0, 30)));
  }
  mesh("no_end_header.ply", "ply\nformat ascii 1.0\nelement vertex 3\n");
  mesh("property_first.ply", "ply\nformat ascii 1.0\nproperty float x\nend_header\n");
  // OBJ and STL.
  for (const std::string x : {"1e39", "nan", "-1e999"})
    mesh("obj_coordinate_" + std::to_string(cases.size()) + ".obj", "v 0 0 0\nv " + x + " 0 0\nv 0 1 0\nf 1 2 3\n");
  for (const std::string face : {"/1/1 2/1/1 3/1/1", "1 2 x", "1 2 3/4/5/6", "0 1 2", "1.5 2 3", "1 2 99999999999",
                                 "#1 /1 3//1", "1 2 3 #/1", "1 2 3 # see 4"})
    mesh("obj_face_" + std::to_string(cases.size()) + ".obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf " + face + "\n");
  mesh("obj_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
  mesh("obj_no_faces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  mesh("obj_device_mtllib.obj", "mtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  for (const std::string x : {"1e39 0 0", "nan 0 0", "0 -1e300 0", "0 0"})
    mesh("stl_coordinate_" + std::to_string(cases.size()) + ".stl", stl(x));
  mesh("stl_binary_count.stl", std::string(80, 's') + std::string("\xff\xff\xff\xff", 4) + std::string(50, '\0'));
  mesh("unknown.xyz", "0 0 0\n");
  // Paths that are not regular files.
  cases.push_back(
      {"mesh is a directory", {{"dir.off/keep", ""}, {"f.txt", "0"}, {"h.txt", "2"}}, "dir.off" + kIndices});
  cases.push_back({"mesh is /dev/zero", {{"f.txt", "0"}, {"h.txt", "2"}}, "/dev/zero" + kIndices});

  // Scenarios: deep nesting in every field, numbers that overflow, wrong types, bad paths.
  auto scenario = [&](const std::string& name, const std::string& json) {
    cases.push_back({"scenario " + name, {{"s.json", json}, {"m.off", kTriangleOff}}, "--scenario s.json"});
  };
  const int deep = 200000;
  scenario("deep fixed", R"({"mesh": "m.off", "fixed": )" + nested(deep) + "}");
  scenario("deep mesh", R"({"mesh": )" + nested(deep, "\"m.off\"") + R"(, "fixed": [0]})");
  scenario("deep name", R"({"name": )" + nested(deep) + R"(, "mesh": "m.off", "fixed": [0]})");
  scenario("deep unknown key", R"({"mesh": "m.off", "fixed": [0], "extra": )" + nested(deep) + "}");
  scenario("deep handles", R"({"mesh": "m.off", "fixed": [0], "handles": )" + nested(deep) + "}");
  scenario("deep vertices", R"({"mesh": "m.off", "handles": [{"vertices": )" + nested(deep) + "}]}");
  scenario("deep matrix",
           R"({"mesh": "m.off", "fixed": [0], "handles": [{"vertices": [1], "matrix": )" + nested(deep) + "}]}");
  scenario("deep translate",
           R"({"mesh": "m.off", "fixed": [0], "handles": [{"vertices": [1], "translate": )" + nested(deep) + "}]}");
  scenario("deep objects", std::string(deep, '{').replace(0, 1, "{\"a\":") + "}");
  {
    std::string objects;
    for (int i = 0; i < deep; ++i) objects += "{\"a\":";
    scenario("deep object chain", objects + "0" + std::string(deep, '}'));
  }
  scenario("33 levels", R"({"mesh": "m.off", "fixed": [0], "x": )" + nested(33) + "}");
  scenario("index 2^64-1", R"({"mesh": "m.off", "fixed": [18446744073709551615]})");
  scenario("index 2^63", R"({"mesh": "m.off", "fixed": [9223372036854775808]})");
  scenario("index 1e400", R"({"mesh": "m.off", "fixed": [1e400]})");
  scenario("index -1", R"({"mesh": "m.off", "fixed": [-1]})");
  scenario("index string", R"({"mesh": "m.off", "fixed": ["0"]})");
  scenario("index beyond the mesh", R"({"mesh": "m.off", "fixed": [3]})");
  scenario("translate overflow", R"({"mesh": "m.off", "fixed": [0], "handles": [{"vertices": [1],
      "translate": [1.7e308, 0, 0], "matrix": [1,0,0,1.7e308, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]})");
  scenario("matrix 1e999", R"({"mesh": "m.off", "fixed": [0], "handles": [{"vertices": [1],
      "matrix": [1e999,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]})");
  scenario("matrix not affine", R"({"mesh": "m.off", "fixed": [0], "handles": [{"vertices": [1],
      "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,1,1]}]})");
  scenario("matrix 15 numbers", R"({"mesh": "m.off", "fixed": [0], "handles": [{"vertices": [1],
      "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0]}]})");
  // (A vertex in two handles is not hostile: it follows the first, arap/constraints.h.)
  scenario("only empty handles", R"({"mesh": "m.off", "handles": [{"vertices": []}, {"vertices": []}]})");
  scenario("no constraints", R"({"mesh": "m.off"})");
  scenario("not an object", "[1, 2, 3]");
  scenario("empty file", "");
  scenario("unterminated long string", R"({"mesh": ")" + std::string(1 << 20, 'a'));
  scenario("mesh is /dev/zero", R"({"mesh": "/dev/zero", "fixed": [0]})");
  scenario("mesh is a folder", R"({"mesh": ".", "fixed": [0]})");
  scenario("mesh missing", R"({"mesh": "nothere.off", "fixed": [0]})");
  cases.push_back({"scenario is /dev/zero", {}, "--scenario /dev/zero"});

  // Arguments.
  auto arg = [&](const std::string& extra) {
    cases.push_back({"argument" + extra,
                     {{"m.off", kTriangleOff}, {"f.txt", "0"}, {"h.txt", "2"}},
                     "m.off --fixed f.txt --handle h.txt" + extra});
  };
  for (const std::string extra :
       {" --translate 1e999,0,0", " --translate nan,0,0", " --translate 0,0", " --rotate x,1e999", " --rotate x,nan",
        " --rotate q,90", " --iterations 99999999999999999999", " --iterations -1", " --iterations 1e3",
        " --tolerance inf", " --tolerance -1", " --threads 0", " --threads 99999999999", " --anderson 1000",
        " --anderson -1", " --weights nan", " --init warm", " --translate 1.7e308,0,0 --rotate z,90"})
    arg(extra);
  cases.push_back({"index file is /dev/zero",
                   {{"m.off", kTriangleOff}, {"h.txt", "2"}},
                   "m.off --fixed /dev/zero --handle h.txt --translate 0,0,1"});
  cases.push_back({"index beyond int",
                   {{"m.off", kTriangleOff}, {"f.txt", "99999999999"}, {"h.txt", "2"}},
                   "m.off --fixed f.txt --handle h.txt --translate 0,0,1"});
  return cases;
}

// name -> bytes of every regular file under `dir`.
std::map<std::string, std::string> contents(const fs::path& dir) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) out[fs::relative(e.path(), dir).string()] = arap_test::TempDir::slurp(e.path().string());
  return out;
}

class HostileCatalogue : public arap_test::Cli {};

TEST_F(HostileCatalogue, EveryCaseExitsTwoWritesNothingAndTouchesNoInput) {
  timeout_s_ = 20;
  const std::vector<Case> cases = catalogue();
  EXPECT_GE(cases.size(), 60u);
  std::printf("hostile catalogue: %zu cases\n", cases.size());
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    for (const auto& [name, bytes] : c.files) {
      fs::create_directories((dir_ / name).parent_path());
      if (name.size() < 5 || name.substr(name.size() - 5) != "/keep") write(name, bytes);
    }
    const auto before = contents(dir_);
    const arap_test::Result r = run(c.args + " --output out.off --report report.json");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_LT(r.err.size(), 400u) << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
    EXPECT_EQ(contents(dir_), before);  // nothing written (no output, report or temporary), inputs untouched
  }
}

}  // namespace

