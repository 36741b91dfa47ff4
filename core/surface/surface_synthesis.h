// Texture synthesis on the surface (inpaintMode "texture", the default; issue 34): a hole's refined
// vertices are synthesised from a photo region near it, whatever the hole's topology (a disc, an annulus,
// a whole side, a hole touching an open border or no mapped face at all). No chart is flattened.
//
// The hole's refined vertices and sample points of the mapped faces around it are the "pixels" (Turk 2001,
// Wei & Levoy 2001 synthesise on a surface's points the same way). Each hole point keeps a coordinate in
// the exemplar; its neighbourhood is a 7 x 7 grid of cells in its tangent plane, oriented by a direction
// field and scaled to the photos' texel density, holding its neighbours' colours (the exemplar at their
// coordinates, or the photos' for known points). Correction passes (Lefebvre & Hoppe 2005, on surfaces
// 2006) give each point, of the kd-tree's nearest exemplar patch (PCA, Kwatra et al. 2005's search) and the
// coherent candidates its neighbours suggest (k-coherence, Tong et al. 2002), the patch nearest to its
// neighbourhood. Known points never change, so the texture continues the border's. Coarse to fine: the
// grid cell doubles per level (a Poisson-disk subset of the points), the exemplar shrinks with it, and a
// finer point inherits its nearest coarser point's coordinate. Points take exemplar texels, never
// averages: Kwatra's averaging M-step was measured and washes the texture out (docs/pipeline.md).
//  - direction field: the mapped faces' photo x axis, carried onto the hole's vertices by harmonic
//    interpolation (the hole's own Poisson factorisation) and projected onto each tangent plane; a photo
//    that is mirrored on the surface (its y axis the other way round the normal) gives mirrored frames;
//  - scale: grid cell = the refined hole's mean edge length; the exemplar is resampled from the photo's
//    pixels per unit on its faces to one pixel per cell;
//  - exemplar: the photo mapped on most of the faces nearest the hole (rings of mapped faces up to three
//    times the hole's area; a hole with no mapped neighbour takes the mapped faces nearest to it in space),
//    its foreground pixels only, with its mean and deviation (L*a*b*) matched to the known points'.
// The result is the guidance of inpaint's Poisson solve (its Laplacian), which keeps the border seamless.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "geometry/poisson.h"
#include "surface/synthesis.h"

namespace montage {

struct HoleExemplar;

struct SurfaceSynthesisOptions {
  int levels = 5;              // coarse to fine: grid cells of 16 .. 1 refined edge lengths (fewer when the
                               // coarsest would leave the hole less than 8 cells across)
  int passes = 3;              // correction passes per level (the finest does one less)
  double exemplarBand = 3;     // exemplar: mapped faces around the hole up to this many times its area
  int maxCandidates = 30000;   // exemplar patches searched per level (a strided subset beyond)
  int pcaDimensions = 12;      // the kd-tree compares patches in this many principal components (24 searched
                               // nearly as slowly as a linear scan; 12 is 18% faster at the final, 23% at the
                               // preview, for the same texture: docs/pipeline.md)
  double rareChi2 = 11.34;     // exemplar patches whose mean colour lies this far (squared Mahalanobis) from
                               // the common ones are features, not texture, and are never taken (chi-square,
                               // 3 degrees of freedom, 99%); 0 takes every patch
  uint64_t seed = 1;           // the same seed gives the same texels
};

struct SurfaceSynthesisInput : HoleInput {
  const TriangleMesh* surface = nullptr;     // the hole's refined surface (its triangles and the ring's)
  std::vector<int> triangleFace;             // per surface triangle: the face of `mesh` it lies in
  std::vector<char> fixed;                   // per surface vertex: its colour is known (from a photo)
  const Eigen::MatrixXd* fixedValues = nullptr;  // per surface vertex, sRGB in [0,1] (rows of fixed vertices)
  const PoissonSolver* solver = nullptr;     // of `surface` with `fixed` (null when nothing is fixed)
  // The user's strokes over the hole, as segments in model space in their direction of travel. The exemplar's
  // grain follows them at the vertices they pass, and the direction field turns smoothly between them and the
  // border.
  std::vector<std::array<Vec3, 2>> strokes;
  // A photo region the user picked (Project::holeModes): the exemplar instead of the photos around the hole. Its
  // scale is the photo's own on the surface where it is mapped, else the band's; its frame the photo's as mapped,
  // else as the photo shows it.
  const HoleExemplar* exemplar = nullptr;
};

// The synthesised texture between the vertices. The vertices sit about 1.5 texels apart (inpaint refines to
// that), so their colours alone, interpolated, keep half the exemplar's gradient energy (tm_inpaint_picture);
// each synthesised vertex also keeps its exemplar coordinate and frame, and the bake looks the exemplar up at
// every texel: the texture at the photo's own resolution, as Lefebvre & Hoppe render a synthesis from its
// coordinates. The colour at a point is the Poisson fill's (the vertices, interpolated) plus the residual
// of the exemplar there against its values at the corners, so vertex colours, seams and border are the
// Poisson solve's, and the residual fades to nothing at fixed (photo) corners.
struct TextureDetail {
  struct Point {
    Vec2f at = Vec2f::Zero();                    // exemplar pixel (centre of pixel (0,0) at 0,0)
    Vec3f du = Vec3f::Zero(), dv = Vec3f::Zero();  // exemplar pixels per model unit along its x and y
    Vec3f colour = Vec3f::Zero();                // the exemplar at `at`
  };
  cv::Mat rgb;                // the exemplar at the photo's stored resolution, matched to the border, CV_8UC3 sRGB
  std::vector<Point> points;  // per synthesised vertex
  // The residual at x inside a triangle with corners at `corner` (model units), barycentrics w, whose corners
  // are points[index[k]] (-1: a fixed corner, which has no exemplar coordinate).
  Vec3f residual(const std::array<int, 3>& index, const std::array<const Vec3*, 3>& corner, const Vec3& w) const;
  Vec3f sample(float x, float y) const;  // sRGB in [0,1], bilinear at exemplar pixel (x, y)
};

struct SurfaceSynthesisResult {
  bool ok = false;
  std::string note;            // what was done, or why it could not be (the caller then falls back)
  Eigen::MatrixXd colours;     // per surface vertex, sRGB in [0,1]: synthesised, fixed rows as given
  int exemplarPhoto = -1;      // the photo the exemplar came from
  int exemplarWidth = 0, exemplarHeight = 0;  // at the finest level
  int levels = 0;              // levels synthesised
  int points = 0;              // points: the hole's and the known ones around it
  double energy = 0;           // mean per-texel distance (L*a*b*) of the neighbourhoods to their patches, last pass
  int strokeVertices = 0;      // stroke vertices that steered the direction field
  std::shared_ptr<const TextureDetail> detail;  // ok: the texture between the vertices
  std::vector<int> detailPoint;                 // per surface vertex: its detail->points index, -1 when fixed
};

// Synthesises the unknown vertices of input.surface (input.job: checked between and within the steps); never throws for a hole it cannot serve (ok = false
// and a note). Throws Cancelled when input.job is cancelled (checked between and within the steps).
SurfaceSynthesisResult synthesiseOnSurface(const SurfaceSynthesisInput& input,
                                           const SurfaceSynthesisOptions& options = {});

}  // namespace montage
