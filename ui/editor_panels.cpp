// The editor's menus and panels: menu bar, tools, lists (features, chains, strokes and clones, history,
// pipeline), status bar, errors, help, modals and keyboard shortcuts.
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>

#include "base/fileio.h"
#include "editor.h"
#include "gl.h"
#include "image/photo.h"
#include "io/mesh_io.h"
#include "io/model.h"
#include "overlays.h"
#include "plain_words.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

double now() {
  return glfwGetTime();
}

std::string timeText(std::time_t t) {
  char buffer[64];
  std::strftime(buffer, sizeof(buffer), "%Y-%m-%d %H:%M:%S", std::localtime(&t));
  return buffer;
}

const char* const kToolKeys[] = {"P", "L", "G", "S", "C", "K"};
const ImVec4 kErrorColor(1.0f, 0.45f, 0.4f, 1.0f);
const ImVec4 kDimColor(0.6f, 0.6f, 0.6f, 1.0f);
const ImVec4 kHintColor(1.0f, 0.75f, 0.35f, 1.0f);

// The last item's rectangle (screen pixels).
Editor::Rect itemRect() {
  const ImVec2 lo = ImGui::GetItemRectMin(), hi = ImGui::GetItemRectMax();
  return Editor::Rect{lo.x, lo.y, hi.x - lo.x, hi.y - lo.y};
}

// The longest prefix of `text` that fits `width` pixels with "..." after it (the text when it fits).
std::string elide(const std::string& text, float width) {
  if (ImGui::CalcTextSize(text.c_str()).x <= width) return text;
  size_t lo = 0, hi = text.size();
  while (lo < hi) {
    const size_t mid = (lo + hi + 1) / 2;
    if (ImGui::CalcTextSize((text.substr(0, mid) + "...").c_str()).x <= width)
      lo = mid;
    else
      hi = mid - 1;
  }
  return text.substr(0, lo) + "...";
}

// A long message for a tooltip: lines of at most about 100 characters, broken at blanks.
std::string wrapped(const std::string& text) {
  std::string out;
  size_t column = 0;
  for (char c : text) {
    if (c == ' ' && column >= 100) {
      out += '\n';
      column = 0;
      continue;
    }
    out += c;
    column = c == '\n' ? 0 : column + 1;
  }
  return out;
}

}  // namespace

const std::vector<Shortcut>& editorShortcuts() {
  static const std::vector<Shortcut> shortcuts = {
      {"Ctrl+Z", "undo"},
      {"Ctrl+Shift+Z, Ctrl+Y", "redo"},
      {"Ctrl+O", "open a project or a mesh"},
      {"Ctrl+S", "save the project (atomic)"},
      {"Ctrl+Shift+S", "save as"},
      {"Ctrl+E", "export the current result (.glb or .obj)"},
      {"Ctrl+Q", "quit (asks when there are unsaved changes)"},
      {"P / L / G / S / C / K", "tool: point, line, polygon, stroke, clone, cut-out"},
      {"Delete, Backspace", "remove the selected point from the active photo"},
      {"Enter", "finish the line or polygon (or clone polygon) being drawn"},
      {"Escape", "cancel what is being drawn, then clear the selection"},
      {"T", "3D view: textured / shaded"},
      {"W", "3D view: wireframe on / off"},
      {"F", "3D view: frame the whole mesh"},
      {"0 ... 9", "show photo 0 ... 9 (the number on its tab) in the image pane"},
      {"F1", "this help"},
      {"3D view: left drag",
       "orbit about the point under the cursor (View > Mouse > Blender: middle drag); stroke tool: draw a stroke; "
       "clone tool: paint the target, Ctrl erases"},
      {"3D view: right or middle drag, Shift+left drag", "pan"},
      {"3D view: wheel", "zoom to the cursor"},
      {"F, Home / .", "frame all (fits width and height) / frame the selected vertex"},
      {"Ctrl+1, Ctrl+3, Ctrl+7 (numpad 1, 3, 7)", "front, right side, top view"},
      {"O (numpad 5)", "orthographic view on / off"},
      {"3D view: left click", "pick the nearest vertex of the triangle under the cursor"},
      {"Photo: left click", "point tool: attach the selected vertex here (or select a point)"},
      {"Photo: left drag on a point", "move it (one undo step)"},
      {"Photo: wheel / right or middle drag", "zoom at the cursor / pan"},
      {"Photo: click the first point", "close the polygon being drawn"},
      {"Photo, cut-out tool: left drag",
       "rectangle (then strokes), foreground / background stroke, or mask brush (tool options); drawn while "
       "GrabCut runs: queued"},
      {"Cut-out tool: Ctrl+Z, Ctrl+Y", "undo / redo the cut's last stroke or rectangle (before the document's edits)"},
      {"Drop files on the window", "a project or mesh opens; photos are added"},
  };
  return shortcuts;
}

