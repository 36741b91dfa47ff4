// What the photos of a scene see through known cameras (see sight.h).
#include "bench/sight.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <array>
#include <string>

#include "geometry/mesh.h"
#include "geometry/raster.h"
#include "image/photo.h"

namespace montage {

Sight cameraSight(const Mesh& mesh, const std::vector<PhotoCamera>& cameras, const std::vector<const Photo*>& photos,
                  const SightOptions& options) {
  TM_CHECK(cameras.size() == photos.size(), "cameraSight: " + std::to_string(cameras.size()) + " cameras for " +
                                                std::to_string(photos.size()) + " photos");
  const int nf = mesh.numFaces();
  Sight out;
  out.faceSeen.assign(nf, 0.0f);
  out.faceBestCos.assign(nf, 0.0f);
  // Seven points spread over the face (centroid, near each corner, near each edge's middle), so that a face
  // partly hidden or partly off the silhouette counts in part.
  const std::array<Vec3, 7> samples = {Vec3(1.0 / 3, 1.0 / 3, 1.0 / 3), Vec3(0.8, 0.1, 0.1), Vec3(0.1, 0.8, 0.1),
                                       Vec3(0.1, 0.1, 0.8),             Vec3(0.45, 0.45, 0.1), Vec3(0.1, 0.45, 0.45),
                                       Vec3(0.45, 0.1, 0.45)};
  std::vector<unsigned char> seen(size_t(nf) * samples.size(), 0);
  Vec3 lo, hi;
  mesh.bounds(lo, hi);
  const double tol = options.depthTolerance * (hi - lo).norm();
  RasterOptions depthOnly;
  depthOnly.barycentrics = false;
  for (size_t k = 0; k < cameras.size(); ++k) {
    const PhotoCamera& camera = cameras[k];
    const Camera& cam = camera.pinhole;
    const RasterBuffers raster = rasterize(mesh, cam, depthOnly);
    const Photo* photo = photos[k];
    const Vec3 eye = cam.center();
    tbb::parallel_for(tbb::blocked_range<int>(0, nf, 1024), [&](const tbb::blocked_range<int>& range) {
      for (int f = range.begin(); f < range.end(); ++f) {
        const auto q = mesh.facePositions(f);
        const Vec3 centroid = (q[0] + q[1] + q[2]) / 3;
        const double facing = mesh.faceNormal(f).dot((eye - centroid).normalized());
        if (!(facing > options.minCos)) continue;
        bool any = false;
        for (size_t s = 0; s < samples.size(); ++s) {
          const Vec3 point = samples[s][0] * q[0] + samples[s][1] * q[1] + samples[s][2] * q[2];
          Vec2 px, pixel;
          double z = 0;
          if (!cam.project(point, px, &z) || !camera.project(point, pixel)) continue;
          if (!(px.x() >= 0 && px.y() >= 0 && px.x() < cam.width && px.y() < cam.height)) continue;
          const int i = raster.index(static_cast<int>(px.x()), static_cast<int>(px.y()));
          if (raster.face[i] != f && raster.face[i] >= 0 && raster.depth[i] < z - tol) continue;  // occluded
          if (photo && !(pixel.x() >= 0 && pixel.y() >= 0 && pixel.x() <= photo->width && pixel.y() <= photo->height &&
                         photo->alphaAt(pixel.x(), pixel.y()) > 0))
            continue;  // off the photo or on its background
          seen[size_t(f) * samples.size() + s] = 1;
          any = true;
        }
        if (any) out.faceBestCos[f] = std::max(out.faceBestCos[f], static_cast<float>(facing));
      }
    });
  }
  double total = 0, unseen = 0;
  for (int f = 0; f < nf; ++f) {
    int n = 0;
    for (size_t s = 0; s < samples.size(); ++s) n += seen[size_t(f) * samples.size() + s];
    out.faceSeen[f] = static_cast<float>(n) / samples.size();
    const double a = mesh.faceArea(f);
    total += a;
    unseen += a * (1 - out.faceSeen[f]);
  }
  out.unseenShare = total > 0 ? unseen / total : 0;
  return out;
}

}  // namespace montage
