// Headless shaded renders of a textured model with the CPU rasterizer (`montage render`, README
// pictures, preview tests).
#pragma once

#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "geometry/raster.h"
#include "io/model.h"

namespace montage {

struct RenderOptions {
  int size = 1024;                              // image width, pixels
  int height = 0;                               // image height, pixels; 0 = size (square)
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
// CV_8UC4 RGBA image of options.size x options.height (or size squared).
cv::Mat renderModel(const TexturedModel& model, const RenderOptions& options = {});

// Renders a mesh whose colour at (face, barycentrics) is `color` (sRGB in [0,1]), e.g. the preview
// tier's surface/preview.h; same camera and shading as renderModel.
cv::Mat renderSurface(const Mesh& mesh, const std::function<Vec3f(int face, const Vec3& bary)>& color,
                      const RenderOptions& options = {});
// `views` renders orbiting the model: yaw = options.yawDeg + 360 k / views, k = 0..views-1.
std::vector<cv::Mat> renderTurntable(const TexturedModel& model, int views, const RenderOptions& options = {});

// One image of all `images` (same size, RGBA) in a grid of `columns` columns (0 = about square),
// separated by `gap` pixels of the background colour.
cv::Mat contactSheet(const std::vector<cv::Mat>& images, int columns = 0, int gap = 4,
                     const cv::Vec4b& background = {255, 255, 255, 255});

// The source layer (atlasSourceLayer codes: photo index + 1, 254 inpainted, 253 empty, 0 none) in
// colours: one hue per photo, inpainted magenta, empty dark grey, none light grey. RGBA8.
cv::Mat colorizeSourceLayer(const cv::Mat& source);
// Colour of one source code, as colorizeSourceLayer paints it (RGBA).
cv::Vec4b sourceLayerColor(int code);
// The codes present in a source layer, ascending, without 0.
std::vector<int> sourceLayerCodes(const cv::Mat& source);
// Draws a legend into the top-left corner of an RGBA image: a swatch and a label per (colour, label).
void drawLegend(cv::Mat& rgba, const std::vector<std::pair<cv::Vec4b, std::string>>& entries);

}  // namespace montage
