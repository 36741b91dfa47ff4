// The preview tier's colours on the CPU. The editor shows the preview on the GPU: a mapped face samples
// its photo through its photo UVs plus the seam levelling offset; an inpainted face interpolates the
// inpainted colours at the vertices of its refined triangles; other faces show a flat colour. This is
// the same rule, for renders, tests (the preview against the final bake) and the editor's shader to
// be checked against.
#pragma once

#include <array>
#include <vector>

#include "base/common.h"
#include "mapping/texture_map.h"

namespace montage {

struct Photo;
struct SeamLevelling;
struct InpaintResult;

class PreviewSurface {
 public:
  // `levelling` and `inpaint` may be null. The referenced objects must outlive the PreviewSurface.
  PreviewSurface(const TextureMap& map, const std::vector<const Photo*>& photos, const SeamLevelling* levelling,
                 const InpaintResult* inpaint, const Vec3f& emptyColor = Vec3f(0.7f, 0.7f, 0.7f));
  // sRGB colour in [0,1] of face f (of the mapping's mesh) at barycentrics b.
  Vec3f color(int face, const Vec3& b) const;

 private:
  const TextureMap& map_;
  std::vector<const Photo*> photos_;
  const SeamLevelling* levelling_;
  const InpaintResult* inpaint_;
  Vec3f empty_;
  std::vector<int> firstTriangle_;  // per face: start of its refined triangles in triangles_ (#F + 1)
  std::vector<int> triangles_;
};

}  // namespace montage
