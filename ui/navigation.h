// 3D-view navigation like Blender and MeshLab, without GL: zoom to the cursor, orbit about a picked
// point, frame all (using both the view's width and height) and frame selected, front/side/top
// presets, a near-orthographic toggle, click-versus-drag by distance and time, and the mouse bindings
// of either program.
#pragma once

#include <array>

#include "view_math.h"

namespace montage {

// Zooms by 0.85^steps about the world point `anchor` (the surface under the cursor): the camera moves
// along the ray to it, so `anchor` stays under the cursor (the eye and the target scale about it).
void zoomAbout(OrbitCamera& camera, const Vec3& anchor, double steps);

// The point a ray from the view pixel (px, py) meets: the surface hit when `hit` is set, else the
// point on the plane through the target facing the camera (zooming in empty space still goes there).
Vec3 anchorAt(const OrbitCamera& camera, int width, int height, double px, double py, const Vec3* hit);

// Orbits by a mouse drag about `pivot` (a picked point): yaw/pitch change as in OrbitCamera::orbit and
// the camera moves so that `pivot` keeps its place in the view.
void orbitAbout(OrbitCamera& camera, const Vec3& pivot, double dxPixels, double dyPixels);

// Fits the bounding box [lo, hi] in a view of width x height: its bounding sphere within both the
// vertical and the horizontal field of view (5% margin). Keeps the viewing direction.
void frameBox(OrbitCamera& camera, const Vec3& lo, const Vec3& hi, int width, int height);
// Centres `point` and fits a sphere of `radius` around it (frame selected).
void framePoint(OrbitCamera& camera, const Vec3& point, double radius, int width, int height);

enum class ViewPreset { Front, Back, Left, Right, Top, Bottom };
inline constexpr std::array<const char*, 6> kViewPresetNames = {"front", "back", "left", "right", "top", "bottom"};
// Turns the camera to look along a world axis (front looks along -Z, from +Z; right from +X; top from +Y).
void applyPreset(OrbitCamera& camera, ViewPreset preset);

// Orthographic view: the field of view narrows to kOrthoFovDeg and the camera backs off so that the
// target's plane keeps its size (a telephoto camera: parallel lines stay parallel to within 0.1%);
// picking and drawing still share one pinhole Camera. Off restores the perspective field of view.
inline constexpr double kPerspectiveFovDeg = 35, kOrthoFovDeg = 0.5;
void setOrthographic(OrbitCamera& camera, bool on);
bool isOrthographic(const OrbitCamera& camera);

// Adaptive resolution while navigating (View > "Reduced resolution while navigating", on by default):
// while the camera moves, the 3D view is drawn into a framebuffer `navigationDivisor` times smaller per
// axis and shown upscaled with linear filtering; once it has not moved for kNavigationSettleSeconds it
// is drawn once at full size. Software GL (llvmpipe) pays per fragment: half per axis is a quarter of
// the fragments. Picking casts rays from the full-size camera and is not affected.
inline constexpr double kNavigationPixels = 120000;      // a reduced view has at most this many pixels
inline constexpr double kNavigationSettleSeconds = 0.2;  // still this long: drawn at full size
// The smallest integer divisor, at most 4, that brings a width x height view to kNavigationPixels or
// fewer: 1 (no reduction) for small views, 2 for the 1280x800 window's 486x729 view, 4 for a
// 1000x1450 view at 2560x1600. An integer keeps each reduced pixel over d x d whole pixels.
int navigationDivisor(int width, int height);

// Whether the camera is moving, from its changes frame by frame. A change in the frame right after
// another (or within the settle time of it) is movement: an orbit, a pan, a wheel turned several
// notches. A lone change (frame all, a preset, one wheel notch) is not, so it is drawn at full size at
// once instead of reduced and then again full.
class NavigationMotion {
 public:
  // Once a frame, before the view is drawn: whether the camera differs from the previous frame's.
  void update(bool cameraChanged, long frame, double seconds);
  bool moving() const { return moving_; }
  // Seconds from `seconds` until moving() turns false if the camera stays still (0 when not moving):
  // how long an idle frame loop may wait for events before the full-size redraw.
  double secondsToSettle(double seconds) const;

 private:
  bool moving_ = false;
  long lastFrame_ = -10;
  double lastSeconds_ = -1e9;
};

// Click versus drag: a press becomes a drag once the pointer moved more than `slopPixels`, except a
// quick release (within `clickSeconds`) that moved less than `quickSlopPixels` stays a click, so a
// hand's jitter during a click does not orbit.
struct ClickDrag {
  double slopPixels = 4;        // movement that starts a drag when the press is slow
  double quickSlopPixels = 12;  // movement a quick click may have
  double clickSeconds = 0.3;    // a quick click is released within this

  void press(double x, double y, double seconds);
  // Feeds the pointer while held; true once the press is a drag (stays true until the next press).
  bool move(double x, double y, double seconds);
  // On release: whether the press was a click.
  bool releaseIsClick(double x, double y, double seconds) const;
  bool dragging() const { return dragging_; }
  double pressX = 0, pressY = 0, pressTime = 0;

 private:
  bool dragging_ = false;
};

// Mouse bindings of the 3D view.
enum class MouseBindings { MeshLab, Blender };
inline constexpr std::array<const char*, 2> kMouseBindingNames = {"meshlab", "blender"};
enum class DragAction { None, Orbit, Pan };
// What a drag with `button` (0 left, 1 right, 2 middle) and modifiers does. MeshLab: left orbits,
// right/middle or Shift+left pan. Blender: middle orbits, Shift+middle or right pans, left only picks.
DragAction dragAction(MouseBindings bindings, int button, bool shift, bool ctrl);

}  // namespace montage
