// arap-mesh-measure: what a pose did to a shape, from the mesh files alone
// (not from the solver): enclosed volume of the closed components, material
// cross-sections, self-intersecting triangle pairs, rigidity distortion.
#include <cstdio>
#include <iostream>
#include <string>

#include <nlohmann/json.hpp>

#include "arap/errors.h"
#include "arap/io/mesh_io.h"
#include "arap/io/polygons.h"
#include "arap/io/shape_measures.h"
#include "arap/tools/quality.h"

namespace {

const char* const kUsage = R"(Usage:
  arap-mesh-measure REST POSED [--planes N] [--list-intersections]

REST and POSED are meshes with the same faces (.off .obj .ply .stl), e.g. an
arap-deform input and its output. Prints one JSON object:
  volume_ratio          posed / rest volume summed over the closed components
                        (1 when there is none), worst_volume_ratio per component
  closed_components, open_components
  cross_section_median, cross_section_min, cross_section_loops
                        area of the rest mesh's cuts by N planes (default 9)
                        across its principal axis, followed as material curves
                        into the posed mesh, posed / rest
  self_intersections    triangle pairs sharing no vertex that cross (posed;
                        --list-intersections: intersecting_pairs, the
                        triangle indices of the fan-triangulated faces),
  rest_self_intersections  the same at rest
  distortion, flipped_triangles  as in arap-deform's report
Exit status 2 on bad input, with one line on stderr.
)";

}  // namespace

int main(int argc, char** argv) {
  using namespace arap;
  try {
    std::string rest_path, posed_path;
    int planes = 9;
    bool list_pairs = false;
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg == "--help" || arg == "-h") {
        std::fputs(kUsage, stdout);
        return 0;
      } else if (arg == "--list-intersections") {
        list_pairs = true;
      } else if (arg == "--planes" && i + 1 < argc) {
        planes = std::stoi(argv[++i]);
        if (planes < 1 || planes > 1000) throw std::invalid_argument("--planes expects 1..1000");
      } else if (rest_path.empty()) {
        rest_path = arg;
      } else if (posed_path.empty()) {
        posed_path = arg;
      } else {
        throw std::invalid_argument("unexpected argument '" + arg + "'");
      }
    }
    if (posed_path.empty()) throw std::invalid_argument("give REST and POSED mesh files");
    const io::PolygonMesh rest = io::read_mesh(rest_path), posed = io::read_mesh(posed_path);
    if (rest.vertices.rows() != posed.vertices.rows() || rest.polygons != posed.polygons)
      throw std::invalid_argument(posed_path + " does not have the vertices and faces of " + rest_path);
    const Triangles triangles = io::triangulate(rest.polygons);
    const measure::VolumeKept volume = measure::volume_kept(rest.vertices, posed.vertices, triangles);
    const measure::CrossSections sections =
        measure::cross_sections(rest.vertices, posed.vertices, triangles, planes);
    int flipped = 0;
    const double distortion = rigidity_distortion(rest.vertices, posed.vertices, triangles, &flipped);
    nlohmann::json r;
    r["volume_ratio"] = volume.ratio;
    r["worst_volume_ratio"] = volume.worst_ratio;
    r["rest_volume"] = volume.rest;
    r["posed_volume"] = volume.posed;
    r["closed_components"] = volume.closed_components;
    r["open_components"] = volume.open_components;
    r["cross_section_median"] = sections.median;
    r["cross_section_min"] = sections.min;
    r["cross_section_loops"] = sections.loops;
    r["cross_section_ratios"] = sections.ratios;
    std::vector<std::pair<int, int>> pairs;
    r["self_intersections"] =
        measure::self_intersecting_pairs(posed.vertices, triangles, list_pairs ? &pairs : nullptr);
    if (list_pairs) r["intersecting_pairs"] = pairs;
    r["rest_self_intersections"] = measure::self_intersecting_pairs(rest.vertices, triangles);
    r["distortion"] = distortion;
    r["flipped_triangles"] = flipped;
    std::cout << r.dump(2) << '\n';
    return 0;
  } catch (const io::FileError& e) {
    std::cerr << "arap-mesh-measure: " << e.what() << '\n';
  } catch (const std::exception& e) {
    std::cerr << "arap-mesh-measure: " << e.what() << " (see --help)\n";
  }
  return 2;
}
