// Export on the original topology: the user's mesh exactly as loaded (vertex order and positions, faces,
// groups, material names), with a new UV atlas of its own faces, and the montage result transferred
// into it by surface-to-surface baking.
//
// The pipeline works on the partition's mesh: the input mesh plus Steiner vertices on input edges
// (Partition::faceParent gives the input face every refined face lies in). A point of input face f at
// barycentrics b lies in exactly one refined child of f, so the correspondence between the two
// surfaces is exact (no ray casting): RefinedLocator finds the child and the point's barycentrics in
// it. The new atlas (charts by LSCM and the packer of atlas.h) follows the montage's charts: an input
// face joins the chart of the refined chart that covers most of its area, so charts break along the
// montage's seams to within one input face. Each texel of the new atlas then takes the montage's colour
// at its surface point.
#pragma once

#include <array>
#include <functional>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "atlas/atlas.h"
#include "base/common.h"
#include "geometry/mesh.h"
#include "io/model.h"

namespace montage {

// Point location from the input mesh into its refinement.
class RefinedLocator {
 public:
  // input: the mesh as loaded; refined: the partition's mesh; faceParent: #F(refined), the input face
  // each refined face lies in. Throws montage::Error when the sizes do not match or a parent is out of
  // range.
  RefinedLocator(const Mesh& input, const Mesh& refined, const std::vector<int>& faceParent);
  // The refined face containing the point at barycentrics b (corner order of faceVertices) of input
  // face f, and the point's barycentrics in it (clamped into the triangle). -1 when f has no child.
  int locate(int f, const Vec3& b, Vec3& childBary) const;
  const std::vector<int>& children(int f) const { return children_[f]; }