void Editor::buildUi() {
  buttonRects_.clear();
  const ImGuiIO& io = ImGui::GetIO();
  menuBar();
  // A menu command may have replaced the document (File > Open recent) or changed its photos (Edit >
  // Redo): the panels below index the loaded photos and mesh by the document's photos and vertices, so
  // they are loaded for the document as it is now (issue 35: the empty editor crashed in photoCanvas).
  syncInputs();
  const float top = ImGui::GetFrameHeight();
  const float statusH = ImGui::GetFrameHeight() + px(8);
  const float W = io.DisplaySize.x, H = io.DisplaySize.y;
  windowRect_ = Rect{0, 0, W, H};
  // The panels where the splitters put them (layout.h).
  const PanelLayout l = computeLayout(layout_, W, H, top, statusH, scale_);
  auto place = [](const LayoutRect& r) {
    ImGui::SetNextWindowPos(ImVec2(float(r.x), float(r.y)));
    ImGui::SetNextWindowSize(ImVec2(float(r.w), float(r.h)));
  };

  const ImGuiWindowFlags fixed = ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse |
                                 ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoBringToFrontOnFocus;
  place(l.tools);
  if (ImGui::Begin("Tools", nullptr, fixed)) toolsPanel();
  ImGui::End();
  place(l.document);
  if (ImGui::Begin("Document", nullptr, fixed)) listsPanel();
  ImGui::End();
  syncInputs();  // the Tools and Document panels edit too (remove, reorder, relink a photo; history)

  place(l.view);
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(0, 0));
  if (ImGui::Begin("3D view", nullptr, fixed | ImGuiWindowFlags_NoScrollbar | ImGuiWindowFlags_NoScrollWithMouse))
    view3d();
  ImGui::End();
  ImGui::PopStyleVar();

  place(l.photos);
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(px(4), px(4)));
  if (ImGui::Begin("Photos", nullptr, fixed | ImGuiWindowFlags_NoScrollbar | ImGuiWindowFlags_NoScrollWithMouse))
    photosPanel();
  ImGui::End();
  ImGui::PopStyleVar();
  hoverVertex_ = hoverVertexNext_;
  splitterActive_ = false;
  splitter("left", l.leftBar, true, top, statusH);
  splitter("tools", l.toolsBar, false, top, statusH);
  splitter("view", l.viewBar, true, top, statusH);
  rememberLayout();

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
    if (chosen->purpose == "add_photos") addPhotoFiles(chosen->paths);
    if (chosen->purpose == "relink_mesh") relinkMesh(chosen->path);
    if (chosen->purpose.rfind("relink_photo:", 0) == 0)
      relinkPhoto(std::stoi(chosen->purpose.substr(std::string("relink_photo:").size())), chosen->path);
  }
  if (!dropped_.empty()) {
    std::vector<std::string> files;
    files.swap(dropped_);
    handleDrop(files);
  }
  missingFilesWindow();
  shortcuts();
}

void Editor::splitter(const char* name, const LayoutRect& bar, bool vertical, float top, float bottom) {
  ImGui::SetNextWindowPos(ImVec2(float(bar.x), float(bar.y)));
  ImGui::SetNextWindowSize(ImVec2(float(bar.w), float(bar.h)));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(0, 0));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowMinSize, ImVec2(1, 1));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowBorderSize, 0);
  ImGui::Begin((std::string("##splitter_") + name).c_str(), nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoSavedSettings |
                   ImGuiWindowFlags_NoBackground | ImGuiWindowFlags_NoFocusOnAppearing |
                   ImGuiWindowFlags_NoScrollWithMouse);
  ImGui::InvisibleButton("##bar", ImVec2(float(std::max(1.0, bar.w)), float(std::max(1.0, bar.h))));
  const bool active = ImGui::IsItemActive(), hovered = ImGui::IsItemHovered();
  const ImGuiIO& io = ImGui::GetIO();
  if (active || hovered) {
    ImGui::SetMouseCursor(vertical ? ImGuiMouseCursor_ResizeEW : ImGuiMouseCursor_ResizeNS);
    const ImVec2 lo = ImGui::GetItemRectMin(), hi = ImGui::GetItemRectMax();
    ImGui::GetWindowDrawList()->AddRectFilled(lo, hi,
                                              active ? IM_COL32(255, 160, 60, 200) : IM_COL32(120, 160, 230, 150));
  }
  if (active && (io.MouseDelta.x != 0 || io.MouseDelta.y != 0))
    dragSplitter(layout_, name, io.MouseDelta.x, io.MouseDelta.y, io.DisplaySize.x, io.DisplaySize.y, top, bottom,
                 scale_);
  splitterActive_ = splitterActive_ || active;
  splitterRects_[name] = Rect{bar.x, bar.y, bar.w, bar.h};
  ImGui::End();
  ImGui::PopStyleVar(3);
}

void Editor::rememberLayout() {
  layout_.grid = gridPanes_;
  layout_.reducedNavigation = reducedNavigation_;
  layout_.mouse = kMouseBindingNames[static_cast<int>(bindings_)];
  if (splitterActive_ || benchOrbit_) return;  // written once the drag ends; benchmarks change nothing
  const std::string now = layout_.toJson();
  if (now == savedLayout_) return;
  saveLayout(layout_);
  savedLayout_ = now;
}

