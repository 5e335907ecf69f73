// write_mesh(): small ASCII writers of our own, not OpenMesh's. Tried first
// through a custom OpenMesh::IO::BaseExporter: OpenMesh 9.0's OFF, OBJ and PLY
// writers all write the float point() even when is_point_double() is true
// (0.1 came out as 0.10000000149011612), and its PLY writer dereferences
// kernel() for custom properties. So the three formats are written here, at
// full double precision (shortest round-trip decimals), faces as given.
#include <charconv>
#include <fstream>

#include "arap/io/mesh_io.h"

namespace arap::io {
namespace {

// Shortest decimal that reads back as the same double.
void put(std::ostream& out, double x) {
  char buf[32];
  auto res = std::to_chars(buf, buf + sizeof(buf), x);
  out.write(buf, res.ptr - buf);
}

void put_point(std::ostream& out, const Points& v, Eigen::Index i) {
  put(out, v(i, 0));
  out << ' ';
  put(out, v(i, 1));
  out << ' ';
  put(out, v(i, 2));
  out << '\n';
}

void write_off(std::ostream& out, const Points& v, const std::vector<std::vector<int>>& faces) {
  out << "OFF\n" << v.rows() << ' ' << faces.size() << " 0\n";
  for (Eigen::Index i = 0; i < v.rows(); ++i) put_point(out, v, i);
  for (const auto& f : faces) {
    out << f.size();
    for (int i : f) out << ' ' << i;
    out << '\n';
  }
}

void write_obj(std::ostream& out, const Points& v, const std::vector<std::vector<int>>& faces) {
  for (Eigen::Index i = 0; i < v.rows(); ++i) {
    out << "v ";
    put_point(out, v, i);
  }
  for (const auto& f : faces) {
    out << 'f';
    for (int i : f) out << ' ' << i + 1;
    out << '\n';
  }
}

void write_ply(std::ostream& out, const Points& v, const std::vector<std::vector<int>>& faces) {
  out << "ply\nformat ascii 1.0\nelement vertex " << v.rows()
      << "\nproperty double x\nproperty double y\nproperty double z\nelement face " << faces.size()
      << "\nproperty list int int vertex_indices\nend_header\n";
  for (Eigen::Index i = 0; i < v.rows(); ++i) put_point(out, v, i);
  for (const auto& f : faces) {
    out << f.size();
    for (int i : f) out << ' ' << i;
    out << '\n';
  }
}

}  // namespace

void write_mesh(const std::string& path, const Points& vertices, const std::vector<std::vector<int>>& polygons) {
  const std::string ext = extension_of(path);
  if (ext != "off" && ext != "obj" && ext != "ply")
    throw FileError(path + ": cannot write '." + ext + "' (expected .off, .obj or .ply)");
  for (std::size_t f = 0; f < polygons.size(); ++f)
    for (int i : polygons[f])
      if (i < 0 || i >= vertices.rows())
        throw FileError(path + ": face " + std::to_string(f) + " refers to a vertex that does not exist");
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw FileError(path + ": cannot create the file");
  if (ext == "off") write_off(out, vertices, polygons);
  if (ext == "obj") write_obj(out, vertices, polygons);
  if (ext == "ply") write_ply(out, vertices, polygons);
  out.close();
  if (!out) throw FileError(path + ": write failed (disk full?)");
}

}  // namespace arap::io
