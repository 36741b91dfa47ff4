// The preview tier as a model the editor draws on the GPU without the atlas bake: photo faces sample
// their photo directly through their photo UVs, plus the seam levelling offset per corner; inpainted
// faces show a small atlas of their own (their charts only, baked from the inpainted colours exactly as
// PreviewSurface and the final bake compute them); empty faces a flat colour.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "atlas/atlas.h"
#include "base/common.h"
#include "io/model.h"
#include "mapping/texture_map.h"

namespace montage {

struct Photo;
struct SeamLevelling;
struct InpaintResult;

// A photo as a preview texture: CV_8UC4 RGBA at its stored resolution (rows top first).
cv::Mat previewTexture(const Photo& photo);

// The preview model over `mesh` (the mapping's mesh; face f of the model is face f of the mapping):
// - material p < photos.size(): photo p, its texture `photoTextures[p]` (previewTexture, shared, not
//   copied) with `photoTransforms[p]` as its Material::transform when given (the textures are then of the
//   photos before colour balance, `photos` the balanced ones: a balance that moves leaves the textures
//   as they are); UVs = photo pixels / photo size, v up (OBJ); TexturedModel::cornerColor holds the seam
//   levelling offsets;
// - material photos.size(), "inpainted": the atlas of the inpainted faces alone (AtlasOptions as given,
//   its size the smallest that fits), colours from PreviewSurface; with `smoothInpaint` (the quick preview:
//   every fill harmonic) no atlas (its charts took 0.17-0.27 s for a head's 14k inpainted faces) but a 1x1
//   black texture and the inpainted colours at the faces' corners as their corner colours;
// - material photos.size() + 1, "empty": untextured, `options.emptyColor`.
// Throws montage::Error when the inputs do not match the mesh.
TexturedModel previewModel(const Mesh& mesh, const TextureMap& map,
                           const std::vector<std::shared_ptr<const Photo>>& photos,
                           const std::vector<cv::Mat>& photoTextures, const SeamLevelling* levelling,
                           const InpaintResult* inpaint, const std::vector<ColorTransform>& photoTransforms = {},
                           const AtlasOptions& options = {}, bool smoothInpaint = false);

}  // namespace montage