void Editor::menuBar() {
  if (!ImGui::BeginMainMenuBar()) return;
  menuStack_.clear();
  if (beginMenu("File")) {
    if (menuItem("Open project or mesh...", "Ctrl+O")) requestOpen();
    if (beginMenu("Open recent", !recent_.files().empty())) {
      for (const std::string& f : recent_.files())
        if (menuItem(f.c_str())) {
          const std::string file = f;
          guardUnsaved([this, file] {
            openFile(file);
            checkRecovery();
          });
        }
      menuSeparator();
      if (menuItem("Clear list")) recent_.clear();
      endMenu();
    }
    menuSeparator();
    const bool hasMesh = !doc_.project().mesh.empty();
    if (menuItem("Add photos...", nullptr, false, hasMesh)) requestAddPhotos(false);
    if (menuItem("Add photos folder...", nullptr, false, hasMesh)) requestAddPhotos(true);
    menuSeparator();
    if (menuItem("Save", "Ctrl+S", false, hasMesh)) save();
    if (menuItem("Save as...", "Ctrl+Shift+S", false, hasMesh)) requestSaveAs();
    if (menuItem("Export result...", "Ctrl+E", false, resultUsable())) requestExport();
    menuSeparator();
    if (menuItem("Quit", "Ctrl+Q")) requestClose();
    endMenu();
  }
  if (beginMenu("Edit")) {
    // With the cut-out tool, its own steps come first (undo() and redo() route them).
    const bool toolUndo = cutoutOwnsUndo(), toolRedo = cutoutOwnsRedo();
    const std::string undoLabel = toolUndo         ? "Undo " + cutoutUndoLabel()
                                  : doc_.canUndo() ? "Undo " + doc_.history()[doc_.position() - 1].label
                                                   : "Undo";
    const std::string redoLabel = toolRedo         ? "Redo " + cutoutRedoLabel()
                                  : doc_.canRedo() ? "Redo " + doc_.history()[doc_.position()].label
                                                   : "Redo";
    if (menuItem(undoLabel.c_str(), "Ctrl+Z", false, toolUndo || doc_.canUndo())) undo();
    if (menuItem(redoLabel.c_str(), "Ctrl+Shift+Z", false, toolRedo || doc_.canRedo())) redo();
    menuSeparator();
    if (menuItem("Delete selected point", "Delete", false, selectedPoint_ >= 0)) deleteSelection();
    if (menuItem("Clear selection", "Escape")) selectVertex(-1);
    endMenu();
  }
  if (beginMenu("View")) {
    menuToggle("Textured", "T", &textured_);
    menuToggle("Wireframe", "W", &wireframe_);
    menuToggle("Partition paths", nullptr, &showPaths_);
    menuToggle("Features", nullptr, &showFeatures_);
    menuToggle("Feature ids", nullptr, &showIds_);
    navigationMenu();
    if (beginMenu("Colour faces by")) {
      for (size_t i = 0; i < kFaceColoringNames.size(); ++i)
        if (menuItem(kFaceColoringNames[i], nullptr, coloring_ == FaceColoring(i))) {
          coloring_ = FaceColoring(i);
          overlayDirty_ = true;
        }
      endMenu();
    }
    menuSeparator();
    menuToggle("Photos in a grid", nullptr, &gridPanes_);
    if (menuItem("Reset layout")) {
      // The splitters back where they start; the grid choice and the bindings stay.
      const LayoutPrefs defaults;
      layout_.left = defaults.left, layout_.tools = defaults.tools, layout_.view = defaults.view;
    }
    menuToggle("Background mask", nullptr, &showMask_);
    menuToggle("Partition curves", nullptr, &showCurves_);
    menuToggle("Rejected pairs", nullptr, &showRejected_);
    menuSeparator();
    menuToggle("Errors", nullptr, &showErrors_);
    endMenu();
  }
  if (beginMenu("Tools")) {
    for (size_t i = 0; i < kToolNames.size(); ++i)
      if (menuItem(kToolNames[i], kToolKeys[i], tool_ == Tool(i))) {
        cancelInProgress();
        tool_ = Tool(i);
      }
    endMenu();
  }
  if (beginMenu("Help")) {
    menuToggle("Shortcuts and mouse", "F1", &showHelp_);
    endMenu();
  }
  ImGui::EndMainMenuBar();
  if (!menuListFile_.empty()) {  // script `menu_list`: every item walked this frame
    try {
      writeFileAtomic(menuListFile_, menuList_.dump(1) + "\n");
    } catch (const Error& e) {
      reportError(e.what());
    }
    menuList_ = nlohmann::json::array();
    menuListFile_.clear();
  }
  // A script's request that no enabled item answered.
  if (!requestedMenu_.empty()) menuFailed_ = requestedMenu_;
  requestedMenu_.clear();
}

namespace {

// "Open project or mesh..." and "Open project or mesh" name the same item.
std::string menuKey(std::string path) {
  while (!path.empty() && path.back() == '.') path.pop_back();
  size_t dots;
  while ((dots = path.find(".../")) != std::string::npos) path.erase(dots, 3);
  return path;
}

}  // namespace

bool Editor::beginMenu(const char* label, bool enabled) {
  const std::string path = menuStack_.empty() ? label : menuStack_.back().path + "/" + label;
  const bool open = ImGui::BeginMenu(label, enabled);
  const bool walked =
      !open && enabled &&
      ((!requestedMenu_.empty() && menuKey(requestedMenu_).rfind(path + "/", 0) == 0) || !menuListFile_.empty());
  if (!menuListFile_.empty() && !enabled) menuList_.push_back({{"path", path + "/"}, {"enabled", false}});
  if (!open && !walked) return false;
  menuStack_.push_back({path, open});
  return true;
}

void Editor::menuSeparator() {
  if (menuStack_.empty() || menuStack_.back().open) ImGui::Separator();
}

void Editor::endMenu() {
  if (menuStack_.back().open) ImGui::EndMenu();
  menuStack_.pop_back();
}

bool Editor::menuItem(const char* label, const char* shortcut, bool selected, bool enabled) {
  const bool drawn = menuStack_.empty() || menuStack_.back().open;
  bool clicked = drawn && ImGui::MenuItem(label, shortcut, selected, enabled);
  const std::string path = (menuStack_.empty() ? "" : menuStack_.back().path + "/") + label;
  if (!menuListFile_.empty()) menuList_.push_back({{"path", path}, {"enabled", enabled}});
  if (enabled && !requestedMenu_.empty() && menuKey(requestedMenu_) == menuKey(path)) {
    clicked = true;
    requestedMenu_.clear();
  }
  return clicked;
}

bool Editor::menuToggle(const char* label, const char* shortcut, bool* value, bool enabled) {
  if (!menuItem(label, shortcut, *value, enabled)) return false;
  *value = !*value;
  return true;
}

