// Simple generated meshes: unit icospheres and planar grids. Tests, benchmarks and examples use them
// where a real mesh is not needed.
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

}  // namespace montage
