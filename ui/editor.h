// The TextureMontage editor: a GLFW window with Dear ImGui panels (3D view, image panes, feature
// list, tools, history, pipeline report, status bar) over the GL-free Document, with the pipeline in
// a background PipelineWorker. One Editor object owns all editor state (no function-local statics);
// its members are destroyed in reverse order of declaration, GL objects before the GL context.
//
// Frame order (docs/editor.md): poll events; synthetic script input; build the UI (the only place
// the document changes); take the worker's finished result; submit the newest snapshot; autosave;
// upload dirty GPU buffers; render the 3D view; render ImGui; screenshots; swap.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "autosave.h"
#include "document.h"
#include "file_dialog.h"
#include "geometry/bvh.h"
#include "image/cutout.h"
#include "input_queue.h"
#include "io/mesh_io.h"
#include "layout.h"
#include "navigation.h"
#include "progress.h"
#include "script.h"
#include "view_math.h"
#include "worker.h"

struct GLFWwindow;
struct ImGuiIO;
struct ImVec2;
struct ImDrawList;

namespace montage {

class ShaderProgram;
class Texture;
class Framebuffer;
class VertexBuffer;
struct OverlayGl;

struct EditorOptions {
  std::string file;              // project (.json) or mesh to open; empty: start empty
  std::string screenshot;        // save the window as PNG after `frames` frames, then exit
  int frames = 3;                // frames rendered before the screenshot
  bool waitWorker = true;        // --screenshot: wait for the worker's result first
  std::string script;            // script of UI actions (docs/editor.md)
  double autosaveSeconds = 120;  // autosave interval
  int width = 1280, height = 800;
  std::string benchOrbit;      // mesh: orbit benchmark
  bool benchWorker = false;    // with `file`: UI frame times while the worker runs
  bool benchOverlays = false;  // with `file`: frame times with every overlay shown against none, one run
  int benchFrames = 240;
  bool vsync = true;
  double scale = 0;  // UI scale (fonts and sizes); 0: the monitor's content scale (glfwGetWindowContentScale)
};

enum class Tool { Point, Line, Polygon, Stroke, Clone, Cutout };
inline constexpr std::array<const char*, 6> kToolNames = {"point", "line", "polygon", "stroke", "clone", "cutout"};

// What a drag in a photo does with the cut-out tool: draw the rectangle GrabCut starts from, a foreground
// or background stroke (GrabCut runs again), or the mask brush (add, erase; no GrabCut).
enum class CutoutMode { Rect, Foreground, Background, Add, Erase };
inline constexpr std::array<const char*, 5> kCutoutModeNames = {"rect", "foreground", "background", "add", "erase"};

// Colour faces of the 3D view by...
enum class FaceColoring { None, Patches, Empty, Stretch, SeamError };
inline constexpr std::array<const char*, 5> kFaceColoringNames = {"none", "patches (photo)", "empty faces",
                                                                  "stretch heatmap", "seam error heatmap"};

// One keyboard shortcut, for the Help window and docs/editor.md.
struct Shortcut {
  const char* keys;
  const char* action;
};
const std::vector<Shortcut>& editorShortcuts();

class Editor {
 public:
  explicit Editor(EditorOptions options);  // creates the window; throws montage::Error when it cannot
  ~Editor();
  Editor(const Editor&) = delete;
  Editor& operator=(const Editor&) = delete;
  // Runs until quit; returns the exit status (non-zero when a script failed).
  int run();

  // A rectangle in window pixels.
  struct Rect {
    double x = 0, y = 0, w = 0, h = 0;
    bool contains(double px, double py) const { return px >= x && py >= y && px < x + w && py < y + h; }
  };