void Editor::toolsPanel() {
  // The tools in as many columns as fit the panel's width (nothing clips at any width or scale).
  float column = 0;
  for (const char* name : kToolNames) column = std::max(column, checkboxWidth(name) + ImGui::GetStyle().ItemSpacing.x);
  const int columns = std::max(1, int(ImGui::GetContentRegionAvail().x / column));
  for (size_t i = 0; i < kToolNames.size(); ++i) {
    if (i % columns != 0) ImGui::SameLine(ImGui::GetStyle().WindowPadding.x + column * (i % columns));
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
      ImGui::TextWrapped(
          "Left-drag on the mesh to draw a guidance stroke: a texture-filled hole's grain runs along it (under other "
          "fill modes the fill flows along it).");
      ImGui::Text("%zu stroke(s) in the project", p.strokes.size());
      break;
    case Tool::Cutout:
      cutoutPanel();
      break;
    case Tool::Clone: {
      if (!exemplarHole_.empty()) {
        ImGui::TextWrapped(
            "Texture for empty region %d: click the corners of a photo region whose texture should fill it (close: "
            "first point or Enter). Escape cancels.",
            exemplarRegion_);
        ImGui::Text("polygon: %zu point(s)", clonePolygon_.size());
        if (button("Cancel##exemplar")) cancelInProgress();
        break;
      }
      ImGui::TextWrapped(
          "1. Click a polygon in a photo (close: first point or Enter). 2. Paint the target on the mesh (Ctrl "
          "erases). 3. Apply.");
      ImGui::Text("polygon: %zu point(s)%s, target: %zu face(s)", clonePolygon_.size(),
                  clonePolygonClosed_ ? " (closed)" : "", cloneFaces_.size());
      ImGui::PushItemWidth(std::max(px(60), ImGui::GetContentRegionAvail().x - ImGui::CalcTextSize("px / unit").x -
                                                ImGui::GetStyle().ItemInnerSpacing.x));
      ImGui::SliderFloat("brush", &cloneBrush_, 0.01f, 0.3f, "%.2f x size");
      float rot = static_cast<float>(cloneRotationDeg_), ppu = static_cast<float>(clonePixelsPerUnit_);
      if (ImGui::SliderFloat("rotation", &rot, -180, 180, "%.0f deg")) cloneRotationDeg_ = rot, cloneDirty_ = true;
      if (ImGui::InputFloat("px / unit", &ppu, 0, 0, "%.1f"))
        clonePixelsPerUnit_ = std::max(0.f, ppu), cloneDirty_ = true;
      ImGui::PopItemWidth();
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
  // The last slip, inline where the tool is explained (no window over the view).
  if (!hint_.empty() && now() - hintTime_ < 10) {
    ImGui::PushStyleColor(ImGuiCol_Text, kHintColor);
    ImGui::TextWrapped("%s", hint_.c_str());
    ImGui::PopStyleColor();
  }
  ImGui::Separator();
  if (selectedVertex_ >= 0) {
    ImGui::Text("selected: vertex %d", selectedVertex_);
    if (selectedPoint_ >= 0) {
      ImGui::SameLine();
      ImGui::Text("(point #%s)", pointName(selectedPoint_).c_str());
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
      // Seam error comes from the seam optimisation stage (paper 4.2) of the last result.
      const bool available = FaceColoring(i) != FaceColoring::SeamError || (result_ && result_->seams);
      if (ImGui::Selectable(kFaceColoringNames[i], coloring == int(i), available ? 0 : ImGuiSelectableFlags_Disabled)) {
        coloring_ = FaceColoring(i);
        overlayDirty_ = true;
      }
      if (!available && ImGui::IsItemHovered(ImGuiHoveredFlags_AllowWhenDisabled))
        ImGui::SetTooltip("run the pipeline first: seam error comes from seam optimisation (paper 4.2)");
    }
    ImGui::EndCombo();
  }
}

// The Document panel's tabs: a row of tab buttons that wraps onto a second row when the panel is narrow,
// so every name shows whole at any width and scale (ImGui's tab bar truncates or scrolls them). The
// script's `tab` verb selects one by name (case-insensitive).
void Editor::listsPanel() {
  static constexpr std::array<const char*, 7> kTabs = {"Points",  "Chains",   "Photos",  "Strokes",
                                                       "History", "Pipeline", "Coverage"};
  if (!requestedTab_.empty()) {
    for (size_t i = 0; i < kTabs.size(); ++i) {
      std::string lower = kTabs[i];
      std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
      if (lower == requestedTab_) listsTab_ = static_cast<int>(i);
    }
    requestedTab_.clear();
  }
  const ImGuiStyle& style = ImGui::GetStyle();
  ImGui::PushStyleVar(ImGuiStyleVar_ItemSpacing, ImVec2(px(2), px(2)));
  for (size_t i = 0; i < kTabs.size(); ++i) {
    if (i > 0) sameLineIfFits(ImGui::CalcTextSize(kTabs[i]).x + style.FramePadding.x * 2);
    const bool shown = listsTab_ == static_cast<int>(i);
    ImGui::PushStyleColor(ImGuiCol_Button, style.Colors[shown ? ImGuiCol_TabActive : ImGuiCol_TabUnfocused]);
    ImGui::PushStyleColor(ImGuiCol_ButtonHovered, style.Colors[ImGuiCol_TabHovered]);
    ImGui::PushStyleColor(ImGuiCol_ButtonActive, style.Colors[ImGuiCol_TabActive]);
    if (button(kTabs[i], nullptr, std::string("tab ") + kTabs[i])) listsTab_ = static_cast<int>(i);
    tabRects_[kTabs[i]] = itemRect();  // whole, unclipped (state: the tabs fit the column)
    ImGui::PopStyleColor(3);
  }
  ImGui::PopStyleVar();
  ImGui::Separator();
  // The tab row stays in place: only the tab's content scrolls (issue 35, finding 5); each tab keeps its own
  // buttons above its list the same way (a child window of its own for the list).
  ImGui::BeginChild("##tab");
  switch (listsTab_) {
    case 0:
      featuresTab();
      break;
    case 1:
      chainsTab();
      break;
    case 2:
      photosTab();
      break;
    case 3:
      strokesClonesTab();
      break;
    case 4:
      historyTab();
      break;
    case 5:
      pipelineTab();
      break;
    default:
      coverageTab();
      break;
  }
  ImGui::EndChild();
}

void Editor::featuresTab() {
  const Project& p = doc_.project();
  ImGui::Text("%zu feature points", p.points.size());
  ImGui::SameLine();
  // The button clears the selection: the disabled state is ended as it was begun (ImGui asserts otherwise;
  // the editor aborted on every click of it).
  const bool none = selectedPoint_ < 0;
  if (none) ImGui::BeginDisabled();
  if (button("Delete point")) {
    edit([&] { doc_.removePoint(selectedPoint_); });
    selectedPoint_ = -1;
  }
  if (none) ImGui::EndDisabled();
  const ImGuiTableFlags flags = ImGuiTableFlags_RowBg | ImGuiTableFlags_ScrollY | ImGuiTableFlags_BordersInnerV;
  if (!ImGui::BeginTable("##points", 3, flags)) return;
  ImGui::TableSetupScrollFreeze(0, 1);
  ImGui::TableSetupColumn("#", ImGuiTableColumnFlags_WidthFixed, ImGui::CalcTextSize("00000").x);
  ImGui::TableSetupColumn("vertex", ImGuiTableColumnFlags_WidthFixed, ImGui::CalcTextSize("0000000").x);
  ImGui::TableSetupColumn("photos");
  ImGui::TableHeadersRow();
  ImGuiListClipper clipper;
  clipper.Begin(static_cast<int>(p.points.size()));
  while (clipper.Step())
    for (int i = clipper.DisplayStart; i < clipper.DisplayEnd; ++i) {
      const FeaturePoint& pt = p.points[i];
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      const std::string id = pointName(i) + "##pt" + std::to_string(i);
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
  ImGui::BeginChild("##list");
  int remove = -1;
  for (size_t i = 0; i < p.chains.size(); ++i) {
    const FeatureChain& c = p.chains[i];
    ImGui::PushID(static_cast<int>(i));
    if (ImGui::SmallButton("x")) remove = static_cast<int>(i);
    ImGui::SameLine();
    std::string pts;
    for (int pt : c.points) pts += pointName(pt) + " ";
    ImGui::Text("#%zu %s in photo %d: %s", i, c.closed ? "polygon" : "line", c.photo, pts.c_str());
    ImGui::PopID();
  }
  ImGui::EndChild();
  if (remove >= 0) edit([&] { doc_.removeChain(remove); });
}

void Editor::strokesClonesTab() {
  const Project& p = doc_.project();
  ImGui::Text("%zu strokes", p.strokes.size());
  ImGui::BeginChild("##list");
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
  ImGui::EndChild();
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
    // The fields leave room for their labels (nothing clips in a narrow column).
    const float labels = ImGui::CalcTextSize("seam gradient weight").x + ImGui::GetStyle().ItemInnerSpacing.x;
    ImGui::PushItemWidth(std::max(px(60), ImGui::GetContentRegionAvail().x - labels));
    float threshold = static_cast<float>(o.backgroundThresholdPx);
    ImGui::SliderFloat("background px", &threshold, 0, 20, "%.1f");
    if (ImGui::IsItemDeactivatedAfterEdit()) o.backgroundThresholdPx = threshold, commit = true;
    int searches = o.stretchSearches;
    ImGui::SliderInt("stretch searches", &searches, 0, 64);
    if (ImGui::IsItemDeactivatedAfterEdit()) o.stretchSearches = searches, commit = true;
    // Seam optimisation (paper 4.2-4.3): stretch weight, rounds, gradient weight (1 - alpha).
    float lambda = static_cast<float>(o.seamLambda);
    ImGui::SliderFloat("seam lambda", &lambda, 0, 1, "%.2f");
    if (ImGui::IsItemDeactivatedAfterEdit()) o.seamLambda = lambda, commit = true;
    int rounds = o.seamRounds;
    ImGui::SliderInt("seam rounds", &rounds, 0, 100);
    if (ImGui::IsItemDeactivatedAfterEdit()) o.seamRounds = rounds, commit = true;
    float gradient = static_cast<float>(o.gradientWeight);
    ImGui::SliderFloat("seam gradient weight", &gradient, 0, 1, "%.2f");
    if (ImGui::IsItemDeactivatedAfterEdit()) o.gradientWeight = gradient, commit = true;
    int seed = static_cast<int>(o.seed);
    ImGui::InputInt("seed", &seed);
    if (ImGui::IsItemDeactivatedAfterEdit()) o.seed = static_cast<unsigned>(std::max(0, seed)), commit = true;
    int mode = static_cast<int>(o.inpaintMode);
    if (ImGui::Combo("inpainting", &mode, kInpaintModeNames.data(), static_cast<int>(kInpaintModeNames.size())))
      o.inpaintMode = InpaintMode(mode), commit = true;
    int correction = static_cast<int>(o.correction);
    if (ImGui::Combo("click correction", &correction, kCorrectionModeNames.data(),
                     static_cast<int>(kCorrectionModeNames.size())))
      o.correction = CorrectionMode(correction), commit = true;
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "photos of the object itself: how far the texture follows each click beyond the fitted camera. noise: "
          "as far as a click is off by more than the clicks' noise (exact clicks stay exact); all: every click "
          "exactly; inliers: the clicks that agree with the camera; off: the camera alone");
    if (ImGui::Checkbox("photos of one camera share it", &o.sharedIntrinsics)) commit = true;
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "photos of the object itself from one camera (one size; one model and focal length where their EXIF "
          "says) are fitted together, with one focal length and one lens, when their clicks agree with that");
    if (ImGui::Checkbox("align photos on their overlaps", &o.photometric)) commit = true;
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "photos of the object itself: their cameras are refined so that where two photos see the same surface "
          "they show it alike, kept only when that predicts a held-out photo better (final result; a second or "
          "more)");
    if (ImGui::Checkbox("find silhouettes without a cut-out", &o.foundSilhouettes)) commit = true;
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "photos of the object itself without a cut-out: the object's edge is found around the mesh's outline "
          "and the camera refined on it, as on a cut-out (final result)");
    if (ImGui::Checkbox("weld seams of the mesh", &o.weldIdenticalPositions)) commit = true;
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "vertices at one position (a mesh split at its UV seams) are one vertex for mapping; the "
          "export keeps the mesh's own vertices");
    // Export: on the mesh as loaded (a new atlas, or baked into the mesh's own UVs) or on the refined mesh.
    int topology = static_cast<int>(o.exportTopology);
    if (ImGui::Combo("export mesh", &topology, kExportTopologyNames.data(),
                     static_cast<int>(kExportTopologyNames.size()))) {
      o.exportTopology = ExportTopology(topology), commit = true;
      if (o.exportTopology == ExportTopology::Refined) o.bakeInto = BakeInto::Atlas;  // meshUVs needs the original
    }
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "original: the mesh as loaded, its own vertices and faces; refined: the mesh the montage "
          "was made on (more faces)");
    int into = static_cast<int>(o.bakeInto);
    if (ImGui::Combo("texture into", &into, kBakeIntoNames.data(), static_cast<int>(kBakeIntoNames.size()))) {
      o.bakeInto = BakeInto(into), commit = true;
      if (o.bakeInto == BakeInto::MeshUVs) o.exportTopology = ExportTopology::Original;
    }
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "atlas: a new texture layout; meshUVs: baked into the mesh's own UVs, one texture per "
          "material and UDIM tile (model.1001.png ...)");
    if (o.bakeInto == BakeInto::MeshUVs) {
      // Powers of two from 256 to kMaxBakeSize; the project file also takes the smaller ones.
      std::vector<std::string> sizes;
      int current = -1;
      for (int size = 256; size <= kMaxBakeSize; size *= 2) {
        if (size == o.bakeSize) current = static_cast<int>(sizes.size());
        sizes.push_back(std::to_string(size));
      }
      if (current < 0) sizes.push_back(std::to_string(o.bakeSize)), current = static_cast<int>(sizes.size()) - 1;
      if (ImGui::BeginCombo("texture size", sizes[current].c_str())) {
        for (const std::string& size : sizes)
          if (ImGui::Selectable(size.c_str(), size == sizes[current])) o.bakeSize = std::stoi(size), commit = true;
        ImGui::EndCombo();
      }
    }
    ImGui::PopItemWidth();
    if (commit) edit([&] { doc_.setOptions(o); });
  }
  if (!result_) {
    ImGui::TextDisabled(ws.busy ? "running..." : "no result yet");
    return;
  }
  if (ImGui::CollapsingHeader("Stages", ImGuiTreeNodeFlags_DefaultOpen) &&
      ImGui::BeginTable("##stages", 2, ImGuiTableFlags_RowBg | ImGuiTableFlags_SizingFixedFit)) {
    // Generic over the stage records: new stages appear without changes here. A stage's counts open as
    // a table of their own (plain_words.h countRows), not as raw JSON.
    for (const StageRecord& s : result_->stages) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      const auto rows = countRows(s.counts);
      const std::string id = s.name + "##stage" + std::to_string(int(s.stage));
      const bool open = !rows.empty() && ImGui::TreeNodeEx(id.c_str(), ImGuiTreeNodeFlags_SpanFullWidth);
      if (rows.empty()) ImGui::TextUnformatted(s.name.c_str());
      if (ImGui::IsItemHovered() && int(s.stage) < pipelineStages().size()) {
        // What the stage reads, as declared (pipelineStages): why an edit ran it again or kept it.
        const StageDecl& d = pipelineStages()[int(s.stage)];
        std::string reads;
        for (int r : d.reads) reads += (reads.empty() ? "" : ", ") + pipelineStages()[r].name;
        for (const std::string& f : d.fields) reads += (reads.empty() ? "" : ", ") + f.substr(1);
        if (!d.also.empty()) reads += (reads.empty() ? "" : "; ") + d.also;
        const std::string text = s.name + " runs again when what it reads changes: " + reads;
        ImGui::BeginTooltip();
        ImGui::PushTextWrapPos(ImGui::GetFontSize() * 32);
        ImGui::TextUnformatted(text.c_str());
        ImGui::PopTextWrapPos();
        ImGui::EndTooltip();
      }
      ImGui::TableNextColumn();
      ImGui::Text(s.cached ? "cached" : "%.3f s", s.seconds);
      if (!open) continue;
      for (const auto& [name, value] : rows) {
        ImGui::TableNextRow();
        ImGui::TableNextColumn();
        ImGui::Indent();
        ImGui::TextDisabled("%s", name.c_str());
        ImGui::Unindent();
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(value.c_str());
      }
      ImGui::TreePop();
    }
    ImGui::EndTable();
  }
  if (ImGui::CollapsingHeader(("Warnings and notes (" + std::to_string(result_->warnings.size()) + ")").c_str(),
                              ImGuiTreeNodeFlags_DefaultOpen)) {
    // In plain words, wrapped at the column's width; the pipeline's own words on hover.
    for (const std::string& w : result_->warnings) {
      const PlainWarning plain = plainWarning(w);
      ImGui::Bullet();
      ImGui::PushTextWrapPos(0);
      ImGui::TextUnformatted(plain.text.c_str());
      ImGui::PopTextWrapPos();
      if (ImGui::IsItemHovered() && plain.text != plain.original)
        ImGui::SetTooltip("%s", wrapped("the pipeline's words: " + plain.original).c_str());
    }
  }
  if (result_->mapping) {
    const auto& rejected = result_->mapping->partition->rejected;
    if (ImGui::CollapsingHeader(("Rejected pairs (" + std::to_string(rejected.size()) + ")").c_str())) {
      ImGuiListClipper clipper;
      clipper.Begin(static_cast<int>(rejected.size()));
      while (clipper.Step())
        for (int i = clipper.DisplayStart; i < clipper.DisplayEnd; ++i) {
          const RejectedPair& r = rejected[i];
          const std::string label = resultPointName(r.fromPoint) + "-" + resultPointName(r.toPoint) + " photo " +
                                    std::to_string(r.photo) + ": " + kRejectReasonNames[int(r.reason)] + "##rj" +
                                    std::to_string(i);
          if (ImGui::Selectable(label.c_str()) && r.photo >= 0) activePhoto_ = r.photo;
          if (ImGui::IsItemHovered() && !r.detail.empty()) ImGui::SetTooltip("%s", r.detail.c_str());
        }
    }
  }
}

