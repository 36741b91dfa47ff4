// Paper section 5: surface texture inpainting and seamless cloning.
//
// Holes (connected sets of faces no photo covers) and clone targets are refined until their edges are
// about one texel long (new vertices on the original triangles, so the shape is unchanged), together
// with one ring of mapped faces around them. Colours live on the refined vertices: the ring's come
// from the photos, the holes' from a Poisson solve (poisson.h) with the ring as Dirichlet boundary and
// a guidance field d chosen per hole (harmonic, RBF of the boundary Laplacian, user strokes). Clones
// then solve again on their target with d = the Laplacian of the photo mapped onto it. Seam levelling
// (surface/level.h) comes before: the ring's photo colours are levelled ones.
#pragma once

#include <Eigen/Core>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "base/common.h"
#include "geometry/poisson.h"
#include "io/options.h"
#include "io/project.h"
#include "mapping/texture_map.h"
#include "surface/level.h"
#include "surface/synthesis.h"

namespace montage {

struct Mesh;
struct Photo;
struct TextureDetail;
class JobControl;

// The refined copy of the base mesh's faces that inpainting and cloning work on.
struct RefinedSurface {
  TriangleMesh mesh;
  std::vector<int> parentFace;                  // per refined triangle: the base-mesh face it lies in
  std::vector<std::array<Vec3, 3>> parentBary;  // per refined triangle corner: barycentrics in parentFace
  std::vector<int> region;                      // per refined triangle: region id, or -1 for ring faces
};

// Per refined vertex colours (sRGB in [0,1]) over a RefinedSurface.
using VertexColors = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;

// A region that inpainting or cloning solved: one hole, or one clone operation's target.
struct InpaintRegion {
  enum class Kind { Hole, Clone };
  Kind kind = Kind::Hole;
  int clone = -1;                            // Project::clones index for Kind::Clone
  InpaintMode mode = InpaintMode::Harmonic;  // guidance used (holes)
  int baseFaces = 0;                         // faces of the base mesh in the region
  int refinedVertices = 0, unknowns = 0;     // refined vertices in the region; solved for
  double texelsPerUnit = 0;                  // refinement density (texels per model unit)
  double refineSeconds = 0, guidanceSeconds = 0, factorSeconds = 0, solveSeconds = 0;
  // Synthesised holes: whether the synthesis was kept from an earlier run (SynthesisMemo).
  using Kept = SynthesisKept;
  Kept synthesisKept = Kept::No;
  std::string note;  // e.g. "no mapped neighbour: filled with the mean colour"
  std::shared_ptr<const TextureDetail> detail;  // texture mode: the synthesised texture between the vertices
};

struct InpaintResult {
  RefinedSurface refined;
  VertexColors colors;          // #refined vertices x 3
  std::vector<int> faceRegion;  // per base face: region id (index into regions), or -1 (keeps its photo)
  std::vector<InpaintRegion> regions;
  std::vector<int> detailPoint;  // per refined vertex: its point in its region's detail, -1 (empty: no detail)
  double seconds = 0;
  // The colour at barycentrics w of refined triangle t: the vertices' colours interpolated, plus, in a
  // texture-synthesised hole, the texture between them (TextureDetail). What the bake and the preview show.
  Vec3f colourAt(int t, const Vec3& w) const;
};

// How a guided fill (any mode but harmonic) is kept inside the per-channel range of the colours on the
// hole's border, so that guidance never invents colours: not at all, by clamping each colour, by
// scaling the guided part f - f_harmonic down per channel until it fits, or by compressing it per
// vertex with tanh into the room left by the harmonic fill (smooth, so no facets; docs/pipeline.md).
enum class GuidanceBound { None, Clamp, Scale, Soft };
inline constexpr std::array<const char*, 4> kGuidanceBoundNames = {"none", "clamp", "scale", "soft"};

struct InpaintOptions {
  InpaintMode mode = InpaintMode::Texture;  // holes without a HoleMode entry (strokes steer "texture"; under
                                            // any other mode a hole with strokes follows them: "strokes")
  GuidanceBound bound = GuidanceBound::Soft;  // keeps guided fills inside the border's colour range
  double structureBlur = 0.35;  // structure: blur of the synthesised texture, in hole radii (SynthesisOptions::blur)
  double structureBand = 1.5;   // structure: the band's area in hole areas (SynthesisOptions::bandAreaRatio; plain
                                // synthesis keeps its 3: unblurred, it needs the wider exemplar; docs/pipeline.md)
  double texelsPerUnit = 0;     // refinement density; 0 = from the mapped faces around each hole
  int maxRefinedVertices = 2000000;  // cap on the refined vertices of all regions (coarser beyond)
  int rbfCentres = 256;              // RBF: boundary centres per hole (boundary values averaged per centre)
  double emptyTexelsPerUnit = 0;     // density when no face is mapped at all (0: 1024 texels across the bbox)
  double detail = 1;                 // refinement density relative to the texel density (the preview uses less)
  // Synthesised holes: a kept chart that covers the hole serves even when its canvas would differ
  // (SynthesisMemo; the preview). Without it only the same canvas is kept.
  bool synthesisReuseCharts = false;
  uint64_t textureSeed = 1;  // texture mode: the same seed gives the same texels (SurfaceSynthesisOptions::seed)
  double textureRareChi2 = 11.34;  // texture mode: exemplar patches this rare are features, never taken
                                   // (SurfaceSynthesisOptions::rareChi2; 0 takes every patch)
};

// What the inpainting reads besides the mapping. Strokes, clones and hole modes use the ids of the
// mesh as loaded; `faceParent` maps the partition mesh's faces to those ids (empty = identity) and
// the vertex ids are shared (partition.h). `where` prefixes error messages (the project file).
struct InpaintInput {
  const Mesh* mesh = nullptr;  // the mesh the texture map is over (Partition::mesh)
  const TextureMap* map = nullptr;
  std::vector<const Photo*> photos;
  const SeamLevelling* levelling = nullptr;  // offsets added to the photo colours (may be null)
  std::vector<int> faceParent;
  std::vector<Stroke> strokes;
  std::vector<CloneOp> clones;
  std::vector<HoleMode> holeModes;
  std::string where;
  InpaintOptions options;
  PoissonCache* solvers = nullptr;  // factorisations kept across runs (may be null: each region factors its own)
  SynthesisMemo* synthesis = nullptr;  // syntheses kept across runs (may be null)
  uint64_t photosKey = 0;              // what identifies the photos' content (0: unknown; SynthesisMemo)
};

// Refines the faces with faceLabel >= -1 (>= 0: region id, -1: ring) by longest-edge bisection until
// no edge is longer than the smaller faceMaxEdge of its faces. New vertices are edge midpoints, so they
// lie on the original triangles and the refinement stays conforming. baseVertex (optional) receives,
// per vertex of `mesh`, its refined vertex or -1.
RefinedSurface refineFaces(const Mesh& mesh, const std::vector<int>& faceLabel, const std::vector<double>& faceMaxEdge,
                           std::vector<int>* baseVertex = nullptr);

// Holes, strokes and clones: see the top of this file. Throws montage::Error naming input.where and
// the stroke or clone that cannot be applied (polygon covering no target vertex, anchor off the
// target), montage::Cancelled when the job is cancelled. Warnings go to `warnings`.
InpaintResult inpaintSurface(const InpaintInput& input, const JobControl& job, std::vector<std::string>* warnings);

// The projection of a clone's photo onto its target faces (the paper's quick preview, and the map the
// clone's Poisson solve uses): per target face (ids of `mesh`, after faceParent) its corners' photo
// positions in pixels. Throws montage::Error for an anchor vertex off the target or a target that has
// no plane to project on; `where` names the clone in messages (e.g. "a.json: clones[2]").
struct CloneProjection {
  std::vector<int> faces;                        // faces of `mesh` in the target
  std::vector<std::array<Vec2, 3>> cornerPixel;  // per target face corner
  double pixelsPerUnit = 0;                      // the scale used (fitted when the clone's is 0)
};
CloneProjection projectClone(const Mesh& mesh, const std::vector<int>& faceParent, const CloneOp& clone,
                             const std::string& where);

}  // namespace montage
