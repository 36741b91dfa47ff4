#include "view_math.h"

#include <algorithm>
#include <cmath>

namespace montage {

namespace {
constexpr double kDeg = M_PI / 180;
}

void OrbitCamera::frame(const Vec3& lo, const Vec3& hi) {
  target = 0.5 * (lo + hi);
  sceneRadius = std::max(0.5 * (hi - lo).norm(), 1e-9);
  sceneCenter = target;
  // Same fit as core's orbitCamera (render.h): the bounding sphere fills the vertical field of view.
  distance = sceneRadius / std::sin(0.5 * fovYDeg * kDeg) * 1.05;
}

void OrbitCamera::orbit(double dxPixels, double dyPixels) {
  yawDeg -= 0.4 * dxPixels;
  yawDeg = std::remainder(yawDeg, 360.0);
  // Stop short of the poles, where "up" (world +Y) would be parallel to the view direction.
  pitchDeg = std::clamp(pitchDeg + 0.4 * dyPixels, -89.0, 89.0);
}

void OrbitCamera::pan(double dxPixels, double dyPixels, int viewHeight) {
  const Camera cam = camera(std::max(viewHeight, 1), std::max(viewHeight, 1));
  // One pixel at the target's depth spans distance / fy model units.
  const double unitsPerPixel = distance / cam.fy;
  const Vec3 right = cam.R.row(0).transpose(), down = cam.R.row(1).transpose();
  target += unitsPerPixel * (-dxPixels * right - dyPixels * down);
}

void OrbitCamera::zoom(double wheelSteps) {
  distance *= std::pow(0.85, wheelSteps);
  // The far limit grows with a narrow (orthographic) field of view.
  distance = std::clamp(distance, sceneRadius * 0.02, sceneRadius * 100 * std::max(1.0, 35.0 / fovYDeg));
}

void OrbitCamera::lookFrom(const Vec3& point, const Vec3& normal) {
  target = point;
  Vec3 n = normal.norm() > 0 ? normal.normalized() : Vec3::UnitZ();
  pitchDeg = std::clamp(std::asin(std::clamp(n.y(), -1.0, 1.0)) / kDeg, -89.0, 89.0);
  yawDeg = std::atan2(n.x(), n.z()) / kDeg;
  distance = std::min(distance, sceneRadius * 1.5);
}

Vec3 OrbitCamera::eye() const {
  const double yaw = yawDeg * kDeg, pitch = pitchDeg * kDeg;
  const Vec3 dir(std::sin(yaw) * std::cos(pitch), std::sin(pitch), std::cos(yaw) * std::cos(pitch));
  return target + distance * dir;
}

Camera OrbitCamera::camera(int width, int height) const {
  return Camera::lookAt(eye(), target, Vec3::UnitY(), fovYDeg, std::max(width, 1), std::max(height, 1));
}

double OrbitCamera::nearPlane() const {
  // The scene's sphere lies within [d - r, d + r] of the eye, wherever the target was moved to.
  const double d = (eye() - sceneCenter).norm();
  return std::max(d - 1.2 * sceneRadius, distance * 1e-3);
}
double OrbitCamera::farPlane() const {
  return std::max((eye() - sceneCenter).norm() + 1.2 * sceneRadius, nearPlane() * 1.01);
}

Mat4f glViewMatrix(const Camera& camera) {
  Mat4f m{};
  // Column-major: m[col * 4 + row]. Rows 1 and 2 of [R|t] are negated (OpenCV -> GL eye coordinates).
  const double flip[3] = {1, -1, -1};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m[c * 4 + r] = static_cast<float>(flip[r] * camera.R(r, c));
    m[12 + r] = static_cast<float>(flip[r] * camera.t[r]);
  }
  m[15] = 1;
  return m;
}