 private:
  // --- Loaded inputs the UI edits against (independent of the pipeline, which may fail).
  struct PhotoSlot {
    std::string key;                     // path + mask: reloaded when it changes
    std::shared_ptr<const Photo> photo;  // null when it failed to load
    std::string error;
    std::unique_ptr<Texture> texture, mask;
    std::unique_ptr<Texture> balanced;    // the colour-balanced photo of the last result (before/after)
    const Photo* balancedFrom = nullptr;  // which balanced photo `balanced` holds
    PaneView tabView, gridView;
  };
  // One step of the cut-out tool, as the user drew it: a rectangle (GrabCut starts over from it), a
  // foreground or background stroke (GrabCut runs again) or a brush stroke (the mask edited, no GrabCut).
  // Steps drawn while GrabCut runs wait in the session's queue and are applied, in order, after it.
  struct CutoutStep {
    CutoutMode mode = CutoutMode::Rect;
    cv::Rect2d rect;      // Rect
    CutoutStroke stroke;  // the other modes
  };
  // The cut-out as it stands after some steps: the tool's undo and redo put it back exactly.
  struct CutoutState {
    std::unique_ptr<Cutout> cut;
    PackedMask mask;  // run-length encoded: a step costs kilobytes, not a full-size copy
    std::vector<CutoutStroke> strokes;
    std::optional<cv::Rect2d> rect;
    double seconds = 0;
    std::string label;  // the step made from this state (undo stack) or undone back to it (redo stack)
  };
  // The cut-out tool's session on one photo (editor_photos.cpp). GrabCut runs on a helper thread: the
  // Cutout object travels to it and back, so the UI never touches it while it runs.
  struct CutoutSession {
    int photo = -1;
    std::string key;  // the photo slot's key when the session started: a reload ends the session
    std::unique_ptr<Cutout> cut;
    struct JobResult {
      std::unique_ptr<Cutout> cut;  // the Cutout back
      std::string error;            // why the step failed ("": it did not)
      cv::Mat mask;                 // its feathered mask, made on the helper thread (12 MP: not on the UI's)
      cv::Mat overlay;              // and the tint's alpha (cutoutOverlay), made there too
    };
    std::future<JobResult> job;
    cv::Mat mask;                      // last result, photo pixels as shown (CV_8UC1, 0..255)
    std::unique_ptr<Texture> overlay;  // `mask` as a tint
    cv::Mat overlayImage;              // the tint of `mask` to upload (setCutoutMask; empty: made at upload)
    bool overlayDirty = false;
    std::vector<CutoutStroke> strokes;  // drawn so far (shown)
    std::vector<Vec2> path;             // being drawn
    bool drawing = false;
    Vec2 dragStart = Vec2::Zero();
    std::optional<cv::Rect2d> rect;
    double seconds = 0;
    // The tool's own history (Ctrl+Z / Ctrl+Y undo and redo its steps before the document's edits): the
    // states before each step, newest last, and the states undone.
    std::vector<CutoutState> undo, redo;
    std::deque<CutoutStep> queue;      // drawn while GrabCut runs: applied in order when it has finished
    std::vector<CutoutStep> unqueued;  // queued steps taken back by undo before they ran (redo queues them)
    std::string jobLabel;              // what the running job applies ("rectangle", "2 strokes")
    bool jobGrabCut = true;            // it runs GrabCut (a brush step or a feather change only makes the mask)
    bool jobStep = true;               // it is an undo step (a feather change is not)
    int undoAfterJob = 0;              // undos asked for while GrabCut ran with nothing queued
    int docPosition = 0;               // the document's history position at the tool's last step, undo or redo
    long stepsApplied = 0;             // steps applied so far (tests: no stroke is lost)
  };
  struct InputMesh {
    std::string path;
    std::shared_ptr<const Mesh> mesh;
    std::unique_ptr<TriangleBvh> bvh;
    std::vector<Vec3> faceCentroids;
    std::string fingerprint;  // meshFingerprint, for the anchors a save writes
    Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();
    std::string error;
  };
  // Synthetic input of one frame (scripts), or an action to run at that point of the queue.
  struct InputStep {
    bool hasPointer = false;
    double x = 0, y = 0;
    std::array<bool, 3> buttons = {false, false, false};
    float wheel = 0;
    std::vector<int> keys;
    bool ctrl = false, shift = false, alt = false;
    std::function<void()> call;  // run instead of input when set
  };

