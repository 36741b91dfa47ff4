// Evaluation of a textured result against a ground-truth textured mesh (`montage eval`).
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "io/model.h"

namespace montage {

struct EvalOptions {
  int samples = 200000;  // random surface samples (area-weighted)
  unsigned seed = 7;
  int seamSamplesPerEdge = 4;
  // The truth's colour (sRGB [0,1]) at a point of its face f with barycentrics b, instead of its texture (a solid
  // pattern, e.g. synth's meshPattern of the truth's mesh); empty = truth.colorAt.
  std::function<Vec3f(int face, const Vec3& bary)> truthColor;
  // Per colour sample (samples entries, 0/1; empty = none): the samples the "seen" figures are taken over, e.g.
  // the samples another model (the projection oracle) textures from a photo, its EvalResult::coveredSample.
  std::vector<char> seen;
};

struct EvalResult {
  int samples = 0, coveredSamples = 0;
  double psnrAll = 0, psnrCovered = 0;                                 // dB, RGB in [0,255]
  double deltaEAll = 0, deltaECovered = 0;                             // mean CIE76 Delta E*uv
  double coveragePhoto = 0, coverageInpainted = 0, coverageEmpty = 0;  // area fractions
  int seenSamples = 0;                       // samples marked by EvalOptions::seen (0: no seen figures)
  double psnrSeen = 0, deltaESeen = 0;       // dB and mean Delta E*uv over those samples, whatever covers them here
  std::vector<char> coveredSample;           // per colour sample: 1 where a photo textures the result there
  int flippedTriangles = 0;                                            // texture triangles oriented against their chart
  int degenerateUvTriangles = 0;          // texture area under 0.1 texel^2 (untextured: 1e-12) while the 3D area is not
  double stretchL2 = 0, stretchLinf = 0;  // Sander 2001, normalised: 1 = isometric up to scale
  double seamMismatch = 0;                // mean Delta E*uv across chart seams (0 when no seams)
  int seamEdges = 0;
  // The same over the seams between faces textured from two different photos (source tags), which
  // seam levelling works on; 0 when the result carries no source tags.
  double photoSeamMismatch = 0;
  int photoSeamEdges = 0;
  nlohmann::json toJson() const;
  std::string summary() const;
};

// Samples the truth surface, finds the closest point on the result surface and compares colours.
// The result may be refined or re-ordered; it must describe the same surface.
EvalResult evaluate(const TexturedModel& result, const TexturedModel& truth, const EvalOptions& options = {});

}  // namespace montage
