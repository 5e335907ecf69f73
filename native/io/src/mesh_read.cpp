// read_mesh(): prescan, OpenMesh's reader into a RawImporter, validation.
#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "arap/io/mesh_io.h"
#include "mesh_prescan.h"
#include "raw_importer.h"

namespace arap::io {
namespace detail {

// OpenMesh's ASCII readers parse coordinates as float. Widening the float
// exactly would turn "0.1" into 0.10000000149011612; instead take the shortest
// decimal that reads back as the same float ("0.1") and parse that as double,
// which restores the file's value whenever it had at most ~7 significant digits.
static double widen(float f) {
  char buf[64];
  auto res = std::to_chars(buf, buf + sizeof(buf) - 1, f);
  *res.ptr = '\0';
  return std::strtod(buf, nullptr);
}

OpenMesh::VertexHandle RawImporter::add_vertex(const OpenMesh::Vec3f& p) {
  return add_vertex(OpenMesh::Vec3d(widen(p[0]), widen(p[1]), widen(p[2])));
}

OpenMesh::VertexHandle RawImporter::add_vertex(const OpenMesh::Vec3d& p) {
  if (points.size() >= max_elements_) throw ImportLimitExceeded("more vertices than the file size allows");
  points.push_back(p);
  return OpenMesh::VertexHandle(static_cast<int>(points.size()) - 1);
}

void RawImporter::set_point(VertexHandle vh, const OpenMesh::Vec3f& p) {
  if (vh.idx() >= 0 && static_cast<std::size_t>(vh.idx()) < points.size())
    points[vh.idx()] = OpenMesh::Vec3d(widen(p[0]), widen(p[1]), widen(p[2]));
}

OpenMesh::FaceHandle RawImporter::add_face(const VHandles& indices) {
  total_indices_ += indices.size();
  if (faces.size() >= max_elements_ || total_indices_ > 4 * max_elements_)
    throw ImportLimitExceeded("more faces than the file size allows");
  std::vector<int>& f = faces.emplace_back();
  f.reserve(indices.size());
  for (const auto& vh : indices) f.push_back(vh.idx());
  return OpenMesh::FaceHandle(static_cast<int>(faces.size()) - 1);
}

// OpenMesh reports problems on std::cerr and its own streams; a command-line
// tool must print one line per error, so both are muted while it reads.
class QuietOpenMesh {
 public:
  QuietOpenMesh() : saved_(std::cerr.rdbuf(sink_.rdbuf())) {
    ::omerr().disable();
    ::omlog().disable();
    ::omout().disable();
  }
  ~QuietOpenMesh() {
    std::cerr.rdbuf(saved_);
    ::omerr().enable();
    ::omlog().enable();
    ::omout().enable();
  }

 private:
  std::ostringstream sink_;
  std::streambuf* saved_;
};

}  // namespace detail

namespace {
[[noreturn]] void fail(const std::string& path, const std::string& what) { throw FileError(path + ": " + what); }
}  // namespace

PolygonMesh read_mesh(const std::string& path) {
  const std::uintmax_t size = require_regular_file(path, "mesh file");
  if (size == 0) fail(path, "empty file");
  const std::string ext = extension_of(path);
  detail::Expected expected = detail::prescan(path, ext);

  // Every vertex and face takes at least one byte of the file.
  detail::RawImporter importer(static_cast<std::size_t>(size) + 16);
  if (expected.complete) {
    importer.faces = std::move(expected.polygons);  // the scan read the whole mesh (OFF)
    importer.points.resize(static_cast<std::size_t>(expected.vertices));
  } else {
    OpenMesh::IO::Options options;
    bool ok = false;
    {
      detail::QuietOpenMesh quiet;
      try {
        // OpenMesh picks its reader from the extension, in lower case.
        ok = OpenMesh::IO::IOManager().read(path, importer, options);
      } catch (const detail::ImportLimitExceeded& e) {
        fail(path, e.what());
      }
    }
    if (!ok) fail(path, "OpenMesh could not parse the file as ." + ext);
  }

  const long long nv = static_cast<long long>(importer.points.size());
  const long long nf = static_cast<long long>(importer.faces.size());
  if (expected.vertices >= 0 && expected.vertices != nv)
    fail(path, "the file declares " + std::to_string(expected.vertices) + " vertices but " + std::to_string(nv) +
                   " could be read");
  if (expected.faces >= 0 && expected.faces != nf)
    fail(path, "the file declares " + std::to_string(expected.faces) + " faces but " + std::to_string(nf) +
                   " could be read" +
                   (ext == "obj" || ext == "stl" ? " (OpenMesh drops faces with fewer than 3 distinct vertices)" : ""));
  if (nv == 0) fail(path, "no vertices");
  if (nf == 0) fail(path, "no faces");

  PolygonMesh mesh;
  mesh.vertices.resize(nv, 3);
  // OpenMesh's ASCII readers parse floats: take the prescan's doubles when they line up.
  const bool exact = expected.coordinates.size() == 3 * static_cast<size_t>(nv);
  for (long long i = 0; i < nv; ++i) {
    for (int k = 0; k < 3; ++k) {
      const double x = exact ? expected.coordinates[3 * i + k] : importer.points[i][k];
      if (!std::isfinite(x)) fail(path, "vertex " + std::to_string(i) + " has a non-finite coordinate");
      mesh.vertices(i, k) = x;
    }
  }
  for (long long f = 0; f < nf; ++f) {
    const std::vector<int>& face = importer.faces[f];
    if (face.size() < 3) fail(path, "face " + std::to_string(f) + " has fewer than 3 vertices");
    for (int idx : face)
      if (idx < 0 || idx >= nv)
        fail(path, "face " + std::to_string(f) + " refers to vertex " + std::to_string(idx) + ", outside [0, " +
                       std::to_string(nv) + ")");
  }
  mesh.polygons = std::move(importer.faces);
  return mesh;
}

}  // namespace arap::io