  // Lifecycle and frame (editor.cpp).
  void initWindow();
  void applyScale(float scale);  // fonts and style sizes for a UI scale (HiDPI)
  // A splitter bar the user drags (layout.h): resizes the panels around it.
  void splitter(const char* name, const LayoutRect& bar, bool vertical, float top, float bottom);
  void rememberLayout();  // writes layout.json when the layout, grid choice or bindings changed
  void shutdownWindow();
  void frame();
  void applyRealInput(ImGuiIO& io);  // the next step of realInput_ into ImGui's IO
  void buildUi();
  void menuBar();
  // Menus that the script's `menu` verb can drive ("File/Save"): like ImGui::BeginMenu / MenuItem, and a
  // requested item is "clicked" even while its menu is closed (then nothing is drawn).
  bool beginMenu(const char* label, bool enabled = true);
  void endMenu();
  void menuSeparator();
  bool menuItem(const char* label, const char* shortcut = nullptr, bool selected = false, bool enabled = true);
  bool menuToggle(const char* label, const char* shortcut, bool* value, bool enabled = true);
  void statusBar(const Rect& r);
  void runControls();  // status bar: progress weighted by stage times, time left, Cancel / Run
  void cancelRun();
  void toolsPanel();
  void listsPanel();
  void featuresTab();
  void chainsTab();
  void strokesClonesTab();
  void historyTab();
  void pipelineTab();
  void photosTab();
  void errorsWindow();
  void helpWindow();
  void modals();
  void shortcuts();
  // Keyboard shortcuts, as ImGui sees them (every real press is seen down for a frame, with the modifiers
  // held at that press: applyRealInput).
  bool keyPressed(int key) const;
  bool ctrlHeld() const;
  bool shiftHeld() const;
  void pollWorker();
  void autosaveTick();
  void syncInputs();  // load the mesh / photos the document names
  void validateSelection();
  // A point as the user knows it: its id (pointId), which deleting another point does not change; of the
  // document, or of the project the result was computed from (its rejected pairs and coverage).
  std::string pointName(int point) const;
  std::string resultPointName(int point) const;
  // ImGui::Button that scripts can click, by its label (without ##...) or by `scriptName` when given.
  bool button(const char* label, const ImVec2* size = nullptr, const std::string& scriptName = "");
  void scriptButton(const std::string& name);  // the last item is clickable by scripts as `name`
  // Layout helpers that keep a row from clipping: SameLine when an item `width` pixels wide still fits the
  // window's row, else a new row; the width of a checkbox with its label.
  static void sameLineIfFits(float width);
  static float checkboxWidth(const char* label);

  // Files (editor.cpp).
  bool openFile(const std::string& path);
  void requestOpen();
  bool saveTo(const std::string& path);
  void save();
  void requestSaveAs();
  void requestExport();
  void requestAddPhotos(bool folder);  // a folder of photos, or files
  std::string projectFolder() const;   // where file dialogs start: the project's (or mesh's) folder
  bool exportTo(const std::string& path);
  void addPhotosFrom(const std::string& path);
  // Adds images (and every image of the folders) among `paths` as one undo step; returns how many.
  int addPhotoFiles(const std::vector<std::string>& paths);
  // Files dropped on the window (GLFW's drop callback, or the script's drop): a project or mesh opens,
  // images are added to the project.
  void handleDrop(const std::vector<std::string>& paths);
  bool relinkPhoto(int photo, const std::string& path);
  bool relinkMesh(const std::string& path);
  void missingFilesWindow();
  void requestClose();
  void guardUnsaved(std::function<void()> then);  // asks when there are unsaved changes
  void reportError(const std::string& message);   // listed once in the Errors window, shown in the status bar
  // An error of a user's operation ("save", "export"): listed as reportError does, and taken off the list
  // when the same operation next succeeds (operationSucceeded), so the count shows only what still fails.
  void reportOperationError(const std::string& operation, const std::string& message);
  void operationSucceeded(const std::string& operation);
  // A slip (a refused edit: a one-point line, a click outside the photo...): an inline hint in the Tools
  // panel and the status bar, not an error in the list.
  void hint(const std::string& message);
  void setStatus(const std::string& message);
  std::string autosavePath() const;
  void checkRecovery();

  // Edits (editor.cpp): every document change goes through these, catching montage::Error.
  template <class Fn>
  bool edit(Fn&& fn) {
    try {
      fn();
      return true;
    } catch (const Error& e) {
      // A refused edit leaves the document as it was (Document applies edits to a copy).
      hint(e.what());
      return false;
    }
  }
  void undo();
  void redo();
  void deleteSelection();
  void finishChain();
  void cancelInProgress();
  void selectVertex(int vertex);

