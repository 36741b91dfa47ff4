// The editor's lifecycle, frame loop, worker hand-off and document edits (undo, selection, chains).
// Files and autosave are in editor_files.cpp, menus and side panels in editor_panels.cpp, the 3D view
// in editor_view.cpp, the image panes in editor_panes.cpp, scripts and benchmarks in editor_script.cpp.
#include "editor.h"

#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "base/fileio.h"
#include "gl.h"
#include "gl_util.h"
#include "image/photo.h"
#include "io/mesh_anchors.h"
#include "io/mesh_io.h"
#include "io/model.h"
#include "overlay_gl.h"
#include "overlays.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

double now() {
  return glfwGetTime();
}

}  // namespace

Editor::Editor(EditorOptions options) : options_(std::move(options)) {
  sessionId_ = std::to_string(static_cast<long long>(getpid())) + "_" +
               std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(
                                  std::chrono::system_clock::now().time_since_epoch())
                                  .count());
  autosaveClock_.setInterval(options_.autosaveSeconds);
  layout_ = loadLayout();
  savedLayout_ = layout_.toJson();
  gridPanes_ = layout_.grid;
  reducedNavigation_ = layout_.reducedNavigation;
  for (size_t i = 0; i < kMouseBindingNames.size(); ++i)
    if (layout_.mouse == kMouseBindingNames[i]) bindings_ = MouseBindings(i);
  initWindow();
  worker_ = std::make_unique<PipelineWorker>([] { glfwPostEmptyEvent(); });  // a result wakes the event loop
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
  if (options_.benchWorker || options_.benchOverlays) benchOrbit_ = true;
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
  const bool interactive = options_.script.empty() && options_.screenshot.empty() && options_.benchOrbit.empty() &&
                           !options_.benchWorker && !options_.benchOverlays;
  glfwSwapInterval(interactive && options_.vsync ? 1 : 0);

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGuiIO& io = ImGui::GetIO();
  io.IniFilename = nullptr;  // the layout is computed; nothing to store in the working folder
  // HiDPI: fonts and sizes follow the monitor's content scale (or --scale), and its changes.
  float xs = 1, ys = 1;
  glfwGetWindowContentScale(window_, &xs, &ys);
  applyScale(options_.scale > 0 ? static_cast<float>(options_.scale) : std::max({xs, ys, 1.0f}));
  // Keys, characters, mouse buttons, the wheel and pointer moves are queued in the order they come and handed
  // to ImGui a step per frame (applyRealInput; input_queue.h says why); the ImGui backend takes the rest
  // (focus, the pointer entering and leaving).
  glfwSetWindowUserPointer(window_, this);
  ImGui_ImplGlfw_InitForOpenGL(window_, false);
  static const auto queue = [](GLFWwindow* window) -> RealInputQueue& {
    return static_cast<Editor*>(glfwGetWindowUserPointer(window))->realInput_;
  };
  glfwSetKeyCallback(window_, [](GLFWwindow* window, int key, int, int action, int mods) {
    if (action == GLFW_REPEAT) return;  // ImGui repeats held keys itself
    const bool modifier = key >= GLFW_KEY_LEFT_SHIFT && key <= GLFW_KEY_RIGHT_SUPER;
    queue(window).push({InputEvent::Kind::Key, key, action == GLFW_PRESS, modifier, mods});
  });
  glfwSetCharCallback(window_, [](GLFWwindow* window, unsigned int c) {
    queue(window).push({InputEvent::Kind::Char, static_cast<int>(c)});
  });
  glfwSetMouseButtonCallback(window_, [](GLFWwindow* window, int button, int action, int mods) {
    queue(window).push({InputEvent::Kind::Button, button, action == GLFW_PRESS});
  });
  glfwSetCursorPosCallback(window_, [](GLFWwindow* window, double x, double y) {
    queue(window).push({InputEvent::Kind::Move, 0, false, false, 0, x, y});
  });
  glfwSetWindowFocusCallback(window_, ImGui_ImplGlfw_WindowFocusCallback);
  glfwSetCursorEnterCallback(window_, ImGui_ImplGlfw_CursorEnterCallback);
  glfwSetScrollCallback(window_, [](GLFWwindow* window, double dx, double dy) {
    queue(window).push({InputEvent::Kind::Scroll, 0, false, false, 0, dx, dy});
  });
  // Files dropped on the window: kept for the next frame's UI (the only place the document changes).
  // The ImGui backend uses neither the window's user pointer nor the drop callback.
  glfwSetDropCallback(window_, [](GLFWwindow* window, int count, const char** paths) {
    auto* editor = static_cast<Editor*>(glfwGetWindowUserPointer(window));
    for (int i = 0; i < count; ++i) editor->dropped_.push_back(paths[i]);
  });
  glfwSetWindowContentScaleCallback(window_, [](GLFWwindow* window, float x, float y) {
    auto* editor = static_cast<Editor*>(glfwGetWindowUserPointer(window));
    if (editor->options_.scale <= 0) editor->pendingScale_ = std::max(x, y);
  });
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
  initOverlays();
}

