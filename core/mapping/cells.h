// The map stage, cell by cell (paper sections 3.2 and 4.1, made incremental).
//
// The partition (3.1) cuts the mesh into cells along its paths. A cell maps into a photo when it is a
// disc bounded by three paths between three feature vertices, with no other feature inside, and the
// three paths have curves in that photo whose texture triangle keeps the cell's orientation (the
// paper's base triangle "that corresponds to a texture triangle in one image"); among several such
// photos, the most frontal view (smallest L-infinity stretch of the texture triangle).
//
// Each mapped cell's boundary is fixed: its corners at their clicks and every path vertex on the
// path's straight curve, at its arc length along the path (pathUVs). A cell's map then depends only
// on its own content, so every cell is mapped on its own (coarseToFineCell: its own progressive mesh
// and coarse-to-fine), independent cells run in parallel, and a cell whose content, boundary and
// photo did not change since an earlier run is taken from a CellCache instead of being mapped again.
#pragma once

#include <algorithm>
#include <array>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "base/common.h"
#include "mapping/fine_map.h"
#include "mapping/texture_map.h"

namespace montage {

struct Scene;
struct Partition;
struct MeshPath;
struct Curve;
struct Mesh;
struct Photo;
class JobControl;

// Why a cell is mapped or left empty.
enum class CellStatus {
  Mapped,         // mapped into `photo`
  TouchesBorder,  // the cell reaches the mesh border with fewer than two paths in one photo around it
  NotDisc,        // the cell is not a disc (a handle, a pinch, or several boundary loops)
  NotTriangle,    // its boundary is not a loop of paths between features (a path ends inside it)
  FeatureInside,  // a feature vertex lies inside the cell (no longer a reason: such a feature constrains it)
  NoCommonPhoto,  // its paths have no photo in common
  Mirrored,       // in every common photo the texture polygon is mirrored or crosses itself
  Failed,         // the cell's map could not be built (see CellPlan::detail)
};
inline constexpr const char* kCellStatusNames[] = {
    "mapped",         "touches the mesh border", "not a disc", "not a triangle",
    "feature inside", "no common photo",         "mirrored",   "failed"};

// A cell maps when it is a disc bounded by paths between features (and, on an open mesh, runs of the mesh border)
// whose curves lie in one photo, forming there a polygon with the cell's orientation: the paper's base triangle
// "that corresponds to a texture triangle in one image", and more generally the polygon of a feature polygon's
// interior or of any closed loop of paths. Features inside it with a click in that photo constrain its map.
struct CellPlan {
  int cell = -1;  // Partition cell id
  CellStatus status = CellStatus::NotTriangle;
  int photo = TextureMap::kEmpty;  // the photo it maps into (Mapped)
  std::vector<int> faces;          // faces of Partition::mesh
  std::vector<int> corners;        // feature vertices on its boundary, counter-clockwise seen from outside (and the
                                   // ends of mesh border runs)
  std::vector<int> sides;          // per corner k: the Partition::paths index of the side from corner k to k + 1,
                                   // or -1 for a run along the mesh border (free in the photo)
  std::vector<int> inner;          // feature vertices inside it with a click in `photo`: fixed there (Mapped)
  std::string detail;              // for the user: what keeps the cell empty
  bool triangle() const {
    return sides.size() == 3 && inner.empty() && std::find(sides.begin(), sides.end(), -1) == sides.end();
  }
};

// Decides, per cell of the partition, whether and into which photo it maps.
std::vector<CellPlan> planCells(const Scene& scene, const Partition& partition);

// The fixed UVs (pixels) of a path's vertices in one photo: on the straight curve between the two
// clicks, at each vertex's arc length along the mesh path, measured along the curve's foreground
// only (a vertex never lands on a background gap the curve crosses). One UV per path vertex.
std::vector<Vec2> pathUVs(const Mesh& mesh, const MeshPath& path, const Curve& curve, const Photo& photo);

// Cell maps from earlier runs, by CellProblem::key. Entries not used for `keepRuns` runs are evicted.
// Thread-safe.
class CellCache {
 public:
  explicit CellCache(int keepRuns = 16) : keepRuns_(keepRuns) {}
  std::shared_ptr<const CellMap> find(const std::string& key);
  void insert(const std::string& key, std::shared_ptr<const CellMap> map);
  void endRun();  // one run finished: age the entries, drop the old ones
  size_t size() const;

 private:
  struct Entry {
    std::shared_ptr<const CellMap> map;
    long lastRun = 0;
  };
  mutable std::mutex mutex_;
  std::unordered_map<std::string, Entry> entries_;
  long run_ = 0;
  int keepRuns_;
};

struct CellMapping {
  TextureMap map;               // over Partition::mesh
  std::vector<CellPlan> cells;  // per partition cell
  FineMapStats stats;           // summed over mapped cells
  int cellsMapped = 0;          // cells whose map was computed in this run
  int cellsReused = 0;          // cells taken from the cache
  int cellsProjected = 0;       // cells into a photo mapped by projection: planned, not mapped (below)
};

// Plans the cells, builds each mapped cell's problem and maps it (in parallel), reusing `cache`
// entries when given. Scene::photoKeys identify the photos' contents; a photo without a key is never
// cached. `projected` (per photo; may be null): photos that fit a camera. The projection stage
// (projection.h) gives each face such a photo sees its projection and leaves the others empty, so it never
// reads the paper's UVs in those photos: their cells keep their plan and their faces the photo (with the
// empty map's UVs), and are not mapped. Throws montage::Cancelled when the job is cancelled.
CellMapping mapCells(const Scene& scene, const Partition& partition, const FineMapOptions& options,
                     const JobControl& job, CellCache* cache = nullptr, const std::vector<char>* projected = nullptr);

}  // namespace montage