  // 3D view (editor_view.cpp).
  void view3d();
  void view3dInput(const Rect& r);
  void renderScene();
  void uploadMesh();
  void uploadOverlay();
  void uploadLines();
  void drawViewLabels(const Rect& r);
  Camera viewCamera() const;
  VertexPick pickAt(double screenX, double screenY) const;
  void strokeAt(double screenX, double screenY);
  void paintCloneAt(double screenX, double screenY, bool erase);
  void updateClonePreview();
  CloneOp currentCloneOp() const;  // the clone tool's operation as set up so far
  bool resultUsable() const;       // a result for the document's mesh (preview or final)
  // What the 3D view shows of the result: the final bake's model, else the preview model; null when
  // there is no usable result.
  const TexturedModel* shownModel() const;

  // Image panes (editor_panes.cpp).
  void photosPanel();
  void photoCanvas(int photo, const Rect& r, PaneView& view, bool showName);
  int hitPosition(int photo, const PaneView& view, double sx, double sy, double radius) const;

  // Photos: the list (add, remove, reorder, mirror, lock, relink, mask) and the cut-out tool
  // (editor_photos.cpp).
  void cutoutPanel();
  void cutoutCanvas(int photo, const PaneView& view, bool hovered);
  bool startCutout(int photo, bool fromCurrentMask);
  // Runs `step` on the helper thread, then the feathered mask and its tint; `label` names it in the busy state and
  // the Edit menu.
  void runCutout(std::function<void(Cutout&)> step, const std::string& label, bool grabCut = true, bool undoStep = true);
  void pollCutout();
  // A drawn step: applied now, or queued while GrabCut runs (applyCutoutQueue takes it then).
  void cutoutStep(const CutoutStep& step);
  void applyCutoutQueue();                        // applies queued steps until one starts GrabCut or none is left
  void pushCutoutUndo(const std::string& label);  // the state before a step, onto the tool's undo stack
  CutoutState takeCutoutState(const std::string& label);
  void restoreCutoutState(CutoutState&& state);
  // The cut's mask, and its tint when made with it (cutoutOverlay; empty: made where it is drawn), to upload.
  void setCutoutMask(cv::Mat mask, cv::Mat tint = {});
  // Whether Ctrl+Z / Ctrl+Y go to the cut-out tool's steps rather than to the document's history: the tool is
  // in use on a cut with steps, and no document edit came after its last step.
  bool cutoutOwnsUndo() const;
  bool cutoutOwnsRedo() const;
  std::string cutoutUndoLabel() const;  // what the tool's undo / redo would take back, for the Edit menu
  std::string cutoutRedoLabel() const;
  void cutoutUndo();
  void cutoutRedo();
  bool applyCutoutMask();
  std::string newMaskPath(int photo) const;
  // Where masks of a project not saved yet go: a folder of this editor session under editorStateDir(),
  // moved beside the project when it is first saved (moveUnsavedMasks), never the mesh's or a photo's.
  std::string unsavedMaskFolder() const;
  // Before saving to `projectFile`: copies the masks the document names from unsavedMaskFolder() into the
  // project's masks/ folder and renames them in the document (every undo step too); returns the copies'
  // sources, removed once the save has succeeded.
  std::vector<std::string> moveUnsavedMasks(const std::string& projectFile);
  void uploadBalanced(PhotoSlot& slot, int photo);

  // Camera feedback in the panes (editor_camera.cpp): wireframe and silhouette, residuals, outliers,
  // the selected vertex's predicted position, proposals; the path of each photo in its caption.
  struct CameraLines {
    std::vector<std::pair<Vec2, Vec2>> wire, silhouette;  // photo pixels
  };
  const CameraFit* photoFit(int photo) const;  // the last result's fit of a photo, or nullptr
  void buildCameraLines();
  void cameraToolbar();
  void cameraOverlay(int photo, const PaneView& view, ImDrawList* draw, const Vec2& mouse, bool hovered,
                     std::string& tooltip);
  // The proposal markers (diamonds) of a photo pane, drawn after its points.
  void proposalMarkers(int photo, const PaneView& view, ImDrawList* draw, const Vec2& mouse, bool hovered,
                       std::string& tooltip);
  // Photos whose camera fit passes but is weak (plain_words.h weakFitConcerns), with why; the banner
  // over the photo panes names them.
  std::vector<std::pair<int, std::vector<std::string>>> weakFits() const;
  void weakFitBanner();
  // Indices into result_->proposals of `photo`'s proposals not yet clicked nor declined.
  std::vector<int> pendingProposals(int photo) const;
  bool clickProposal(int photo, bool decline);  // true when the click went to a proposal
  std::string cameraCaption(int photo) const;
  // The usable result's map choice for photo `photo` of another subject (warp or the paper's map), or null.
  const SubjectChoice* subjectChoice(int photo) const;

