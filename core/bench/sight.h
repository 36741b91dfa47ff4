// What the photos of a scene see through known cameras, by geometry alone (issue 34): the honest "no photo
// sees it" share that the pipeline's inpainted share is held against. The projection oracle (pipeline.h)
// answers a different question: what the pipeline's own visibility tests and view selection make of the true
// cameras, which refuse some surface a photo does show.
#pragma once

#include <vector>

#include "mapping/camera.h"

namespace montage {

struct Mesh;
struct Photo;

struct SightOptions {
  double depthTolerance = 0.005;  // occlusion test tolerance, share of the bounding-box diagonal (the projection
                                  // stage's own)
  double minCos = 0.0;            // a point is seen only from cameras it faces by more than this cosine
};

// Per face: how much of it some photo sees.
struct Sight {
  std::vector<float> faceSeen;     // #F: share of the face's seven sample points seen by at least one photo
  std::vector<float> faceBestCos;  // #F: the largest cosine between the face's normal and the direction to a
                                   // camera that sees one of its samples (0 when none does)
  double unseenShare = 0;          // area share of the surface no photo sees
};

// A sample point of a face is seen by a photo when it lies in front of the camera and inside the image, faces
// the camera (cosine > options.minCos), the z-buffer of `mesh` through the camera shows its face or nothing
// nearer than the tolerance, and the photo's alpha there is above 0 (its silhouette). `photos[k]` may be null
// (every pixel foreground). Cameras and photos in photo order, the same count.
Sight cameraSight(const Mesh& mesh, const std::vector<PhotoCamera>& cameras, const std::vector<const Photo*>& photos,
                  const SightOptions& options = {});

}  // namespace montage
