// Paper section 2, step 5: the texture atlas. Charts (photo patches cropped from their photo, inpainted
// and empty regions flattened by LSCM), packing into one square image with a guaranteed gutter,
// baking of the colours (photo resampling, inpainted vertex colours, seam levelling offsets), gutter
// dilation, and the textured model with the atlas as its single material.
//
// Coordinates: atlas texel coordinates follow the pixel convention of photo.h (x right, y down,
// origin at the top-left corner, texel (c, r) centred at (c + 0.5, r + 0.5)). The TexturedModel made
// by atlasModel converts them to OBJ texture coordinates u = x / size, v = 1 - y / size.
//
// Footprint and gutter: the footprint of a chart is every texel a bilinear lookup anywhere on its
// triangles can read, i.e. every texel whose centre is within Chebyshev distance 1 of a triangle.
// Baking writes exactly the footprint; footprints of two charts are at least `gutter` texels apart
// (Chebyshev distance > gutter) and at least `gutter` texels from the atlas border.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "base/common.h"
#include "geometry/lscm.h"
#include "io/model.h"
#include "mapping/texture_map.h"

namespace montage {

struct Mesh;
struct Photo;
struct InpaintResult;
struct SeamLevelling;

inline constexpr int kMinAtlasSize = 256, kMaxAtlasSize = 8192, kAtlasSizeStep = 256;

struct AtlasOptions {
  // Atlas width and height in texels. 0 (automatic): the smallest multiple of 256 that holds every
  // chart at its photo's own texel density (never magnified), at most 8192 (beyond, the charts shrink).
  // 256 to 8192: that size, with the charts grown or shrunk to fill it (up to maxScale).
  int size = 0;
  int gutter = 4;  // texels between the footprints of two charts and from the border, 0 to 64
  // Fixed sizes: upper bound of the global scale (atlas texels per photo pixel). 0 = none: the charts
  // grow until they fill the atlas. 1 never magnifies a photo. (The automatic size always uses 1.)
  double maxScale = 0;
  // An LSCM chart is split in two while its area-weighted L2 stretch (1 = isometric) exceeds this or
  // while it has flipped triangles. Lower = more, smaller, less distorted charts.
  double maxChartStretch = 1.5;
  // An LSCM chart with more faces than this is split in two before it is flattened, so that no single
  // chart's sparse factorisation takes minutes (issue 15: one 1M-face empty chart took 220 s). Lower =
  // more, smaller charts and faster flattening (docs/atlas.md measures it).
  int maxLscmFaces = 100000;
  // Texel density of empty charts relative to the others: they are one flat colour.
  double emptyDensity = 0.25;
  bool rotateCharts = true;  // let the packer turn charts by 90 degrees where that packs tighter
  // Charts of one photo are kept together where it costs little: the packer may place a chart up to
  // this many texels lower than its best position when that is nearer to its photo's other charts.
  int photoAffinityTexels = 8;
  Vec3f emptyColor = Vec3f(0.7f, 0.7f, 0.7f);  // sRGB colour of empty faces (the model's default diffuse)
  int threads = 0;                             // baking threads; 0 = std::thread::hardware_concurrency()
  LscmOptions lscm;
};

// What the atlas needs to know about the surface. Built by atlasInput() from the pipeline's data, or
// by hand (tests, tools).
struct AtlasInput {
  std::vector<int> faceSource;  // #F: photo index >= 0, kSourceInpainted or kSourceEmpty (model.h)
  // #F x 3, corner order of Mesh::faceVertices: photo pixel coordinates (photo.h) for faces with a
  // photo; ignored for the others.
  std::vector<std::array<Vec2, 3>> cornerUV;
  std::vector<cv::Size> photoSizes;  // per photo index, in pixels
  // Optional #F: texel density wanted for non-photo faces, in texels per model unit at scale 1
  // (inpainting's refinement density); 0 or empty = the photo charts' mean density.
  std::vector<double> faceDensity;
  // Optional #F: faces of different groups never share a chart (e.g. the charts of another atlas of
  // the same surface, so that the new charts follow its seams); empty = no constraint.
  std::vector<int> faceGroup;
};

// The input for the pipeline: faces of an inpainted region or clone target (inpaint->faceRegion >= 0)
// become kSourceInpainted with the region's density, other faces keep their photo, the rest are
// kSourceEmpty. `inpaint` may be null.
AtlasInput atlasInput(const Mesh& mesh, const TextureMap& map, const std::vector<std::shared_ptr<const Photo>>& photos,
                      const InpaintResult* inpaint);

// One chart: an edge-connected set of faces with one source and continuous texture coordinates.
struct AtlasChart {
  int source = kSourceEmpty;  // photo index, kSourceInpainted or kSourceEmpty
  std::vector<int> faces;     // mesh faces, ascending
  // Rectangle of the atlas holding the chart's footprint (texels, top-left x, y, width, height).
  int x = 0, y = 0, width = 0, height = 0;
  bool rotated = false;  // turned by 90 degrees by the packer
  // Photo charts: photo pixel = toPhoto * (atlas x, atlas y, 1). A similarity (scale 1 / Atlas::scale).
  Eigen::Matrix<double, 2, 3> toPhoto = Eigen::Matrix<double, 2, 3>::Zero();
  FlatteningQuality quality;  // LSCM charts: the flattening's quality (photo charts: defaults)
};

struct AtlasTimes {
  double charts = 0, lscm = 0, pack = 0;  // seconds (charts: grouping, cutting and checks; lscm: the solves)
};

struct Atlas {
  int size = 0, gutter = 0;
  double scale = 0;  // atlas texels per photo pixel (and per density-hint texel), chosen to fit
  std::vector<AtlasChart> charts;
  std::vector<int> faceSource;                // #F, as given in the input
  std::vector<int> faceChart;                 // #F: index into charts
  std::vector<std::array<Vec2, 3>> cornerUV;  // #F x 3: atlas texel coordinates (y down)
  double utilisation = 0;                     // area of all chart triangles / atlas area
  int photoCharts = 0, lscmCharts = 0;
  int discCuts = 0;       // splits of closed, annular or higher-genus regions into discs
  int stretchSplits = 0;  // splits of LSCM charts that flipped or stretched beyond the threshold
  int sizeSplits = 0;     // splits of LSCM charts larger than AtlasOptions::maxLscmFaces
  int packAttempts = 0;   // packings tried while searching the scale
  AtlasTimes times;
  nlohmann::json stats() const;  // figures for report.json (no per-chart data)
};

// Charts, LSCM and packing. Throws montage::Error for options out of range, an input whose sizes do
// not match the mesh, a photo index without a size, non-finite UVs, or charts that cannot fit into the
// atlas even at a tiny scale. `progress` (may be empty) gets fractions in [0,1] and may throw
// montage::Cancelled.
Atlas buildAtlas(const Mesh& mesh, const AtlasInput& input, const AtlasOptions& options = {},
                 const std::function<void(double)>& progress = {});

// The baked atlas image and which chart wrote each texel.
struct AtlasImage {
  cv::Mat rgba;   // CV_8UC4, size x size, RGBA, opaque; gutters and free space filled with the nearest chart colour
  cv::Mat chart;  // CV_32SC1: chart index per texel of a footprint, -1 elsewhere
  double seconds = 0;  // time the bake took
};

// Bakes the charts: photo charts resample their photo (bilinear; area-averaged first when the atlas
// minifies it) plus the seam levelling offset interpolated over the face; faces of an inpainted
// region rasterise their refined triangles with Gouraud-interpolated inpainted colours; inpainted
// faces without refined triangles and empty faces get a flat colour. Then every texel outside the
// footprints takes the colour of the nearest footprint texel, so bilinear filtering and mipmaps never
// see a background colour. `levelling` and `inpaint` may be null. Throws montage::Error when a photo
// is missing or the inputs do not match the atlas.
AtlasImage bakeAtlas(const Atlas& atlas, const Mesh& mesh, const std::vector<std::shared_ptr<const Photo>>& photos,
                     const SeamLevelling* levelling, const InpaintResult* inpaint, const AtlasOptions& options = {});

// Bakes any surface colour into the atlas: every footprint texel takes color(face, barycentrics of the
// face) at its centre when the centre lies in one of its chart's triangles, else at the nearest point of
// the chart's triangles; then the same gutter fill as bakeAtlas. `color` returns sRGB in [0,1] and may
// set `label` (0 by default); `labels`, when given, receives the labels as a CV_8UC1 image (0 outside
// every footprint). `color` is called from several threads at once. Used to transfer a result between
// two atlases of one surface (atlas/transfer.h).
AtlasImage bakeAtlasSurface(const Atlas& atlas,
                            const std::function<Vec3f(int face, const Vec3& bary, unsigned char& label)>& color,
                            const AtlasOptions& options = {}, cv::Mat* labels = nullptr);

// Extra layers. Source per texel (CV_8UC1): photo index + 1 (up to 250), 254 inpainted, 253 empty,
// 0 outside every footprint. Hole mask (CV_8UC1): 255 on inpainted and empty charts, 0 elsewhere.
cv::Mat atlasSourceLayer(const Atlas& atlas, const AtlasImage& image);
cv::Mat atlasHoleMask(const Atlas& atlas, const AtlasImage& image);
// Writes DIR/<base>_atlas_source.png and DIR/<base>_atlas_holes.png (atomically).
void writeAtlasLayers(const Atlas& atlas, const AtlasImage& image, const std::string& dir,
                      const std::string& base = "model");
// The same from a source layer (atlasSourceLayer's codes); the hole mask is where it is 253 or 254.
void writeAtlasLayers(const cv::Mat& source, const std::string& dir, const std::string& base = "model");

// The model exportObj/exportGlb write for the refined topology: the mesh, atlas UVs (OBJ convention), the
// given face sources and one material per source ("photo_<k>", "inpainted", "empty"), all showing the
// baked image (texture name "atlas"), so exportObj(model, dir, "model") writes model.obj, model.mtl and
// one model_atlas.png.
TexturedModel atlasModel(const Mesh& mesh, const Atlas& atlas, const AtlasImage& image);

}  // namespace montage
