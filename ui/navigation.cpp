#include "navigation.h"

#include <algorithm>
#include <cmath>

namespace montage {

namespace {
constexpr double kDeg = M_PI / 180;

Vec3 viewDirection(const OrbitCamera& c) {  // from the target to the eye
  const double yaw = c.yawDeg * kDeg, pitch = c.pitchDeg * kDeg;
  return Vec3(std::sin(yaw) * std::cos(pitch), std::sin(pitch), std::cos(yaw) * std::cos(pitch));
}
}  // namespace

void zoomAbout(OrbitCamera& camera, const Vec3& anchor, double steps) {
  const double before = camera.distance;
  camera.zoom(steps);  // clamps the distance to the scene's size
  const double s = camera.distance / before;
  // Eye and target both scale about the anchor: the view direction is kept and the anchor's ray too.
  camera.target = anchor + s * (camera.target - anchor);
}

Vec3 anchorAt(const OrbitCamera& camera, int width, int height, double px, double py, const Vec3* hit) {
  if (hit) return *hit;
  const Camera cam = camera.camera(width, height);
  Vec3 origin, direction;
  pixelRay(cam, px, py, origin, direction);
  const Vec3 n = viewDirection(camera);  // plane through the target, facing the camera
  const double denom = direction.dot(n);
  if (std::abs(denom) < 1e-12) return camera.target;
  return origin + direction * ((camera.target - origin).dot(n) / denom);
}

void orbitAbout(OrbitCamera& camera, const Vec3& pivot, double dxPixels, double dyPixels) {
  // The pivot in camera coordinates before the turn stays where it is after it.
  const Camera before = camera.camera(1, 1);
  const Vec3 pc = before.toCamera(pivot);
  camera.orbit(dxPixels, dyPixels);
  const Camera turned = camera.camera(1, 1);  // R depends on the direction only
  const Vec3 eye = pivot - turned.R.transpose() * pc;
  camera.target = eye - camera.distance * viewDirection(camera);
}

void frameBox(OrbitCamera& camera, const Vec3& lo, const Vec3& hi, int width, int height) {
  const double radius = std::max(0.5 * (hi - lo).norm(), 1e-9);
  camera.sceneRadius = radius;
  camera.sceneCenter = 0.5 * (lo + hi);
  framePoint(camera, 0.5 * (lo + hi), radius, width, height);
}

void framePoint(OrbitCamera& camera, const Vec3& point, double radius, int width, int height) {
  camera.target = point;
  const double halfY = 0.5 * camera.fovYDeg * kDeg;
  const double halfX = std::atan(std::tan(halfY) * std::max(width, 1) / std::max(height, 1));
  const double half = std::min(halfX, halfY);
  camera.distance = std::max(radius, 1e-9) / std::sin(half) * 1.05;
}

void applyPreset(OrbitCamera& camera, ViewPreset preset) {
  switch (preset) {
    case ViewPreset::Front:
      camera.yawDeg = 0, camera.pitchDeg = 0;
      break;
    case ViewPreset::Back:
      camera.yawDeg = 180, camera.pitchDeg = 0;
      break;
    case ViewPreset::Right:
      camera.yawDeg = 90, camera.pitchDeg = 0;
      break;
    case ViewPreset::Left:
      camera.yawDeg = -90, camera.pitchDeg = 0;
      break;
    case ViewPreset::Top:
      camera.yawDeg = 0, camera.pitchDeg = 89;
      break;
    case ViewPreset::Bottom:
      camera.yawDeg = 0, camera.pitchDeg = -89;
      break;
  }
}

void setOrthographic(OrbitCamera& camera, bool on) {
  if (on == isOrthographic(camera)) return;
  const double fov = on ? kOrthoFovDeg : kPerspectiveFovDeg;
  // Same height of the target's plane in view: distance * tan(fov / 2) is kept.
  camera.distance *= std::tan(0.5 * camera.fovYDeg * kDeg) / std::tan(0.5 * fov * kDeg);
  camera.fovYDeg = fov;
}

bool isOrthographic(const OrbitCamera& camera) {
  return camera.fovYDeg < 2;
}

void ClickDrag::press(double x, double y, double seconds) {
  pressX = x, pressY = y, pressTime = seconds;
  dragging_ = false;
}

bool ClickDrag::move(double x, double y, double seconds) {
  if (dragging_) return true;
  const double moved = std::hypot(x - pressX, y - pressY);
  const bool quick = seconds - pressTime < clickSeconds;
  dragging_ = moved > quickSlopPixels || (!quick && moved > slopPixels);
  return dragging_;
}

bool ClickDrag::releaseIsClick(double x, double y, double seconds) const {
  if (dragging_) return false;
  const double moved = std::hypot(x - pressX, y - pressY);
  return seconds - pressTime < clickSeconds ? moved <= quickSlopPixels : moved <= slopPixels;
}

int navigationDivisor(int width, int height) {
  const double pixels = double(std::max(width, 1)) * std::max(height, 1);
  int d = 1;
  while (d < 4 && pixels / (double(d) * d) > kNavigationPixels) ++d;
  return d;
}

void NavigationMotion::update(bool cameraChanged, long frame, double seconds) {
  if (cameraChanged) {
    moving_ = frame - lastFrame_ <= 1 || seconds - lastSeconds_ < kNavigationSettleSeconds;
    lastFrame_ = frame;
    lastSeconds_ = seconds;
  } else if (moving_ && seconds - lastSeconds_ >= kNavigationSettleSeconds) {
    moving_ = false;
  }
}

double NavigationMotion::secondsToSettle(double seconds) const {
  return moving_ ? std::max(0.0, lastSeconds_ + kNavigationSettleSeconds - seconds) : 0.0;
}

DragAction dragAction(MouseBindings bindings, int button, bool shift, bool ctrl) {
  if (bindings == MouseBindings::MeshLab) {
    if (button == 0) return shift || ctrl ? DragAction::Pan : DragAction::Orbit;
    return DragAction::Pan;
  }
  if (button == 2) return shift ? DragAction::Pan : DragAction::Orbit;
  if (button == 1) return DragAction::Pan;
  return shift ? DragAction::Pan : DragAction::None;
}

}  // namespace montage
