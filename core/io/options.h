// Options of the pipeline stages, as stored in the project file's "options" object. Each field has
// a default and a one-line comment; enums have a name table that feeds both the command line and
// the editor's combo boxes.
#pragma once

#include <array>
#include <string>

namespace montage {

// Guidance of a hole's Poisson fill (paper section 5): d = 0, RBF of the boundary Laplacian, the
// user's strokes (flow lines), or no fill (the hole stays empty).
enum class InpaintMode { Harmonic, Rbf, Strokes, Off };
inline constexpr std::array<const char*, 4> kInpaintModeNames = {"harmonic", "rbf", "strokes", "off"};

// Seam levelling (end of paper section 5): none, one mean colour difference per seam (the paper), or
// per seam vertex (docs/pipeline.md compares them).
enum class LevelMode { Off, Seam, Vertex };
inline constexpr std::array<const char*, 3> kLevelModeNames = {"off", "seam", "vertex"};

// Colour balance between photos (the paper's Photoshop step, automated; docs/pipeline.md): off, or per
// photo and channel a gain, or a gain and an offset, on linear RGB, solved over the seams between photos.
enum class BalanceMode { Off, Gain, GainOffset };
inline constexpr std::array<const char*, 3> kBalanceModeNames = {"off", "gain", "gain-offset"};

// Name tables by enum type, for the project reader and writer and the editor's combo boxes.
template <class E>
struct EnumNames;
template <>
struct EnumNames<InpaintMode> {
  static constexpr const auto& names = kInpaintModeNames;
  static constexpr const char* what = "an inpainting mode";
};
template <>
struct EnumNames<LevelMode> {
  static constexpr const auto& names = kLevelModeNames;
  static constexpr const char* what = "a seam levelling mode";
};
template <>
struct EnumNames<BalanceMode> {
  static constexpr const auto& names = kBalanceModeNames;
  static constexpr const char* what = "a colour balance mode";
};

struct PipelineOptions {
  double backgroundThresholdPx = 2.0;  // partition: max mean distance (px) of a curve to the foreground
  int stretchSearches = 4;             // coarse-to-fine: random line searches per vertex (paper 4.1); 0 keeps the
                                       // barycentric placement (closer to the photo, more stretch: docs/pipeline.md)
  double seamLambda = 0.1;             // seams: weight of geometric stretch vs texture mismatch (paper 4.2)
  int seamRounds = 30;                 // seams: alternating optimisation rounds (paper 4.2)
  double gradientWeight = 0.0;         // seams: 1 - alpha of paper eq. (4); 0 = colours only
  BalanceMode colorBalance = BalanceMode::GainOffset;  // colour balance between photos, before levelling
  LevelMode seamLevelling = LevelMode::Vertex;  // seam levelling between photos (paper end of 5)
  InpaintMode inpaintMode = InpaintMode::Rbf;   // inpainting: guidance of holes without strokes
  int maxInpaintVertices = 2000000;             // inpainting: cap on refined vertices (coarser beyond)
  int atlasSize = 4096;                         // atlas: width and height in texels (1024..8192)
  int gutter = 4;                               // atlas: texels between charts and from the border
  unsigned seed = 1;                            // random line searches: seed, so runs are repeatable

  bool operator==(const PipelineOptions& o) const {
    return backgroundThresholdPx == o.backgroundThresholdPx && stretchSearches == o.stretchSearches &&
           seamLambda == o.seamLambda && seamRounds == o.seamRounds && gradientWeight == o.gradientWeight &&
           colorBalance == o.colorBalance && seamLevelling == o.seamLevelling && inpaintMode == o.inpaintMode &&
           maxInpaintVertices == o.maxInpaintVertices && atlasSize == o.atlasSize && gutter == o.gutter &&
           seed == o.seed;
  }
};

}  // namespace montage
