// arap-make-mesh: write a procedural mesh and "bottom fixed / top moved"
// constraint files for arap-deform.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>

#include "arap/errors.h"
#include "arap/io/mesh_io.h"
#include "arap/io/numbers.h"
#include "arap/io/polygons.h"
#include "arap/tools/procedural.h"

namespace {

const char* const kUsage = R"(Usage:
  arap-make-mesh bar|cylinder|sphere [--vertices N] [--dims NX,NY,NZ] --output MESH.obj
                 [--fixed-out fixed.txt] [--handle-out handle.txt]
                 [--fixed-fraction F] [--handle-fraction H]

Shapes (all closed, standing along +z):
  bar        box 1 x 1 x 5 (--vertices N picks the subdivision, default 1000;
             --dims NX,NY,NZ gives the cells directly)
  cylinder   radius 0.5, height 5, capped (--vertices N, default 1000)
  sphere     bumpy sphere of radius 1 (--vertices N, default 1000)

Constraint files hold 0-based vertex indices: --fixed-out gets the vertices in
the lowest F of the height (default 0.2), --handle-out those in the highest H
(default 0.05). Exit status 2 on bad arguments, with one line on stderr.

Example (bend a bar):
  arap-make-mesh bar --vertices 2000 --output bar.obj --fixed-out fixed.txt --handle-out handle.txt
  arap-deform bar.obj --fixed fixed.txt --handle handle.txt --translate 2,0,-1 --max-iterations 20 --output bent.obj
)";

struct Usage : std::runtime_error {
  using std::runtime_error::runtime_error;
};

double number(const std::string& flag, const std::string& s) {
  double v = 0;
  if (!arap::io::parse_finite(s, v)) throw Usage(flag + " expects a number");
  return v;
}

// A whole number, written as one ("2000", "2e3").
int integer(const std::string& flag, const std::string& s) {
  double v = 0;
  if (!arap::io::parse_finite(s, v) || v != std::floor(v) || v < 1 || v > 1e8)
    throw Usage(flag + " expects a positive integer");
  return static_cast<int>(v);
}

void write_indices(const std::string& path, const std::vector<int>& indices) {
  std::ofstream out(path);
  for (std::size_t i = 0; i < indices.size(); ++i) out << indices[i] << ((i + 1) % 16 == 0 ? '\n' : ' ');
  out << '\n';
  out.close();
  if (!out) throw arap::io::FileError(path + ": cannot write");
}

int run(int argc, char** argv) {
  std::string shape, output, fixed_out, handle_out;
  int vertices = 1000;
  int dims[3] = {0, 0, 0};
  double fixed_fraction = 0.2, handle_fraction = 0.05;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw Usage(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--help" || arg == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (arg == "--vertices") {
      vertices = integer(arg, value());
    } else if (arg == "--dims") {
      const std::string v = value();
      const std::size_t a = v.find(','), b = a == std::string::npos ? a : v.find(',', a + 1);
      long long n[3] = {0, 0, 0};
      const bool ok = b != std::string::npos && v.find(',', b + 1) == std::string::npos &&
                      arap::io::parse_integer(std::string_view(v).substr(0, a), n[0]) &&
                      arap::io::parse_integer(std::string_view(v).substr(a + 1, b - a - 1), n[1]) &&
                      arap::io::parse_integer(std::string_view(v).substr(b + 1), n[2]);
      for (int k = 0; k < 3; ++k) {
        if (!ok || n[k] < 1 || n[k] > 10000) throw Usage("--dims expects NX,NY,NZ (integers from 1 to 10000)");
        dims[k] = static_cast<int>(n[k]);
      }
    } else if (arg == "--output" || arg == "-o") {
      output = value();
    } else if (arg == "--fixed-out") {
      fixed_out = value();
    } else if (arg == "--handle-out") {
      handle_out = value();
    } else if (arg == "--fixed-fraction") {
      fixed_fraction = number(arg, value());
    } else if (arg == "--handle-fraction") {
      handle_fraction = number(arg, value());
    } else if (!arg.empty() && arg[0] == '-') {
      throw Usage("unknown option '" + arg + "'");
    } else if (shape.empty()) {
      shape = arg;
    } else {
      throw Usage("unexpected argument '" + arg + "'");
    }
  }
  if (shape.empty()) throw Usage("give a shape: bar, cylinder or sphere");
  if (output.empty()) throw Usage("--output is required");
  arap::procedural::TriMesh mesh;
  if (shape == "bar") {
    mesh = dims[0] > 0 ? arap::procedural::make_bar(dims[0], dims[1], dims[2], 1.0, 1.0, 5.0)
                       : arap::procedural::make_bar_with_vertices(vertices, 5.0);
  } else if (shape == "cylinder") {
    // rings ~ 3.2 x segments keeps the side quads roughly square (height 5, circumference pi).
    const int segments = std::max(3, static_cast<int>(std::lround(std::sqrt(vertices / 3.2))));
    const int rings = std::max(1, vertices / segments - 1);
    mesh = arap::procedural::make_cylinder(segments, rings, 0.5, 5.0);
  } else if (shape == "sphere") {
    mesh = arap::procedural::make_sphere(std::max(vertices, 8));
  } else {
    throw Usage("unknown shape '" + shape + "' (expected bar, cylinder or sphere)");
  }
  arap::io::write_mesh(output, mesh.vertices, arap::io::to_polygons(mesh.triangles));
  const auto picked = arap::procedural::pick_by_height(mesh.vertices, 2, fixed_fraction, handle_fraction);
  if (!fixed_out.empty()) write_indices(fixed_out, picked.fixed);
  if (!handle_out.empty()) write_indices(handle_out, picked.handle);
  std::printf("%s: %s with %ld vertices, %ld triangles; %zu fixed, %zu handle vertices\n", output.c_str(),
              shape.c_str(), static_cast<long>(mesh.vertices.rows()), static_cast<long>(mesh.triangles.rows()),
              picked.fixed.size(), picked.handle.size());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const Usage& e) {
    std::cerr << "arap-make-mesh: " << e.what() << " (see --help)\n";
  } catch (const std::exception& e) {
    std::cerr << "arap-make-mesh: " << e.what() << '\n';
  }
  return 2;
}