Mat4f glProjectionMatrix(const Camera& camera, double n, double f) {
  // GL eye coordinates (xe, ye, ze), ze < 0 in front. Camera::project gives px = fx * xe / -ze + cx and
  // py = fy * -ye / -ze + cy (y down); NDC x = 2 px / w - 1 and NDC y = 1 - 2 py / h (y up).
  const double w = camera.width, h = camera.height;
  Mat4f m{};
  m[0] = static_cast<float>(2 * camera.fx / w);
  m[8] = static_cast<float>(1 - 2 * camera.cx / w);
  m[5] = static_cast<float>(2 * camera.fy / h);
  m[9] = static_cast<float>(2 * camera.cy / h - 1);
  m[10] = static_cast<float>(-(f + n) / (f - n));
  m[14] = static_cast<float>(-2 * f * n / (f - n));
  m[11] = -1;
  return m;
}

Mat4f multiply(const Mat4f& a, const Mat4f& b) {
  Mat4f m{};
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) {
      float s = 0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + r] * b[c * 4 + k];
      m[c * 4 + r] = s;
    }
  return m;
}

void pixelRay(const Camera& camera, double px, double py, Vec3& origin, Vec3& direction) {
  origin = camera.center();
  const Vec3 d((px - camera.cx) / camera.fx, (py - camera.cy) / camera.fy, 1.0);
  direction = (camera.R.transpose() * d).normalized();
}

VertexPick pickVertex(const Mesh& mesh, const TriangleBvh& bvh, const Camera& camera, double px, double py) {
  Vec3 origin, direction;
  pixelRay(camera, px, py, origin, direction);
  const RayHit hit = bvh.raycast(origin, direction);
  VertexPick pick;
  if (hit.face < 0) return pick;
  pick.face = hit.face;
  pick.point = origin + hit.t * direction;
  const auto corners = mesh.faceVertices(hit.face);
  double best = std::numeric_limits<double>::infinity();
  for (int v : corners) {
    const double d = (mesh.position(v) - pick.point).squaredNorm();
    if (d < best) {
      best = d;
      pick.vertex = v;
    }
  }
  return pick;
}

bool vertexVisible(const Mesh& mesh, const TriangleBvh& bvh, const Camera& camera, int vertex) {
  Vec2 pixel;
  double depth = 0;
  if (!camera.project(mesh.position(vertex), pixel, &depth)) return false;
  if (pixel.x() < 0 || pixel.y() < 0 || pixel.x() > camera.width || pixel.y() > camera.height) return false;
  const Vec3 origin = camera.center();
  const Vec3 toVertex = mesh.position(vertex) - origin;
  const double length = toVertex.norm();
  const RayHit hit = bvh.raycast(origin, toVertex / length);
  if (hit.face < 0) return true;
  if (hit.t >= length * (1 - 1e-6)) return true;
  const auto corners = mesh.faceVertices(hit.face);
  return std::find(corners.begin(), corners.end(), vertex) != corners.end() && hit.t > length * (1 - 1e-3);
}

std::vector<Vec3f> vertexNormals(const Mesh& mesh) {
  std::vector<Vec3> sum(mesh.numVertices(), Vec3::Zero());
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto q = mesh.facePositions(f);
    const Vec3 n = (q[1] - q[0]).cross(q[2] - q[0]);  // length = twice the area: area weighting
    for (int v : mesh.faceVertices(f)) sum[v] += n;
  }
  std::vector<Vec3f> out(sum.size());
  for (size_t i = 0; i < sum.size(); ++i)
    out[i] = sum[i].norm() > 0 ? sum[i].normalized().cast<float>() : Vec3f(0, 1, 0);
  return out;
}

void PaneView::fit(int w, int h, const Vec2& lo, const Vec2& size) {
  const double margin = 8;
  zoom = std::max(1e-3, std::min((size.x() - 2 * margin) / std::max(w, 1), (size.y() - 2 * margin) / std::max(h, 1)));
  origin = lo + 0.5 * (size - zoom * Vec2(w, h));
  fitted = true;
}

void PaneView::zoomAt(const Vec2& screen, double factor) {
  const Vec2 photo = toPhoto(screen);
  zoom = std::clamp(zoom * factor, 0.02, 64.0);
  origin = screen - zoom * photo;
}

}  // namespace montage
