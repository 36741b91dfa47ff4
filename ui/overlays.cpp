#include "overlays.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "geometry/stretch.h"

namespace montage {

Vec3f photoColor(int photo) {
  // Well-separated hues (Tableau 10), repeated beyond ten photos.
  static const Vec3f kPalette[] = {{0.31f, 0.47f, 0.65f}, {0.95f, 0.56f, 0.17f}, {0.35f, 0.63f, 0.31f},
                                   {0.88f, 0.34f, 0.35f}, {0.46f, 0.72f, 0.70f}, {0.93f, 0.79f, 0.28f},
                                   {0.69f, 0.48f, 0.63f}, {1.00f, 0.62f, 0.66f}, {0.61f, 0.46f, 0.37f},
                                   {0.73f, 0.69f, 0.67f}};
  return kPalette[((photo % 10) + 10) % 10];
}

Vec3f heatColor(double t) {
  t = std::clamp(t, 0.0, 1.0);
  // Piecewise linear blue -> cyan -> green -> yellow -> red.
  static const Vec3f kStops[] = {{0.19f, 0.28f, 0.85f},
                                 {0.15f, 0.75f, 0.90f},
                                 {0.25f, 0.80f, 0.30f},
                                 {0.98f, 0.85f, 0.15f},
                                 {0.90f, 0.15f, 0.10f}};
  const double s = t * 4;
  const int i = std::min(3, static_cast<int>(s));
  const float u = static_cast<float>(s - i);
  return (1 - u) * kStops[i] + u * kStops[i + 1];
}

namespace {
const Vec4f kTransparent(0, 0, 0, 0);
const Vec4f kEmptyHighlight(0.95f, 0.10f, 0.75f, 0.75f);
}  // namespace

std::vector<Vec4f> patchOverlay(const TexturedModel& model) {
  const int F = model.mesh.numFaces();
  std::vector<Vec4f> out(F, kTransparent);
  for (int f = 0; f < F && f < static_cast<int>(model.faceSource.size()); ++f) {
    const int s = model.faceSource[f];
    if (s >= 0) {
      const Vec3f c = photoColor(s);
      out[f] = Vec4f(c.x(), c.y(), c.z(), 0.65f);
    } else if (s == kSourceEmpty) {
      out[f] = kEmptyHighlight;
    } else {
      out[f] = Vec4f(0.55f, 0.6f, 0.75f, 0.65f);
    }
  }
  return out;
}

std::vector<Vec4f> emptyOverlay(const TexturedModel& model) {
  const int F = model.mesh.numFaces();
  std::vector<Vec4f> out(F, kTransparent);
  for (int f = 0; f < F && f < static_cast<int>(model.faceSource.size()); ++f)
    if (model.faceSource[f] == kSourceEmpty) out[f] = kEmptyHighlight;
  return out;
}

std::vector<double> normalizedStretch(const Mesh& mesh, const TextureMap& map) {
  const int F = std::min(mesh.numFaces(), map.numFaces());
  std::vector<double> out(mesh.numFaces(), std::numeric_limits<double>::quiet_NaN());
  double surface = 0, texture = 0;
  for (int f = 0; f < F; ++f) {
    if (map.facePhoto[f] == TextureMap::kEmpty) continue;
    const auto& uv = map.cornerUV[f];
    surface += mesh.faceArea(f);
    texture += 0.5 * std::abs((uv[1] - uv[0]).x() * (uv[2] - uv[0]).y() - (uv[1] - uv[0]).y() * (uv[2] - uv[0]).x());
  }
  if (surface <= 0 || texture <= 0) return out;
  // Stretch is surface length per texture length; scaling the texture by s scales it by 1/s.
  const double scale = std::sqrt(texture / surface);
  for (int f = 0; f < F; ++f) {
    if (map.facePhoto[f] == TextureMap::kEmpty) continue;
    // Pixel coordinates are y-down; in the frame (x, -y) a face seen by its camera is counter-clockwise
    // like on the mesh, which is the orientation triangleStretch expects (as fine_map.cpp uses it).
    const auto& uv = map.cornerUV[f];
    const std::array<Vec2, 3> up = {Vec2(uv[0].x(), -uv[0].y()), Vec2(uv[1].x(), -uv[1].y()),
                                    Vec2(uv[2].x(), -uv[2].y())};
    const TriangleStretch s = triangleStretch(mesh.facePositions(f), up);
    out[f] = s.flipped ? std::numeric_limits<double>::infinity() : s.l2() * scale;
  }
  return out;
}

std::vector<Vec4f> stretchOverlay(const std::vector<double>& stretch) {
  std::vector<Vec4f> out(stretch.size(), kTransparent);
  for (size_t f = 0; f < stretch.size(); ++f) {
    const double s = stretch[f];
    if (std::isnan(s)) continue;
    if (std::isinf(s)) {
      out[f] = Vec4f(0.05f, 0.05f, 0.05f, 0.9f);
      continue;
    }
    const Vec3f c = heatColor(std::log2(std::max(s, 1.0)) / 2.0);  // 1 -> 0, 4 -> 1
    out[f] = Vec4f(c.x(), c.y(), c.z(), 0.85f);
  }
  return out;
}

std::vector<Vec4f> seamErrorOverlay(const std::vector<float>& faceError) {
  constexpr double kRed = 20;  // Delta E*uv shown in full red: a clearly visible seam
  std::vector<Vec4f> out(faceError.size(), kTransparent);
  for (size_t f = 0; f < faceError.size(); ++f) {
    if (!(faceError[f] >= 0)) continue;
    const Vec3f c = heatColor(std::min(1.0, faceError[f] / kRed));
    out[f] = Vec4f(c.x(), c.y(), c.z(), 0.9f);
  }
  return out;
}

}  // namespace montage
