// Options of the pipeline stages, as stored in the project file's "options" object. Each field has
// a default and a one-line comment; enums have a name table that feeds both the command line and
// the editor's combo boxes.
#pragma once

#include <array>
#include <string>

namespace montage {

// Guidance of a hole's Poisson fill (paper section 5): d = 0, RBF of the boundary Laplacian, the
// user's strokes (flow lines), no fill (the hole stays empty), the Laplacian of a texture synthesised
// from the photo patches around the hole on a flattened chart (surface/synthesis.h), of that texture
// blurred to its large-scale structure (what continues across the hole, without the grain), or of a
// texture optimised on the surface itself, for holes of any shape (surface/surface_synthesis.h).
enum class InpaintMode { Harmonic, Rbf, Strokes, Off, Synthesis, Structure, Texture };
inline constexpr std::array<const char*, 7> kInpaintModeNames = {"harmonic",  "rbf",       "strokes", "off",
                                                                 "synthesis", "structure", "texture"};

// Seam levelling (end of paper section 5): none, one mean colour difference per seam (the paper), or
// per seam vertex (docs/pipeline.md compares them).
enum class LevelMode { Off, Seam, Vertex };
inline constexpr std::array<const char*, 3> kLevelModeNames = {"off", "seam", "vertex"};

// Colour balance between photos (the paper's Photoshop step, automated; docs/pipeline.md): off, or per
// photo and channel a gain, or a gain and an offset, on linear RGB, solved over the seams between photos.
enum class BalanceMode { Off, Gain, GainOffset };
inline constexpr std::array<const char*, 3> kBalanceModeNames = {"off", "gain", "gain-offset"};

// Topology of the exported model: the user's mesh as loaded, with a new UV atlas and the montage baked
// into it surface to surface (core/atlas/transfer.h), or the partition's refined mesh (input plus Steiner
// vertices) with the montage's own charts.
enum class ExportTopology { Original, Refined };
inline constexpr std::array<const char*, 2> kExportTopologyNames = {"original", "refined"};

// What the exported texture is laid out in (exportTopology "original"): a new atlas of the mesh's faces, or
// the mesh's own UV layout (atlas/transfer.h, bakeMeshUVs: one texture per material and UDIM tile).
enum class BakeInto { Atlas, MeshUVs };
inline constexpr std::array<const char*, 2> kBakeIntoNames = {"atlas", "meshUVs"};

// Camera fit per photo (mapping/camera.h): automatic (a photo whose clicks agree with one perspective
// camera is mapped by projection, the others take the paper's path), or off (every photo takes the
// paper's path).
enum class CameraMode { Auto, Off };
inline constexpr std::array<const char*, 2> kCameraModeNames = {"auto", "off"};

// What a photo shows (mapping/camera.h, mapping/subject.h): decided from its clicks (auto); the object itself (a
// camera fitted to its clicks maps it by projection, and a click the camera disagrees with is an outlier); or
// another subject (a camera fitted to every click and a warp that keeps each one exact, or the paper's piecewise
// map where that maps with less error; no click is ever an outlier).
enum class PhotoMode { Auto, Object, Subject };
inline constexpr std::array<const char*, 3> kPhotoModeNames = {"auto", "object", "subject"};

// Which clicks the correction field of projection mapping keeps exact (mapping/projection.h): none
// (the camera alone), those that agree with the camera, every click (the paper: clicks are hard
// constraints), or every click as far as its residual exceeds what the clicks' noise explains (exact clicks stay
// exact, noisy ones no longer pull the texture off the camera's projection).
enum class CorrectionMode { Off, Inliers, All, Noise };
inline constexpr std::array<const char*, 4> kCorrectionModeNames = {"off", "inliers", "all", "noise"};

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
template <>
struct EnumNames<CameraMode> {
  static constexpr const auto& names = kCameraModeNames;
  static constexpr const char* what = "a camera mode";
};
template <>
struct EnumNames<PhotoMode> {
  static constexpr const auto& names = kPhotoModeNames;
  static constexpr const char* what = "a photo mode";
};
template <>
struct EnumNames<CorrectionMode> {
  static constexpr const auto& names = kCorrectionModeNames;
  static constexpr const char* what = "a correction mode";
};

template <>
struct EnumNames<ExportTopology> {
  static constexpr const auto& names = kExportTopologyNames;
  static constexpr const char* what = "an export topology";
};
template <>
struct EnumNames<BakeInto> {
  static constexpr const auto& names = kBakeIntoNames;
  static constexpr const char* what = "a bake layout";
};
inline constexpr int kMinAtlasSizeOption = 256, kMaxAtlasSizeOption = 8192;  // atlas/atlas.h's limits
inline constexpr int kMinBakeSize = 16, kMaxBakeSize = 8192;                 // bakeSize: a power of two

struct PipelineOptions {
  double backgroundThresholdPx = 2.0;  // partition: max mean distance (px) of a curve to the foreground
  int stretchSearches = 4;             // coarse-to-fine: random line searches per vertex (paper 4.1); 0 keeps the
                                       // barycentric placement (closer to the photo, more stretch: docs/pipeline.md)
  double seamLambda = 0.1;             // seams: weight of geometric stretch vs texture mismatch (paper 4.2)
  int seamRounds = 30;                 // seams: alternating optimisation rounds (paper 4.2)
  double gradientWeight = 0.0;         // seams: 1 - alpha of paper eq. (4); 0 = colours only
  BalanceMode colorBalance = BalanceMode::GainOffset;  // colour balance between photos, before levelling
  LevelMode seamLevelling = LevelMode::Vertex;         // seam levelling between photos (paper end of 5)
  InpaintMode inpaintMode = InpaintMode::Texture;      // inpainting: guidance of holes (InpaintOptions::mode; chosen by
                                                       // measurement, docs/pipeline.md)
  int maxInpaintVertices = 2000000;                    // inpainting: cap on refined vertices (coarser beyond)
  int atlasSize = 0;  // atlas: 0 = the smallest size holding the photos at their own resolution, or a fixed
                      // width and height (256..8192) that the charts are scaled to fill
  int gutter = 4;     // atlas: texels between charts and from the border
  unsigned seed = 1;  // random line searches: seed, so runs are repeatable

