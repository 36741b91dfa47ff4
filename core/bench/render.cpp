#include "bench/render.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace montage {

Camera orbitCamera(const Mesh& mesh, const RenderOptions& options) {
  Vec3 lo, hi;
  mesh.bounds(lo, hi);
  const Vec3 center = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * (hi - lo).norm(), 1e-9);
  const int size = options.size * std::max(1, options.supersample);
  const double yaw = options.yawDeg * M_PI / 180, pitch = options.pitchDeg * M_PI / 180;
  const Vec3 dir(std::sin(yaw) * std::cos(pitch), std::sin(pitch), std::cos(yaw) * std::cos(pitch));
  const double distance = radius / std::sin(0.5 * options.fovYDeg * M_PI / 180) * 1.05;
  return Camera::lookAt(center + distance * dir, center, Vec3::UnitY(), options.fovYDeg, size, size);
}

cv::Mat renderModel(const TexturedModel& model, const RenderOptions& options) {
  return renderSurface(
      model.mesh, [&](int f, const Vec3& b) { return model.colorAt(f, b); }, options);
}

cv::Mat renderSurface(const Mesh& mesh, const std::function<Vec3f(int face, const Vec3& bary)>& color,
                      const RenderOptions& options) {
  const Camera camera = orbitCamera(mesh, options);
  const RasterBuffers buffers = rasterize(mesh, camera);
  const Vec3 eye = camera.center();

  cv::Mat big(buffers.height, buffers.width, CV_8UC4,
              cv::Scalar(options.background[0], options.background[1], options.background[2], options.background[3]));
  for (int y = 0; y < buffers.height; ++y) {
    auto* row = big.ptr<cv::Vec4b>(y);
    for (int x = 0; x < buffers.width; ++x) {
      const int i = buffers.index(x, y);
      const int f = buffers.face[i];
      if (f < 0) continue;
      const Vec3 b = buffers.bary[i].cast<double>();
      Vec3f c = color(f, b);
      if (options.shading) {
        const auto q = mesh.facePositions(f);
        const Vec3 p = b[0] * q[0] + b[1] * q[1] + b[2] * q[2];
        const double lambert = std::abs(mesh.faceNormal(f).dot((eye - p).normalized()));
        c *= static_cast<float>(0.35 + 0.65 * lambert);
      }
      for (int k = 0; k < 3; ++k) row[x][k] = cv::saturate_cast<uchar>(255.f * c[k] + 0.5f);
      row[x][3] = 255;
    }
  }
  if (big.cols == options.size) return big;
  cv::Mat out;
  cv::resize(big, out, cv::Size(options.size, options.size), 0, 0, cv::INTER_AREA);
  return out;
}

}  // namespace montage
