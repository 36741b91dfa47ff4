// What the 3D view colours faces by, computed from what the pipeline returned (no GL): patches by
// photo, empty faces, Sander stretch and seam error. (The clone tool's preview is core's projectClone.)
#pragma once

#include <array>
#include <optional>
#include <vector>

#include "io/model.h"
#include "io/project.h"
#include "mapping/texture_map.h"

namespace montage {

// A distinct colour per photo index (sRGB [0,1]); stable across runs so a photo keeps its colour.
Vec3f photoColor(int photo);
// Heat colour for t in [0,1]: blue (0) - green - yellow - red (1).
Vec3f heatColor(double t);

// Per face RGBA overlays (alpha = blend weight), #F of the model's mesh.
// Patches: the face's source photo colour; empty faces magenta; inpainted faces grey-blue.
std::vector<Vec4f> patchOverlay(const TexturedModel& model);
// Empty faces (no photo) highlighted in magenta, everything else transparent.
std::vector<Vec4f> emptyOverlay(const TexturedModel& model);

// Sander L2 stretch per face of `map` over `mesh` (the partition's mesh), normalised so that 1 means
// isometric up to the global scale of the map (the ratio of surface area to texture area over the
// mapped faces, as eval.h normalises). Empty faces get NaN; flipped faces +inf.
std::vector<double> normalizedStretch(const Mesh& mesh, const TextureMap& map);
// Heatmap of those values: log2 scale from 1 (blue) to 4 and more (red); flipped black, empty transparent.
std::vector<Vec4f> stretchOverlay(const std::vector<double>& stretch);
// Heatmap of the per-face seam error of seam optimisation (SeamResult::faceError, mean Delta E*uv across
// the face's seam edges): 0 blue to 20 and more red; faces on no seam (-1) transparent.
std::vector<Vec4f> seamErrorOverlay(const std::vector<float>& faceError);

}  // namespace montage
