#include "surface/preview.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "image/photo.h"
#include "surface/inpaint.h"
#include "surface/level.h"

namespace montage {

PreviewSurface::PreviewSurface(const TextureMap& map, const std::vector<const Photo*>& photos,
                               const SeamLevelling* levelling, const InpaintResult* inpaint, const Vec3f& emptyColor)
    : map_(map), photos_(photos), levelling_(levelling), inpaint_(inpaint), empty_(emptyColor) {
  const int nf = map.numFaces();
  firstTriangle_.assign(nf + 1, 0);
  if (!inpaint_ || inpaint_->faceRegion.empty()) return;
  const auto& parent = inpaint_->refined.parentFace;
  for (int p : parent) ++firstTriangle_[p + 1];
  for (int f = 0; f < nf; ++f) firstTriangle_[f + 1] += firstTriangle_[f];
  triangles_.resize(parent.size());
  std::vector<int> next(firstTriangle_.begin(), firstTriangle_.end() - 1);
  for (int t = 0; t < static_cast<int>(parent.size()); ++t) triangles_[next[parent[t]]++] = t;

  // Grids over the faces with many refined triangles (a hole's faces refined to the texel density have
  // hundreds: the bake's lookups scanned them all).
  constexpr int kGridAbove = 12;
  constexpr double kPad = 1e-9;  // a triangle that takes a point by rounding still lists it
  const auto& bary = inpaint_->refined.parentBary;
  grids_.assign(nf, Grid{});
  cellStart_.push_back(0);
  std::vector<std::vector<int>> cells;
  for (int f = 0; f < nf; ++f) {
    const int n = firstTriangle_[f + 1] - firstTriangle_[f];
    if (n <= kGridAbove) continue;
    const int g = std::clamp(static_cast<int>(std::ceil(std::sqrt(n / 2.0))), 2, 64);
    cells.assign(size_t(g) * g, {});
    for (int i = firstTriangle_[f]; i < firstTriangle_[f + 1]; ++i) {
      const auto& pb = bary[triangles_[i]];
      const double x0 = std::min({pb[0].x(), pb[1].x(), pb[2].x()}) - kPad;
      const double x1 = std::max({pb[0].x(), pb[1].x(), pb[2].x()}) + kPad;
      const double y0 = std::min({pb[0].y(), pb[1].y(), pb[2].y()}) - kPad;
      const double y1 = std::max({pb[0].y(), pb[1].y(), pb[2].y()}) + kPad;
      const int cx0 = cellOf(x0, g), cx1 = cellOf(x1, g), cy0 = cellOf(y0, g), cy1 = cellOf(y1, g);
      for (int cy = cy0; cy <= cy1; ++cy)
        for (int cx = cx0; cx <= cx1; ++cx) cells[size_t(cy) * g + cx].push_back(triangles_[i]);
    }
    grids_[f] = {g, static_cast<int>(cellStart_.size()) - 1};
    for (const auto& c : cells) {
      cellTriangles_.insert(cellTriangles_.end(), c.begin(), c.end());
      cellStart_.push_back(static_cast<int>(cellTriangles_.size()));
    }
  }
}

int PreviewSurface::cellOf(double x, int size) {
  return std::clamp(static_cast<int>(std::floor(x * size)), 0, size - 1);
}

std::pair<const int*, const int*> PreviewSurface::gridCell(int f, const Vec3& b) const {
  const Grid& grid = grids_[f];
  if (grid.size == 0 || !std::isfinite(b.x()) || !std::isfinite(b.y())) return {nullptr, nullptr};
  const int c = grid.firstCell + cellOf(b.y(), grid.size) * grid.size + cellOf(b.x(), grid.size);
  return {cellTriangles_.data() + cellStart_[c], cellTriangles_.data() + cellStart_[c + 1]};
}

std::vector<int> PreviewSurface::candidates(int f, const Vec3& b) const {
  if (grids_.empty()) return {};
  if (const auto [first, last] = gridCell(f, b); first) return {first, last};
  return {triangles_.begin() + firstTriangle_[f], triangles_.begin() + firstTriangle_[f + 1]};
}

bool refinedBarycentrics(const std::array<Vec3, 3>& pb, const Vec3& b, Vec3& w) {
  // Solve b = w0 pb0 + w1 pb1 + w2 pb2 with w0 + w1 + w2 = 1, in two of the three coordinates.
  const Vec3 e1 = pb[1] - pb[0], e2 = pb[2] - pb[0], d = b - pb[0];
  const double det = e1.x() * e2.y() - e1.y() * e2.x();
  if (std::abs(det) < 1e-300) return false;
  const double w1 = (d.x() * e2.y() - d.y() * e2.x()) / det, w2 = (e1.x() * d.y() - e1.y() * d.x()) / det;
  w = Vec3(1 - w1 - w2, w1, w2);
  return true;
}

Vec3f PreviewSurface::color(int f, const Vec3& b) const {
  const bool inpainted = inpaint_ && !inpaint_->faceRegion.empty() && inpaint_->faceRegion[f] >= 0;
  if (!inpainted) return map_.facePhoto[f] >= 0 ? mappedColor(map_, photos_, levelling_, f, b) : empty_;
  // The refined triangle of f containing b (in the parent's barycentric coordinates): the one whose
  // smallest barycentric coordinate of b is largest (>= 0 inside, up to rounding).
  const RefinedSurface& rs = inpaint_->refined;
  int best = -1;
  double bestMin = -std::numeric_limits<double>::infinity();
  Vec3 bestW = Vec3::Zero();
  // Scans the triangles [first, last) in order, keeping the best; true at the first that contains b (m >= 0).
  auto scan = [&](const int* first, const int* last) {
    for (const int* i = first; i != last; ++i) {
      const int t = *i;
      Vec3 w;
      if (!refinedBarycentrics(rs.parentBary[t], b, w)) continue;
      const double m = w.minCoeff();
      if (m > bestMin) bestMin = m, best = t, bestW = w;
      if (m >= 0) return true;
    }
    return false;
  };
  bool found = false;
  if (const auto [first, last] = gridCell(f, b); first) {
    // Every triangle that contains b lists it in b's cell, in triangles_'s order: the first that contains
    // b there is the first of all.
    found = scan(first, last);
    if (!found) best = -1, bestMin = -std::numeric_limits<double>::infinity();
  }
  if (!found) scan(triangles_.data() + firstTriangle_[f], triangles_.data() + firstTriangle_[f + 1]);
  if (best < 0) return map_.facePhoto[f] >= 0 ? mappedColor(map_, photos_, levelling_, f, b) : empty_;
  return inpaint_->colourAt(best, bestW);
}

}  // namespace montage