// The status bar, left to right: the run (progress weighted by stage times, time left, Cancel; or the
// result's state), the error count, the message (elided to its own space, the whole text on hover), and
// on the right the document's state and the frame time in a space reserved for their widest text. The
// parts never overlap; statusParts_ records where each was drawn (the script's `state`).
void Editor::statusBar(const Rect& r) {
  ImGui::SetNextWindowPos(ImVec2(float(r.x), float(r.y)));
  ImGui::SetNextWindowSize(ImVec2(float(r.w), float(r.h)));
  ImGui::PushStyleVar(ImGuiStyleVar_WindowPadding, ImVec2(px(8), px(4)));
  ImGui::Begin("##status", nullptr,
               ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoSavedSettings |
                   ImGuiWindowFlags_NoBringToFrontOnFocus);
  statusParts_.clear();
  const float gap = ImGui::GetStyle().ItemSpacing.x * 2;
  char right[160];
  const bool autosaved = autosavedRevision_ == doc_.revision() && doc_.modified();
  std::snprintf(right, sizeof(right), "%s%s%.1f ms", doc_.modified() ? "unsaved  " : "", autosaved ? "autosaved  " : "",
                frameMs_);
  // Room for the widest frame time, so that the message does not move as the time changes.
  const std::string widest =
      std::string(doc_.modified() ? "unsaved  " : "") + (autosaved ? "autosaved  " : "") + "9999.9 ms";
  const float rightX = float(r.w) - ImGui::CalcTextSize(widest.c_str()).x - px(8);  // window coordinates

  ImGui::BeginGroup();
  runControls();
  ImGui::EndGroup();
  statusParts_["run"] = itemRect();
  float x = ImGui::GetItemRectMax().x - float(r.x) + gap;

  if (!errors_.empty() && x + ImGui::CalcTextSize("99 errors").x < rightX) {
    ImGui::SameLine(x);
    const std::string count = std::to_string(errors_.size()) + (errors_.size() == 1 ? " error" : " errors");
    ImGui::TextColored(kErrorColor, "%s", count.c_str());
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s\n(click: the list)", errors_.back().c_str());
    if (ImGui::IsItemClicked()) showErrors_ = true;
    statusParts_["errors"] = itemRect();
    x = ImGui::GetItemRectMax().x - float(r.x) + gap;
  }

  // The message: the newest of the hint, the status and the error, for 8 s; a failed run's error stays.
  const double t = now();
  std::string message;
  ImVec4 colour = ImGui::GetStyle().Colors[ImGuiCol_Text];
  bool isError = false;
  double newest = -1;
  if (!status_.empty() && t - statusTime_ < 8) message = status_, newest = statusTime_;
  if (!hint_.empty() && t - hintTime_ < 8 && hintTime_ >= newest)
    message = hint_, newest = hintTime_, colour = kHintColor;
  if (!errors_.empty() && t - errorTime_ < 8 && errorTime_ >= newest)
    message = errors_.back(), newest = errorTime_, colour = kErrorColor, isError = true;
  if (message.empty() && !lastError_.empty()) message = "pipeline: " + lastError_, colour = kErrorColor, isError = true;
  const float room = rightX - gap - x;
  if (!message.empty() && room > ImGui::CalcTextSize("a...").x) {
    ImGui::SameLine(x);
    const std::string shown = elide(message, room);
    ImGui::TextColored(colour, "%s", shown.c_str());
    if (ImGui::IsItemHovered() && shown != message) ImGui::SetTooltip("%s", wrapped(message).c_str());
    if (ImGui::IsItemClicked() && isError) showErrors_ = true;
    statusParts_["message"] = itemRect();
  }

  ImGui::SameLine(std::max(rightX, float(r.w) - ImGui::CalcTextSize(right).x - px(8)));
  ImGui::TextDisabled("%s", right);
  statusParts_["right"] = itemRect();
  ImGui::End();
  ImGui::PopStyleVar();
}