void Editor::applyScale(float scale) {
  scale_ = std::clamp(scale, 0.5f, 4.0f);
  ImGuiIO& io = ImGui::GetIO();
  const bool rebuild = io.Fonts->IsBuilt();
  io.Fonts->Clear();
  const char* font = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
  std::error_code ec;
  if (fs::exists(font, ec)) {
    io.Fonts->AddFontFromFileTTF(font, std::round(15.0f * scale_));
  } else {
    ImFontConfig config;
    config.SizePixels = std::round(13.0f * scale_);
    io.Fonts->AddFontDefault(&config);
  }
  ImGuiStyle& style = ImGui::GetStyle();
  style = ImGuiStyle();
  ImGui::StyleColorsDark();
  style.WindowRounding = 0;
  style.FrameRounding = 3;
  style.WindowBorderSize = 1;
  style.ItemSpacing = ImVec2(7, 5);
  style.ScaleAllSizes(scale_);
  if (rebuild) {
    // A scale change after start-up: the font texture again.
    ImGui_ImplOpenGL3_DestroyFontsTexture();
    ImGui_ImplOpenGL3_CreateFontsTexture();
  }
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
  spareTextures_.clear();
  meshShader_.reset();
  lineShader_.reset();
  textureShader_.reset();
  viewFbo_.reset();
  meshVbo_.reset();
  lineVbo_.reset();
  pointVbo_.reset();
  selectionVbo_.reset();
  cloneVbo_.reset();
  overlayGl_.reset();
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

// The next step of the real input, after the backend's NewFrame (which reads the buttons and the pointer as
// they are now): each key and button as the queue presents it, the pointer where this step's last event
// happened, the modifiers as held at this step's key press.
void Editor::applyRealInput(ImGuiIO& io) {
  const InputFrame in = realInput_.next();
  realPresses_ = in.presses;
  std::copy(in.keys.begin(), in.keys.end(), std::begin(io.KeysDown));
  std::copy(in.buttons.begin(), in.buttons.end(), std::begin(io.MouseDown));
  if (in.taken && in.hasPointer) io.MousePos = ImVec2(float(in.x), float(in.y));
  for (unsigned c : in.chars) io.AddInputCharacter(c);
  io.MouseWheelH += float(in.wheelX);
  io.MouseWheel += float(in.wheelY);
  auto held = [&in](int left, int right, int mod) { return in.keys[left] || in.keys[right] || (in.pressMods & mod); };
  io.KeyCtrl = held(GLFW_KEY_LEFT_CONTROL, GLFW_KEY_RIGHT_CONTROL, GLFW_MOD_CONTROL);
  io.KeyShift = held(GLFW_KEY_LEFT_SHIFT, GLFW_KEY_RIGHT_SHIFT, GLFW_MOD_SHIFT);
  io.KeyAlt = held(GLFW_KEY_LEFT_ALT, GLFW_KEY_RIGHT_ALT, GLFW_MOD_ALT);
  io.KeySuper = held(GLFW_KEY_LEFT_SUPER, GLFW_KEY_RIGHT_SUPER, GLFW_MOD_SUPER);
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
  const bool busy = worker_->status().busy;
  // A script waiting for the worker waits as a user would (below), so that its timings are the user's.
  const bool scriptRuns = scripted_ && (frameNumber_ < 2 || !waitUntil_ || !waitOnEvents_);
  if (scriptRuns || benchOrbit_ || !inputQueue_.empty() || realInput_.pending() || realPresses_) {
    glfwPollEvents();
  } else {
    // Redraw on input and when the worker has a result (it posts an event); otherwise a few times a
    // second (worker progress, dialogs, autosave clock). A redraw costs a core under software GL, which
    // the worker needs.
    // A view drawn reduced while the camera moved is drawn at full size once it has settled.
    double wait = busy ? 0.25 : dialogs_.active() ? 0.05 : autosaveJob_.valid() ? 0.25 : 1.0;
    if (viewDivisor_ > 1) wait = std::min(wait, viewMotion_.secondsToSettle(glfwGetTime()) + 0.005);
    glfwWaitEventsTimeout(wait);
  }
  // The frame's time is its work, from here: the wait for events above is idle time, not the frame's.
  const double start = now();
  if (glfwWindowShouldClose(window_)) {
    glfwSetWindowShouldClose(window_, GLFW_FALSE);
    requestClose();
  }
  if (pendingScale_ > 0 && pendingScale_ != scale_) applyScale(pendingScale_);
  pendingScale_ = 0;
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGuiIO& io = ImGui::GetIO();
  applyRealInput(io);
  if (scripted_) {
    try {
      scriptStep();
    } catch (const Error& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      exitStatus_ = 1;
      quit_ = true;
    }
    if (!waitRealInput_) applySyntheticInput(io);  // `real_input`: the real mouse and keys, not the script's
  }
  if (benchOrbit_) benchOrbitStep();
  ImGui::NewFrame();

  syncInputs();
  pollCutout();
  buildUi();
  syncInputs();  // the dialogs, drops and shortcuts at the end of buildUi edit too; the 3D view draws next
  validateSelection();
  pollWorker();
  // Each document change goes to the worker as an immutable snapshot. During a drag (an open group) so does
  // the newest position, whenever the worker is not computing the first tier of a snapshot (the quick
  // preview, or the preview where they are the same; issue 36): the preview follows the drag as fast as the
  // pipeline delivers it, a running refinement or final of an earlier position is cancelled, and the pipeline
  // is never restarted at every mouse move.
  bool send = !doc_.project().mesh.empty() && doc_.revision() != submittedRevision_;
  if (send && doc_.inGroup()) {
    const WorkerStatus ws = worker_->status();
    send = !(ws.busy && ws.first);
  }
  if (send) {
    const auto at = std::chrono::steady_clock::now();  // before the worker may start
    submittedGeneration_ = worker_->submit(doc_.snapshot());
    submittedAt_[submittedGeneration_] = {at, frameNumber_};
    while (submittedAt_.size() > 64) submittedAt_.erase(submittedAt_.begin());
    cancelled_ = false;
    submittedRevision_ = doc_.revision();
    generationRevision_[submittedGeneration_] = submittedRevision_;
  }
  autosaveTick();
  renderScene();
  if (shownGeneration_ >= 0) {  // the result taken this frame is drawn: the edit's latency
    if (auto it = submittedAt_.find(shownGeneration_); it != submittedAt_.end()) {
      const auto drawn = std::chrono::steady_clock::now();
      const auto seconds = [](auto from, auto to) { return std::chrono::duration<double>(to - from).count(); };
      const int tier = static_cast<int>(result_->tier);
      shownLatency_[tier] = seconds(it->second.at, drawn);
      const OutcomeTimes& t = shownTimes_;
      shownParts_[tier] = {
          seconds(it->second.at, t.started), seconds(t.started, t.modelStarted), seconds(t.modelStarted, t.finished),
          seconds(t.finished, takenAt_),     seconds(takenAt_, drawn),           frameNumber_ - it->second.frame};
    }
    shownGeneration_ = -1;
    glfwPostEmptyEvent();  // one more frame at once: a script waiting for this result, the layout settling
  }

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
        input_.fingerprint = meshFingerprint(*input_.mesh);
        // A mesh re-exported or retopologised since the project was saved: the clicks follow their positions.
        try {
          const MeshCarry carry = doc_.carryToMesh(*input_.mesh, input_.fingerprint);
          if (carry.changed)
            reportError(located(doc_.project().file, carry.message + " (Edit > Undo puts the ids back)"));
        } catch (const Error& e) {
          reportError(e.what());  // the runs refuse the project with the same words
        }
        camera_.frame(input_.lo, input_.hi);
        frameWhenShown_ = true;  // again with the view's width and height, once it is laid out
        if (!pendingRecent_.empty()) recent_.add(pendingRecent_);
      } catch (const Error& e) {
        input_.error = e.what();
        // A mesh the opened project names but that is missing is listed already (openFile).
        const bool listed =
            std::any_of(missing_.begin(), missing_.end(), [](const MissingFile& m) { return m.field == "mesh"; });
        if (!listed) reportError(e.what());
      }
    }
    pendingRecent_.clear();
  }
  photos_.resize(p.photos.size());
  for (size_t i = 0; i < p.photos.size(); ++i) {
    PhotoSlot& slot = photos_[i];
    const std::string key = p.photos[i].path + "|" + p.photos[i].mask + "|" + std::to_string(p.options.maxPhotoSide) +
                            (p.photos[i].mirror ? "|mirror" : "");
    if (slot.key == key) continue;
    slot.key = key;
    slot.photo.reset();
    slot.error.clear();
    slot.balancedFrom = nullptr;
    slot.tabView.fitted = slot.gridView.fitted = false;
    try {
      // The core's loader, so the foreground (alpha or mask) follows the pipeline's rule exactly.
      PhotoLoadOptions options;
      options.maxSide = p.options.maxPhotoSide;
      options.mirror = p.photos[i].mirror;
      auto photo = std::make_shared<Photo>(loadPhoto(p.photos[i].path, p.photos[i].mask, options));
      const cv::Mat rgba = toRgba8(photo->rgb, false, photo->path);  // any depth, stored resolution
      if (!slot.texture) slot.texture = std::make_unique<Texture>();
      slot.texture->upload(rgba);
      // Background overlay: a blue tint where the photo is background, clear on the foreground.
      cv::Mat mask(photo->rgb.size(), CV_8UC4, cv::Scalar(0, 0, 0, 0));
      if (photo->hasBackground) mask.setTo(cv::Scalar(40, 70, 220, 80), photo->alpha <= 0);
      if (!slot.mask) slot.mask = std::make_unique<Texture>();
      slot.mask->upload(mask);
      slot.photo = photo;
    } catch (const Error& e) {
      slot.error = e.what();
      // A photo the opened project names but that is missing is listed already (openFile).
      const std::string field = "photos[" + std::to_string(i) + "]";
      const bool listed = std::any_of(missing_.begin(), missing_.end(),
                                      [&](const MissingFile& m) { return m.field.rfind(field, 0) == 0; });
      if (!listed) reportError(e.what());
    }
  }
}

