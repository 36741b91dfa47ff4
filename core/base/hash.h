// A 64-bit hash built by mixing values in, for cache keys of large inputs (meshes, fields) where an exact
// byte key would cost as much as the data. Mixing is order-dependent; doubles mix by their bits, so -0
// and 0 differ and a NaN equals only the same NaN.
#pragma once

#include <cstdint>
#include <cstring>

#include "base/common.h"

namespace montage {

inline uint64_t hashMix(uint64_t h, uint64_t v) {
  v *= 0x9E3779B97F4A7C15ull;
  v ^= v >> 31;
  return (h ^ v) * 0xBF58476D1CE4E5B9ull + 0x94D049BB133111EBull;
}

inline uint64_t hashMix(uint64_t h, double d) {
  uint64_t bits;
  std::memcpy(&bits, &d, sizeof bits);
  return hashMix(h, bits);
}

inline uint64_t hashMix(uint64_t h, int v) {
  return hashMix(h, static_cast<uint64_t>(static_cast<int64_t>(v)));
}

inline uint64_t hashMix(uint64_t h, const Vec3& p) {
  return hashMix(hashMix(hashMix(h, p.x()), p.y()), p.z());
}

inline uint64_t hashMix(uint64_t h, const Vec2& p) {
  return hashMix(hashMix(h, p.x()), p.y());
}

}  // namespace montage