  // Coverage tab (editor_coverage.cpp): the empty regions of the result with why and the fix, where to
  // click next, fly to a region (and outline it), rejected pairs by reason.
  const CoverageReport* coverage();  // of the current result (computed once per result), or nullptr
  void coverageTab();
  void flyToRegion(int index);
  void appendCoverageLines(std::vector<float>& lines);  // the highlighted region's edges (uploadLines)
  nlohmann::json coverageState() const;
  // Its own holeModes entry (its fill mode, and the photo region its texture comes from), if the project gives one.
  const HoleMode* regionHoleMode(int region) const;
  std::vector<int> regionFaces(int region) const;              // its faces (the mesh ids holeModes use)
  void holeFillCombo(int region);                 // its fill, and the photo region its texture comes from
  // The clone tool's polygon, once closed, becomes the texture source of a hole (exemplarHole_) instead of a
  // clone's source.
  void pickHoleTexture(int region);
  void closeClonePolygon();

  // Scripts, screenshots, benchmarks (editor_script.cpp).
  void applySyntheticInput(ImGuiIO& io);
  void scriptStep();
  void runAction(const ScriptAction& action);
  // `onEvents`: frames meanwhile wait for events as a user's editor does (worker waits), instead of
  // running back to back.
  void waitFor(const std::string& what, double seconds, std::function<bool()> condition, bool onEvents = false);
  void queueClick(double x, double y, int button = 0);
  // Runs `queue` on an empty input queue and puts what it queued before the steps already waiting.
  void queueFirst(const std::function<void()>& queue);
  // Clicks the script button `label` once its place has held for a frame (retries up to `attempts` times).
  void queueButtonClick(const std::string& label, const std::string& where, int attempts);
  void queueDrag(double x0, double y0, double x1, double y1, int button, int steps = 8);
  void queueKey(const KeyCombo& combo);
  void writeState(const std::string& path) const;
  void takeScreenshot(const std::string& path);
  void benchOrbitStep();
  void benchReport();
  // Navigation (editor_navigation.cpp).
  void frameAll();
  void frameSelected();
  void setViewPreset(ViewPreset preset);
  void navigationShortcuts();
  void navigationMenu();
  // Overlays from vertex buffers (editor_overlays.cpp).
  void initOverlays();
  void drawPaneOverlay(int photo, const PaneView& view, int focusPoint);
  void drawCameraWire(int photo, const PaneView& view);  // the camera feedback's wireframe and silhouette
  void updatePaneOverlay(int photo, int focusPoint);     // the pane's buffer, rebuilt when it changed
  bool updateCameraWire(int photo);                      // same for the camera lines; false: none
  void addPaneDraw(ImDrawList* draw, int photo, const PaneView& view, bool camera);
  // The pane's photo, mask (0: none), buffer and camera lines from its cache, rendered again when they or
  // `content` (what else identifies the textures' pixels) changed (editor_overlays.cpp).
  void drawPaneCached(int photo, const Rect& r, const PaneView& view, unsigned photoTexture, unsigned maskTexture,
                      const std::string& content, int focusPoint);
  bool paneCached_ = false;  // the pane being drawn comes from its cache (the camera lines are in it)
  int paneRejectedCount(int photo, bool* allDrawn) const;
  void readViewDepth(const Mat4f& view, const Mat4f& projection);  // after the mesh: id visibility
  void drawMarkers(const Mat4f& view, const Mat4f& projection);
  void drawFeatureLabels(const Rect& r, const Camera& cam);
  void benchOverlaysStep();  // editor_bench.cpp
  void benchOverlaysReport();
  void setOverlaysShown(bool on);  // features, ids, paths, pane markers, curves, rejected pairs, camera feedback
  bool resultCurrent() const;

