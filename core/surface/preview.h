// The preview tier's colours on the CPU. The editor shows the preview on the GPU: a mapped face samples
// its photo through its photo UVs plus the seam levelling offset; an inpainted face interpolates the
// inpainted colours at the vertices of its refined triangles; other faces show a flat colour. This is
// the same rule, for renders, tests (the preview against the final bake) and the editor's shader to
// be checked against.
#pragma once

#include <array>
#include <utility>
#include <vector>

#include "base/common.h"
#include "mapping/texture_map.h"

namespace montage {

struct Photo;
struct SeamLevelling;
struct InpaintResult;

// The barycentrics w of point b of a face (b in the face's barycentrics) in a refined triangle of it
// whose corners have the face's barycentrics pb; false when the triangle is degenerate. b lies in the
// triangle when w's smallest coordinate is >= 0 (up to rounding).
bool refinedBarycentrics(const std::array<Vec3, 3>& pb, const Vec3& b, Vec3& w);

class PreviewSurface {
 public:
  // `levelling` and `inpaint` may be null. The referenced objects must outlive the PreviewSurface.
  PreviewSurface(const TextureMap& map, const std::vector<const Photo*>& photos, const SeamLevelling* levelling,
                 const InpaintResult* inpaint, const Vec3f& emptyColor = Vec3f(0.7f, 0.7f, 0.7f));
  // sRGB colour in [0,1] of face f (of the mapping's mesh) at barycentrics b.
  Vec3f color(int face, const Vec3& b) const;
  // The refined triangles that color(face, b) scans first, in order: b's cell of the face's grid, or all
  // the face's refined triangles when it has no grid (few of them). For tests.
  std::vector<int> candidates(int face, const Vec3& b) const;

 private:
  static int cellOf(double x, int size);  // the grid cell of barycentric coordinate x, clamped into the grid
  // The triangles of b's cell in face f's grid; {null, null} when f has no grid or b is not finite.
  std::pair<const int*, const int*> gridCell(int f, const Vec3& b) const;

  const TextureMap& map_;
  std::vector<const Photo*> photos_;
  const SeamLevelling* levelling_;
  const InpaintResult* inpaint_;
  Vec3f empty_;
  std::vector<int> firstTriangle_;  // per face: start of its refined triangles in triangles_ (#F + 1)
  std::vector<int> triangles_;
  // A face refined into many triangles gets a uniform grid over its barycentrics (x, y): per cell, in
  // triangles_'s order, the triangles whose box (padded) meets the cell. A lookup scans its cell and
  // takes the same triangle as a scan of all of them; a point in no candidate (rounding at the face's
  // border) scans all of them.
  struct Grid {
    int size = 0;       // cells a side; 0 = no grid (few triangles)
    int firstCell = 0;  // index into cellStart_
  };
  std::vector<Grid> grids_;     // #F
  std::vector<int> cellStart_;  // per cell: start in cellTriangles_; one more entry at the end
  std::vector<int> cellTriangles_;
};

}  // namespace montage
