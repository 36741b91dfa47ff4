// Paper section 3.2: the progressive mesh. Half-edge collapses (as in Schreiner et al. 2004) keep
// every feature vertex and preserve the topology of the mesh and of the path network, down to a
// base mesh whose edges are paths. Each removed vertex stores its generalized barycentric
// coordinates (Meyer et al. 2002) in its conformally flattened one-ring, and for a vertex on a path
// (or on the mesh border) separate coordinates in the left and right sub-polygons.
#pragma once

#include <array>
#include <vector>

#include "base/common.h"

namespace montage {

struct Partition;
class JobControl;

struct CollapseRecord {
  int removed = -1;  // the vertex taken out (v_i of the paper)
  int kept = -1;     // the vertex it collapsed into (v_j)
  // One-ring of `removed` just before the collapse, counter-clockwise around the outward normal.
  // Interior vertex: a closed ring. Border vertex: from one border neighbour to the other.
  std::vector<int> ring;
  std::vector<double> weights;  // barycentric coordinates of `removed` over `ring` (sum 1)
  // For a vertex on a path or on the border: ring indices of its two path (border) neighbours, and
  // coordinates over the left sub-polygon ring[a..b] and the right one ring[b..a] (cyclic, both
  // inclusive), in ring order. For a border vertex only `left` exists. -1 when not on a path.
  // On a path, a is the next vertex along MeshPath::vertices and b the previous one, so `left` lies
  // to the left of the path direction. On the border, a = 0 and b = ring.size() - 1.
  int pathA = -1, pathB = -1;
  std::vector<double> left, right;
  std::vector<int> removedFaces;                  // faces that disappear with the collapse
  std::vector<std::pair<int, int>> movedCorners;  // (face, corner) whose vertex went removed -> kept
};

// Which generalized barycentric coordinates were used (see polygonCoordinates).
enum class CoordinateKind { OnEdge, Meyer, MeanValue, MeanValue3d, Uniform, None };
inline constexpr int kCoordinateKinds = 5;  // all but None

// Generalized barycentric coordinates of p over a polygon (counter-clockwise, not closed): the
// edge's linear coordinates when p lies on an edge (also for a 2-point polygon); else Meyer et al.
// 2002 (Wachspress) when all are positive; else mean value coordinates (Floater 2003) when the
// polygon is star-shaped around p. Empty, with kind None, otherwise.
std::vector<double> polygonCoordinates(const std::vector<Vec2>& polygon, const Vec2& p, CoordinateKind* kind = nullptr);

struct SimplifyStats {
  std::array<int, kCoordinateKinds> weights{};  // records per CoordinateKind of `weights`
  std::array<int, kCoordinateKinds> sides{};    // left/right sub-polygons per CoordinateKind
  int baseExtraVertices = 0;                    // non-feature vertices left at the base
  double seconds = 0;                           // construction time
};

struct SimplifyOptions {
  double maxNormalFlipDeg = 90;  // refuse collapses that turn a face normal by more than this
};

// What a progressive mesh is built over: a manifold triangle mesh, the vertices that must stay
// (features), and paths (vertex sequences along edges) whose vertices only collapse along them and
// which never merge with each other or with the mesh border.
struct SimplifyInput {
  std::vector<Vec3> positions;            // #V, model units
  std::vector<std::array<int, 3>> faces;  // #F, indices into positions, counter-clockwise
  std::vector<char> pinned;               // #V: never removed (empty = none)
  std::vector<std::vector<int>> paths;    // vertex sequences; consecutive vertices share an edge
};

// The whole partition mesh with its features pinned and its paths (the paper's global progressive
// mesh; the pipeline maps cell by cell, see cells.h, and builds one progressive mesh per cell).
SimplifyInput simplifyInput(const Partition& partition);

// A progressive mesh over the faces of a SimplifyInput. Faces keep their ids at every level: a
// collapse retires some faces and re-points corners of others, a split undoes exactly that.
class ProgressiveMesh {
 public:
  // Collapses as far as the constraints allow. The result is at the base level.
  ProgressiveMesh(const SimplifyInput& input, const SimplifyOptions& options, const JobControl& job);
  ProgressiveMesh(const Partition& partition, const SimplifyOptions& options, const JobControl& job)
      : ProgressiveMesh(simplifyInput(partition), options, job) {}

  const std::vector<CollapseRecord>& records() const { return records_; }
  int level() const { return level_; }  // collapses currently applied; records().size() at the base
  bool atBase() const { return level_ == static_cast<int>(records_.size()); }
  bool atFull() const { return level_ == 0; }
  // Undoes the last applied collapse (one vertex split) and returns its record.
  const CollapseRecord& split();
  // Re-applies the next collapse and returns its record.
  const CollapseRecord& collapse();

  const std::array<int, 3>& face(int f) const { return faces_[f]; }  // current corner vertices
  bool faceAlive(int f) const { return faceAlive_[f]; }
  bool vertexAlive(int v) const { return vertexAlive_[v]; }
  int numFaces() const { return static_cast<int>(faces_.size()); }
  int numVertices() const { return static_cast<int>(vertexAlive_.size()); }
  const std::vector<int>& vertexFaces(int v) const { return vertexFaces_[v]; }  // alive incident faces
  int aliveFaces() const;
  int aliveVertices() const;
  // Whether the edge (a, b) lies on a path at the current level, and which (index into
  // SimplifyInput::paths); -1 when it does not.
  int pathOfEdge(int a, int b) const;
  const SimplifyStats& stats() const { return stats_; }

 private:
  void apply(const CollapseRecord& r);
  void undo(const CollapseRecord& r);
  std::vector<std::array<int, 3>> faces_;
  std::vector<char> faceAlive_, vertexAlive_;
  std::vector<std::vector<int>> vertexFaces_;
  std::vector<std::vector<std::pair<int, int>>> pathEdges_;  // per vertex: (neighbour, path) pairs
  std::vector<CollapseRecord> records_;
  SimplifyStats stats_;
  int level_ = 0;
};

}  // namespace montage
