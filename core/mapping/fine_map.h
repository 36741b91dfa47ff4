// Paper sections 3.2 (base mesh and coarse map) and 4.1 (coarse-to-fine map construction), run on
// one cell of the partition at a time (cells.h decides which cells map into which photo).
//
// A mapped cell is a disc bounded by three paths whose texture triangle lies in one photo. Its
// boundary is fixed in the photo: the corners at their clicks, the path vertices along their straight
// curves (cells.h says where). The cell gets its own progressive mesh: half-edge collapses of its
// inner vertices, never of its boundary. The base mesh's inner vertices (those no legal collapse
// could remove) are placed by a Tutte embedding (mean value weights) inside the fixed boundary. The vertex splits are
// then replayed in reverse order: each inserted vertex starts at its stored barycentric coordinates
// (the centroid of its one-ring kernel when those would flip a face) and is optimised, then its
// one-ring neighbours, by random line searches (Sander et al. 2001) that minimise the L-infinity
// stretch, never flip a triangle and never land on the photo's background.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "base/common.h"

namespace montage {

struct Photo;
class JobControl;

struct FineMapOptions {
  int lineSearches = 8;  // random directions tried per vertex optimisation (0: barycentric placement only)
  int searchSteps = 12;  // bisection steps along each direction
  int finalSweeps = 2;   // extra optimisation sweeps over all vertices at full resolution
  unsigned seed = 1;     // random directions are drawn from this seed (and the cell's content): runs repeat
};

// Figures of one cell's map, or summed over cells.
struct FineMapStats {
  int baseFaces = 0, baseMappedFaces = 0;  // base faces of mapped cells; of them, cells mapped
  int splits = 0;
  int centroidFallbacks = 0;  // initial positions that would have flipped (paper: use the centroid)
  int optimisedVertices = 0;
  int baseInnerVertices = 0;  // inner vertices left at the base (placed by the Tutte embedding)
  int flippedFaces = 0;       // after the run (should be 0)
  int onBackground = 0;       // free vertices that could not leave the background
  double maxStretch = 0;      // L-infinity stretch over mapped faces
  void add(const FineMapStats& o);
};

// The map problem of one cell, in a canonical form that depends on the cell's content only (not on
// how the rest of the mesh is numbered), so that a cell's map can be cached and reused across runs.
struct CellProblem {
  std::vector<Vec3> positions;            // local vertices, model units
  std::vector<std::array<int, 3>> faces;  // local faces, counter-clockwise seen from outside
  std::vector<char> fixed;                // per local vertex: its UV is given (the cell's boundary)
  std::vector<Vec2> fixedUV;              // per local vertex: the given UV (pixels, photo.h), else unused
  std::vector<std::vector<int>> sides;    // the boundary's paths (fixed) as local vertex sequences
  bool triangle = true;  // the paper's base triangle (three sides, nothing inside): coarse to fine from its
                         // coarsest mesh; else embedded at full resolution first, then optimised
  std::string key;       // everything the map depends on (content, photo, options)
};

// The map of one cell: a UV per local vertex (pixels), or a failure reason.
struct CellMap {
  std::vector<Vec2> uv;
  FineMapStats stats;
  std::string failure;  // empty when mapped
};

// Maps one cell into `photo`. Throws montage::Cancelled when the job is cancelled.
CellMap coarseToFineCell(const CellProblem& problem, const Photo& photo, const FineMapOptions& options,
                         const JobControl& job);

}  // namespace montage
