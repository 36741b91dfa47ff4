// Small 2D geometry predicates shared by the partition, the progressive mesh, the mapping, inpainting
// and the editor.
#pragma once

#include <vector>

#include "base/common.h"

namespace montage {

// z component of the cross product of two 2D vectors.
inline double cross2(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// Twice the signed area of triangle (a, b, c): > 0 when counter-clockwise (in a y-up frame).
inline double orient2(const Vec2& a, const Vec2& b, const Vec2& c) {
  return cross2(b - a, c - a);
}

// Whether point p is inside the polygon (even-odd rule; any orientation, not necessarily simple).
inline bool insidePolygon(const std::vector<Vec2>& poly, const Vec2& p) {
  bool in = false;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Vec2 &a = poly[i], &b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      in = !in;
  }
  return in;
}

}  // namespace montage