  EditorOptions options_;
  GLFWwindow* window_ = nullptr;
  bool imguiReady_ = false;
  int exitStatus_ = 0;
  bool quit_ = false;
  long frameNumber_ = 0;
  float scale_ = 1;          // UI scale: fonts and sizes (HiDPI); px() scales a size given for scale 1
  float pendingScale_ = 0;   // the monitor's content scale changed (GLFW callback): applied next frame
  LayoutPrefs layout_;       // splitter positions, grid or tabs, mouse bindings (remembered)
  std::string savedLayout_;  // layout_ as last written
  bool splitterActive_ = false;
  std::map<std::string, Rect> splitterRects_;  // last frame's splitter bars (scripts, state)
  float px(float v) const { return v * scale_; }
  double lastFrameSeconds_ = 0, frameMs_ = 0;

  // GL objects (destroyed in shutdownWindow, before the context).
  std::unique_ptr<ShaderProgram> meshShader_, lineShader_, textureShader_;
  std::unique_ptr<Framebuffer> viewFbo_;
  std::unique_ptr<VertexBuffer> meshVbo_, lineVbo_, pointVbo_, selectionVbo_, cloneVbo_;
  // Material textures by content hash: the shown model's, and the unused ones of the model shown before
  // it (a drag's preview after a final finds its photos still on the GPU).
  std::map<std::uint64_t, std::unique_ptr<Texture>> textureCache_, spareTextures_;
  // The content hashes of the textures of the shown model and the one before, by pixel buffer, each
  // buffer held so that its address stays its own: a next result's textures that are the same buffers (a
  // preview's photos after a final) are not hashed again. Results are immutable: a buffer's content
  // never changes.
  std::map<const unsigned char*, std::pair<cv::Mat, std::uint64_t>> textureHashes_, spareHashes_;
  std::vector<unsigned> materialTextureIds_;                         // per material: GL texture or 0
  std::vector<std::pair<int, std::pair<int, int>>> materialRanges_;  // material, [first vertex, count)
  std::vector<int> gpuFaceOrder_;                                    // faces in upload order (sorted by material)
  int lineVertices_ = 0, pathLineVertices_ = 0, pointVertices_ = 0, cloneVertices_ = 0;

  // Document and pipeline.
  Document doc_;
  std::unique_ptr<PipelineWorker> worker_;
  long submittedRevision_ = -1, submittedGeneration_ = 0;
  // Edit -> result on screen: when each generation was submitted, and the last latency per tier
  // (seconds from the submit to the end of the frame that first drew the result; -1 = none yet).
  struct Submitted {
    std::chrono::steady_clock::time_point at;
    long frame = 0;  // the frame number then
  };
  std::map<long, Submitted> submittedAt_;
  long shownGeneration_ = -1;  // generation taken this frame, measured after it is drawn
  std::array<double, kTierNames.size()> shownLatency_ = {-1, -1, -1};  // by Tier
  // The last latency per tier split into its parts, in seconds: submit -> worker start (waiting for a
  // cancelled run to stop), the pipeline run, the preview model, published -> taken by the UI, taken ->
  // drawn (mesh upload, frame); and the UI frames drawn meanwhile (they share the cores with the worker).
  struct LatencyParts {
    double queue = -1, pipeline = -1, model = -1, take = -1, draw = -1;
    long frames = -1;
  };
  std::array<LatencyParts, kTierNames.size()> shownParts_;
  OutcomeTimes shownTimes_;  // of the outcome taken this frame
  std::chrono::steady_clock::time_point takenAt_;
  std::shared_ptr<const PipelineResult> result_;
  std::shared_ptr<const TexturedModel> resultPreview_;  // the worker's preview model of result_ (preview tier)
  long resultGeneration_ = 0;
  std::vector<std::pair<long, Tier>> outcomes_;  // every outcome taken, in order, and its tier (tests: newest wins)
  std::map<long, long> generationRevision_;
  std::string lastError_;
  long lastErrorGeneration_ = 0;
  std::vector<std::string> errors_;                          // shown in the Errors window, newest last
  std::multimap<std::string, std::string> operationErrors_;  // operation -> its errors still listed
  bool showErrors_ = false, showHelp_ = false;
  std::string status_;
  double statusTime_ = 0;
  std::string hint_;  // the last slip (Tools panel and status bar)
  double hintTime_ = 0;
  std::string lastProblem_;                    // the last error or hint (scripts name it when an action fails)
  RunProgress progress_;                       // stage weights from the last runs (status bar)
  bool cancelled_ = false;                     // the user cancelled the run of the current document
  double cancelAt_ = -1, cancelSeconds_ = -1;  // when Cancel was pressed; how long the job took to stop
  std::map<std::string, Rect> statusParts_;    // status bar parts as drawn last frame (state: never overlap)
  double errorTime_ = 0;                       // when the newest error was listed

