// Paper sections 3.2 (coarse map) and 4.1 (coarse-to-fine map construction). The base mesh's
// triangles whose three edges pair with a texture triangle in one photo are mapped to it; the
// vertex splits are then replayed in reverse order, each inserted vertex placed by its stored
// barycentric coordinates and optimised, with its one-ring neighbours, by random line searches
// (Sander et al. 2001) that minimise the L-infinity stretch, never flip a triangle and never land
// on a photo's background. Feature vertices stay exactly at their clicks.
#pragma once

#include <functional>
#include <vector>

#include "base/common.h"
#include "mapping/texture_map.h"

namespace montage {

struct Scene;
struct Partition;
class ProgressiveMesh;
class JobControl;

struct FineMapOptions {
  int lineSearches = 8;  // random directions tried per vertex optimisation
  int searchSteps = 12;  // bisection steps along each direction
  int finalSweeps = 2;   // extra optimisation sweeps over all vertices at full resolution
  unsigned seed = 1;     // random directions are drawn from this seed: runs are repeatable
};

// The energy a boundary vertex (mapped into two photos) minimises on one side, given its candidate
// position there. Section 4.2 plugs the content-based E_boundary in here; when empty, the
// geometric L-infinity stretch is used on both sides.
using BoundaryEnergy = std::function<double(int vertex, int photo, const Vec2& uv, double geometricStretch)>;

struct FineMapStats {
  int baseFaces = 0, baseMappedFaces = 0;
  int splits = 0;
  int centroidFallbacks = 0;  // initial positions that would have flipped (paper: use the centroid)
  int optimisedVertices = 0;
  int flippedFaces = 0;   // after the run (should be 0)
  double maxStretch = 0;  // L-infinity stretch over mapped faces
};

// Maps the partition's mesh. `pm` must be at its base level; it is at full resolution afterwards.
// Returns per face of Partition::mesh its photo (or empty) and its corner UVs in photo pixels.
TextureMap coarseToFine(const Scene& scene, const Partition& partition, ProgressiveMesh& pm,
                        const FineMapOptions& options, const JobControl& job, FineMapStats* stats = nullptr,
                        const BoundaryEnergy& boundaryEnergy = {});

}  // namespace montage
