// Sander et al. 2001 texture stretch: the singular values of the Jacobian of the map from texture
// space to the surface, per triangle, and their L2 and L-infinity norms over a mesh.
#pragma once

#include <array>

#include "base/common.h"

namespace montage {

struct TriangleStretch {
  double gamma = 0;      // largest singular value (max stretch of a unit texture vector)
  double sigma = 0;      // smallest singular value
  double l2() const;     // sqrt((gamma^2 + sigma^2)/2)
  bool flipped = false;  // texture triangle has non-positive signed area
};

// Stretch of one triangle: q are the 3D corners, uv the texture corners (any consistent unit).
// For a flipped or degenerate texture triangle, gamma = sigma = +inf and flipped = true.
TriangleStretch triangleStretch(const std::array<Vec3, 3>& q, const std::array<Vec2, 3>& uv);

}  // namespace montage
