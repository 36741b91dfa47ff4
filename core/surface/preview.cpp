#include "surface/preview.h"

#include <algorithm>
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
  for (int i = firstTriangle_[f]; i < firstTriangle_[f + 1]; ++i) {
    const int t = triangles_[i];
    const auto& pb = rs.parentBary[t];
    // Solve b = w0 pb0 + w1 pb1 + w2 pb2 with w0 + w1 + w2 = 1, in two of the three coordinates.
    const Vec3 e1 = pb[1] - pb[0], e2 = pb[2] - pb[0], d = b - pb[0];
    const double det = e1.x() * e2.y() - e1.y() * e2.x();
    if (std::abs(det) < 1e-300) continue;
    const double w1 = (d.x() * e2.y() - d.y() * e2.x()) / det, w2 = (e1.x() * d.y() - e1.y() * d.x()) / det;
    const Vec3 w(1 - w1 - w2, w1, w2);
    const double m = w.minCoeff();
    if (m > bestMin) bestMin = m, best = t, bestW = w;
    if (m >= 0) break;
  }
  if (best < 0) return map_.facePhoto[f] >= 0 ? mappedColor(map_, photos_, levelling_, f, b) : empty_;
  const auto& tri = rs.mesh.triangles[best];
  Vec3f c = Vec3f::Zero();
  for (int k = 0; k < 3; ++k) c += float(bestW[k]) * inpaint_->colors.row(tri[k]).transpose();
  return c;
}

}  // namespace montage
