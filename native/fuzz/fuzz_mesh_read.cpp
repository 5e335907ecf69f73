// libFuzzer target: arap::io::read_mesh() on arbitrary bytes, through the
// prescan and (for OBJ, PLY, STL) OpenMesh's readers. The first byte picks
// the format ('o' OFF, 'b' OBJ, 'p' PLY, 's' STL; others by value mod 4).
// A read either throws FileError or returns finite vertices and faces of at
// least 3 in-range indices; any other exception, crash or hang is a finding.
#include <cmath>
#include <cstdint>

#include "arap/io/mesh_io.h"
#include "fuzz_common.h"

namespace {

const char* format_of(uint8_t selector) {
  switch (selector) {
    case 'o':
      return "off";
    case 'b':
      return "obj";
    case 'p':
      return "ply";
    case 's':
      return "stl";
    default: {
      static const char* const formats[] = {"off", "obj", "ply", "stl"};
      return formats[selector % 4];
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string path = arap_fuzz::scratch_file(std::string("mesh.") + format_of(data[0]), data + 1, size - 1);
  arap::io::PolygonMesh mesh;
  try {
    mesh = arap::io::read_mesh(path);
  } catch (const arap::io::FileError&) {
    return 0;
  }
  if (mesh.vertices.rows() == 0 || mesh.polygons.empty()) arap_fuzz::broken("empty mesh returned");
  if (!mesh.vertices.allFinite()) arap_fuzz::broken("non-finite vertex returned");
  for (const auto& face : mesh.polygons) {
    if (face.size() < 3) arap_fuzz::broken("face with fewer than 3 vertices returned");
    for (int i : face)
      if (i < 0 || i >= mesh.vertices.rows()) arap_fuzz::broken("face index out of range returned");
  }
  return 0;
}
