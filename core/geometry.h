// Small 2D geometry predicates shared by the partition, the progressive mesh and the mapping.
#pragma once

#include "common.h"

namespace montage {

// z component of the cross product of two 2D vectors.
inline double cross2(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// Twice the signed area of triangle (a, b, c): > 0 when counter-clockwise (in a y-up frame).
inline double orient2(const Vec2& a, const Vec2& b, const Vec2& c) {
  return cross2(b - a, c - a);
}

}  // namespace montage
