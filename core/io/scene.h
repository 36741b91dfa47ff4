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
  Project project;  // what the stages read (see skippedPhotos)
  std::shared_ptr<const Mesh> mesh;
  MeshReport meshReport;
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
  Project requested;  // the project as given, when photos were skipped (otherwise empty: see document())
  const Project& document() const { return skippedPhotos.empty() ? project : requested; }
};

}  // namespace montage
