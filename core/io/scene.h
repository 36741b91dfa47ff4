// The loaded inputs of a project, as every stage reads them.
#pragma once

#include <map>
#include <memory>
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
  // Photos that could not be loaded (missing or unreadable file or mask): index -> reason. Such a photo
  // is a placeholder in `photos` (1 x 1, all background) and `project` leaves out its positions, chains
  // and clones (withoutPhotoReferences), so it textures nothing while the other photos still do.
  std::map<int, std::string> skippedPhotos;
  Project requested;  // the project as given, when photos were skipped (otherwise empty: see document())
  const Project& document() const { return skippedPhotos.empty() ? project : requested; }
};

}  // namespace montage
