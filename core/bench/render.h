// Headless shaded renders of a textured model with the CPU rasterizer (`montage render`, README
// pictures, preview tests).
#pragma once

#include <functional>
#include <opencv2/core.hpp>

#include "geometry/raster.h"
#include "io/model.h"

namespace montage {

struct RenderOptions {
  int size = 1024;                              // image width and height, pixels
  double yawDeg = 30;                           // orbit angle around the model's up axis (+Y), degrees
  double pitchDeg = 20;                         // elevation above the horizontal plane, degrees
  double fovYDeg = 30;                          // vertical field of view
  bool shading = true;                          // modulate colours by a head light (ambient 0.35 + diffuse 0.65)
  int supersample = 2;                          // samples per pixel side (anti-aliasing)
  cv::Vec4b background = {235, 235, 235, 255};  // RGBA
};

// The camera `render` uses: orbiting the bounding box centre at a distance that fits the bounding
// sphere. Exposed so that tests can project points into a render.
Camera orbitCamera(const Mesh& mesh, const RenderOptions& options);

// Renders the model: textured where it has a texture, its material colour otherwise; returns an
// CV_8UC4 RGBA image of options.size squared.
cv::Mat renderModel(const TexturedModel& model, const RenderOptions& options = {});

// Renders a mesh whose colour at (face, barycentrics) is `color` (sRGB in [0,1]), e.g. the preview
// tier's surface/preview.h; same camera and shading as renderModel.
cv::Mat renderSurface(const Mesh& mesh, const std::function<Vec3f(int face, const Vec3& bary)>& color,
                      const RenderOptions& options = {});

}  // namespace montage
