// A CPU rasterizer: pinhole cameras, a z-buffer with perspective-correct barycentrics, and a 2D
// triangle scan converter for texture space. Baking, synthetic photos, evaluation renders and
// headless previews use it.
#pragma once

#include <array>
#include <functional>
#include <vector>

#include "base/common.h"

namespace montage {

struct Mesh;

// Pinhole camera, OpenCV convention: camera coordinates x right, y down, z forward;
// p_cam = R * p_world + t; pixel = (fx * x / z + cx, fy * y / z + cy) in the pixel convention of
// photo.h (origin top-left corner, pixel centres at +0.5).
struct Camera {
  int width = 0, height = 0;
  double fx = 1, fy = 1, cx = 0, cy = 0;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Vec3 t = Vec3::Zero();

  // A camera at `eye` looking at `target`; `up` is the world direction that appears up in the image.
  static Camera lookAt(const Vec3& eye, const Vec3& target, const Vec3& up, double fovYDeg, int width, int height);
  Vec3 toCamera(const Vec3& p) const { return R * p + t; }
  Vec3 center() const { return -R.transpose() * t; }  // eye position in world coordinates
  // Projects a world point; returns false when it is behind the camera (z <= 1e-12).
  bool project(const Vec3& p, Vec2& pixel, double* depth = nullptr) const;
};

// Result of rasterising a mesh: per pixel (row-major, width*height) the nearest face and the
// perspective-correct barycentrics of its corners (corner order of Mesh::faceVertices).
struct RasterBuffers {
  int width = 0, height = 0;
  std::vector<float> depth;  // camera-space z of the nearest surface; +inf where empty
  std::vector<int> face;     // face index; -1 where empty
  std::vector<Vec3f> bary;   // barycentrics of that face's corners at the pixel centre (empty when not asked for)
  int index(int x, int y) const { return y * width + x; }
};

struct RasterOptions {
  bool cullBackFaces = false;  // drop faces whose front side (CCW) does not face the camera
  bool barycentrics = true;    // fill RasterBuffers::bary (false: left empty, for depth and face ids only)
};

// Rasterises every face at pixel centres with a z-buffer (top-left fill rule, near plane clip by
// dropping triangles with a corner behind the camera).
RasterBuffers rasterize(const Mesh& mesh, const Camera& camera, const RasterOptions& options = {});

// Largest distance (pixels) between where two cameras put the vertices of `mesh` (about 512 of them, spread
// over the vertex order); infinite when one of them is behind either camera. What a frame or a contour made
// through `a` errs by when it serves `b` (the preview tier's reuse).
double cameraShiftPx(const Mesh& mesh, const Camera& a, const Camera& b);

// Scan-converts a 2D triangle (pixel coordinates) and calls visit(x, y, b) for every pixel whose
// centre lies inside (top-left fill rule), with b the barycentrics of the centre. Pixels outside
// [0,width) x [0,height) are skipped. Degenerate triangles visit nothing.
void scanTriangle(const std::array<Vec2, 3>& p, int width, int height,
                  const std::function<void(int x, int y, const Vec3& b)>& visit);

}  // namespace montage
