// Reading and writing polygon meshes (OFF, OBJ, PLY, STL in; OFF, OBJ, PLY
// out) through OpenMesh's IO modules, without building a halfedge mesh: every
// face of the file is kept, non-manifold ones included.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "arap/solver.h"

namespace arap::io {

// A file that cannot be read or written; the message names the file and the problem.
class FileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct PolygonMesh {
  Points vertices;                         // #V by 3, in the file's order
  std::vector<std::vector<int>> polygons;  // the file's faces, 0-based, >= 3 vertices each
};

// Reads `path` (format from its extension). Throws FileError when the file is
// missing, of an unsupported format, malformed or truncated, has counts its
// size cannot hold, non-finite coordinates, face indices outside [0, #V),
// faces with fewer than 3 vertices, or no face at all. OFF and PLY faces with
// a repeated vertex are kept (the solver counts them as degenerate); OpenMesh's
// OBJ and STL readers drop faces with fewer than 3 distinct vertices (an error
// here: the face counts disagree) and remove repeats from larger faces. OpenMesh parses
// coordinates as float; decimals of up to ~7 significant digits come back
// exact. std::cerr is muted while OpenMesh reads (it reports there), so do not
// call this while other threads write to std::cerr.
PolygonMesh read_mesh(const std::string& path);

// Writes `vertices` and `polygons` to `path` (format from its extension:
// off, obj or ply; ASCII, shortest decimals that round-trip every double).
// Throws FileError on failure.
void write_mesh(const std::string& path, const Points& vertices, const std::vector<std::vector<int>>& polygons);

// Fan triangulation (v0, vk, vk+1) of every polygon, in order; #F' by 3.
Triangles triangulate(const std::vector<std::vector<int>>& polygons);

// The triangles of `triangles` as 3-vertex polygons.
std::vector<std::vector<int>> to_polygons(const Triangles& triangles);

// Lower-case extension of `path` without the dot ("" when none).
std::string extension_of(const std::string& path);

}  // namespace arap::io
