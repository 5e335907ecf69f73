// Reading polygon meshes (OFF, OBJ, PLY, STL) and writing them (OFF, OBJ,
// PLY). OFF is parsed here in full; OBJ, PLY and STL go through OpenMesh's
// readers, without building a halfedge mesh, so every face of the file is
// kept, non-manifold ones included. Writing uses small writers of our own
// (mesh_write.cpp says why not OpenMesh's).
#pragma once

#include <string>
#include <vector>

#include "arap/io/files.h"
#include "arap/types.h"

namespace arap::io {

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

}  // namespace arap::io
