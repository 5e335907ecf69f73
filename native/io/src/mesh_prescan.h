// Structural checks of a mesh file before OpenMesh reads it, and the OFF
// reader itself.
//
// OpenMesh's readers trust the counts they read: an OFF or PLY header that
// claims 10^12 vertices, a negative or huge face size ("-3 0 1 2" is read as
// 4294967293 indices) or a PLY list count of 2^31 make them loop for hours or
// allocate gigabytes, and a truncated OFF leaves uninitialised indices in the
// last face. These scanners walk the file once without allocating from its
// counts and throw FileError (naming the problem) when the structure cannot be
// right, so that OpenMesh only ever sees files whose counts fit their size.
// Every number OpenMesh will parse is checked against the type it parses it
// as (a float beyond 3.4e38 or a non-integer index stops its stream, and it
// then reads uninitialised values). OFF is parsed here completely (comments,
// the full double range), so OpenMesh never reads OFF.
#pragma once

#include <string>
#include <vector>

namespace arap::io::detail {

// What the scan expects OpenMesh to deliver; -1 when the format does not say.
struct Expected {
  long long vertices = -1;
  long long faces = -1;
  // x, y, z of every vertex parsed as double from ASCII formats (OpenMesh's
  // readers parse floats); empty for binary files.
  std::vector<double> coordinates;
  // When `complete`, the scan read the whole mesh: `polygons` are its faces
  // (indices checked against `vertices`) and OpenMesh is not needed.
  bool complete = false;
  std::vector<std::vector<int>> polygons;
};

// Dispatches on `ext` ("off", "obj", "ply", "stl").
Expected prescan(const std::string& path, const std::string& ext);

}  // namespace arap::io::detail
