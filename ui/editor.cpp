// The editor's lifecycle, frame loop, menus, side panels, files, autosave and worker hand-off.
// The 3D view is in editor_view.cpp, the image panes in editor_panes.cpp, scripts and benchmarks in
// editor_script.cpp.
#include "editor.h"

#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "fileio.h"
#include "gl.h"
#include "gl_util.h"
#include "model.h"
#include "overlays.h"
#include "photo.h"

namespace fs = std::filesystem;

namespace montage {

const std::vector<Shortcut>& editorShortcuts() {
  static const std::vector<Shortcut> shortcuts = {
      {"Ctrl+Z", "undo"},
      {"Ctrl+Shift+Z, Ctrl+Y", "redo"},
      {"Ctrl+O", "open a project or a mesh"},
      {"Ctrl+S", "save the project (atomic)"},
      {"Ctrl+Shift+S", "save as"},
      {"Ctrl+E", "export the current result (.glb or .obj)"},
      {"Ctrl+Q", "quit (asks when there are unsaved changes)"},
      {"P / L / G / S / C", "tool: point, line, polygon, stroke, clone"},
      {"Delete, Backspace", "remove the selected point from the active photo"},
      {"Enter", "finish the line or polygon (or clone polygon) being drawn"},
      {"Escape", "cancel what is being drawn, then clear the selection"},
      {"T", "3D view: textured / shaded"},
      {"W", "3D view: wireframe on / off"},
      {"F", "3D view: frame the whole mesh"},
      {"1 ... 9", "show photo 1 ... 9 in the image pane"},
      {"F1", "this help"},
      {"3D view: left drag", "orbit (stroke tool: draw a stroke; clone tool: paint the target, Ctrl erases)"},
      {"3D view: right or middle drag, Shift+left drag", "pan"},
      {"3D view: wheel", "zoom"},
      {"3D view: left click", "pick the nearest vertex of the triangle under the cursor"},
      {"Photo: left click", "point tool: attach the selected vertex here (or select a point)"},
      {"Photo: left drag on a point", "move it (one undo step)"},
      {"Photo: wheel / right or middle drag", "zoom at the cursor / pan"},
      {"Photo: click the first point", "close the polygon being drawn"},
  };
  return shortcuts;
}

namespace {

double now() {
  return glfwGetTime();
}

std::string timeText(std::time_t t) {
  char buffer[64];
  std::strftime(buffer, sizeof(buffer), "%Y-%m-%d %H:%M:%S", std::localtime(&t));
  return buffer;
}

const char* const kToolKeys[] = {"P", "L", "G", "S", "C"};
const ImVec4 kErrorColor(1.0f, 0.45f, 0.4f, 1.0f);
const ImVec4 kDimColor(0.6f, 0.6f, 0.6f, 1.0f);

}  // namespace

Editor::Editor(EditorOptions options) : options_(std::move(options)) {
  autosaveClock_.setInterval(options_.autosaveSeconds);
  initWindow();
  worker_ = std::make_unique<PipelineWorker>();
  if (!options_.script.empty()) {
    script_ = loadScript(options_.script);
    scripted_ = true;
  }
  if (!options_.screenshot.empty()) {
    // --screenshot is a built-in script: wait for the result, render N frames, save, quit.
    std::string text;
    if (options_.waitWorker) text += "wait_worker 600\n";
    text += "wait_frames " + std::to_string(std::max(1, options_.frames)) + "\n";
    text += "screenshot \"" + options_.screenshot + "\"\nquit\n";
    auto extra = parseScript(text, "--screenshot");
    script_.insert(script_.end(), extra.begin(), extra.end());
    scripted_ = true;
  }
  if (!options_.benchOrbit.empty()) {
    benchOrbit_ = true;
    options_.file = options_.benchOrbit;
  }
  if (options_.benchWorker) benchOrbit_ = true;
  if (scripted_ || benchOrbit_) dialogs_.disableZenity();  // never block a script on a desktop dialog
  if (!options_.file.empty()) openFile(options_.file);
  if (!benchOrbit_) checkRecovery();
}

Editor::~Editor() {
  worker_.reset();  // joins the pipeline thread before anything it could report to goes away
  if (autosaveJob_.valid()) autosaveJob_.wait();
  shutdownWindow();
}

void Editor::initWindow() {
  glfwSetErrorCallback([](int code, const char* text) { std::fprintf(stderr, "glfw error %d: %s\n", code, text); });
  TM_CHECK(glfwInit(), "cannot open a window: GLFW failed to initialise (is there a display? DISPLAY=" +
                           std::string(std::getenv("DISPLAY") ? std::getenv("DISPLAY") : "") + ")");
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  window_ = glfwCreateWindow(options_.width, options_.height, "TextureMontage", nullptr, nullptr);
  if (!window_) {
    glfwTerminate();
    throw Error("cannot open a window: no OpenGL 3.3 core context (a display with OpenGL 3.3 is needed)");
  }
  glfwMakeContextCurrent(window_);
  const bool interactive =
      options_.script.empty() && options_.screenshot.empty() && options_.benchOrbit.empty() && !options_.benchWorker;
  glfwSwapInterval(interactive && options_.vsync ? 1 : 0);

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGuiIO& io = ImGui::GetIO();
  io.IniFilename = nullptr;  // the layout is computed; nothing to store in the working folder
  ImGui::StyleColorsDark();
  ImGuiStyle& style = ImGui::GetStyle();
  style.WindowRounding = 0;
  style.FrameRounding = 3;
  style.WindowBorderSize = 1;
  style.ItemSpacing = ImVec2(7, 5);
  const char* font = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
  std::error_code ec;
  if (fs::exists(font, ec)) io.Fonts->AddFontFromFileTTF(font, 15.0f);
  ImGui_ImplGlfw_InitForOpenGL(window_, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");
  imguiReady_ = true;

  meshShader_ = std::make_unique<ShaderProgram>("mesh.vert", "mesh.frag");
  lineShader_ = std::make_unique<ShaderProgram>("lines.vert", "lines.frag");
  textureShader_ = std::make_unique<ShaderProgram>("texture.vert", "texture.frag");
  viewFbo_ = std::make_unique<Framebuffer>();
  meshVbo_ = std::make_unique<VertexBuffer>();
  lineVbo_ = std::make_unique<VertexBuffer>();
  pointVbo_ = std::make_unique<VertexBuffer>();
  selectionVbo_ = std::make_unique<VertexBuffer>();
  cloneVbo_ = std::make_unique<VertexBuffer>();
}

void Editor::shutdownWindow() {
  if (!window_) return;
  glfwMakeContextCurrent(window_);
  // GL objects first, while the context exists.
  for (auto& slot : photos_) {
    slot.texture.reset();
    slot.mask.reset();
  }
  textureCache_.clear();
  meshShader_.reset();
  lineShader_.reset();
  textureShader_.reset();
  viewFbo_.reset();
  meshVbo_.reset();
  lineVbo_.reset();
  pointVbo_.reset();
  selectionVbo_.reset();
  cloneVbo_.reset();
  if (imguiReady_) {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    imguiReady_ = false;
  }
  glfwDestroyWindow(window_);
  window_ = nullptr;
  glfwTerminate();
}

int Editor::run() {
  while (!quit_) frame();
  // A clean exit: whatever the user chose about unsaved changes has been done; the side file would
  // otherwise be offered as a crash recovery next time.
  if (autosaveJob_.valid()) autosaveJob_.wait();
  if (exitStatus_ == 0 && !lastAutosavePath_.empty()) removeAutosave(lastAutosavePath_);
  if (exitStatus_ == 0) removeAutosave(autosavePath());
  if (benchOrbit_) benchReport();
  return exitStatus_;
}

void Editor::frame() {
  const double start = now();
  const bool busy = worker_->status().busy;
  if (scripted_ || benchOrbit_ || !inputQueue_.empty()) {
    glfwPollEvents();
  } else {
    // Redraw on input; otherwise a few times a second (worker progress, autosave clock).
    glfwWaitEventsTimeout(busy || dialogs_.active() ? 0.05 : 0.25);
  }
  if (glfwWindowShouldClose(window_)) {
    glfwSetWindowShouldClose(window_, GLFW_FALSE);
    requestClose();
  }
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGuiIO& io = ImGui::GetIO();
  if (scripted_) {
    try {
      scriptStep();
    } catch (const Error& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      exitStatus_ = 1;
      quit_ = true;
    }
    applySyntheticInput(io);
  }
  if (benchOrbit_) benchOrbitStep();
  ImGui::NewFrame();

  syncInputs();
  buildUi();
  validateSelection();
  pollWorker();
  // Each document change goes to the worker as an immutable snapshot; a drag (open group) sends
  // its final state only, so the pipeline is not restarted at every mouse move.
  if (!doc_.project().mesh.empty() && doc_.revision() != submittedRevision_ && !doc_.inGroup()) {
    submittedGeneration_ = worker_->submit(doc_.snapshot());
    submittedRevision_ = doc_.revision();
    generationRevision_[submittedGeneration_] = submittedRevision_;
  }
  autosaveTick();
  renderScene();

  ImGui::Render();
  int fbw = 0, fbh = 0;
  glfwGetFramebufferSize(window_, &fbw, &fbh);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glViewport(0, 0, fbw, fbh);
  glClearColor(0.1f, 0.1f, 0.11f, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  if (!pendingScreenshot_.empty()) {
    try {
      takeScreenshot(pendingScreenshot_);
    } catch (const Error& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      exitStatus_ = 1;
      quit_ = true;
    }
    pendingScreenshot_.clear();
  }
  glfwSwapBuffers(window_);
  if (benchOrbit_) glFinish();  // frame times count the whole frame, not just its submission
  ++frameNumber_;
  lastFrameSeconds_ = now() - start;
  frameMs_ = 0.9 * frameMs_ + 0.1 * lastFrameSeconds_ * 1000;
}

// --- Loading what the document names -------------------------------------------------------------

void Editor::syncInputs() {
  const Project& p = doc_.project();
  if (p.mesh != input_.path) {
    input_ = InputMesh{};
    input_.path = p.mesh;
    result_.reset();
    meshDirty_ = overlayDirty_ = linesDirty_ = true;
    if (!p.mesh.empty()) {
      try {
        LoadedMesh loaded = loadMesh(p.mesh);
        input_.mesh = requireUsable(std::move(loaded));
        input_.bvh = std::make_unique<TriangleBvh>(*input_.mesh);
        input_.mesh->bounds(input_.lo, input_.hi);
        input_.faceCentroids.resize(input_.mesh->numFaces());
        for (int f = 0; f < input_.mesh->numFaces(); ++f) {
          const auto q = input_.mesh->facePositions(f);
          input_.faceCentroids[f] = (q[0] + q[1] + q[2]) / 3.0;
        }
        camera_.frame(input_.lo, input_.hi);
      } catch (const Error& e) {
        input_.error = e.what();
        reportError(e.what());
      }
    }
  }
  photos_.resize(p.photos.size());
  for (size_t i = 0; i < p.photos.size(); ++i) {
    PhotoSlot& slot = photos_[i];
    const std::string key = p.photos[i].path + "|" + p.photos[i].mask;
    if (slot.key == key) continue;
    slot.key = key;
    slot.photo.reset();
    slot.error.clear();
    slot.tabView.fitted = slot.gridView.fitted = false;
    try {
      // The core's loader, so the foreground (alpha or mask) follows the pipeline's rule exactly.
      auto photo = std::make_shared<Photo>(loadPhoto(p.photos[i].path, p.photos[i].mask));
      cv::Mat rgb8, rgba;
      photo->rgb.convertTo(rgb8, CV_8UC3, 255.0);
      cv::cvtColor(rgb8, rgba, cv::COLOR_RGB2RGBA);
      if (!slot.texture) slot.texture = std::make_unique<Texture>();
      slot.texture->upload(rgba);
      // Background overlay: a blue tint where the photo is background, clear on the foreground.
      cv::Mat mask(photo->height, photo->width, CV_8UC4, cv::Scalar(0, 0, 0, 0));
      for (int y = 0; y < photo->height; ++y)
        for (int x = 0; x < photo->width; ++x)
          if (photo->alpha.at<float>(y, x) <= 0) mask.at<cv::Vec4b>(y, x) = cv::Vec4b(40, 70, 220, 80);
      if (!slot.mask) slot.mask = std::make_unique<Texture>();
      slot.mask->upload(mask);
      slot.photo = photo;
    } catch (const Error& e) {
      slot.error = e.what();
      reportError(e.what());
    }
  }
}

void Editor::validateSelection() {
  const Project& p = doc_.project();
  if (selectedPoint_ >= static_cast<int>(p.points.size())) selectedPoint_ = -1;
  if (!input_.mesh || selectedVertex_ >= input_.mesh->numVertices()) selectedVertex_ = -1;
  if (activePhoto_ >= static_cast<int>(p.photos.size())) activePhoto_ = std::max(0, int(p.photos.size()) - 1);
  // A chain in progress refers to point indices: an undo or a deletion may have renumbered them.
  for (int pt : chain_) {
    const bool ok = pt < static_cast<int>(p.points.size()) && doc_.pointAt(p.points[pt].vertex, chainPhoto_) == pt;
    if (!ok) {
      chain_.clear();
      chainPhoto_ = -1;
      break;
    }
  }
}

// --- Worker ---------------------------------------------------------------------------------------

bool Editor::resultUsable() const {
  return result_ && result_->model && result_->scene && result_->scene->project.mesh == doc_.project().mesh;
}

bool Editor::resultCurrent() const {
  return resultUsable() && result_->scene->project.sameDocument(doc_.project());
}

void Editor::pollWorker() {
  std::optional<WorkerOutcome> outcome = worker_->take();
  if (!outcome) return;
  outcomeGenerations_.push_back(outcome->generation);
  if (outcome->result) {
    // A result for a mesh the document no longer names (a file opened meanwhile) is dropped.
    if (!outcome->result->scene || outcome->result->scene->project.mesh != doc_.project().mesh) return;
    result_ = outcome->result;
    resultGeneration_ = outcome->generation;
    lastError_.clear();
    meshDirty_ = overlayDirty_ = linesDirty_ = true;
    stretch_.clear();
    if (result_->mapping) stretch_ = normalizedStretch(result_->mapping->partition.mesh, result_->mapping->map);
  } else {
    lastError_ = outcome->error;
    lastErrorGeneration_ = outcome->generation;
    reportError("pipeline: " + outcome->error);
  }
}

// --- Autosave and recovery ------------------------------------------------------------------------

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
  autosaveJob_ = std::async(std::launch::async, [snapshot = doc_.snapshot(), path = lastAutosavePath_]() {
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
  errors_.push_back(message);
  if (errors_.size() > 200) errors_.erase(errors_.begin());
  showErrors_ = true;
  std::fprintf(stderr, "texturemontage: %s\n", message.c_str());
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
    if (ext == ".json") {
      project = loadProject(abs);
    } else {
      std::error_code ec;
      TM_CHECK(fs::is_regular_file(abs, ec), located(abs, "file not found"));
      TM_CHECK(ext == ".obj" || ext == ".ply" || ext == ".off" || ext == ".stl",
               located(abs, "not a project (.json) or a mesh (.obj .ply .off .stl)"));
      project.mesh = abs;  // a new, unsaved project on this mesh
    }
    doc_.reset(std::move(project));
    selectedVertex_ = selectedPoint_ = -1;
    chain_.clear();
    stroke_.clear();
    cancelInProgress();
    result_.reset();
    lastError_.clear();
    autosaveClock_.reset(now(), doc_.revision());
    recent_.add(abs);
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
    dialogs_.request(DialogKind::OpenFile, "Open a project or a mesh",
                     {{"Projects and meshes", {"*.json", "*.obj", "*.ply", "*.off", "*.stl"}}, {"All files", {"*"}}},
                     "open", doc_.project().file.empty() ? "" : fs::path(doc_.project().file).parent_path().string());
  });
}

bool Editor::saveTo(const std::string& path) {
  std::string target = fs::absolute(path).lexically_normal().string();
  if (fs::path(target).extension().empty()) target += ".json";
  const std::string oldAutosave = autosavePath();
  try {
    Project copy = doc_.project();
    saveProject(copy, target);  // atomic: temporary file, fsync, rename
    // An autosave still being written would land after this save and look like newer work.
    if (autosaveJob_.valid()) autosaveJob_.wait();
    doc_.markSaved(copy.file);
    removeAutosave(oldAutosave);
    removeAutosave(autosavePath());
    autosaveClock_.reset(now(), doc_.revision());
    recent_.add(copy.file);
    setStatus("saved " + copy.file);
    glfwSetWindowTitle(window_, ("TextureMontage - " + fs::path(copy.file).filename().string()).c_str());
    return true;
  } catch (const Error& e) {
    reportError(e.what());
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

void Editor::requestSaveAs() {
  const std::string dir = doc_.project().file.empty() ? fs::path(doc_.project().mesh).parent_path().string()
                                                      : fs::path(doc_.project().file).parent_path().string();
  dialogs_.request(DialogKind::SaveFile, "Save the project as", {{"Projects", {"*.json"}}}, "save_as", dir);
}

bool Editor::exportTo(const std::string& path) {
  try {
    TM_CHECK(resultUsable(), "export: there is no result yet (the pipeline has not finished on this document)");
    const std::string abs = fs::absolute(path).lexically_normal().string();
    const std::string ext = lowerExtension(abs);
    if (ext == ".glb") {
      exportGlb(*result_->model, abs);
    } else if (ext == ".obj") {
      exportObj(*result_->model, fs::path(abs).parent_path().string(), fs::path(abs).stem().string());
    } else {
      throw Error(located(abs, "export: choose a file name ending in .glb or .obj"));
    }
    setStatus("exported " + abs);
    return true;
  } catch (const Error& e) {
    reportError(e.what());
    return false;
  }
}

void Editor::addPhotosFrom(const std::string& path) {
  std::vector<PhotoRef> refs;
  std::error_code ec;
  const std::string abs = fs::absolute(path).lexically_normal().string();
  if (fs::is_directory(abs, ec)) {
    std::vector<std::string> files;
    for (fs::directory_iterator it(abs, ec), end; !ec && it != end; it.increment(ec))
      if (it->is_regular_file() && isImageExtension(lowerExtension(it->path().string())))
        files.push_back(it->path().string());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) refs.push_back(PhotoRef{f, ""});
    if (refs.empty()) {
      reportError(located(abs, "no images (.png .jpg .jpeg .tif .tiff .bmp) in this folder"));
      return;
    }
  } else if (fs::is_regular_file(abs, ec) && isImageExtension(lowerExtension(abs))) {
    refs.push_back(PhotoRef{abs, ""});
  } else {
    reportError(located(abs, "not an image file or a folder of images"));
    return;
  }
  if (edit([&] { activePhoto_ = doc_.addPhotos(refs); }))
    setStatus("added " + std::to_string(refs.size()) + " photo(s)");
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

void Editor::undo() {
  if (dragging_) return;  // the drag's group closes on release
  cancelInProgress();
  if (doc_.canUndo()) {
    setStatus("undo: " + doc_.history()[doc_.position() - 1].label);
    doc_.undo();
  }
}

void Editor::redo() {
  if (dragging_) return;
  cancelInProgress();
  if (doc_.canRedo()) {
    setStatus("redo: " + doc_.history()[doc_.position()].label);
    doc_.redo();
  }
}

void Editor::selectVertex(int vertex) {
  selectedVertex_ = vertex;
  if (vertex < 0) {
    selectedPoint_ = -1;
    return;
  }
  const int inActive = doc_.pointAt(vertex, activePhoto_);
  selectedPoint_ = inActive >= 0 ? inActive : doc_.pointOfVertex(vertex);
}

void Editor::deleteSelection() {
  if (selectedPoint_ < 0) {
    setStatus("nothing selected to delete");
    return;
  }
  const auto& at = doc_.project().points[selectedPoint_].at;
  const bool inActive = std::any_of(at.begin(), at.end(), [&](const PhotoPoint& a) { return a.photo == activePhoto_; });
  if (edit([&] {
        if (inActive) {
          doc_.removePosition(selectedPoint_, activePhoto_);
        } else {
          doc_.removePoint(selectedPoint_);
        }
      })) {
    selectedPoint_ = -1;
  }
}

void Editor::finishChain() {
  if (tool_ == Tool::Clone && !clonePolygonClosed_ && clonePolygon_.size() >= 3) {
    clonePolygonClosed_ = true;
    setStatus("clone: now paint the target region on the mesh (left drag in the 3D view)");
    return;
  }
  if ((tool_ != Tool::Line && tool_ != Tool::Polygon) || chain_.empty()) return;
  FeatureChain chain{chainPhoto_, chain_, tool_ == Tool::Polygon};
  if (edit([&] { doc_.addChain(chain); })) {
    setStatus(std::string(chain.closed ? "polygon" : "line") + " of " + std::to_string(chain.points.size()) +
              " points added");
    chain_.clear();
    chainPhoto_ = -1;
  }
}

void Editor::cancelInProgress() {
  chain_.clear();
  chainPhoto_ = -1;
  stroke_.clear();
  clonePolygon_.clear();
  clonePolygonClosed_ = false;
  clonePhoto_ = -1;
  cloneFaces_.clear();
  cloneAnchorVertex_ = -1;
  cloneDirty_ = true;
}

// --- UI -------------------------------------------------------------------------------------------

bool Editor::button(const char* label, const ImVec2* size) {
  const bool pressed = ImGui::Button(label, size ? *size : ImVec2(0, 0));
  const ImVec2 lo = ImGui::GetItemRectMin(), hi = ImGui::GetItemRectMax();
  std::string name = label;
  if (auto pos = name.find("##"); pos != std::string::npos) name = name.substr(0, pos);
  buttonRects_[name] = Rect{lo.x, lo.y, hi.x - lo.x, hi.y - lo.y};
  return pressed;
}

void Editor::buildUi() {
  buttonRects_.clear();
  const ImGuiIO& io = ImGui::GetIO();
  menuBar();
  const float top = ImGui::GetFrameHeight();
  const float statusH = ImGui::GetFrameHeight() + 8;
  const float W = io.DisplaySize.x, H = io.DisplaySize.y;
  const float leftW = std::clamp(std::floor(W * 0.24f), 280.0f, 400.0f);
  const float mainH = H - top - statusH;
  const float viewW = std::floor((W - leftW) * 0.5f);
  windowRect_ = Rect{0, 0, W, H};

  const ImGuiWindowFlags fixed = ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse |
                                 ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoBringToFrontOnFocus;
  const float toolsH = std::floor(mainH * 0.42f);
  ImGui::SetNextWindowPos(ImVec2(0, top));
  ImGui::SetNextWindowSize(ImVec2(leftW, toolsH));
  if (ImGui::Begin("Tools", nullptr, fixed)) toolsPanel();
  ImGui::End();
  ImGui::SetNextWindowPos(ImVec2(0, top + toolsH));
  ImGui::SetNextWindowSize(ImVec2(leftW, mainH - toolsH));
  if (ImGui::Begin("Document", nullptr, fixed)) listsPanel();
  ImGui::End();

  ImGui::SetNextWindowPos(ImVec2(leftW, top));
  ImGui::SetNextWindowSize(ImVec2(viewW, mainH));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(0, 0));
  if (ImGui::Begin("3D view", nullptr, fixed | ImGuiWindowFlags_NoScrollbar | ImGuiWindowFlags_NoScrollWithMouse))
    view3d();
  ImGui::End();
  ImGui::PopStyleVar();

  ImGui::SetNextWindowPos(ImVec2(leftW + viewW, top));
  ImGui::SetNextWindowSize(ImVec2(W - leftW - viewW, mainH));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(4, 4));
  if (ImGui::Begin("Photos", nullptr, fixed | ImGuiWindowFlags_NoScrollbar | ImGuiWindowFlags_NoScrollWithMouse))
    photosPanel();
  ImGui::End();
  ImGui::PopStyleVar();

  statusBar(Rect{0, H - statusH, W, statusH});
  errorsWindow();
  helpWindow();
  modals();
  if (auto chosen = dialogs_.frame()) {
    if (chosen->purpose == "open") {
      openFile(chosen->path);
      checkRecovery();
    }
    if (chosen->purpose == "save_as") saveTo(chosen->path);
    if (chosen->purpose == "export") exportTo(chosen->path);
    if (chosen->purpose == "add_photos") addPhotosFrom(chosen->path);
  }
  shortcuts();
}

void Editor::menuBar() {
  if (!ImGui::BeginMainMenuBar()) return;
  if (ImGui::BeginMenu("File")) {
    if (ImGui::MenuItem("Open project or mesh...", "Ctrl+O")) requestOpen();
    if (ImGui::BeginMenu("Open recent", !recent_.files().empty())) {
      for (const std::string& f : recent_.files())
        if (ImGui::MenuItem(f.c_str())) {
          const std::string file = f;
          guardUnsaved([this, file] {
            openFile(file);
            checkRecovery();
          });
        }
      ImGui::Separator();
      if (ImGui::MenuItem("Clear list")) recent_.clear();
      ImGui::EndMenu();
    }
    ImGui::Separator();
    const bool hasMesh = !doc_.project().mesh.empty();
    if (ImGui::MenuItem("Add photo...", nullptr, false, hasMesh))
      dialogs_.request(DialogKind::OpenFile, "Add a photo",
                       {{"Images", {"*.png", "*.jpg", "*.jpeg", "*.tif", "*.tiff", "*.bmp"}}}, "add_photos",
                       fs::path(doc_.project().mesh).parent_path().string());
    if (ImGui::MenuItem("Add photos folder...", nullptr, false, hasMesh))
      dialogs_.request(DialogKind::OpenFolder, "Add every photo of a folder", {}, "add_photos",
                       fs::path(doc_.project().mesh).parent_path().string());
    ImGui::Separator();
    if (ImGui::MenuItem("Save", "Ctrl+S", false, hasMesh)) save();
    if (ImGui::MenuItem("Save as...", "Ctrl+Shift+S", false, hasMesh)) requestSaveAs();
    if (ImGui::MenuItem("Export result...", "Ctrl+E", false, resultUsable()))
      dialogs_.request(DialogKind::SaveFile, "Export the textured model (.glb or .obj)",
                       {{"glTF binary", {"*.glb"}}, {"OBJ + MTL + PNG", {"*.obj"}}}, "export", "");
    ImGui::Separator();
    if (ImGui::MenuItem("Quit", "Ctrl+Q")) requestClose();
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Edit")) {
    const std::string undoLabel = doc_.canUndo() ? "Undo " + doc_.history()[doc_.position() - 1].label : "Undo";
    const std::string redoLabel = doc_.canRedo() ? "Redo " + doc_.history()[doc_.position()].label : "Redo";
    if (ImGui::MenuItem(undoLabel.c_str(), "Ctrl+Z", false, doc_.canUndo())) undo();
    if (ImGui::MenuItem(redoLabel.c_str(), "Ctrl+Shift+Z", false, doc_.canRedo())) redo();
    ImGui::Separator();
    if (ImGui::MenuItem("Delete selected point", "Delete", false, selectedPoint_ >= 0)) deleteSelection();
    if (ImGui::MenuItem("Clear selection", "Escape")) selectVertex(-1);
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("View")) {
    ImGui::MenuItem("Textured", "T", &textured_);
    ImGui::MenuItem("Wireframe", "W", &wireframe_);
    ImGui::MenuItem("Partition paths", nullptr, &showPaths_);
    ImGui::MenuItem("Features", nullptr, &showFeatures_);
    ImGui::MenuItem("Feature ids", nullptr, &showIds_);
    if (ImGui::BeginMenu("Colour faces by")) {
      for (size_t i = 0; i < kFaceColoringNames.size(); ++i)
        if (ImGui::MenuItem(kFaceColoringNames[i], nullptr, coloring_ == FaceColoring(i))) {
          coloring_ = FaceColoring(i);
          overlayDirty_ = true;
        }
      ImGui::EndMenu();
    }
    if (ImGui::MenuItem("Frame all", "F")) camera_.frame(input_.lo, input_.hi);
    ImGui::Separator();
    ImGui::MenuItem("Photos in a grid", nullptr, &gridPanes_);
    ImGui::MenuItem("Background mask", nullptr, &showMask_);
    ImGui::MenuItem("Partition curves", nullptr, &showCurves_);
    ImGui::MenuItem("Rejected pairs", nullptr, &showRejected_);
    ImGui::Separator();
    ImGui::MenuItem("Errors", nullptr, &showErrors_);
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Tools")) {
    for (size_t i = 0; i < kToolNames.size(); ++i)
      if (ImGui::MenuItem(kToolNames[i], kToolKeys[i], tool_ == Tool(i))) {
        cancelInProgress();
        tool_ = Tool(i);
      }
    ImGui::EndMenu();
  }
  if (ImGui::BeginMenu("Help")) {
    ImGui::MenuItem("Shortcuts and mouse", "F1", &showHelp_);
    ImGui::EndMenu();
  }
  ImGui::EndMainMenuBar();
}

void Editor::toolsPanel() {
  for (size_t i = 0; i < kToolNames.size(); ++i) {
    if (i % 3 != 0) ImGui::SameLine(8 + 92.0f * (i % 3));
    if (ImGui::RadioButton(kToolNames[i], tool_ == Tool(i)) && tool_ != Tool(i)) {
      cancelInProgress();
      tool_ = Tool(i);
    }
  }
  ImGui::Separator();
  const Project& p = doc_.project();
  switch (tool_) {
    case Tool::Point:
      ImGui::TextWrapped("Pick a vertex in the 3D view, then click where it is in a photo. Drag a point to move it.");
      break;
    case Tool::Line:
    case Tool::Polygon:
      ImGui::TextWrapped("Click points in one photo (existing ones, or pick a vertex then click). %s",
                         tool_ == Tool::Polygon ? "Close by clicking the first point or Enter." : "Finish with Enter.");
      if (!chain_.empty()) {
        ImGui::Text("drawing in photo %d: %zu point(s)", chainPhoto_, chain_.size());
        if (button("Finish")) finishChain();
        ImGui::SameLine();
        if (button("Cancel")) cancelInProgress();
      }
      break;
    case Tool::Stroke:
      ImGui::TextWrapped("Left-drag on the mesh to draw a guidance stroke (direction = direction of travel).");
      ImGui::Text("%zu stroke(s) in the project", p.strokes.size());
      break;
    case Tool::Clone: {
      ImGui::TextWrapped(
          "1. Click a polygon in a photo (close: first point or Enter). 2. Paint the target on the mesh (Ctrl "
          "erases). 3. Apply.");
      ImGui::Text("polygon: %zu point(s)%s, target: %zu face(s)", clonePolygon_.size(),
                  clonePolygonClosed_ ? " (closed)" : "", cloneFaces_.size());
      ImGui::SliderFloat("brush", &cloneBrush_, 0.01f, 0.3f, "%.2f x size");
      float rot = static_cast<float>(cloneRotationDeg_), ppu = static_cast<float>(clonePixelsPerUnit_);
      if (ImGui::SliderFloat("rotation", &rot, -180, 180, "%.0f deg")) cloneRotationDeg_ = rot, cloneDirty_ = true;
      if (ImGui::InputFloat("px / unit", &ppu, 0, 0, "%.1f"))
        clonePixelsPerUnit_ = std::max(0.f, ppu), cloneDirty_ = true;
      ImGui::TextDisabled("px / unit 0 fits the polygon to the region");
      const bool ready = clonePolygonClosed_ && !cloneFaces_.empty();
      if (!ready) ImGui::BeginDisabled();
      if (button("Apply clone")) {
        const CloneOp op = currentCloneOp();
        if (edit([&] { doc_.addClone(op); })) {
          setStatus("clone added: the next run clones it seamlessly");
          cancelInProgress();
        }
      }
      if (!ready) ImGui::EndDisabled();
      ImGui::SameLine();
      if (button("Cancel##clone")) cancelInProgress();
      break;
    }
  }
  ImGui::Separator();
  if (selectedVertex_ >= 0) {
    ImGui::Text("selected: vertex %d", selectedVertex_);
    if (selectedPoint_ >= 0) {
      ImGui::SameLine();
      ImGui::Text("(point #%d)", selectedPoint_);
    }
  } else {
    ImGui::TextDisabled("no vertex selected");
  }
  ImGui::Separator();
  ImGui::Checkbox("textured", &textured_);
  ImGui::SameLine();
  ImGui::Checkbox("wireframe", &wireframe_);
  ImGui::SameLine();
  ImGui::Checkbox("paths", &showPaths_);
  ImGui::Checkbox("features", &showFeatures_);
  ImGui::SameLine();
  ImGui::Checkbox("ids", &showIds_);
  ImGui::SameLine();
  ImGui::Checkbox("mask", &showMask_);
  ImGui::Checkbox("curves", &showCurves_);
  ImGui::SameLine();
  ImGui::Checkbox("rejected pairs", &showRejected_);
  int coloring = static_cast<int>(coloring_);
  ImGui::SetNextItemWidth(-1);
  if (ImGui::BeginCombo("##coloring", (std::string("faces: ") + kFaceColoringNames[coloring]).c_str())) {
    for (size_t i = 0; i < kFaceColoringNames.size(); ++i) {
      // Seam error comes from seam optimisation (paper 4.2), which this pipeline does not run yet.
      const bool available = FaceColoring(i) != FaceColoring::SeamError;
      if (ImGui::Selectable(kFaceColoringNames[i], coloring == int(i), available ? 0 : ImGuiSelectableFlags_Disabled)) {
        coloring_ = FaceColoring(i);
        overlayDirty_ = true;
      }
      if (!available && ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
        ImGui::SetTooltip("the pipeline does not compute seam error yet (seam optimisation, paper 4.2)");
    }
    ImGui::EndCombo();
  }
}

void Editor::listsPanel() {
  if (!ImGui::BeginTabBar("##lists")) return;
  if (ImGui::BeginTabItem("Points")) {
    featuresTab();
    ImGui::EndTabItem();
  }
  if (ImGui::BeginTabItem("Chains")) {
    chainsTab();
    ImGui::EndTabItem();
  }
  if (ImGui::BeginTabItem("Strokes")) {
    strokesClonesTab();
    ImGui::EndTabItem();
  }
  if (ImGui::BeginTabItem("History")) {
    historyTab();
    ImGui::EndTabItem();
  }
  if (ImGui::BeginTabItem("Pipeline")) {
    pipelineTab();
    ImGui::EndTabItem();
  }
  ImGui::EndTabBar();
}

void Editor::featuresTab() {
  const Project& p = doc_.project();
  ImGui::Text("%zu feature points", p.points.size());
  ImGui::SameLine();
  if (selectedPoint_ < 0) ImGui::BeginDisabled();
  if (button("Delete point")) {
    edit([&] { doc_.removePoint(selectedPoint_); });
    selectedPoint_ = -1;
  }
  if (selectedPoint_ < 0) ImGui::EndDisabled();
  const ImGuiTableFlags flags = ImGuiTableFlags_RowBg | ImGuiTableFlags_ScrollY | ImGuiTableFlags_BordersInnerV;
  if (!ImGui::BeginTable("##points", 3, flags)) return;
  ImGui::TableSetupScrollFreeze(0, 1);
  ImGui::TableSetupColumn("#", ImGuiTableColumnFlags_WidthFixed, 36);
  ImGui::TableSetupColumn("vertex", ImGuiTableColumnFlags_WidthFixed, 60);
  ImGui::TableSetupColumn("photos");
  ImGui::TableHeadersRow();
  ImGuiListClipper clipper;
  clipper.Begin(static_cast<int>(p.points.size()));
  while (clipper.Step())
    for (int i = clipper.DisplayStart; i < clipper.DisplayEnd; ++i) {
      const FeaturePoint& pt = p.points[i];
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      const std::string id = std::to_string(i) + "##pt" + std::to_string(i);
      if (ImGui::Selectable(id.c_str(), selectedPoint_ == i, ImGuiSelectableFlags_SpanAllColumns)) {
        selectedPoint_ = i;
        selectedVertex_ = pt.vertex;
        if (!pt.at.empty()) activePhoto_ = pt.at[0].photo;
      }
      ImGui::TableNextColumn();
      ImGui::Text("%d", pt.vertex);
      ImGui::TableNextColumn();
      std::string photos;
      for (const PhotoPoint& a : pt.at) photos += std::to_string(a.photo) + " ";
      ImGui::TextUnformatted(photos.c_str());
    }
  ImGui::EndTable();
}

void Editor::chainsTab() {
  const Project& p = doc_.project();
  ImGui::Text("%zu chains (feature lines and polygons)", p.chains.size());
  int remove = -1;
  for (size_t i = 0; i < p.chains.size(); ++i) {
    const FeatureChain& c = p.chains[i];
    ImGui::PushID(static_cast<int>(i));
    if (ImGui::SmallButton("x")) remove = static_cast<int>(i);
    ImGui::SameLine();
    std::string pts;
    for (int pt : c.points) pts += std::to_string(pt) + " ";
    ImGui::Text("#%zu %s in photo %d: %s", i, c.closed ? "polygon" : "line", c.photo, pts.c_str());
    ImGui::PopID();
  }
  if (remove >= 0) edit([&] { doc_.removeChain(remove); });
}

void Editor::strokesClonesTab() {
  const Project& p = doc_.project();
  ImGui::Text("%zu strokes", p.strokes.size());
  int removeStroke = -1, removeClone = -1;
  for (size_t i = 0; i < p.strokes.size(); ++i) {
    ImGui::PushID(static_cast<int>(i));
    if (ImGui::SmallButton("x")) removeStroke = static_cast<int>(i);
    ImGui::SameLine();
    ImGui::Text("stroke #%zu: %zu vertices (%d -> %d)", i, p.strokes[i].vertices.size(), p.strokes[i].vertices.front(),
                p.strokes[i].vertices.back());
    ImGui::PopID();
  }
  ImGui::Separator();
  ImGui::Text("%zu clones", p.clones.size());
  for (size_t i = 0; i < p.clones.size(); ++i) {
    ImGui::PushID(1000000 + static_cast<int>(i));
    if (ImGui::SmallButton("x")) removeClone = static_cast<int>(i);
    ImGui::SameLine();
    ImGui::Text("clone #%zu: photo %d, %zu-gon -> %zu faces, %.0f deg", i, p.clones[i].photo,
                p.clones[i].polygon.size(), p.clones[i].targetFaces.size(), p.clones[i].rotationDeg);
    ImGui::PopID();
  }
  if (removeStroke >= 0) edit([&] { doc_.removeStroke(removeStroke); });
  if (removeClone >= 0) edit([&] { doc_.removeClone(removeClone); });
}

void Editor::historyTab() {
  if (button("Undo")) undo();
  ImGui::SameLine();
  if (button("Redo")) redo();
  ImGui::SameLine();
  ImGui::TextDisabled("%d / %zu steps", doc_.position(), doc_.history().size());
  ImGui::BeginChild("##history");
  if (ImGui::Selectable("(opened)", doc_.position() == 0)) doc_.jumpTo(0);
  const auto& history = doc_.history();
  for (size_t i = 0; i < history.size(); ++i) {
    const bool applied = static_cast<int>(i) < doc_.position();
    if (!applied) ImGui::PushStyleColor(ImGuiCol_Text, kDimColor);
    const std::string label = std::to_string(i + 1) + ". " + history[i].label + "##h" + std::to_string(i);
    if (ImGui::Selectable(label.c_str(), static_cast<int>(i) + 1 == doc_.position())) {
      cancelInProgress();
      doc_.jumpTo(static_cast<int>(i) + 1);
    }
    if (!applied) ImGui::PopStyleColor();
  }
  ImGui::EndChild();
}

void Editor::pipelineTab() {
  const WorkerStatus ws = worker_->status();
  if (!lastError_.empty()) {
    ImGui::PushStyleColor(ImGuiCol_Text, kErrorColor);
    ImGui::TextWrapped("error: %s", lastError_.c_str());
    ImGui::PopStyleColor();
  }
  if (ImGui::CollapsingHeader("Options", ImGuiTreeNodeFlags_DefaultOpen)) {
    // Sliders edit a copy; the document changes once, when the slider is released (one undo step,
    // one pipeline run).
    static_assert(sizeof(float) == 4);
    PipelineOptions o = doc_.project().options;
    bool commit = false;
    float threshold = static_cast<float>(o.backgroundThresholdPx);
    ImGui::SliderFloat("background px", &threshold, 0, 20, "%.1f");
    if (ImGui::IsItemDeactivatedAfterEdit()) o.backgroundThresholdPx = threshold, commit = true;
    int searches = o.stretchSearches;
    ImGui::SliderInt("stretch searches", &searches, 0, 64);
    if (ImGui::IsItemDeactivatedAfterEdit()) o.stretchSearches = searches, commit = true;
    int seed = static_cast<int>(o.seed);
    ImGui::InputInt("seed", &seed);
    if (ImGui::IsItemDeactivatedAfterEdit()) o.seed = static_cast<unsigned>(std::max(0, seed)), commit = true;
    int mode = static_cast<int>(o.inpaintMode);
    if (ImGui::Combo("inpainting", &mode, kInpaintModeNames.data(), static_cast<int>(kInpaintModeNames.size())))
      o.inpaintMode = InpaintMode(mode), commit = true;
    if (commit) edit([&] { doc_.setOptions(o); });
  }
  if (!result_) {
    ImGui::TextDisabled(ws.busy ? "running..." : "no result yet");
    return;
  }
  if (ImGui::CollapsingHeader("Stages", ImGuiTreeNodeFlags_DefaultOpen) &&
      ImGui::BeginTable("##stages", 3, ImGuiTableFlags_RowBg | ImGuiTableFlags_SizingFixedFit)) {
    // Generic over the stage records: new stages appear without changes here.
    for (const StageRecord& s : result_->stages) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(stageName(s.stage));
      ImGui::TableNextColumn();
      ImGui::Text(s.cached ? "cached" : "%.3f s", s.seconds);
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(s.counts.dump().c_str());
      if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", s.counts.dump(2).c_str());
    }
    ImGui::EndTable();
  }
  if (ImGui::CollapsingHeader(("Warnings and notes (" + std::to_string(result_->warnings.size()) + ")").c_str(),
                              ImGuiTreeNodeFlags_DefaultOpen))
    for (const std::string& w : result_->warnings) ImGui::BulletText("%s", w.c_str());
  if (result_->mapping) {
    const auto& rejected = result_->mapping->partition.rejected;
    if (ImGui::CollapsingHeader(("Rejected pairs (" + std::to_string(rejected.size()) + ")").c_str())) {
      ImGuiListClipper clipper;
      clipper.Begin(static_cast<int>(rejected.size()));
      while (clipper.Step())
        for (int i = clipper.DisplayStart; i < clipper.DisplayEnd; ++i) {
          const RejectedPair& r = rejected[i];
          const std::string label = std::to_string(r.fromPoint) + "-" + std::to_string(r.toPoint) + " photo " +
                                    std::to_string(r.photo) + ": " + kRejectReasonNames[int(r.reason)] + "##rj" +
                                    std::to_string(i);
          if (ImGui::Selectable(label.c_str()) && r.photo >= 0) activePhoto_ = r.photo;
          if (ImGui::IsItemHovered() && !r.detail.empty()) ImGui::SetTooltip("%s", r.detail.c_str());
        }
    }
  }
}

void Editor::statusBar(const Rect& r) {
  ImGui::SetNextWindowPos(ImVec2(float(r.x), float(r.y)));
  ImGui::SetNextWindowSize(ImVec2(float(r.w), float(r.h)));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(8, 4));
  ImGui::Begin("##status", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoSavedSettings |
                   ImGuiWindowFlags_NoBringToFrontOnFocus);
  const WorkerStatus ws = worker_->status();
  if (ws.busy) {
    const int stage = static_cast<int>(ws.stage);
    const double overall = (stage + std::clamp(ws.fraction, 0.0, 1.0)) / double(kStageNames.size());
    ImGui::ProgressBar(static_cast<float>(overall), ImVec2(110, 0), "");
    ImGui::SameLine();
    ImGui::Text("%s %3.0f%% %s", stageName(ws.stage), 100 * ws.fraction, ws.what.c_str());
  } else if (doc_.project().mesh.empty()) {
    ImGui::TextDisabled("open a project or a mesh (Ctrl+O)");
  } else if (resultCurrent()) {
    ImGui::TextColored(ImVec4(0.5f, 0.85f, 0.5f, 1), "preview up to date");
  } else if (!lastError_.empty()) {
    ImGui::TextColored(kErrorColor, "pipeline failed");
  } else {
    ImGui::TextDisabled("waiting for the worker");
  }
  if (result_) {
    ImGui::SameLine();
    ImGui::TextDisabled("|");
    std::string timings;
    double total = 0;
    for (const StageRecord& s : result_->stages) {
      char part[64];
      std::snprintf(part, sizeof(part), s.cached ? "%s cached  " : "%s %.2fs  ", stageName(s.stage), s.seconds);
      timings += part;
      total += s.seconds;
    }
    ImGui::SameLine();
    ImGui::Text("%s= %.2fs", timings.c_str(), total);
  }
  if (!lastError_.empty()) {
    ImGui::SameLine();
    ImGui::TextDisabled("|");
    ImGui::SameLine();
    std::string shortError = lastError_.size() > 90 ? lastError_.substr(0, 90) + "..." : lastError_;
    ImGui::TextColored(kErrorColor, "%s", shortError.c_str());
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s\n(click: Errors window)", lastError_.c_str());
    if (ImGui::IsItemClicked()) showErrors_ = true;
  } else if (!status_.empty() && now() - statusTime_ < 8) {
    ImGui::SameLine();
    ImGui::TextDisabled("|");
    ImGui::SameLine();
    ImGui::TextUnformatted(status_.c_str());
  }
  // Right side: document state, autosave, frame time.
  char right[160];
  std::snprintf(right, sizeof(right), "%s%s  %.1f ms", doc_.modified() ? "unsaved  " : "",
                autosavedRevision_ == doc_.revision() && doc_.modified() ? "autosaved" : "", frameMs_);
  const float width = ImGui::CalcTextSize(right).x;
  ImGui::SameLine(std::max(ImGui::GetCursorPosX() + 10, float(r.w) - width - 12));
  ImGui::TextDisabled("%s", right);
  ImGui::End();
  ImGui::PopStyleVar();
}

void Editor::errorsWindow() {
  if (!showErrors_) return;
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowSize(ImVec2(std::min(640.f, display.x * 0.6f), 240), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowPos(ImVec2(display.x * 0.5f, display.y - 60), ImGuiCond_FirstUseEver, ImVec2(0.5f, 1.0f));
  if (ImGui::Begin("Errors", &showErrors_, ImGuiWindowFlags_NoSavedSettings)) {
    if (button("Clear")) errors_.clear(), lastError_.clear();
    ImGui::Separator();
    for (auto it = errors_.rbegin(); it != errors_.rend(); ++it) {
      ImGui::PushStyleColor(ImGuiCol_Text, kErrorColor);
      ImGui::TextWrapped("%s", it->c_str());
      ImGui::PopStyleColor();
    }
  }
  ImGui::End();
}

void Editor::helpWindow() {
  if (!showHelp_) return;
  ImGui::SetNextWindowSize(ImVec2(620, 560), ImGuiCond_FirstUseEver);
  if (ImGui::Begin("Help: shortcuts and mouse", &showHelp_, ImGuiWindowFlags_NoSavedSettings)) {
    if (ImGui::BeginTable("##keys", 2, ImGuiTableFlags_RowBg | ImGuiTableFlags_BordersInnerV)) {
      ImGui::TableSetupColumn("keys", ImGuiTableColumnFlags_WidthFixed, 250);
      ImGui::TableSetupColumn("action");
      for (const Shortcut& s : editorShortcuts()) {
        ImGui::TableNextRow();
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(s.keys);
        ImGui::TableNextColumn();
        ImGui::TextWrapped("%s", s.action);
      }
      ImGui::EndTable();
    }
    ImGui::TextWrapped("Scripts, command-line flags and the workflow: docs/editor.md.");
  }
  ImGui::End();
}

void Editor::modals() {
  if (recoveryPopup_) {
    ImGui::OpenPopup("Recover unsaved work?");
    recoveryPopup_ = false;
  }
  const ImVec2 center(ImGui::GetIO().DisplaySize.x * 0.5f, ImGui::GetIO().DisplaySize.y * 0.5f);
  ImGui::SetNextWindowPos(center, ImGuiCond_Appearing, ImVec2(0.5f, 0.5f));
  if (ImGui::BeginPopupModal("Recover unsaved work?", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::TextWrapped("The editor did not close cleanly last time. Autosaved work was found:");
    int choose = -1, discard = -1;
    for (size_t i = 0; i < recovery_.size(); ++i) {
      const RecoveryCandidate& c = recovery_[i];
      ImGui::PushID(static_cast<int>(i));
      ImGui::Separator();
      ImGui::Text("%s", c.projectFile.empty() ? ("unsaved project on " + c.meshFile).c_str() : c.projectFile.c_str());
      ImGui::TextDisabled("autosaved %s, %d feature points", timeText(c.time).c_str(), c.points);
      if (button(recovery_.size() == 1 ? "Recover" : "Recover##r")) choose = static_cast<int>(i);
      ImGui::SameLine();
      if (button("Discard")) discard = static_cast<int>(i);
      ImGui::PopID();
    }
    ImGui::Separator();
    if (button("Not now")) {
      recovery_.clear();
      ImGui::CloseCurrentPopup();
    }
    if (choose >= 0) {
      const RecoveryCandidate c = recovery_[choose];
      try {
        Project recovered = loadRecovery(c);
        doc_.reset(std::move(recovered), /*modified=*/true);
        cancelInProgress();
        selectedVertex_ = selectedPoint_ = -1;
        // The side file stays until the recovered work is saved: a second crash loses nothing.
        lastAutosavePath_ = c.autosavePath;
        autosaveClock_.reset(now(), -1);
        setStatus("recovered " + std::to_string(doc_.project().points.size()) + " feature points from " +
                  c.autosavePath + " (not saved yet)");
      } catch (const Error& e) {
        reportError(e.what());
      }
      recovery_.clear();
      ImGui::CloseCurrentPopup();
    } else if (discard >= 0) {
      removeAutosave(recovery_[discard].autosavePath);
      recovery_.erase(recovery_.begin() + discard);
      if (recovery_.empty()) ImGui::CloseCurrentPopup();
    }
    ImGui::EndPopup();
  }

  if (unsavedPopup_) {
    ImGui::OpenPopup("Unsaved changes");
    unsavedPopup_ = false;
  }
  ImGui::SetNextWindowPos(center, ImGuiCond_Appearing, ImVec2(0.5f, 0.5f));
  if (ImGui::BeginPopupModal("Unsaved changes", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::Text("Save the changes to %s first?",
                doc_.project().file.empty() ? "the new project" : fs::path(doc_.project().file).filename().c_str());
    if (button("Save")) {
      ImGui::CloseCurrentPopup();
      if (doc_.project().file.empty()) {
        requestSaveAs();  // the pending action waits for the next attempt
        afterUnsaved_ = nullptr;
      } else {
        saveTo(doc_.project().file);
        if (!doc_.modified() && afterUnsaved_) afterUnsaved_();
        afterUnsaved_ = nullptr;
      }
    }
    ImGui::SameLine();
    if (button("Don't save")) {
      ImGui::CloseCurrentPopup();
      removeAutosave(autosavePath());
      if (afterUnsaved_) afterUnsaved_();
      afterUnsaved_ = nullptr;
    }
    ImGui::SameLine();
    if (button("Cancel")) {
      ImGui::CloseCurrentPopup();
      afterUnsaved_ = nullptr;
    }
    ImGui::EndPopup();
  }
}

void Editor::shortcuts() {
  ImGuiIO& io = ImGui::GetIO();
  if (io.WantTextInput || ImGui::IsPopupOpen(nullptr, ImGuiPopupFlags_AnyPopupId)) return;
  const bool ctrl = io.KeyCtrl, shift = io.KeyShift;
  auto pressed = [](int key) { return ImGui::IsKeyPressed(key, false); };
  if (ctrl) {
    if (pressed(GLFW_KEY_Z)) shift ? redo() : undo();
    if (pressed(GLFW_KEY_Y)) redo();
    if (pressed(GLFW_KEY_S)) shift ? requestSaveAs() : save();
    if (pressed(GLFW_KEY_O)) requestOpen();
    if (pressed(GLFW_KEY_E) && resultUsable())
      dialogs_.request(DialogKind::SaveFile, "Export the textured model (.glb or .obj)",
                       {{"glTF binary", {"*.glb"}}, {"OBJ + MTL + PNG", {"*.obj"}}}, "export", "");
    if (pressed(GLFW_KEY_Q)) requestClose();
    return;
  }
  const std::pair<int, Tool> tools[] = {{GLFW_KEY_P, Tool::Point},
                                        {GLFW_KEY_L, Tool::Line},
                                        {GLFW_KEY_G, Tool::Polygon},
                                        {GLFW_KEY_S, Tool::Stroke},
                                        {GLFW_KEY_C, Tool::Clone}};
  for (const auto& [key, tool] : tools)
    if (pressed(key) && tool_ != tool) {
      cancelInProgress();
      tool_ = tool;
    }
  if (pressed(GLFW_KEY_T)) textured_ = !textured_;
  if (pressed(GLFW_KEY_W)) wireframe_ = !wireframe_;
  if (pressed(GLFW_KEY_F)) camera_.frame(input_.lo, input_.hi);
  if (pressed(GLFW_KEY_F1)) showHelp_ = !showHelp_;
  if (pressed(GLFW_KEY_DELETE) || pressed(GLFW_KEY_BACKSPACE)) deleteSelection();
  if (pressed(GLFW_KEY_ENTER) || pressed(GLFW_KEY_KP_ENTER)) finishChain();
  if (pressed(GLFW_KEY_ESCAPE)) {
    if (!chain_.empty() || !stroke_.empty() || !clonePolygon_.empty() || !cloneFaces_.empty()) {
      cancelInProgress();
    } else {
      selectVertex(-1);
    }
  }
  for (int k = 0; k < 9; ++k)
    if (pressed(GLFW_KEY_1 + k) && k < static_cast<int>(doc_.project().photos.size())) activePhoto_ = k;
}

}  // namespace montage