 private:
  std::vector<std::vector<int>> children_;    // per input face: its refined faces
  std::vector<std::array<Vec3, 3>> corners_;  // per refined face: its corners' barycentrics in the parent
};

// The montage result's colour at a point of the refined surface (sRGB in [0,1]): face of `refined`,
// barycentrics in it. Called from several threads at once.
using SurfaceColor = std::function<Vec3f(int refinedFace, const Vec3& bary)>;

struct TransferOptions {
  // Texel density of the new atlas relative to the refined atlas's. LSCM's map is not the photo's, so
  // the new atlas needs more texels than the photo has pixels to keep what it shows. 2.5 keeps every test
  // scene within 41 dB of the montage's own colours (3 spends 44% more texels for 0.5-2 dB more;
  // docs/atlas.md).
  double oversample = 2.5;
  // Area-weighted surface samples of the loss measurement. On the cat, three seeds give PSNRs within
  // 0.2 dB of each other at 50,000 samples as at 200,000 (docs/pipeline.md).
  int samples = 50000;
  unsigned seed = 7;     // their random seed
};

// Loss of the transfer: PSNR (RGB in [0,255]) of the original-topology model against the refined
// model at the same surface points, overall and split by where it is lost.
struct TransferLoss {
  int samples = 0;
  double psnr = 0;          // dB, whole surface
  double psnrInterior = 0;  // dB, faces away from the new atlas's chart borders
  double psnrBorder = 0;    // dB, faces with an edge on a chart border of the new atlas
  double psnrSmall = 0;     // dB, thin features: faces under 2 texels of new-atlas area (0 when none)
  double borderShare = 0;   // area fraction of chart-border faces
  double smallShare = 0;    // area fraction of thin faces
  // Against the montage's own colours (when measureTransfer gets them): what each export loses by
  // sampling the surface into its atlas. At the photos' own resolution two exports of a detailed photo
  // differ more from each other than either does from the montage (two independent resamplings).
  double psnrOriginalVsMontage = 0, psnrRefinedVsMontage = 0;
  nlohmann::json toJson() const;
};

struct OriginalModel {
  Atlas atlas;          // charts over the input mesh's faces
  AtlasImage image;     // the transferred colours
  cv::Mat source;       // CV_8UC1 per texel: the codes of atlasSourceLayer (photo + 1, 254 inpainted, 253 empty)
  TexturedModel model;  // the input mesh, atlas UVs, the input's materials (all showing the atlas), no face sources
  TransferLoss loss;    // measured against atlasModel(refined mesh, refined atlas, refined image)
  double seconds = 0;   // all of it
  // Where the time goes: charts + LSCM + packing, the bake (colours and source layer), the loss.
  double atlasSeconds = 0, bakeSeconds = 0, measureSeconds = 0;
};

// Builds the new atlas over `input`, bakes the refined result into it and measures the loss.
// refinedAtlas/refinedImage: the montage's atlas over `refined` (bakeAtlas): its charts and densities
// shape the new atlas, and the loss is measured against it. `color`, when given, is where the new
// atlas's texels take their colour (the montage's own colours, e.g. surface/preview.h over the final
// tier: one resampling of the photos, as the refined atlas's); otherwise they are looked up in
// refinedImage (a second resampling). Options: the atlas size and gutter of the new atlas.
OriginalModel bakeOriginalTopology(const Mesh& input, const Mesh& refined, const std::vector<int>& faceParent,
                                   const Atlas& refinedAtlas, const AtlasImage& refinedImage,
                                   const AtlasOptions& options = {}, const TransferOptions& transfer = {},
                                   const SurfaceColor& color = {});

// The loss measurement alone: samples `original`'s surface (area-weighted), compares its colour with
// `refined`'s at the same point (via locator) and classifies samples by the faces of `originalAtlas`.
TransferLoss measureTransfer(const TexturedModel& original, const TexturedModel& refined, const RefinedLocator& locator,
                             const Atlas& originalAtlas, const TransferOptions& options = {},
                             const SurfaceColor& montage = {});

// ---------------------------------------------------------------------------------------------
// Baking into the mesh's own UV layout (project option bakeInto "meshUVs").
//
// The input mesh keeps its texture coordinates (Mesh::cornerUV, v up). UDIM tiles: a face belongs to the tile
// of its UV centroid, 1001 + floor(u) + 10 floor(v) (u in 0..10, v >= 0); a mesh whose UVs all lie in [0,1]^2
// has the one tile 1001. Each (material, tile) gets a texture of its own, size x size texels, baked like the
// atlas (bakeAtlasSurface: every texel of a face's footprint takes the montage's colour at its surface point,
// then the gutters take the nearest baked colour, so filtering and mipmaps never see a background).

struct MeshUVOptions {
  int size = 2048;  // texels a side of every tile's texture, a power of two in 16..8192
  Vec3f emptyColor = Vec3f(0.7f, 0.7f, 0.7f);  // sRGB colour where the montage has no refined face
  int samples = 50000;                          // area-weighted surface samples of the PSNR measurement
  unsigned seed = 7;                            // their random seed
};

// One texture of the bake: a material's faces in one UDIM tile.
struct MeshUVTile {
  int material = 0;  // index into the exported model's source materials (Mesh::materialNames; 0 when none)
  int udim = 1001;   // 1001 + floor(u) + 10 floor(v)
  std::vector<int> faces;  // input faces baked into it, ascending
  cv::Mat rgba;            // CV_8UC4, size x size, row 0 = top (v = tile's v + 1)
  cv::Mat source;          // CV_8UC1: codes of atlasSourceLayer (photo + 1, 254 inpainted, 253 empty), 0 = gutter
};

struct MeshUVBake {
  // The input mesh exactly as loaded with its own UVs; one material per (material, tile), named after the input
  // material (with "_<udim>" when the mesh has several tiles), each showing its tile's texture. The texture names
  // (Material::textureName) make exportObj write model.<udim>.png, or model_<material>.<udim>.png when the mesh
  // has several materials.
  TexturedModel model;
  std::vector<MeshUVTile> tiles;  // by (material, udim)
  // Faces whose UVs overlap another face's (one of them shows in the texture), faces that cross a tile border
  // (baked into their centroid's tile; the part outside repeats the tile), faces outside the UDIM range (u not
  // in 0..10 or v < 0: baked wrapped into their tile's place in 1001), each naming the first faces.
  std::vector<std::string> warnings;
  int overlappingFaces = 0, crossingFaces = 0, outOfRangeFaces = 0;
  // The bake against the montage at the same surface points (RGB in [0,255]): all samples, and the covered ones
  // (whose refined face shows a photo).
  double psnr = 0, psnrCovered = 0;
  int samples = 0, coveredSamples = 0;
  double seconds = 0, bakeSeconds = 0, measureSeconds = 0;
};

// Bakes the montage into `input`'s own UVs. refined/faceParent as for RefinedLocator; refinedSource: #F(refined)
// face sources (FaceSource or photo index: the refined atlas's faceSource); color: the montage's colour at a
// point of the refined surface. Throws montage::Error when the input has no texture coordinates, the sizes do not
// match or the size is not a power of two in 16..8192.
MeshUVBake bakeMeshUVs(const Mesh& input, const Mesh& refined, const std::vector<int>& faceParent,
                       const std::vector<int>& refinedSource, const SurfaceColor& color,
                       const MeshUVOptions& options = {});

}  // namespace montage
