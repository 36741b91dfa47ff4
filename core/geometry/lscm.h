// Least squares conformal maps (Levy, Petitjean, Ray, Maillot, SIGGRAPH 2002): the flattening the
// atlas uses for charts no photo covers (inpainted and empty regions), plus the checks that decide
// whether a chart is a disc and whether its flattening is good enough to keep.
#pragma once

#include <array>
#include <utility>
#include <vector>

#include "base/common.h"

namespace montage {

struct LscmOptions {
  // Triangles with 4 * area < degenerateRatio * (longest edge)^2 have their weight capped at that
  // value: zero-area and sliver faces then pull like a thin-but-valid triangle instead of with an
  // infinite (or NaN) weight.
  double degenerateRatio = 1e-4;
  // Weight, relative to the mean conformal weight, of a uniform graph Laplacian added to the energy.
  // It makes the system positive definite when a vertex is used only by zero-area faces (which give
  // no conformal constraint at all) and is far too small to change a regular chart's result.
  double regularisation = 1e-9;
};

// Flattens a connected triangle mesh (a topological disc; the result is meaningless for a closed
// surface) conformally. positions: #V model-space points; triangles: #T index triples. Two vertices
// far apart are pinned at their 3D distance apart, so the result is in model units up to the scale
// LSCM picks (use uvArea / 3D area to renormalise). Returns #V points, oriented so that the total
// signed area is positive (counter-clockwise corners stay counter-clockwise, v up). Vertices no
// triangle uses are placed at the origin. Throws montage::Error when there are no triangles, an index
// is out of range or the solve fails.
std::vector<Vec2> lscm(const std::vector<Vec3>& positions, const std::vector<std::array<int, 3>>& triangles,
                       const LscmOptions& options = {});

// The same with the vertices of `pins` held at the given UVs (at least two, distinct): the conformal map closest to
// those constraints (with a fixed boundary: the harmonic map inside it). No reorientation.
std::vector<Vec2> lscm(const std::vector<Vec3>& positions, const std::vector<std::array<int, 3>>& triangles,
                       const std::vector<std::pair<int, Vec2>>& pins, const LscmOptions& options = {});

// Quality of a flattening: Sander stretch normalised so that 1 means isometric up to one global scale
// (the uv are scaled to the 3D area first), and flips among the faces with a non-zero 3D area.
struct FlatteningQuality {
  int flipped = 0;         // faces of non-zero 3D area whose uv triangle is not counter-clockwise
  double stretchL2 = 1;    // area-weighted L2 stretch, >= 1
  double stretchLinf = 1;  // largest per-face stretch (gamma), over non-degenerate, unflipped faces
  double areaScale = 1;    // sqrt(3D area / uv area): multiply uv by this for unit density
};
FlatteningQuality flatteningQuality(const std::vector<Vec3>& positions,
                                    const std::vector<std::array<int, 3>>& triangles, const std::vector<Vec2>& uv);

// Topology of a set of triangles (index triples into some vertex array, edge-connected or not).
struct PatchTopology {
  int vertices = 0, edges = 0, faces = 0;
  int components = 0;       // edge-connected components
  int boundaryLoops = 0;    // closed chains of boundary edges (edges with one face)
  int pinchedVertices = 0;  // vertices whose faces form more than one fan
  int eulerCharacteristic() const { return vertices - edges + faces; }
  // One component, no pinched vertex, chi = 1: a topological disc, which LSCM can flatten.
  bool isDisc() const { return components == 1 && pinchedVertices == 0 && eulerCharacteristic() == 1; }
};
PatchTopology patchTopology(const std::vector<std::array<int, 3>>& triangles);

}  // namespace montage
