// The result of the mapping stages: per face a source photo (or empty), per face corner a UV in
// that photo's pixel coordinates, and the partition that produced them.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "base/common.h"

namespace montage {

struct TextureMap {
  static constexpr int kEmpty = -1;
  std::vector<int> facePhoto;                 // #F: photo index, or kEmpty
  std::vector<std::array<Vec2, 3>> cornerUV;  // #F x 3, pixel coordinates in facePhoto's photo (photo.h)
  std::vector<int> facePatch;                 // #F: patch id (connected set of faces of one partition cell)

  // Why parts of the surface stayed empty, for the user (e.g. "no features", "pair 3-7 rejected:
  // curve crosses the background (mean 5.2 px)").
  std::vector<std::string> notes;

  int numFaces() const { return static_cast<int>(facePhoto.size()); }
  int numMapped() const;
  // All faces empty: the map the pipeline starts from (paper section 3: no features = one empty patch).
  static TextureMap allEmpty(int numFaces);
};

}  // namespace montage
