#include "bench_cases.h"

#include <filesystem>
#include <stdexcept>

#include "arap/io/mesh_io.h"
#include "arap/io/polygons.h"
#include "arap/io/scenario.h"
#include "arap/tools/procedural.h"

namespace bench {
namespace {

void bend_scenario(Case& c) {
  arap::procedural::Bend b = arap::procedural::bend(c.rest);
  c.constrained = std::move(b.constrained);
  c.targets = std::move(b.targets);
  c.fixed_count = b.fixed_count;
}

}  // namespace

Case procedural_case(const std::string& shape, int vertices) {
  arap::procedural::TriMesh mesh;
  if (shape == "sphere")
    mesh = arap::procedural::make_ellipsoid(vertices, Eigen::Vector3d(1, 1, 2));
  else if (shape == "bar")
    mesh = arap::procedural::make_bar_with_vertices(vertices, 6.0);
  else
    throw std::runtime_error("unknown shape '" + shape + "' (sphere or bar)");
  Case c;
  c.rest = std::move(mesh.vertices);
  c.triangles = std::move(mesh.triangles);
  const long n = static_cast<long>(c.rest.rows());
  c.name = shape + "-" + (n >= 1000000 ? std::to_string((n + 500000) / 1000000) + "M"
                         : n >= 1000  ? std::to_string((n + 500) / 1000) + "k"
                                      : std::to_string(n));
  c.source = "procedural";
  bend_scenario(c);
  return c;
}

Case file_case(const std::string& path) {
  Case c;
  c.source = path;
  c.name = std::filesystem::path(path).stem().string();
  auto read = [&c](const std::string& mesh_path) {
    arap::io::PolygonMesh mesh = arap::io::read_mesh(mesh_path);
    c.rest = std::move(mesh.vertices);
    c.triangles = arap::io::triangulate(mesh.polygons);
  };
  if (arap::io::extension_of(path) != "json") {
    read(path);
    bend_scenario(c);
    return c;
  }
  const arap::io::Scenario scenario = arap::io::load_scenario(path);
  if (!scenario.name.empty()) c.name = scenario.name;
  read(scenario.mesh_path);
  arap::io::Constraints constraints = arap::io::build_constraints(c.rest, scenario.fixed, scenario.handles);
  c.constrained = std::move(constraints.constrained);
  c.targets = std::move(constraints.targets);
  c.fixed_count = constraints.fixed_count;
  return c;
}

}  // namespace bench
