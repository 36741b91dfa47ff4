// Seam levelling (paper end of section 5, after Agarwala et al. 2004): a smooth additive colour offset
// per (vertex, photo) that closes the colour difference along every seam between two photos.
#pragma once

#include <array>
#include <vector>

#include "base/common.h"
#include "io/options.h"
#include "mapping/texture_map.h"

namespace montage {

struct Mesh;
struct Photo;
class JobControl;
class PoissonCache;

// Seam levelling (paper end of section 5, after Agarwala et al. 2004): an additive sRGB offset per
// mapped face corner, linear over each face, to be added to the photo colour when baking.
struct SeamLevelling {
  std::vector<std::array<Vec3f, 3>> cornerOffset;  // #F x 3 (zero for unmapped faces); empty = none
  int seams = 0;                                   // seams (maximal runs of edges between two photos) levelled
  double meanMismatchBefore = 0;                   // mean |colour difference| across seam samples, sRGB [0,1] units
  double meanMismatchAfter = 0;
  double seconds = 0;
};

// Levels the colours across seams between photos (faces mapped to different photos sharing an edge).
// Samples clipped on either side (clippedColor) are left out; an edge's difference is its own as far as the
// edge is trusted (the smaller faceTrust of its faces) and otherwise the trusted mean of its photo pair, or 0
// when the pair has fewer than 16 trusted samples: grazing, smeared texels do not shift a photo's colours.
// `solvers` (may be null) keeps each photo's factorisation across runs: a photo whose faces and seam
// vertices did not change is solved again without factorising (PoissonCache; the same result bit for bit).
SeamLevelling levelSeams(const Mesh& mesh, const TextureMap& map, const std::vector<const Photo*>& photos,
                         LevelMode mode, const JobControl& job, PoissonCache* solvers = nullptr);

// The colour a mapped face shows at barycentrics b: its photo's colour there plus the levelling offset.
Vec3f mappedColor(const TextureMap& map, const std::vector<const Photo*>& photos, const SeamLevelling* levelling,
                  int face, const Vec3& b);

}  // namespace montage