  InputMesh input_;
  std::vector<PhotoSlot> photos_;
  std::vector<double> stretch_;  // per model face, from the result (NaN: empty)

  // Tools and selection.
  Tool tool_ = Tool::Point;
  int selectedVertex_ = -1, selectedPoint_ = -1;
  int activePhoto_ = 0;
  int shownTab_ = -1;  // the photo tab ImGui showed last frame
  bool gridPanes_ = false;
  std::vector<int> chain_;  // chain in progress (point indices)
  int chainPhoto_ = -1;
  std::vector<int> stroke_;  // stroke in progress (vertices)
  std::vector<Vec2> clonePolygon_;
  int clonePhoto_ = -1;
  bool clonePolygonClosed_ = false;
  std::set<int> cloneFaces_;
  int cloneAnchorVertex_ = -1;
  double cloneRotationDeg_ = 0, clonePixelsPerUnit_ = 0;
  float cloneBrush_ = 0.06f;  // brush radius as a fraction of the mesh's bounding-box diagonal
  bool cloneDirty_ = false;
  std::vector<int> exemplarHole_;  // the hole whose texture source the clone tool's polygon is (empty: a clone)
  int exemplarRegion_ = -1;        // its coverage region when the pick began (for messages)
  int dragPoint_ = -1, dragPhoto_ = -1;
  bool dragging_ = false;
  double pressX_ = 0, pressY_ = 0;
  bool viewPressed_ = false;
  int viewPressButton_ = -1;
  bool viewDragged_ = false;
  ClickDrag clickDrag_;
  Vec3 orbitPivot_ = Vec3::Zero();
  bool frameWhenShown_ = false;
  ViewState pendingView_;          // the camera an opened project was saved with: applied once its mesh is shown
  bool orbitAtPick_ = true;        // orbit about the surface point under the cursor at the press
  bool reducedNavigation_ = true;  // the 3D view drawn at reduced resolution while the camera moves
  NavigationMotion viewMotion_;    // camera changes frame by frame
  std::string viewCameraKey_;      // the camera the motion was last checked against
  int viewDivisor_ = 1;            // the view's framebuffer: viewRect_ divided by this per axis
  long reducedRedraws_ = 0, fullRedraws_ = 0;  // 3D-view redraws at reduced and at full size
  int reducedSize_[2] = {0, 0};                // the last reduced redraw's framebuffer size
  MouseBindings bindings_ = MouseBindings::MeshLab;

  // Display.
  OrbitCamera camera_;
  bool textured_ = true, wireframe_ = false, showPaths_ = true, showFeatures_ = true, showIds_ = true;
  bool showMask_ = true, showCurves_ = true, showRejected_ = true, showPaneIds_ = true;
  bool showCamera_ = true;                // camera feedback in the panes
  bool proposalsButton_ = false;          // the Accept proposals button is shown (a photo of the object fits a camera)
  int hoverProposal_ = -1;                // proposal under the mouse (index into result_->proposals)
  std::vector<CameraLines> cameraLines_;  // per photo, for the result cameraLinesFor_
  const void* cameraLinesFor_ = nullptr;
  FaceColoring coloring_ = FaceColoring::None;
  bool meshDirty_ = true, overlayDirty_ = true, linesDirty_ = true;
  const void* uploadedModel_ = nullptr;  // what the mesh buffer holds (model or input mesh)
  long linesRevision_ = -1;
  long uploadCount_ = 0;  // buffers uploaded so far: part of the scene key
  std::string sceneKey_;  // what the 3D view's framebuffer shows; redraw when it changes
  Rect viewRect_, paneRect_, windowRect_;
  Rect weakBannerRect_;              // the weak camera fit banner this frame (empty: none)
  std::map<int, Rect> canvasRects_;  // per photo, last frame
  std::map<std::string, Rect> buttonRects_;
  std::vector<char> featureVisible_;  // per feature point, from the 3D view's depth when it was last drawn
  std::vector<int> drawnLabels_;      // the point ids labelled in the 3D view's last frame (script state)
  std::unique_ptr<OverlayGl> overlayGl_;
  int hoverVertex_ = -1;      // vertex under the cursor (3D view) or of the hovered photo point
  int hoverVertexNext_ = -1;  // being found this frame
  double hoverPickX_ = -1, hoverPickY_ = -1;
  int hoverPick_ = -1;  // 3D pick at (hoverPickX_, hoverPickY_) from hoverPickEye_
  Vec3 hoverPickEye_ = Vec3::Zero();

