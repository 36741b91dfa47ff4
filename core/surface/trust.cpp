#include "surface/trust.h"

#include <algorithm>
#include <cmath>

#include "base/common.h"
#include "geometry/mesh.h"
#include "geometry/stretch.h"

namespace montage {

FaceTrust faceTrust(const Mesh& mesh, const TextureMap& map, const TrustOptions& options) {
  TM_CHECK(options.grazingRatio >= 0 && options.grazingRatio < options.fullRatio && options.fullRatio <= 1,
           "trust: grazingRatio and fullRatio must satisfy 0 <= grazingRatio < fullRatio <= 1");
  const int nf = mesh.numFaces();
  TM_CHECK(map.numFaces() == nf,
           "trust: the map has " + std::to_string(map.numFaces()) + " faces, the mesh " + std::to_string(nf));
  FaceTrust out;
  out.trust.assign(nf, 0.0f);
  out.ratio.assign(nf, 0.0f);
  std::vector<double> density(nf, 0.0);
  std::vector<double> known;
  for (int f = 0; f < nf; ++f) {
    if (map.facePhoto[f] < 0) continue;
    std::array<Vec3, 3> q = mesh.facePositions(f);
    std::array<Vec2, 3> uv = map.cornerUV[f];
    // Photo pixels run y down: a face seen from the front may wind either way in the photo.
    const double twice = (uv[1] - uv[0]).x() * (uv[2] - uv[0]).y() - (uv[2] - uv[0]).x() * (uv[1] - uv[0]).y();
    if (twice < 0) std::swap(uv[1], uv[2]), std::swap(q[1], q[2]);
    const TriangleStretch s = triangleStretch(q, uv);  // surface length per pixel
    if (s.flipped || !(s.gamma > 0) || !std::isfinite(s.gamma) || !(s.sigma > 0)) continue;
    out.ratio[f] = float(s.sigma / s.gamma);
    density[f] = 1 / (s.gamma * s.sigma);
    known.push_back(density[f]);
  }
  if (known.empty()) return out;
  std::nth_element(known.begin(), known.begin() + known.size() / 2, known.end());
  out.medianDensity = known[known.size() / 2];
  for (int f = 0; f < nf; ++f) {
    if (!(density[f] > 0)) continue;
    const double angle =
        std::clamp((out.ratio[f] - options.grazingRatio) / (options.fullRatio - options.grazingRatio), 0.0, 1.0);
    const double dense = std::min(1.0, std::sqrt(density[f] / out.medianDensity));
    out.trust[f] = float(angle * dense);
  }
  return out;
}

bool clippedColor(const Vec3f& srgb, const TrustOptions& options) {
  for (int c = 0; c < 3; ++c)
    if (srgb[c] <= options.clipLow || srgb[c] >= options.clipHigh) return true;
  return false;
}

}  // namespace montage
