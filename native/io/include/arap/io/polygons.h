// Polygon faces as files hold them, and the triangles the solver takes.
#pragma once

#include <vector>

#include "arap/types.h"

namespace arap::io {

// Fan triangulation (v0, vk, vk+1) of every polygon, in order; #F' by 3.
Triangles triangulate(const std::vector<std::vector<int>>& polygons);

// The triangles of `triangles` as 3-vertex polygons.
std::vector<std::vector<int>> to_polygons(const Triangles& triangles);

}  // namespace arap::io