  // Coverage.
  std::shared_ptr<const CoverageReport> coverage_;
  const void* coverageFor_ = nullptr;     // the result coverage_ describes
  std::vector<int> coverageRegionOf_;     // per mesh face (Project::holeModes ids): its coverage_ region, or -1
  int coverageRegion_ = -1;               // the highlighted region
  bool showExpectedRejected_ = false;     // list rejected pairs around no empty region too
  std::string requestedTab_;              // lists-panel tab to select next frame (script `tab`)
  int listsTab_ = 0;                      // the Document panel's tab shown (Points ... Coverage)
  std::map<std::string, Rect> tabRects_;  // its tab buttons, last frame, unclipped
  std::string requestedMenu_;             // menu item to activate next frame (script `menu`), "File/Save"
  std::string menuFailed_;                // a requested item that was not found or disabled
  std::string menuListFile_;              // script `menu_list`: the next menu bar walks every menu, writes here
  nlohmann::json menuList_;               // the items walked so far: {"path", "enabled"}
  struct MenuLevel {
    std::string path;
    bool open = false;  // ImGui drew it (else only a script's request walks through it)
  };
  std::vector<MenuLevel> menuStack_;

  // Files.
  FileDialogs dialogs_;
  RecentFiles recent_;
  std::string pendingRecent_;  // opened file that joins the recent list once its mesh has loaded
  AutosaveClock autosaveClock_;
  std::future<std::string> autosaveJob_;  // error text ("" on success)
  long autosaveJobRevision_ = -1;
  long autosavedRevision_ = -1;
  std::string lastAutosavePath_;
  std::vector<RecoveryCandidate> recovery_;
  bool recoveryPopup_ = false;
  std::function<void()> afterUnsaved_;
  bool unsavedPopup_ = false;
  std::string exportFormat_ = ".glb";
  std::vector<MissingFile> missing_;  // what the opened project names but is not there (relink offered)
  bool missingPopup_ = false;
  std::vector<std::string> dropped_;  // files dropped on the window, handled in the next frame
  RealInputQueue realInput_;          // keys, characters, buttons and moves from GLFW, handed to ImGui a step per frame
  bool realPresses_ = false;  // the last frame took a key, character or button: one more frame draws its outcome
  std::string sessionId_;     // this editor process (pid, start time): its unsaved-mask folder's name

  // Photos and the cut-out tool.
  CutoutSession cutout_;
  CutoutMode cutoutMode_ = CutoutMode::Rect;
  float cutoutRadius_ = 8;     // stroke and brush radius, photo pixels
  float cutoutFeather_ = 0;    // feathered edge of the mask written, photo pixels
  double cutoutDelay_ = 0;     // seconds each GrabCut run waits first (script `cutout_delay`: tests of the queue)
  bool showBalanced_ = false;  // photo panes: the colour-balanced photos of the last result (after) or the files

  // Scripts and benchmarks.
  std::vector<ScriptAction> script_;
  size_t scriptPos_ = 0;
  bool scripted_ = false;
  std::deque<InputStep> inputQueue_;
  InputStep frameInput_;          // this frame's synthetic input
  double heldX_ = 0, heldY_ = 0;  // synthetic pointer position, kept between steps
  std::vector<int> syntheticKeys_;
  std::function<bool()> waitUntil_;
  bool waitOnEvents_ = false;
  bool waitRealInput_ = false;  // script `real_input`: the X mouse and keyboard drive the editor meanwhile
  double waitDeadline_ = 0;
  std::string waitWhat_;
  std::string pendingScreenshot_;
  bool benchOrbit_ = false;
  std::vector<double> benchTimes_, benchBusyTimes_;
  int benchFrame_ = 0;
  bool benchWasBusy_ = false;
  struct OverlayBench {
    int frame = 0;
    bool full = true;
    double lastCpu = 0;
    std::vector<double> bareTimes, fullCpu, bareCpu;
    std::string load;
  } bench_;
};

}  // namespace montage
