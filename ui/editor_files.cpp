// The editor's files: open, save, export, adding photos, autosave and recovery.
#include <imgui.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "base/fileio.h"
#include "base/output_folder.h"
#include "editor.h"
#include "gl.h"
#include "gl_util.h"
#include "image/photo.h"
#include "io/mesh_anchors.h"
#include "io/mesh_io.h"
#include "io/model.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

double now() {
  return glfwGetTime();
}

}  // namespace

std::string Editor::autosavePath() const {
  return autosavePathFor(doc_.project().file, doc_.project().mesh);
}

void Editor::autosaveTick() {
  if (autosaveJob_.valid() && autosaveJob_.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
    const std::string error = autosaveJob_.get();
    if (error.empty()) {
      autosavedRevision_ = autosaveJobRevision_;
    } else {
      reportError("autosave: " + error);
    }
  }
  if (autosaveJob_.valid() || doc_.project().mesh.empty()) return;
  const double t = now();
  if (!autosaveClock_.due(t, doc_.revision(), doc_.modified())) return;
  autosaveClock_.written(t, doc_.revision());
  autosaveJobRevision_ = doc_.revision();
  lastAutosavePath_ = autosavePath();
  // Written on a helper thread from the immutable snapshot: the fsync never stalls a frame.
  std::shared_ptr<const Project> snapshot = doc_.snapshot();
  if (input_.mesh && input_.path == snapshot->mesh) {  // the anchors a save writes, so a recovery keeps them too
    auto anchored = std::make_shared<Project>(*snapshot);
    anchored->anchors = anchorsOf(*anchored, *input_.mesh, input_.fingerprint);
    snapshot = std::move(anchored);
  }
  autosaveJob_ = std::async(std::launch::async, [snapshot, path = lastAutosavePath_]() {
    try {
      writeAutosave(*snapshot, path);
      return std::string();
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
  });
}

void Editor::checkRecovery() {
  recovery_.clear();
  const Project& p = doc_.project();
  if (!p.mesh.empty()) {
    if (auto c = findRecovery(p.file, p.mesh)) recovery_.push_back(*c);
  } else {
    recovery_ = listRecoveries();
  }
  recoveryPopup_ = !recovery_.empty();
}

// --- Files ----------------------------------------------------------------------------------------

void Editor::reportError(const std::string& message) {
  // Each error once: the same message again (also as the worker's "pipeline: ..." of a load error the UI
  // reported itself) moves the listed one to the newest place instead of repeating it.
  const auto bare = [](const std::string& m) { return m.rfind("pipeline: ", 0) == 0 ? m.substr(10) : m; };
  const auto same =
      std::find_if(errors_.begin(), errors_.end(), [&](const std::string& e) { return bare(e) == bare(message); });
  if (same != errors_.end()) errors_.erase(same);
  errors_.push_back(message);
  if (errors_.size() > 200) errors_.erase(errors_.begin());
  // No window opens over the view: the status bar shows the newest error (click: the list).
  lastProblem_ = message;
  errorTime_ = now();
  std::fprintf(stderr, "texturemontage: %s\n", message.c_str());
}

void Editor::reportOperationError(const std::string& operation, const std::string& message) {
  reportError(message);
  operationErrors_.emplace(operation, message);
}

void Editor::operationSucceeded(const std::string& operation) {
  const auto [from, to] = operationErrors_.equal_range(operation);
  for (auto it = from; it != to; ++it) {
    errors_.erase(std::remove(errors_.begin(), errors_.end(), it->second), errors_.end());
    if (lastProblem_ == it->second) lastProblem_.clear();
  }
  operationErrors_.erase(from, to);
}

void Editor::hint(const std::string& message) {
  hint_ = message;
  hintTime_ = now();
  lastProblem_ = message;
  setStatus(message);
}

void Editor::setStatus(const std::string& message) {
  status_ = message;
  statusTime_ = now();
}

bool Editor::openFile(const std::string& path) {
  try {
    const std::string abs = fs::absolute(path).lexically_normal().string();
    const std::string ext = lowerExtension(abs);
    Project project;
    std::vector<MissingFile> missing;
    if (ext == ".json") {
      // A project whose files moved still opens: what is missing is listed, with a relink offered.
      project = loadProjectAllowingMissing(abs, missing);
    } else {
      std::error_code ec;
      TM_CHECK(fs::is_regular_file(abs, ec), located(abs, "file not found"));
      TM_CHECK(isMeshExtension(ext), located(abs, "not a project (.json) or a mesh (" + meshExtensionList() + ")"));
      project.mesh = abs;  // a new, unsaved project on this mesh
    }
    pendingView_ = project.view;  // shown once the mesh is (Editor::view3d)
    doc_.reset(std::move(project));
    missing_ = std::move(missing);
    missingPopup_ = !missing_.empty();
    for (const MissingFile& m : missing_) reportError(located(abs, m.field + ": file '" + m.path + "' not found"));
    cutout_ = CutoutSession{};
    selectedVertex_ = selectedPoint_ = -1;
    chain_.clear();
    stroke_.clear();
    cancelInProgress();
    result_.reset();
    lastError_.clear();
    autosaveClock_.reset(now(), doc_.revision());
    // The recent list gets the file once its mesh has loaded (syncInputs): a file that fails to load
    // never enters it.
    if (doc_.project().mesh == input_.path && input_.mesh)
      recent_.add(abs);  // the same mesh, already loaded: syncInputs will not load it again
    else
      pendingRecent_ = abs;
    setStatus("opened " + abs);
    glfwSetWindowTitle(window_, ("TextureMontage - " + fs::path(abs).filename().string()).c_str());
    return true;
  } catch (const Error& e) {
    reportError(e.what());
    return false;
  }
}

void Editor::requestOpen() {
  guardUnsaved([this] {
    std::vector<std::string> projectAndMesh = meshExtensions();
    projectAndMesh.insert(projectAndMesh.begin(), ".json");
    dialogs_.request(DialogKind::OpenFile, "Open a project or a mesh",
                     {{"Projects and meshes", patternsOf(projectAndMesh)},
                      {"Projects", {"*.json"}},
                      {"Meshes", patternsOf(meshExtensions())},
                      {"All files", {"*"}}},
                     "open", projectFolder());
  });
}

bool Editor::saveTo(const std::string& path) {
  std::string target = fs::absolute(path).lexically_normal().string();
  if (fs::path(target).extension().empty()) target += ".json";
  const std::string oldAutosave = autosavePath();
  try {
    // Masks cut out before the first save move beside the project (editor_photos.cpp).
    const std::vector<std::string> movedMasks = moveUnsavedMasks(target);
    Project copy = doc_.project();
    // The 3D view goes with the project, so that opening it again shows what the user last looked at.
    if (input_.mesh) {
      copy.view = ViewState{true, camera_.target, camera_.distance, camera_.yawDeg, camera_.pitchDeg, camera_.fovYDeg};
      copy.anchors = anchorsOf(copy, *input_.mesh, input_.fingerprint);  // where the ids lie (io/mesh_anchors.h)
    }
    saveProject(copy, target);  // atomic: temporary file, fsync, rename
    for (const std::string& mask : movedMasks) {
      std::error_code ec;
      fs::remove(mask, ec);  // best effort: the project names the copy now
    }
    // An autosave still being written would land after this save and look like newer work.
    if (autosaveJob_.valid()) autosaveJob_.wait();
    doc_.markSaved(copy.file);
    removeAutosave(oldAutosave);
    removeAutosave(autosavePath());
    autosaveClock_.reset(now(), doc_.revision());
    recent_.add(copy.file);
    operationSucceeded("save");
    setStatus("saved " + copy.file);
    glfwSetWindowTitle(window_, ("TextureMontage - " + fs::path(copy.file).filename().string()).c_str());
    return true;
  } catch (const Error& e) {
    reportOperationError("save", e.what());
    return false;
  }
}

void Editor::save() {
  if (doc_.project().file.empty()) {
    requestSaveAs();
  } else {
    saveTo(doc_.project().file);
  }
}

std::string Editor::projectFolder() const {
  const Project& p = doc_.project();
  if (!p.file.empty()) return fs::path(p.file).parent_path().string();
  if (!p.mesh.empty()) return fs::path(p.mesh).parent_path().string();
  return "";  // the dialog's last folder
}

void Editor::requestSaveAs() {
  dialogs_.request(DialogKind::SaveFile, "Save the project as", {{"Projects", {"*.json"}}}, "save_as", projectFolder());
}

void Editor::requestExport() {
  if (!resultUsable()) return;
  dialogs_.request(DialogKind::SaveFile, "Export the textured model",
                   {{"glTF binary", {"*.glb"}}, {"OBJ + MTL + PNG", {"*.obj"}}}, "export", projectFolder());
}

void Editor::requestAddPhotos(bool folder) {
  const std::vector<FileFilter> images = {{"Images", {"*.png", "*.jpg", "*.jpeg", "*.tif", "*.tiff", "*.bmp"}}};
  if (folder)
    dialogs_.request(DialogKind::OpenFolder, "Add every photo of a folder", images, "add_photos", projectFolder());
  else
    dialogs_.request(DialogKind::OpenFiles, "Add photos (select several)", images, "add_photos", projectFolder());
}

bool Editor::exportTo(const std::string& path) {
  try {
    TM_CHECK(resultUsable(), "export: there is no result yet (the pipeline has not finished on this document)");
    // Only a final bake is exported; a result of an earlier state is exported, and the status says so.
    TM_CHECK(result_->model,
             "export: the final bake of this document is still running (the view shows its preview): "
             "export again when the caption says \"result - up to date\"");
    const bool stale = !resultCurrent();
    const std::string abs = fs::absolute(path).lexically_normal().string();
    const std::string ext = lowerExtension(abs);
    std::string how;  // what became of the user's own glTF, when the mesh is one
    if (ext == ".glb") {
      const nlohmann::json glb = exportResultGlb(*result_, abs);
      if (glb.value("written_into_source", false))
        how = " (into a copy of " + fs::path(result_->scene->project.mesh).filename().string() +
              ": its skins, morph targets, normals and UV sets kept)";
      else if (glb.contains("why"))
        how = " as a new GLB: the mesh's own file could not take the texture (" + glb["why"].get<std::string>() + ")";
    } else if (ext == ".obj") {
      // The OBJ, its MTL and textures are written beside the user's other files: staged in a hidden
      // folder, then renamed in place textures first and the OBJ last, so a kill never leaves an OBJ
      // naming a missing file (base/output_folder.h).
      const std::string stem = fs::path(abs).stem().string();
      publishFiles(fs::path(abs).parent_path().string(), stem + ".obj", {stem + ".mtl", stem + ".obj"},
                   [&](const std::string& staging) {
                     exportObj(result_->exported ? *result_->exported : *result_->model, staging, stem);
                   });
    } else {
      throw Error(located(abs,
                          "export: the file type comes from the name's ending: choose a name ending in .glb "
                          "(glTF binary) or .obj (OBJ + MTL + PNG)"));
    }
    operationSucceeded("export");
    setStatus(stale ? "exported " + abs + how + " - the result of an earlier state: the document changed since"
                    : "exported " + abs + how);
    return true;
  } catch (const Error& e) {
    reportOperationError("export", e.what());
    return false;
  }
}

void Editor::addPhotosFrom(const std::string& path) {
  addPhotoFiles({path});
}

int Editor::addPhotoFiles(const std::vector<std::string>& paths) {
  std::vector<PhotoRef> refs;
  for (const std::string& path : paths) {
    std::error_code ec;
    const std::string abs = fs::absolute(path).lexically_normal().string();
    if (fs::is_directory(abs, ec)) {
      std::vector<std::string> files;
      for (fs::directory_iterator it(abs, ec), end; !ec && it != end; it.increment(ec))
        if (it->is_regular_file() && isImageExtension(lowerExtension(it->path().string())))
          files.push_back(it->path().string());
      std::sort(files.begin(), files.end());
      for (const auto& f : files) refs.push_back(PhotoRef{f, ""});
      if (files.empty()) reportError(located(abs, "no images (.png .jpg .jpeg .tif .tiff .bmp) in this folder"));
    } else if (fs::is_regular_file(abs, ec) && isImageExtension(lowerExtension(abs))) {
      refs.push_back(PhotoRef{abs, ""});
    } else {
      reportError(located(abs, "not an image file or a folder of images"));
    }
  }
  if (refs.empty()) return 0;
  if (doc_.project().mesh.empty()) {
    reportError("add photos: open a mesh or a project first (the photos are added to it)");
    return 0;
  }
  if (!edit([&] { activePhoto_ = doc_.addPhotos(refs); })) return 0;
  setStatus("added " + std::to_string(refs.size()) + " photo(s)");
  return static_cast<int>(refs.size());
}

void Editor::handleDrop(const std::vector<std::string>& paths) {
  // A project or a mesh among the files opens first (asking about unsaved changes); the images then
  // join the opened document.
  std::string open;
  std::vector<std::string> images;
  for (const std::string& p : paths) {
    const std::string ext = lowerExtension(p);
    const bool openable = ext == ".json" || isMeshExtension(ext);
    if (openable && open.empty())
      open = p;
    else if (openable)
      reportError(located(p, "dropped with another project or mesh: only one opens at a time"));
    else
      images.push_back(p);
  }
  if (open.empty()) {
    addPhotoFiles(images);
    return;
  }
  guardUnsaved([this, open, images] {
    if (openFile(open)) {
      checkRecovery();
      if (!images.empty()) addPhotoFiles(images);
    }
  });
}

bool Editor::relinkPhoto(int photo, const std::string& path) {
  const std::string abs = fs::absolute(path).lexically_normal().string();
  try {
    // The new file must be an image; a photo with points must keep its size (the points are in its pixels).
    const cv::Size size = readImageSize(abs);
    const PhotoSlot* slot = photo < static_cast<int>(photos_.size()) ? &photos_[photo] : nullptr;
    if (slot && slot->photo)
      TM_CHECK(slot->photo->width == size.width && slot->photo->height == size.height,
               located(abs, "is " + std::to_string(size.width) + "x" + std::to_string(size.height) + " but photo " +
                                std::to_string(photo) + " was " + std::to_string(slot->photo->width) + "x" +
                                std::to_string(slot->photo->height) + ": relink to the same photo, moved or renamed"));
  } catch (const Error& e) {
    reportError(e.what());
    return false;
  }
  if (!edit([&] { doc_.relinkPhoto(photo, abs); })) return false;
  missing_.erase(
      std::remove_if(missing_.begin(), missing_.end(),
                     [&](const MissingFile& m) { return m.field == "photos[" + std::to_string(photo) + "].path"; }),
      missing_.end());
  setStatus("photo " + std::to_string(photo) + " relinked to " + abs);
  return true;
}

bool Editor::relinkMesh(const std::string& path) {
  const std::string abs = fs::absolute(path).lexically_normal().string();
  std::error_code ec;
  if (!fs::is_regular_file(abs, ec)) {
    reportError(located(abs, "file not found"));
    return false;
  }
  if (!edit([&] { doc_.relinkMesh(abs); })) return false;
  missing_.erase(
      std::remove_if(missing_.begin(), missing_.end(), [](const MissingFile& m) { return m.field == "mesh"; }),
      missing_.end());
  setStatus("mesh relinked to " + abs);
  return true;
}

void Editor::guardUnsaved(std::function<void()> then) {
  if (!doc_.modified()) {
    then();
    return;
  }
  afterUnsaved_ = std::move(then);
  unsavedPopup_ = true;
}

void Editor::requestClose() {
  guardUnsaved([this] { quit_ = true; });
}

// --- Edits ----------------------------------------------------------------------------------------

}  // namespace montage
