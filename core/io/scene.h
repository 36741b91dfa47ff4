// The loaded inputs of a project, as every stage reads them.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "geometry/mesh.h"
#include "image/photo.h"
#include "io/project.h"

namespace montage {

// The loaded inputs of a project: immutable once built, shared between runs and threads.
struct Scene {
  Project project;  // what the stages read (see skippedPhotos and `loaded`): mesh ids are `mesh`'s
  // The mesh the stages work on: the mesh as loaded, or (options.weldIdenticalPositions) that mesh with its
  // vertices at identical positions merged, a surface split at UV seams made whole (WeldedMesh).
  std::shared_ptr<const Mesh> mesh;
  // The mesh as in the file, whose vertex and face ids the project's document names and whose vertices the
  // export keeps. The same object as `mesh` when nothing was welded; else `mesh`'s vertexOrigin and faceOrigin
  // index it, and `vertexOf` / `faceOf` go the other way (WeldedMesh).
  std::shared_ptr<const Mesh> loaded;
  std::shared_ptr<const std::vector<int>> vertexOf, faceOf;  // null when nothing was welded
  MeshReport meshReport;                                     // of `mesh`
  bool welded() const { return mesh != loaded; }
  // A vertex id of `mesh` (or of a refinement whose first vertices are mesh's) as the document names it: the
  // loaded vertex at its position; -1 for a vertex the refinement added.
  int documentVertex(int v) const {
    if (v < 0 || v >= mesh->numVertices()) return -1;
    return welded() ? mesh->vertexOrigin[v] : v;
  }
  // The other way: the vertex of `mesh` a document's vertex id names (-1 for one outside the loaded mesh or used
  // by no face).
  int meshVertex(int v) const {
    if (v < 0 || v >= loaded->numVertices()) return -1;
    return welded() ? (*vertexOf)[v] : v;
  }
  std::vector<std::shared_ptr<const Photo>> photos;
  // Per photo: what identifies its content (file, size, time, mask), so that results computed from it
  // can be reused; empty when unknown (such results are never cached).
  std::vector<std::string> photoKeys;
  // What the validation of the project against its mesh and photos found worth a word (points on a
  // photo's background, crossing feature lines, self-intersecting polygons), each naming the element;
  // `montage info` and `run` show the same list.
  std::vector<std::string> warnings;
  // Photos that could not be loaded (missing or unreadable file or mask): index -> reason. Such a photo
  // is a placeholder in `photos` (1 x 1, all background) and `project` leaves out its positions, chains
  // and clones (withoutPhotoReferences), so it textures nothing while the other photos still do.
  std::map<int, std::string> skippedPhotos;
  Project requested;  // the project as given, when photos were skipped or ids welded (else empty: see document())
  const Project& document() const { return skippedPhotos.empty() && !welded() ? project : requested; }
};

}  // namespace montage