  // Export: the user's mesh as loaded with a new atlas (original) or the refined mesh (refined).
  ExportTopology exportTopology = ExportTopology::Original;
  BakeInto bakeInto = BakeInto::Atlas;  // export (original topology): a new atlas, or the mesh's own UVs (UDIM tiles)
  int bakeSize = 2048;     // export, bakeInto meshUVs: texels a side of each texture (16..8192, power of 2)
  int pngCompression = 3;  // export: zlib level of the atlas PNG, 0..9 (up to 3: run-length, fast; 6: 7% smaller, 3x
                           // slower; 9 smallest, 25x slower)
  CameraMode cameraMode = CameraMode::Auto;  // camera fit per photo; off = every photo takes the paper's path
  double cameraThreshold = 0.006;            // camera fit: a click agrees within this share of the image diagonal
  bool sharedIntrinsics = true;  // camera fit: the object photos of one camera (one size; one model and focal length
                                 // where their EXIF says) share focal length and lens terms when Akaike's criterion
                                 // prefers it (a bundle adjustment over all their clicks)
  bool photometric = true;       // camera fit: the object photos' poses refined on what they show where they overlap,
                                 // kept when held-out photos are re-rendered better (mapping/photometric.h)
  bool foundSilhouettes = true;  // camera fit: a photo of the object itself without a cut-out is refined on the
                                 // silhouette GrabCut finds around the mesh's outline (mapping/found_silhouette.h)
  CorrectionMode correction = CorrectionMode::Noise;  // projection: clicks the correction field keeps exact
  double viewSmoothness = 1.0;                      // projection: seam cost of view selection (0 = best view per face)
  int maxPhotoSide = 0;  // load: working resolution, photos kept at most this many pixels a side (0 = full;
                         // else 256..16384); coordinates stay the files' pixels; less memory, coarser texture
  bool weldIdenticalPositions = true;  // load: vertices at one position (a mesh split at UV seams) are one vertex
                                       // for every stage; the export keeps the mesh's own vertices

  bool operator==(const PipelineOptions& o) const {
    return backgroundThresholdPx == o.backgroundThresholdPx && stretchSearches == o.stretchSearches &&
           seamLambda == o.seamLambda && seamRounds == o.seamRounds && gradientWeight == o.gradientWeight &&
           colorBalance == o.colorBalance && seamLevelling == o.seamLevelling && inpaintMode == o.inpaintMode &&
           maxInpaintVertices == o.maxInpaintVertices && atlasSize == o.atlasSize && gutter == o.gutter &&
           seed == o.seed && exportTopology == o.exportTopology && bakeInto == o.bakeInto && bakeSize == o.bakeSize &&
           pngCompression == o.pngCompression && cameraMode == o.cameraMode && cameraThreshold == o.cameraThreshold &&
           sharedIntrinsics == o.sharedIntrinsics && photometric == o.photometric &&
           foundSilhouettes == o.foundSilhouettes && correction == o.correction && viewSmoothness == o.viewSmoothness &&
           maxPhotoSide == o.maxPhotoSide && weldIdenticalPositions == o.weldIdenticalPositions;
  }
};

}  // namespace montage