void Editor::runControls() {
  const WorkerStatus ws = worker_->status();
  if (!ws.busy && cancelAt_ >= 0) {
    cancelSeconds_ = now() - cancelAt_;  // the job stopped at its next progress point
    cancelAt_ = -1;
  }
  if (ws.busy) {
    // Weighted by the stages' seconds in the last run of this tier (typical shares before the first).
    const double done = progress_.overall(ws.tier, ws.stage, ws.fraction);
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - ws.started).count();
    const std::string timeText = progress_.timeText(
        ws.tier, ws.stage, ws.fraction, elapsed, std::chrono::duration<double>(ws.started.time_since_epoch()).count());
    char overlay[16];
    std::snprintf(overlay, sizeof(overlay), "%.0f%%", 100 * done);
    ImGui::ProgressBar(static_cast<float>(done), ImVec2(px(90), 0), overlay);
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("%s%s %.0f%% %s", ws.tier == Tier::Final ? "final: " : "preview: ", stageName(ws.stage),
                        100 * ws.fraction, ws.what.c_str());
    // Cancel right after the bar: it stays in place while the stage and time texts change width.
    ImGui::SameLine();
    if (ImGui::SmallButton("Cancel##run")) cancelRun();
    scriptButton("Cancel run");
    ImGui::SameLine();
    ImGui::Text("%s%s", ws.tier == Tier::Final ? "final: " : "", stageName(ws.stage));
    if (!timeText.empty()) {
      ImGui::SameLine();
      ImGui::TextDisabled("%s", timeText.c_str());
    }
    return;
  }
  if (doc_.project().mesh.empty()) {
    ImGui::TextDisabled("open a project or a mesh (Ctrl+O)");
  } else if (cancelled_) {
    ImGui::TextColored(kHintColor, "cancelled");
    ImGui::SameLine();
    if (ImGui::SmallButton("Run##run")) {
      cancelled_ = false;
      submittedRevision_ = -1;  // submitted again by the frame loop
    }
    scriptButton("Run");
  } else if (resultCurrent()) {
    ImGui::TextColored(ImVec4(0.5f, 0.85f, 0.5f, 1), result_->model ? "up to date" : "preview up to date");
  } else if (!lastError_.empty()) {
    ImGui::TextColored(kErrorColor, "pipeline failed");
  } else {
    ImGui::TextDisabled("waiting for the worker");
  }
  if (result_ && ImGui::IsItemHovered()) {
    // The stage times of the shown result (also in the Pipeline tab).
    std::string timings;
    double total = 0;
    for (const StageRecord& s : result_->stages) {
      char part[64];
      std::snprintf(part, sizeof(part), s.cached ? "%s cached\n" : "%s %.2f s\n", stageName(s.stage), s.seconds);
      timings += part;
      total += s.seconds;
    }
    ImGui::SetTooltip("%s%stotal %.2f s", result_->tier == Tier::Final ? "final\n" : "preview\n", timings.c_str(),
                      total);
  }
}

