#include "geometry/stretch.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace montage {

double TriangleStretch::l2() const {
  return std::sqrt(0.5 * (gamma * gamma + sigma * sigma));
}

TriangleStretch triangleStretch(const std::array<Vec3, 3>& q, const std::array<Vec2, 3>& uv) {
  // Sander, Snyder, Gortler, Hoppe 2001, "Texture mapping progressive meshes", section 3.
  const double s1 = uv[0].x(), t1 = uv[0].y();
  const double s2 = uv[1].x(), t2 = uv[1].y();
  const double s3 = uv[2].x(), t3 = uv[2].y();
  const double twiceArea = (s2 - s1) * (t3 - t1) - (s3 - s1) * (t2 - t1);
  TriangleStretch out;
  if (!(twiceArea > 0) || !std::isfinite(twiceArea)) {
    out.gamma = out.sigma = std::numeric_limits<double>::infinity();
    out.flipped = true;
    return out;
  }
  // Partial derivatives of the surface point with respect to s and t.
  const Vec3 ss = (q[0] * (t2 - t3) + q[1] * (t3 - t1) + q[2] * (t1 - t2)) / twiceArea;
  const Vec3 st = (q[0] * (s3 - s2) + q[1] * (s1 - s3) + q[2] * (s2 - s1)) / twiceArea;
  const double a = ss.dot(ss), b = ss.dot(st), c = st.dot(st);
  const double root = std::sqrt((a - c) * (a - c) + 4 * b * b);
  out.gamma = std::sqrt(std::max(0.0, 0.5 * ((a + c) + root)));
  out.sigma = std::sqrt(std::max(0.0, 0.5 * ((a + c) - root)));
  return out;
}

}  // namespace montage