std::string Editor::pointName(int point) const {
  const Project& p = doc_.project();
  return std::to_string(point >= 0 && point < static_cast<int>(p.points.size()) ? pointId(p, point) : point);
}

std::string Editor::resultPointName(int point) const {
  if (result_ && result_->mapping && result_->mapping->partition) {
    const std::vector<int>& ids = result_->mapping->partition->featureId;
    if (point >= 0 && point < static_cast<int>(ids.size())) return std::to_string(ids[point]);
  }
  return pointName(point);
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
  return result_ && (result_->model || resultPreview_) && result_->scene &&
         result_->scene->project.mesh == doc_.project().mesh;
}

const TexturedModel* Editor::shownModel() const {
  if (!resultUsable()) return nullptr;
  return result_->model ? result_->model.get() : resultPreview_.get();
}

bool Editor::resultCurrent() const {
  return resultUsable() && result_->scene->document().sameDocument(doc_.project());
}

void Editor::pollWorker() {
  std::optional<WorkerOutcome> outcome = worker_->take();
  if (!outcome) return;
  takenAt_ = std::chrono::steady_clock::now();
  outcomes_.emplace_back(outcome->generation, outcome->tier);
  if (outcome->result) {
    // A result for a mesh the document no longer names (a file opened meanwhile) is dropped.
    if (!outcome->result->scene || outcome->result->scene->project.mesh != doc_.project().mesh) return;
    result_ = outcome->result;
    resultPreview_ = outcome->preview;
    progress_.record(outcome->tier, result_->stages);  // the next run's progress weights
    resultGeneration_ = outcome->generation;
    shownGeneration_ = outcome->generation;
    shownTimes_ = outcome->times;
    lastError_.clear();
    meshDirty_ = overlayDirty_ = linesDirty_ = true;
    stretch_.clear();
    if (result_->mapping) stretch_ = normalizedStretch(result_->mapping->partition->mesh, result_->mapping->map);
  } else {
    lastError_ = outcome->error;
    lastErrorGeneration_ = outcome->generation;
    // Each error once: the pipeline's failure to read a file the UI has already reported (a missing
    // or broken mesh or photo, worded by another loader) is not listed again.
    const Project& p = doc_.project();
    std::vector<std::string> files = {p.mesh};
    for (const PhotoRef& photo : p.photos) files.push_back(photo.path), files.push_back(photo.mask);
    bool listed = false;
    for (const std::string& f : files)
      if (!f.empty() && outcome->error.find(f) != std::string::npos)
        listed = listed || std::any_of(errors_.begin(), errors_.end(),
                                       [&](const std::string& e) { return e.find(f) != std::string::npos; });
    if (listed)
      lastProblem_ = "pipeline: " + outcome->error;
    else
      reportError("pipeline: " + outcome->error);
  }
}

