// The 3D view's camera and picking, without GL: an orbit camera that produces the core's pinhole
// Camera (raster.h), the OpenGL matrices that draw exactly what that Camera projects, pixel rays, and
// vertex picking by a BVH ray cast. Drawing and picking share one Camera, so a click lands on what is
// drawn under the cursor.
#pragma once

#include <array>

#include "geometry/bvh.h"
#include "geometry/mesh.h"
#include "geometry/raster.h"

namespace montage {

// Orbits a target point: yaw around the world's +Y axis, pitch above the horizontal plane (the same
// angles as `montage render`), at `distance` from the target.
struct OrbitCamera {
  Vec3 target = Vec3::Zero();
  double distance = 1;
  double yawDeg = 30, pitchDeg = 20;
  double fovYDeg = 35;
  double sceneRadius = 1;  // radius of the mesh's bounding sphere: sets near/far planes and pan speed
  Vec3 sceneCenter = Vec3::Zero();  // centre of that sphere (near/far planes hold it wherever the target is)

  // Fits a bounding box in view (key F).
  void frame(const Vec3& lo, const Vec3& hi);
  // Mouse drags in pixels of a view `viewHeight` pixels high.
  void orbit(double dxPixels, double dyPixels);
  void pan(double dxPixels, double dyPixels, int viewHeight);
  void zoom(double wheelSteps);  // positive: closer
  // Turns the camera to look at `point` from direction `normal` (which points to the camera).
  void lookFrom(const Vec3& point, const Vec3& normal);

  Vec3 eye() const;
  // The core camera for a view of width x height pixels (OpenCV convention, y down).
  Camera camera(int width, int height) const;
  double nearPlane() const;
  double farPlane() const;
};

using Mat4f = std::array<float, 16>;  // column-major, as glUniformMatrix4fv takes it

// GL view matrix of a core Camera: its [R|t] followed by the flip from OpenCV (y down, z forward) to
// GL eye coordinates (y up, z backward).
Mat4f glViewMatrix(const Camera& camera);
// GL projection matrix from the Camera's intrinsics, so that a point projects to the same pixel as
// Camera::project (with GL's window y flipped), and depth in [near, far] maps to [-1, 1].
Mat4f glProjectionMatrix(const Camera& camera, double nearPlane, double farPlane);
Mat4f multiply(const Mat4f& a, const Mat4f& b);

// The ray through pixel position (px, py) (pixel convention of photo.h: pixel centres at +0.5).
void pixelRay(const Camera& camera, double px, double py, Vec3& origin, Vec3& direction);

struct VertexPick {
  int vertex = -1;  // -1: nothing under the cursor
  int face = -1;
  Vec3 point = Vec3::Zero();  // hit point on the surface
};

// Casts the ray through (px, py) and takes the corner of the hit triangle nearest to the hit point
// (the paper's editor picks vertices). Faces are those of `mesh`; `bvh` must be built on it.
VertexPick pickVertex(const Mesh& mesh, const TriangleBvh& bvh, const Camera& camera, double px, double py);

// Whether `vertex` is visible from the camera: the ray to its projection hits a face that has it as
// a corner (or hits nothing closer than the vertex).
bool vertexVisible(const Mesh& mesh, const TriangleBvh& bvh, const Camera& camera, int vertex);

// Area-weighted vertex normals (#V, unit length) for smooth shading.
std::vector<Vec3f> vertexNormals(const Mesh& mesh);

// Image pane mapping between photo pixel coordinates and screen coordinates: screen = origin + zoom * photo.
struct PaneView {
  double zoom = 1;             // screen pixels per photo pixel
  Vec2 origin = Vec2::Zero();  // screen position of photo point (0, 0)
  bool fitted = false;         // set once the pane has been fitted to its first size

  Vec2 toScreen(const Vec2& photo) const { return origin + zoom * photo; }
  Vec2 toPhoto(const Vec2& screen) const { return (screen - origin) / zoom; }
  // Fits a photo of w x h into the rectangle [lo, lo + size] with a margin.
  void fit(int w, int h, const Vec2& lo, const Vec2& size);
  // Zooms by `factor` keeping the photo point under `screen` fixed (mouse-wheel zoom).
  void zoomAt(const Vec2& screen, double factor);
};

}  // namespace montage
