// Options of the pipeline stages, as stored in the project file's "options" object. Each field has
// a default and a one-line comment; enums have a name table that feeds both the command line and
// the editor's combo boxes.
#pragma once

#include <array>
#include <string>

namespace montage {

enum class InpaintMode { Harmonic, Rbf, Strokes };
inline constexpr std::array<const char*, 3> kInpaintModeNames = {"harmonic", "rbf", "strokes"};

struct PipelineOptions {
  double backgroundThresholdPx = 2.0;  // partition: max mean distance (px) of a curve to the foreground
  int stretchSearches = 4;  // coarse-to-fine: random line searches per vertex (paper 4.1); 0 keeps the
                            // barycentric placement (closer to the photo, more stretch: docs/pipeline.md)
  double seamLambda = 0.1;             // seams: weight of geometric stretch vs texture mismatch (paper 4.2)
  int seamRounds = 30;                 // seams: alternating optimisation rounds (paper 4.2)
  double gradientWeight = 0.0;         // seams: 1 - alpha of paper eq. (4); 0 = colours only
  InpaintMode inpaintMode = InpaintMode::Rbf;  // inpainting: guidance for holes without strokes
  int atlasSize = 4096;                // atlas: width and height in texels (1024..8192)
  int gutter = 4;                      // atlas: texels between charts and from the border
  unsigned seed = 1;                   // random line searches: seed, so runs are repeatable

  bool operator==(const PipelineOptions& o) const {
    return backgroundThresholdPx == o.backgroundThresholdPx && stretchSearches == o.stretchSearches &&
           seamLambda == o.seamLambda &&
           seamRounds == o.seamRounds && gradientWeight == o.gradientWeight && inpaintMode == o.inpaintMode &&
           atlasSize == o.atlasSize && gutter == o.gutter && seed == o.seed;
  }
};

}  // namespace montage