// --- Autosave and recovery ------------------------------------------------------------------------

void Editor::undo() {
  if (dragging_) return;   // the drag's group closes on release
  if (cutoutOwnsUndo()) {  // the cut-out tool's last stroke or rectangle first (editor_photos.cpp)
    cutoutUndo();
    return;
  }
  cancelInProgress();
  if (doc_.canUndo()) {
    setStatus("undo: " + doc_.history()[doc_.position() - 1].label);
    doc_.undo();
  }
}

void Editor::redo() {
  if (dragging_) return;
  if (cutoutOwnsRedo()) {
    cutoutRedo();
    return;
  }
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
    hint("nothing selected to delete");
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
    closeClonePolygon();
    return;
  }
  if ((tool_ != Tool::Line && tool_ != Tool::Polygon) || chain_.empty()) return;
  FeatureChain chain{chainPhoto_, chain_, tool_ == Tool::Polygon};
  const size_t needed = chain.closed ? 3 : 2;
  if (chain_.size() < needed) {
    // A slip, not an error: say what is missing where the tool is explained; the chain stays open.
    hint(std::string(chain.closed ? "a polygon needs at least 3 points" : "a line needs at least 2 points") +
         ": click " + std::to_string(needed - chain_.size()) + " more in photo " + std::to_string(chainPhoto_) +
         ", or Escape to cancel");
    return;
  }
  if (edit([&] { doc_.addChain(chain); })) {
    setStatus(std::string(chain.closed ? "polygon" : "line") + " of " + std::to_string(chain.points.size()) +
              " points added");
    chain_.clear();
    chainPhoto_ = -1;
  }
}

