// Paper section 3.1: partition of the mesh and the photos by path-curve pairs, after Kraevoy et al.
// 2003 (Matchmaker). Feature lines and polygons enter first; then shortest mesh paths between all
// pairs of feature vertices are tried in order of length, and a pair is accepted only when it is a
// valid path-curve pair in a photo where both ends have a position. Steiner vertices (edge splits)
// give paths room where the mesh is too coarse or two paths would share a vertex or an edge.
#pragma once

#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "base/common.h"
#include "geometry/mesh.h"

namespace montage {

struct Scene;
class JobControl;

// An image curve paired with a mesh path: the straight segment between the two feature positions
// in one photo (pixel coordinates, photo.h), oriented like its path (from -> to).
struct Curve {
  int photo = 0;
  Vec2 from = Vec2::Zero(), to = Vec2::Zero();
};

// A mesh path between two feature points, with the photos whose curve it pairs with. Its vertices
// are vertex ids of Partition::mesh; no two paths share a vertex other than their end points, and
// no two share an edge.
struct MeshPath {
  int fromPoint = 0, toPoint = 0;  // indices into Project::points
  std::vector<int> vertices;       // from the feature vertex of fromPoint to that of toPoint
  std::vector<Curve> curves;       // one per photo in which the pair was accepted (>= 1)
  bool fromChain = false;          // entered as a feature line/polygon segment
  double length = 0;               // model units
};

enum class RejectReason {
  NoCommonPhoto,        // the two points have no position in a common photo
  CurveCrossesCurve,    // the image segment crosses an accepted curve of that photo
  CurveOverBackground,  // mean distance of the curve to the foreground above the threshold
  CyclicOrder,          // order of pairs around an end point differs between mesh and photo
  NoPath,               // no mesh path avoids the accepted paths, even after Steiner splits
  Duplicate,            // the same pair was already accepted in that photo
};
inline constexpr const char* kRejectReasonNames[] = {
    "no common photo", "curve crosses a curve", "curve over background", "cyclic order", "no path", "duplicate"};

struct RejectedPair {
  int fromPoint = 0, toPoint = 0;  // indices into Project::points
  int photo = -1;                  // photo of the failed test, -1 for NoCommonPhoto / NoPath
  RejectReason reason = RejectReason::NoCommonPhoto;
  std::string detail;  // e.g. "mean distance 5.2 px > 2 px", "crosses curve 3-8"
};

struct PartitionOptions {
  double backgroundThresholdPx = 2.0;  // max mean distance (px) of a curve to the foreground (paper: 2)
  double curveSampleSpacingPx = 0.9;   // sample spacing along a curve for the background test (< 1 px)
  int maxSteinerPerPath = 64;          // edge splits one path may cause before it is given up
};

struct Partition {
  // The input mesh with the Steiner vertices appended (vertex ids of the input stay valid; faces
  // are renumbered). Per-corner UVs, materials and groups of the input are not carried over.
  Mesh mesh;
  std::vector<int> faceParent;     // #F of `mesh`: the input face each face lies in
  std::vector<int> featureVertex;  // per Project::points entry: its vertex id
  std::vector<int> featureId;      // per Project::points entry: its id as the user knows it (pointId)
  std::vector<MeshPath> paths;     // accepted pairs, in acceptance order
  std::vector<RejectedPair> rejected;
  std::vector<int> faceCell;  // #F: cell id, a face-connected region bounded by paths/the border
  int numCells = 0;
  int steinerVertices = 0;  // vertices added by edge splits
  int searches = 0;         // shortest-path searches the run needed
  int searchesReused = 0;   // of them, taken from a PartitionMemo
  bool replayed = false;    // the memo's trace answered the run (PartitionMemo)
};

// The shortest-path searches of earlier partition runs, keyed by the state of the mesh when they ran
// (a hash of the mesh, its feature vertices and every change the run made so far: accepted paths,
// Steiner splits) and by the query. A rerun that passes through the same states, such as a dragged
// point whose pairs stay valid, takes its paths from here instead of searching again. It also keeps the
// background test's mean distance of each photo segment tested (keyed by the photo's identity, the
// segment's ends and the sample spacing). Entries not used in the last run are dropped at the start of
// the next.
//
// It also keeps the last run's trace: its result and every decision that read a photo position (image
// tests, sectors and cyclic orders, with what each read). A rerun whose input differs from the last
// one's only in positions of points replays those decisions in the photos whose positions moved; when
// each comes out as before, the run would take the same course, and its result is the last one with
// those photos' curves and rejection details renewed. Not thread-safe.
class PartitionMemo {
 public:
  PartitionMemo();
  ~PartitionMemo();
  void beginRun();
  const std::vector<int>* find(const std::string& key);
  void store(const std::string& key, const std::vector<int>& path);
  const double* findBackground(uint64_t key);
  void storeBackground(uint64_t key, double meanDistance) { background_[key] = meanDistance; }
  size_t size() const { return current_.size() + previous_.size(); }
  struct Trace;
  std::unique_ptr<Trace> trace;  // the last run's (partition.cpp)
  int replays = 0;               // runs answered by replaying the trace (counted for tests and reports)

 private:
  std::unordered_map<std::string, std::vector<int>> current_, previous_;
  std::unordered_map<uint64_t, double> background_, previousBackground_;
};

// Runs the partition on a loaded scene (its project's points and chains, its photos' distance
// maps), reusing the searches in `memo` when given. Throws montage::Cancelled when the job is cancelled.
Partition partitionMesh(const Scene& scene, const PartitionOptions& options, const JobControl& job,
                        PartitionMemo* memo = nullptr);
// The same, shared: with a memo, the result its trace keeps (a replay copies the last one, mesh included,
// and renews the moved photos' curves and rejection details).
std::shared_ptr<const Partition> partitionShared(const Scene& scene, const PartitionOptions& options,
                                                 const JobControl& job, PartitionMemo* memo = nullptr);

// Shortest path along mesh edges between two vertices (Dijkstra with edge lengths), avoiding the
// vertices for which `blocked[v]` is true (the end points are always allowed). Returns the vertex
// sequence from `from` to `to`, or an empty vector when no path exists.
std::vector<int> shortestPath(const Mesh& mesh, int from, int to, const std::vector<char>& blocked = {});

}  // namespace montage