void Editor::cancelRun() {
  worker_->cancel();
  cancelled_ = true;
  cancelAt_ = now();
  cancelSeconds_ = -1;
  setStatus("run cancelled: the view keeps the last result; Run computes the current document");
}

void Editor::errorsWindow() {
  if (!showErrors_) return;
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowSize(ImVec2(std::min(px(640), display.x * 0.6f), px(240)), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowPos(ImVec2(display.x * 0.5f, display.y - px(60)), ImGuiCond_FirstUseEver, ImVec2(0.5f, 1.0f));
  if (ImGui::Begin("Errors", &showErrors_, ImGuiWindowFlags_NoSavedSettings)) {
    if (button("Clear")) errors_.clear(), operationErrors_.clear(), lastError_.clear();
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
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowSize(ImVec2(std::min(px(620), display.x * 0.9f), std::min(px(560), display.y * 0.85f)),
                           ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowPos(ImVec2(display.x * 0.5f, display.y * 0.5f), ImGuiCond_FirstUseEver, ImVec2(0.5f, 0.5f));
  if (ImGui::Begin("Help: shortcuts and mouse", &showHelp_, ImGuiWindowFlags_NoSavedSettings)) {
    if (ImGui::BeginTable("##keys", 2, ImGuiTableFlags_RowBg | ImGuiTableFlags_BordersInnerV)) {
      ImGui::TableSetupColumn("keys", ImGuiTableColumnFlags_WidthStretch, 0.4f);
      ImGui::TableSetupColumn("action", ImGuiTableColumnFlags_WidthStretch, 0.6f);
      for (const Shortcut& s : editorShortcuts()) {
        ImGui::TableNextRow();
        ImGui::TableNextColumn();
        ImGui::TextWrapped("%s", s.keys);
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

bool Editor::keyPressed(int key) const {
  return ImGui::IsKeyPressed(key, false);
}

bool Editor::ctrlHeld() const {
  return ImGui::GetIO().KeyCtrl;
}

bool Editor::shiftHeld() const {
  return ImGui::GetIO().KeyShift;
}

void Editor::shortcuts() {
  ImGuiIO& io = ImGui::GetIO();
  if (io.WantTextInput || ImGui::IsPopupOpen(nullptr, ImGuiPopupFlags_AnyPopupId)) return;
  navigationShortcuts();
  const bool ctrl = ctrlHeld(), shift = shiftHeld();
  auto pressed = [this](int key) { return keyPressed(key); };
  if (ctrl) {
    if (pressed(GLFW_KEY_Z)) shift ? redo() : undo();
    if (pressed(GLFW_KEY_Y)) redo();
    if (pressed(GLFW_KEY_S)) shift ? requestSaveAs() : save();
    if (pressed(GLFW_KEY_O)) requestOpen();
    if (pressed(GLFW_KEY_E)) requestExport();
    if (pressed(GLFW_KEY_Q)) requestClose();
    return;
  }
  const std::pair<int, Tool> tools[] = {{GLFW_KEY_P, Tool::Point},   {GLFW_KEY_L, Tool::Line},
                                        {GLFW_KEY_G, Tool::Polygon}, {GLFW_KEY_S, Tool::Stroke},
                                        {GLFW_KEY_C, Tool::Clone},   {GLFW_KEY_K, Tool::Cutout}};
  for (const auto& [key, tool] : tools)
    if (pressed(key) && tool_ != tool) {
      cancelInProgress();
      tool_ = tool;
    }
  if (pressed(GLFW_KEY_T)) textured_ = !textured_;
  if (pressed(GLFW_KEY_W)) wireframe_ = !wireframe_;
  if (pressed(GLFW_KEY_F)) frameAll();
  if (pressed(GLFW_KEY_F1)) showHelp_ = !showHelp_;
  if (pressed(GLFW_KEY_DELETE) || pressed(GLFW_KEY_BACKSPACE)) deleteSelection();
  if (pressed(GLFW_KEY_ENTER) || pressed(GLFW_KEY_KP_ENTER)) finishChain();
  if (pressed(GLFW_KEY_ESCAPE)) {
    if (!chain_.empty() || !stroke_.empty() || !clonePolygon_.empty() || !cloneFaces_.empty() ||
        !exemplarHole_.empty()) {
      cancelInProgress();
    } else {
      selectVertex(-1);
    }
  }
  // Digit N shows the photo labelled N (tabs, lists and messages number photos from 0).
  for (int k = 0; k <= 9; ++k)
    if (pressed(GLFW_KEY_0 + k) && k < static_cast<int>(doc_.project().photos.size())) activePhoto_ = k;
}

}  // namespace montage