void Editor::closeClonePolygon() {
  if (exemplarHole_.empty()) {
    clonePolygonClosed_ = true;
    cloneDirty_ = true;
    setStatus("clone: now paint the target region on the mesh (left drag in the 3D view)");
    return;
  }
  const HoleExemplar exemplar{clonePhoto_, clonePolygon_};
  const std::vector<int> hole = exemplarHole_;
  const int region = exemplarRegion_;
  if (edit([&] { doc_.setHoleExemplar(hole, hole.front(), exemplar); })) {
    setStatus("region " + std::to_string(region) + " now takes its texture from photo " +
              std::to_string(exemplar.photo) + ": the next run synthesises it");
    cancelInProgress();
    tool_ = Tool::Point;
  }
}

void Editor::cancelInProgress() {
  exemplarHole_.clear();
  exemplarRegion_ = -1;
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

bool Editor::button(const char* label, const ImVec2* size, const std::string& scriptName) {
  const bool pressed = ImGui::Button(label, size ? *size : ImVec2(0, 0));
  std::string name = scriptName.empty() ? label : scriptName;
  if (auto pos = name.find("##"); pos != std::string::npos) name = name.substr(0, pos);
  scriptButton(name);
  return pressed;
}

void Editor::sameLineIfFits(float width) {
  const float right = ImGui::GetItemRectMax().x + ImGui::GetStyle().ItemSpacing.x + width;
  if (right <= ImGui::GetWindowPos().x + ImGui::GetWindowContentRegionMax().x) ImGui::SameLine();
}

float Editor::checkboxWidth(const char* label) {
  const ImGuiStyle& style = ImGui::GetStyle();
  return ImGui::GetFrameHeight() + style.ItemInnerSpacing.x + ImGui::CalcTextSize(label).x;
}

void Editor::scriptButton(const std::string& name) {
  // The part of the button on screen (a panel may clip it), so that a scripted click lands on it.
  const ImVec2 clipLo = ImGui::GetWindowDrawList()->GetClipRectMin(),
               clipHi = ImGui::GetWindowDrawList()->GetClipRectMax();
  const ImVec2 lo(std::max(ImGui::GetItemRectMin().x, clipLo.x), std::max(ImGui::GetItemRectMin().y, clipLo.y));
  const ImVec2 hi(std::min(ImGui::GetItemRectMax().x, clipHi.x), std::min(ImGui::GetItemRectMax().y, clipHi.y));
  if (hi.x > lo.x && hi.y > lo.y)
    buttonRects_[name] = Rect{lo.x, lo.y, hi.x - lo.x, hi.y - lo.y};
  else
    buttonRects_.erase(name);  // scrolled out of sight: a scripted click waits for it
}

}  // namespace montage
