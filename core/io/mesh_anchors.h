// A project that survives a changed mesh (issue 38, item 3). A project names mesh vertices and faces by id; a mesh
// re-exported with another vertex order, or retopologised, gives the same ids to other places. When it is saved
// against its mesh, a project keeps the mesh's fingerprint and the position of every vertex and face it names
// (Project::anchors); loaded against a mesh whose fingerprint differs, each id moves to the new mesh's nearest
// vertex or face, and what moved is reported. A project without anchors cannot be checked and is taken as it is.
#pragma once

#include <string>
#include <vector>

#include "geometry/mesh.h"
#include "io/project.h"

namespace montage {

// 16 hexadecimal digits over the mesh's vertex positions (their bits, in order) and faces: any re-export
// that moves, adds or renumbers a vertex changes it.
std::string meshFingerprint(const Mesh& mesh);

// The anchors of `project` on `mesh`: its fingerprint, counts, and the position of every vertex (points,
// strokes, clone anchors, declined proposals) and the centroid of every face (clone regions, hole modes) the
// project names. Ids outside the mesh are left out (the project's validation names them).
// `fingerprint`: the mesh's, when the caller keeps it (else computed).
MeshAnchors anchorsOf(const Project& project, const Mesh& mesh, const std::string& fingerprint = "");

// Whether `project` was anchored to a mesh other than the one of `fingerprint` (false without anchors).
bool meshChanged(const Project& project, const std::string& fingerprint);

struct MeshCarry {
  bool changed = false;            // the project's anchors name another mesh: its ids were carried
  int vertexIds = 0, faceIds = 0;  // distinct ids carried
  int moved = 0;                   // of them, how many landed more than half a mean edge from where they were
  double farthest = 0;             // the farthest landing, in mean edge lengths of the new mesh
  std::vector<int> movedPoints;    // feature points (ids the user sees) whose vertex moved more than half an edge
  std::string message;             // one sentence for the user (a warning): what changed and what moved
};

// Carries `project` to `mesh` when its anchors name another mesh: every vertex id to the nearest vertex of `mesh`
// to its anchored position, every face id to the face whose centroid is nearest; consecutive repeats in strokes
// and repeated faces of a clone region are dropped; the anchors become `mesh`'s. Throws montage::Error naming the
// project file when the mesh changed and an id the project uses has no anchor (nothing can say where it went).
// `fingerprint`: the mesh's, when the caller keeps it (else computed, once).
MeshCarry carryToMesh(Project& project, const Mesh& mesh, const std::string& fingerprint = "");

}  // namespace montage
