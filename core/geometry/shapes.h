// Simple generated meshes: unit icospheres, planar grids, and midpoint subdivision. Tests, benchmarks and examples use
// them where a real mesh is not needed.
#pragma once

#include <memory>

#include "geometry/mesh.h"

namespace montage {

// Icosphere of radius 1 centred at the origin: the icosahedron subdivided `levels` times
// (20 * 4^levels faces, CCW seen from outside). Vertices 0..11 are the icosahedron's.
std::unique_ptr<Mesh> makeIcosphere(int levels);

// Grid of nx by ny vertices in the plane z = 0 with spacing `step`, vertex (i, j) at index j*nx + i
// and position (i*step, j*step, 0); each cell split along its (i,j)-(i+1,j+1) diagonal; CCW seen
// from +z.
std::unique_ptr<Mesh> makeGrid(int nx, int ny, double step = 1.0);

// Midpoint subdivision, `levels` times: every triangle into four (4^levels times the faces), new
// vertices at edge midpoints appended after the existing ones (whose ids stay valid).
std::unique_ptr<Mesh> subdivideMidpoint(const Mesh& mesh, int levels);

}  // namespace montage
