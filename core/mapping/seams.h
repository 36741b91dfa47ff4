// Paper sections 4.2 and 4.3: content-based optimisation of the texture coordinates along the seams,
// as a pass over the final texture map (docs/pipeline.md explains why it does not run inside the
// coarse-to-fine replay as in the paper).
//
// A vertex on a seam (an edge whose two faces show different photos, or the same photo through
// different texture coordinates) has one UV per side. Each side's UV moves by random line searches
// (Sander et al. 2001) that minimise
//     E_boundary = lambda * E_geo + (1 - lambda) * E_tex                                    (eq. 2)
// where E_geo is the L-infinity stretch of the side's faces (Sander's, normalised per photo so that
// 1 = isometric at the photo's mean scale) and E_tex the mean, over sample points spaced under half a
// pixel in both photos along the vertex's seam edges, of
//     alpha * |I1(s) - I2(s)|_LUV / 100 + (1 - alpha) * |G'1(s) - G'2(s)| / 50               (eq. 3, 4)
// each term clamped to [0, 1], with bilinear samples of the photos' L*u*v* images. G' is the colour
// gradient carried into the plane of the hinge map of the edge's two triangles (section 4.3); with
// gradients on (alpha < 1) the one-ring neighbours inside the patches move too, since they change
// that map. The sides of a vertex alternate, each search seeing the other side's latest position.
// Feature vertices never move; no texture triangle flips; no vertex lands on a photo's background.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <unordered_map>
#include <vector>

#include "base/common.h"
#include "base/job.h"
#include "mapping/texture_map.h"

namespace montage {

struct Mesh;
struct Photo;
class LuvTiles;

struct SeamOptions {
  double lambda = 0.1;           // weight of E_geo against E_tex (eq. 2): higher keeps the stretch lower, 1 = no move
  int rounds = 30;               // alternating rounds over the seam vertices (fewer when E stops falling); 0 = off
  double gradientWeight = 0;     // 1 - alpha of eq. (4): weight of the gradient mismatch against the colour one
  int lineSearches = 4;          // random directions per side and round
  int searchSteps = 6;           // golden-section steps per line search (after 6 coarse samples of the chord)
  unsigned seed = 1;             // random directions: runs are repeatable
  bool measureGradients = true;  // measure gradientBefore/After even when gradientWeight is 0 (three times the
                                 // samples); false leaves them NaN (the editor's warm preview)
};

// A run's optimised sides, keyed by what a side's energy reads: its faces and the faces across its seam
// edges (positions, photos, UVs before the optimisation). The editor's preview passes the last run's
// (SeamInput::warm): a side found there takes its UV from it and starts asleep, so only the sides an
// edit changed are optimised.
// `near` keys the same sides without their UVs (positions and photos only), with the UV each started
// from and ended at: with SeamInput::warmTolerancePx > 0, a side whose start and every start its
// energy reads moved less than that (a refitted camera shifts a whole photo by a fraction of a pixel)
// takes the kept move, start + (uv - kept start), and starts asleep too.
// `structure` is the last run's sides and seam edges (which corners share a UV, and the seam edges between
// them) and its plan of the rounds: a warm run on the same mesh (SeamInput::meshHash), the same photo per
// face and corners grouped the same way takes them instead of building them again.
struct SeamStructure;
struct SeamMemo {
  struct Move {
    Vec2 start, uv;
  };
  std::unordered_map<uint64_t, Vec2> uv;
  std::unordered_map<uint64_t, Move> near;
  std::shared_ptr<const SeamStructure> structure;
};

struct SeamInput {
  const Mesh* mesh = nullptr;       // the mesh the map is over (Partition::mesh)
  const TextureMap* map = nullptr;  // per face a photo and its corner UVs in pixels
  std::vector<const Photo*> photos;
  std::vector<int> fixedVertices;  // vertices whose UVs never move (Partition::featureVertex; -1 entries ignored)
  // Per photo (empty = none): photos mapped by a camera's projection (mapping/projection.h). There the
  // projection is the geometric truth, so E_geo of a side in such a photo is its squared distance from
  // where the projection put it, in pixels, instead of the stretch (which would pull it off the truth).
  std::vector<char> projectedPhotos;
  // Per photo (empty or null = made here): its L*u*v* tiles, when the caller keeps them across runs.
  std::vector<std::shared_ptr<const LuvTiles>> luv;
  const SeamMemo* warm = nullptr;  // may be null: see SeamMemo
  uint64_t meshHash = 0;           // the mesh's positions and faces hashed (0: unknown; see SeamMemo::structure)
  double warmTolerancePx = 0;      // see SeamMemo::near (0: only sides whose UVs are the same)
};

struct SeamResult {
  TextureMap map;                // the input map with the seam vertices (and, with gradients, their neighbours) moved
  std::vector<float> faceError;  // #F: mean Delta E*uv over the samples of the face's seam edges; -1 = no seam edge
  int seamEdges = 0, seamVertices = 0;  // edges with a texture discontinuity; non-feature vertices on them
  int neighbourVertices = 0;            // one-ring neighbours optimised for the gradient term
  int sleepingSides = 0;  // sides left as they were: their seams matched below the noticeable difference at the start
  int movedSides = 0;     // vertex sides whose UV moved
  int rounds = 0;         // rounds run
  int warmSides = 0;      // sides that took their UV from SeamInput::warm
  int warmNearSides = 0;  // of those, sides whose surroundings moved within SeamInput::warmTolerancePx
  bool structureKept = false;  // the sides and seam edges came from SeamInput::warm (SeamMemo::structure)
  std::shared_ptr<const SeamMemo> memo;              // this run's sides, for the next run's SeamInput::warm
  double deltaEBefore = 0, deltaEAfter = 0;          // mean Delta E*uv over all seam samples
  double gradientBefore = 0, gradientAfter = 0;      // mean |G'1 - G'2| (L*u*v* per pixel) over seam samples
                                                     // (NaN when not measured: SeamOptions::measureGradients)
  double maxStretchBefore = 0, maxStretchAfter = 0;  // L-infinity stretch over mapped faces, normalised per photo
  double setupSeconds = 0, measureSeconds = 0, roundSeconds = 0;  // parts of `seconds`: sides and seam edges;
                                                                  // the figures before and after; the rounds
  double seconds = 0;
};

// Runs sections 4.2-4.3 on `input.map`. Throws montage::Error when the map does not match the mesh or
// names a photo that does not exist; montage::Cancelled when the job is cancelled.
SeamResult optimiseSeams(const SeamInput& input, const SeamOptions& options = {}, const JobControl& job = {});

}  // namespace montage
