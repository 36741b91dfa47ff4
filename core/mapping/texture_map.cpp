#include "mapping/texture_map.h"

#include <algorithm>

namespace montage {

int TextureMap::numMapped() const {
  return static_cast<int>(std::count_if(facePhoto.begin(), facePhoto.end(), [](int p) { return p != kEmpty; }));
}

TextureMap TextureMap::allEmpty(int numFaces) {
  TextureMap map;
  map.facePhoto.assign(numFaces, kEmpty);
  map.cornerUV.assign(numFaces, {Vec2::Zero(), Vec2::Zero(), Vec2::Zero()});
  map.facePatch.assign(numFaces, 0);
  return map;
}

}  // namespace montage
