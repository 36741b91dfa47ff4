// Photos in the editor: the photo list (add several at once, remove, reorder, mirror, colour lock, relink,
// mask), the missing-files window, the before/after of the colour balance, and the cut-out tool in the
// photo panes (GrabCut from a rectangle and strokes, refined by more strokes; the mask brush; a feathered
// edge; the mask written as a PNG beside the project and referenced from the photo's entry).
#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "editor.h"
#include "gl.h"
#include "gl_util.h"
#include "image/photo.h"
#include "io/mesh_io.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

const ImVec4 kErrorText(1.0f, 0.45f, 0.4f, 1.0f);

ImVec2 im(const Vec2& v) {
  return ImVec2(float(v.x()), float(v.y()));
}

ImTextureID imTexture(const Texture& t) {
  return reinterpret_cast<ImTextureID>(static_cast<intptr_t>(t.id()));
}

ImU32 strokeColour(const CutoutStroke& s, bool brush) {
  if (brush) return s.foreground ? IM_COL32(255, 255, 255, 150) : IM_COL32(20, 20, 20, 170);
  return s.foreground ? IM_COL32(70, 230, 90, 200) : IM_COL32(240, 70, 60, 200);
}

// The cut-out's tint over the photo: opaque where the mask is background (Texture::uploadAlpha, drawn in
// kCutoutTint). At 12 MP an RGBA tint took 80 ms to make (idle machine), this under 1 ms once its memory is
// mapped, and a quarter of the upload.
const ImU32 kCutoutTint = IM_COL32(200, 40, 160, 140);
cv::Mat cutoutOverlay(const cv::Mat& mask) {
  cv::Mat inverse;
  cv::bitwise_not(mask, inverse);
  return inverse;
}

const char* const kSpinner[] = {"|", "/", "-", "\\"};
// What a drag does in each cut-out mode (CutoutMode order), written beside the cursor.
const char* const kModeText[] = {"rectangle", "foreground stroke", "background stroke", "brush: add", "brush: erase"};

// The session key: a cut-out belongs to a photo file as shown (mirrored or not), whatever its mask.
std::string cutoutKey(const PhotoRef& ref) {
  return ref.path + (ref.mirror ? "|mirror" : "");
}

}  // namespace

// --- The photo list ------------------------------------------------------------------------------

void Editor::photosTab() {
  const Project& p = doc_.project();
  const bool hasMesh = !p.mesh.empty();
  if (!hasMesh) ImGui::BeginDisabled();
  if (button("Add photos...")) requestAddPhotos(false);
  ImGui::SameLine();
  if (button("Add folder...")) requestAddPhotos(true);
  if (!hasMesh) ImGui::EndDisabled();
  ImGui::SameLine();
  ImGui::TextDisabled("or drop files here");
  ImGui::Checkbox("show balanced colours", &showBalanced_);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "photo panes: the photos after the colour balance of the last result (after), or as in their "
        "files (before)");
  const ColorBalance* balance = resultUsable() && result_->balanced ? &result_->balanced->balance : nullptr;

  // The list scrolls under the buttons above, which stay in place (issue 35, finding 5).
  ImGui::BeginChild("##list");
  int remove = -1, moveFrom = -1, moveTo = -1, cut = -1;
  for (int i = 0; i < static_cast<int>(p.photos.size()); ++i) {
    const PhotoRef& ref = p.photos[i];
    const PhotoSlot* slot = i < static_cast<int>(photos_.size()) ? &photos_[i] : nullptr;
    const std::string id = std::to_string(i);
    ImGui::PushID(i);
    ImGui::Separator();
    const std::string name = id + ": " + fs::path(ref.path).filename().string();
    if (ImGui::Selectable(name.c_str(), activePhoto_ == i, 0, ImVec2(ImGui::GetContentRegionAvail().x * 0.55f, 0)))
      activePhoto_ = i;
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("%s%s%s", ref.path.c_str(), ref.mask.empty() ? "" : "\nmask: ", ref.mask.c_str());
    ImGui::SameLine();
    if (slot && slot->photo) {
      ImGui::TextDisabled("%dx%d%s", slot->photo->width, slot->photo->height,
                          ref.mask.empty() ? (slot->photo->hasBackground ? " alpha" : " no mask") : " mask");
    } else {
      ImGui::TextColored(kErrorText, "%s", slot && !slot->error.empty() ? "cannot load" : "loading");
      if (slot && !slot->error.empty() && ImGui::IsItemHovered()) ImGui::SetTooltip("%s", slot->error.c_str());
    }
    bool mirror = ref.mirror, locked = ref.colorLocked;
    if (ImGui::Checkbox("mirror", &mirror)) {
      const int width = slot && slot->photo ? slot->photo->width : 0;
      edit([&] { doc_.setPhotoMirror(i, mirror, width); });
    }
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("flip left to right on load (the file is not changed)");
    ImGui::SameLine();
    if (ImGui::Checkbox("lock colours", &locked)) edit([&] { doc_.setColorLocked(i, locked); });
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("colour balance: keep this photo as it is and match the others to it");
    ImGui::SameLine();
    if (i == 0) ImGui::BeginDisabled();
    if (button("^", nullptr, "photo up " + id)) moveFrom = i, moveTo = i - 1;
    if (i == 0) ImGui::EndDisabled();
    ImGui::SameLine();
    if (i + 1 == static_cast<int>(p.photos.size())) ImGui::BeginDisabled();
    if (button("v", nullptr, "photo down " + id)) moveFrom = i, moveTo = i + 1;
    if (i + 1 == static_cast<int>(p.photos.size())) ImGui::EndDisabled();
    ImGui::SameLine();
    if (button("x", nullptr, "remove photo " + id)) remove = i;
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("remove the photo with its points, chains and clones (undoable)");
    // What the photo shows: decides how its clicks map it (mapping/subject.h).
    static constexpr const char* kShows[] = {"auto: decided from the clicks", "the object itself", "another subject"};
    int shows = static_cast<int>(ref.mode);
    ImGui::AlignTextToFramePadding();
    ImGui::TextUnformatted("shows");
    ImGui::SameLine();
    ImGui::SetNextItemWidth(ImGui::CalcTextSize(kShows[0]).x + px(40));
    if (ImGui::Combo(("##shows" + id).c_str(), &shows, kShows, IM_ARRAYSIZE(kShows)))
      edit([&] { doc_.setPhotoMode(i, PhotoMode(shows)); });
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip(
          "the object itself: a camera fitted to the clicks projects the photo; a click the camera disagrees with is "
          "marked as an outlier\nanother subject (e.g. a tiger's flank for a cat): every click is kept exactly, by a "
          "camera and a smooth warp, or by the paper's piecewise map\ndecide from the clicks: from its first 8 "
          "clicks, and it changes only when all the clicks clearly say otherwise");
    if (resultUsable() && result_->cameras && i < static_cast<int>(result_->cameras->fits.size()) &&
        !result_->cameras->fits[i].decision.empty()) {
      ImGui::PushTextWrapPos(0);
      ImGui::TextDisabled("%s", result_->cameras->fits[i].decision.c_str());
      if (const SubjectChoice* choice = subjectChoice(i)) ImGui::TextDisabled("map: %s", choice->why.c_str());
      ImGui::PopTextWrapPos();
    }
    if (button("Cut out", nullptr, "cut out photo " + id)) cut = i;
    ImGui::SameLine();
    if (button("Relink...", nullptr, "relink photo " + id))
      dialogs_.request(DialogKind::OpenFile, "Relink photo " + id,
                       {{"Images", {"*.png", "*.jpg", "*.jpeg", "*.tif", "*.tiff", "*.bmp"}}}, "relink_photo:" + id,
                       fs::path(ref.path).parent_path().string());
    if (!ref.mask.empty()) {
      ImGui::SameLine();
      if (button("No mask", nullptr, "remove mask " + id)) edit([&] { doc_.setPhotoMask(i, ""); });
    }
    if (balance && i < static_cast<int>(balance->transforms.size())) {
      const ColorTransform& t = balance->transforms[i];
      if (balance->reference[i])
        ImGui::TextDisabled("colour balance: reference (kept as it is)");
      else
        ImGui::TextDisabled("colour balance: gain %.3f %.3f %.3f, offset %+.3f %+.3f %+.3f", t.gain[0], t.gain[1],
                            t.gain[2], t.offset[0], t.offset[1], t.offset[2]);
    }
    ImGui::PopID();
  }
  ImGui::EndChild();
  if (remove >= 0 && edit([&] { doc_.removePhoto(remove); })) setStatus("photo " + std::to_string(remove) + " removed");
  if (moveFrom >= 0) edit([&] { doc_.movePhoto(moveFrom, moveTo); });
  if (cut >= 0) {
    cancelInProgress();
    tool_ = Tool::Cutout;
    activePhoto_ = cut;
    startCutout(cut, true);
  }
}

void Editor::missingFilesWindow() {
  // Only what the document still names and is still not there.
  const Project& p = doc_.project();
  missing_.erase(std::remove_if(missing_.begin(), missing_.end(),
                                [&](const MissingFile& m) {
                                  std::error_code ec;
                                  if (fs::exists(m.path, ec)) return true;
                                  if (m.field == "mesh") return p.mesh != m.path;
                                  for (const PhotoRef& ref : p.photos)
                                    if (ref.path == m.path || ref.mask == m.path) return false;
                                  return true;
                                }),
                 missing_.end());
  if (missing_.empty()) missingPopup_ = false;
  if (!missingPopup_) return;
  const ImVec2 display = ImGui::GetIO().DisplaySize;
  ImGui::SetNextWindowPos(ImVec2(display.x * 0.5f, display.y * 0.35f), ImGuiCond_Appearing, ImVec2(0.5f, 0.5f));
  ImGui::SetNextWindowSize(ImVec2(std::min(720.f, display.x * 0.7f), 0), ImGuiCond_Appearing);
  if (ImGui::Begin("Missing files", &missingPopup_, ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoCollapse)) {
    ImGui::TextWrapped(
        "The project opened, but these files are not where it says. Relink each to its new place, or "
        "remove the photo; a photo that cannot load is left out of the preview, the others still "
        "texture.");
    for (size_t k = 0; k < missing_.size(); ++k) {
      const MissingFile& m = missing_[k];
      ImGui::PushID(static_cast<int>(k));
      ImGui::Separator();
      ImGui::TextColored(kErrorText, "%s", m.field.c_str());
      ImGui::SameLine();
      ImGui::TextWrapped("%s", m.path.c_str());
      int photo = -1;
      bool mask = false;
      for (int i = 0; i < static_cast<int>(p.photos.size()); ++i) {
        if (p.photos[i].path == m.path) photo = i;
        if (p.photos[i].mask == m.path) photo = i, mask = true;
      }
      const std::string start = fs::path(p.file.empty() ? p.mesh : p.file).parent_path().string();
      if (m.field == "mesh") {
        if (button("Relink...", nullptr, "relink mesh"))
          dialogs_.request(DialogKind::OpenFile, "Relink the mesh",
                           {{"Meshes", patternsOf(meshExtensions())}, {"All files", {"*"}}}, "relink_mesh", start);
      } else if (photo >= 0 && !mask) {
        if (button("Relink...", nullptr, "relink photo " + std::to_string(photo)))
          dialogs_.request(DialogKind::OpenFile, "Relink photo " + std::to_string(photo),
                           {{"Images", {"*.png", "*.jpg", "*.jpeg", "*.tif", "*.tiff", "*.bmp"}}},
                           "relink_photo:" + std::to_string(photo), start);
        ImGui::SameLine();
        if (button("Remove photo", nullptr, "remove photo " + std::to_string(photo)))
          edit([&] { doc_.removePhoto(photo); });
      } else if (photo >= 0) {
        if (button("Drop the mask", nullptr, "remove mask " + std::to_string(photo)))
          edit([&] { doc_.setPhotoMask(photo, ""); });
      }
      ImGui::PopID();
    }
  }
  ImGui::End();
}

// --- Colour balance: before / after --------------------------------------------------------------

void Editor::uploadBalanced(PhotoSlot& slot, int photo) {
  if (!resultUsable() || !result_->balanced || !result_->balanced->scene) return;
  const auto& photos = result_->balanced->scene->photos;
  if (photo >= static_cast<int>(photos.size()) || !slot.photo) return;
  const Photo* balanced = photos[photo].get();
  // Only a result for this very file (the document may have changed since) is shown.
  if (!balanced || balanced->path != slot.photo->path || balanced->width != slot.photo->width ||
      balanced->mirrored != slot.photo->mirrored || slot.balancedFrom == balanced)
    return;
  const cv::Mat rgba = toRgba8(balanced->rgb, false, balanced->path);  // any depth, stored resolution
  if (!slot.balanced) slot.balanced = std::make_unique<Texture>();
  slot.balanced->upload(rgba);
  slot.balancedFrom = balanced;
}

// --- The cut-out tool ----------------------------------------------------------------------------

void Editor::cutoutPanel() {
  int mode = static_cast<int>(cutoutMode_);
  const char* labels[] = {"rectangle", "foreground", "background", "add", "erase"};
  for (int m = 0; m < 5; ++m) {
    if (m % 3) sameLineIfFits(ImGui::CalcTextSize(labels[m]).x + ImGui::GetFrameHeight() * 1.5f);
    if (ImGui::RadioButton(labels[m], mode == m)) cutoutMode_ = CutoutMode(m);
  }
  ImGui::PushItemWidth(std::max(
      ImGui::GetFontSize() * 4,
      ImGui::GetContentRegionAvail().x - ImGui::CalcTextSize("feather").x - ImGui::GetStyle().ItemInnerSpacing.x));
  ImGui::SliderFloat("radius", &cutoutRadius_, 1, 60, "%.0f px");
  ImGui::SliderFloat("feather", &cutoutFeather_, 0, 20, "%.1f px");
  ImGui::PopItemWidth();
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("soft edge of the mask written: alpha ramps up over this width");
  // A new feather: the mask made again on the helper thread (137 ms at 12 MP), after the step that runs.
  if (cutout_.cut && std::abs(cutout_.cut->options().featherPx - cutoutFeather_) > 1e-6 && !cutout_.job.valid() &&
      cutout_.queue.empty()) {
    runCutout([](Cutout&) {}, "feather", false, false);
  }
  const bool running = cutout_.job.valid();
  if (cutout_.photo >= 0) {
    if (running) {
      // The busy state: what runs, and what waits for it (nothing drawn meanwhile is lost).
      ImGui::TextColored(
          ImVec4(1.0f, 0.85f, 0.4f, 1.0f), "%s photo %d: %s (%s)%s", kSpinner[int(ImGui::GetTime() * 8) % 4],
          cutout_.photo, cutout_.jobGrabCut ? "GrabCut running" : "making the mask", cutout_.jobLabel.c_str(),
          cutout_.queue.empty() ? "" : (", then " + std::to_string(cutout_.queue.size()) + " queued").c_str());
    } else if (!cutout_.mask.empty()) {
      const double share = cv::countNonZero(cutout_.mask) / double(cutout_.mask.total());
      ImGui::Text("photo %d: foreground %.1f%%%s", cutout_.photo, 100 * share,
                  cutout_.seconds > 0 ? "" : " (not cut yet)");
      if (cutout_.seconds > 0) {
        ImGui::SameLine();
        ImGui::TextDisabled("GrabCut %.2f s", cutout_.seconds);
      }
    }
  } else {
    ImGui::TextDisabled("no cut-out yet: drag in a photo");
  }
  const bool ready = cutout_.cut && cutout_.cut->started() && !running && cutout_.queue.empty();
  if (!ready) ImGui::BeginDisabled();
  if (button("Use mask")) applyCutoutMask();
  if (!ready) ImGui::EndDisabled();
  ImGui::SameLine();
  if (button("Start over##cutout")) {
    const int photo = cutout_.photo;
    if (running) {
      setStatus("cut-out: GrabCut is running; start over once it has finished");
    } else if (photo >= 0 && cutout_.cut) {
      // An undoable step like the others: the cut drawn so far comes back with Ctrl+Z.
      pushCutoutUndo("start over");
      const Photo* shown = photo < static_cast<int>(photos_.size()) ? photos_[photo].photo.get() : nullptr;
      if (shown) {
        CutoutOptions options;
        options.featherPx = cutoutFeather_;
        cutout_.cut = std::make_unique<Cutout>(shown->rgb, options, cv::Size(shown->width, shown->height));
        setCutoutMask(cutout_.cut->mask());
        cutout_.strokes.clear();
        cutout_.rect.reset();
        cutout_.seconds = 0;
        cutoutMode_ = CutoutMode::Rect;
      }
    }
  }
  // The help last, so that the buttons stay on screen in a short panel.
  ImGui::TextWrapped(
      "Drag a rectangle around the object in a photo; GrabCut separates it. Then drag strokes on what is wrong "
      "(foreground / background), or paint the mask (add / erase). Ctrl+Z undoes the last stroke or rectangle. "
      "Use mask writes it beside the project.");
}

bool Editor::startCutout(int photo, bool fromCurrentMask) {
  if (cutout_.job.valid()) {
    setStatus("cut-out: GrabCut is still running");
    return false;
  }
  const Project& p = doc_.project();
  if (photo < 0 || photo >= static_cast<int>(photos_.size()) || !photos_[photo].photo) {
    setStatus("cut-out: photo " + std::to_string(photo) + " is not loaded");
    return false;
  }
  const Photo& shown = *photos_[photo].photo;
  cutout_ = CutoutSession{};
  cutout_.photo = photo;
  cutout_.key = cutoutKey(p.photos[photo]);
  cutout_.docPosition = doc_.position();
  try {
    CutoutOptions options;
    options.featherPx = cutoutFeather_;
    cutout_.cut = std::make_unique<Cutout>(shown.rgb, options, cv::Size(shown.width, shown.height));
    // Refining what the photo already has (a mask, or alpha): GrabCut starts from it.
    if (fromCurrentMask && shown.hasBackground) cutout_.cut->startFrom(shown.alpha);
  } catch (const Error& e) {
    reportError(e.what());
    cutout_ = CutoutSession{};
    return false;
  }
  setCutoutMask(cutout_.cut->mask());
  return true;
}

void Editor::runCutout(std::function<void(Cutout&)> step, const std::string& label, bool grabCut, bool undoStep) {
  if (!cutout_.cut || cutout_.job.valid()) return;
  cutout_.jobLabel = label;
  cutout_.jobGrabCut = grabCut;
  cutout_.jobStep = undoStep;
  // The Cutout goes to the helper thread and comes back with the result (pollCutout).
  cutout_.job = std::async(std::launch::async, [cut = std::move(cutout_.cut), step = std::move(step),
                                                delay = cutoutDelay_, feather = cutoutFeather_]() mutable {
    CutoutSession::JobResult r;
    try {
      if (delay > 0) std::this_thread::sleep_for(std::chrono::duration<double>(delay));
      step(*cut);
      cut->setFeather(feather);
      r.mask = cut->mask();
      r.overlay = cutoutOverlay(r.mask);
    } catch (const Error& e) {
      r.error = e.what();
    } catch (const std::exception& e) {
      r.error = std::string("cut-out: ") + e.what();
    }
    r.cut = std::move(cut);
    return r;
  });
}

void Editor::pollCutout() {
  if (cutout_.job.valid() && cutout_.job.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
    CutoutSession::JobResult r = cutout_.job.get();
    cutout_.cut = std::move(r.cut);
    cutout_.jobLabel.clear();
    if (!r.error.empty()) {
      // The step failed (a rectangle over the whole photo...): the cut goes back to the state before it.
      setStatus(r.error);
      reportError(r.error);
      if (cutout_.jobStep && !cutout_.undo.empty()) {
        restoreCutoutState(std::move(cutout_.undo.back()));
        cutout_.undo.pop_back();
      } else {
        setCutoutMask(cutout_.cut->mask());
      }
    } else {
      setCutoutMask(std::move(r.mask), std::move(r.overlay));  // a feather changed meanwhile: the slider's check
    }
    cutout_.seconds = cutout_.cut->lastSeconds();
    // Undos asked for while it ran take back the newest steps first, then what was drawn meanwhile runs.
    for (; cutout_.undoAfterJob > 0; --cutout_.undoAfterJob) cutoutUndo();
    applyCutoutQueue();
  }
  // The session ends when its photo goes away or shows another file.
  const Project& p = doc_.project();
  if (cutout_.photo >= 0 && !cutout_.job.valid() &&
      (cutout_.photo >= static_cast<int>(p.photos.size()) || cutoutKey(p.photos[cutout_.photo]) != cutout_.key)) {
    if (!cutout_.queue.empty()) setStatus("cut-out: the photo changed; the strokes drawn on it were not applied");
    cutout_ = CutoutSession{};
  }
}

void Editor::pushCutoutUndo(const std::string& label) {
  CutoutState before;
  before.cut = std::make_unique<Cutout>(cutout_.cut->copy());
  before.mask = PackedMask(cutout_.mask);
  before.strokes = cutout_.strokes;
  before.rect = cutout_.rect;
  before.seconds = cutout_.seconds;
  before.label = label;
  cutout_.undo.push_back(std::move(before));
  cutout_.redo.clear();
  cutout_.docPosition = doc_.position();
  // Bounded: a session keeps its last 100 steps (each a copy of the working labels, about 0.25 MB, and its
  // mask run-length encoded).
  if (cutout_.undo.size() > 100) cutout_.undo.erase(cutout_.undo.begin());
}

Editor::CutoutState Editor::takeCutoutState(const std::string& label) {
  CutoutState now;
  now.cut = std::move(cutout_.cut);
  now.mask = PackedMask(cutout_.mask);
  now.strokes = std::move(cutout_.strokes);
  now.rect = cutout_.rect;
  now.seconds = cutout_.seconds;
  now.label = label;
  return now;
}

void Editor::restoreCutoutState(CutoutState&& state) {
  cutout_.cut = std::move(state.cut);
  setCutoutMask(state.mask.unpack());
  cutout_.strokes = std::move(state.strokes);
  cutout_.rect = state.rect;
  cutout_.seconds = state.seconds;
}

void Editor::setCutoutMask(cv::Mat mask, cv::Mat tint) {
  cutout_.mask = std::move(mask);
  cutout_.overlayImage = std::move(tint);
  cutout_.overlayDirty = true;
}

void Editor::cutoutStep(const CutoutStep& step) {
  cutout_.queue.push_back(step);
  cutout_.unqueued.clear();
  if (cutout_.job.valid()) {
    setStatus("cut-out: GrabCut is running; your " +
              std::string(step.mode == CutoutMode::Rect ? "rectangle" : "stroke") + " is queued (" +
              std::to_string(cutout_.queue.size()) + " waiting)");
    return;
  }
  applyCutoutQueue();
}

void Editor::applyCutoutQueue() {
  while (!cutout_.queue.empty() && cutout_.cut && !cutout_.job.valid()) {
    const CutoutStep step = cutout_.queue.front();
    cutout_.queue.pop_front();
    ++cutout_.stepsApplied;
    if (step.mode == CutoutMode::Rect) {
      const size_t replaced = cutout_.strokes.size();
      pushCutoutUndo(replaced == 0 ? "rectangle"
                                   : "rectangle (replaced " + std::to_string(replaced) +
                                         (replaced == 1 ? " stroke)" : " strokes)"));
      cutout_.rect = step.rect;
      cutout_.strokes.clear();
      runCutout([rect = step.rect](Cutout& c) { c.setRect(rect); }, "rectangle");
      return;
    }
    if (step.mode == CutoutMode::Add || step.mode == CutoutMode::Erase) {
      // The brush edits the labels directly (no GrabCut); the full-size feathered mask is made on the helper
      // thread, as a GrabCut step's is (12 MP: not on the UI's). A failed step gives back the cut before it.
      const std::string label = step.mode == CutoutMode::Add ? "add brush" : "erase brush";
      pushCutoutUndo(label);
      cutout_.strokes.push_back(step.stroke);
      runCutout([stroke = step.stroke](Cutout& c) { c.brush(stroke); }, label, false);
      return;
    }
    // GrabCut strokes: this one and the ones queued right after it, in one run and one undo step.
    std::vector<CutoutStroke> strokes = {step.stroke};
    while (!cutout_.queue.empty() && (cutout_.queue.front().mode == CutoutMode::Foreground ||
                                      cutout_.queue.front().mode == CutoutMode::Background)) {
      strokes.push_back(cutout_.queue.front().stroke);
      cutout_.queue.pop_front();
      ++cutout_.stepsApplied;
    }
    const std::string label = strokes.size() == 1
                                  ? std::string(strokes[0].foreground ? "foreground" : "background") + " stroke"
                                  : std::to_string(strokes.size()) + " strokes";
    pushCutoutUndo(label);
    cutout_.strokes.insert(cutout_.strokes.end(), strokes.begin(), strokes.end());
    runCutout([strokes](Cutout& c) { c.addStrokes(strokes); }, label);
    return;
  }
}

bool Editor::cutoutOwnsUndo() const {
  if (tool_ != Tool::Cutout || cutout_.photo < 0 || doc_.position() > cutout_.docPosition) return false;
  return !cutout_.undo.empty() || !cutout_.redo.empty() || !cutout_.queue.empty() || cutout_.job.valid();
}

bool Editor::cutoutOwnsRedo() const {
  if (tool_ != Tool::Cutout || cutout_.photo < 0 || doc_.position() != cutout_.docPosition) return false;
  return !cutout_.redo.empty() || !cutout_.unqueued.empty();
}

std::string Editor::cutoutUndoLabel() const {
  if (!cutout_.queue.empty()) return "queued cut-out stroke";
  if (cutout_.job.valid() && cutout_.jobStep) return "cut-out " + cutout_.jobLabel;
  return cutout_.undo.empty() ? "" : "cut-out " + cutout_.undo.back().label;
}

std::string Editor::cutoutRedoLabel() const {
  if (!cutout_.unqueued.empty()) return "queued cut-out stroke";
  return cutout_.redo.empty() ? "" : "cut-out " + cutout_.redo.back().label;
}

void Editor::cutoutUndo() {
  if (cutout_.drawing) return;
  if (!cutout_.queue.empty()) {
    // Not run yet: taken off the queue (redo puts it back).
    cutout_.unqueued.push_back(cutout_.queue.back());
    cutout_.queue.pop_back();
    setStatus("undo: queued cut-out stroke");
  } else if (cutout_.job.valid()) {
    ++cutout_.undoAfterJob;  // the job cannot stop midway: the newest step is taken back when it has finished
    setStatus("undo: " + cutoutUndoLabel() + " (once " + (cutout_.jobGrabCut ? "GrabCut" : "the mask") +
              " has finished)");
  } else if (!cutout_.undo.empty()) {
    CutoutState before = std::move(cutout_.undo.back());
    cutout_.undo.pop_back();
    const std::string label = before.label;
    cutout_.redo.push_back(takeCutoutState(label));
    restoreCutoutState(std::move(before));
    setStatus("undo: cut-out " + label);
  } else {
    hint("cut-out: this is where the cut started (Ctrl+Y redoes; choose another tool to undo document edits)");
  }
  cutout_.docPosition = doc_.position();
}

void Editor::cutoutRedo() {
  if (cutout_.drawing) return;
  if (!cutout_.unqueued.empty()) {
    const CutoutStep step = cutout_.unqueued.back();
    cutout_.unqueued.pop_back();
    std::vector<CutoutStep> rest;
    rest.swap(cutout_.unqueued);
    cutoutStep(step);  // clears the unqueued list: the rest is kept
    cutout_.unqueued.swap(rest);
    setStatus("redo: queued cut-out stroke");
  } else if (cutout_.job.valid()) {
    setStatus("cut-out: GrabCut is running; redo once it has finished");
  } else if (!cutout_.redo.empty()) {
    CutoutState after = std::move(cutout_.redo.back());
    cutout_.redo.pop_back();
    const std::string label = after.label;
    cutout_.undo.push_back(takeCutoutState(label));
    restoreCutoutState(std::move(after));
    setStatus("redo: cut-out " + label);
  }
  cutout_.docPosition = doc_.position();
}

std::string Editor::newMaskPath(int photo) const {
  // Beside the project, in masks/; while it is unsaved, in this session's own folder, which the first save
  // moves beside it (never beside the mesh: that may be a shared folder). A new name each time, so that undo
  // goes back to the previous file, which stays as it was.
  const Project& p = doc_.project();
  const fs::path dir = p.file.empty() ? fs::path(unsavedMaskFolder()) : fs::path(p.file).parent_path() / "masks";
  const std::string stem = fs::path(p.photos[photo].path).stem().string();
  for (int n = 1;; ++n) {
    const fs::path candidate = dir / (stem + (n == 1 ? "_mask.png" : "_mask_" + std::to_string(n) + ".png"));
    std::error_code ec;
    if (!fs::exists(candidate, ec)) return candidate.string();
  }
}

std::string Editor::unsavedMaskFolder() const {
  return (fs::path(editorStateDir()) / "unsaved-masks" / sessionId_).string();
}

std::vector<std::string> Editor::moveUnsavedMasks(const std::string& projectFile) {
  const fs::path from = fs::path(unsavedMaskFolder()).lexically_normal();
  const fs::path dir = fs::path(projectFile).parent_path() / "masks";
  std::map<std::string, std::string> moved;
  std::vector<std::string> sources;
  for (const std::string& mask : doc_.masksNamed()) {
    std::error_code ec;
    if (fs::path(mask).parent_path().lexically_normal() != from || !fs::exists(mask, ec)) continue;
    fs::create_directories(dir, ec);
    TM_CHECK(!ec, "save: cannot create the masks folder " + dir.string() + ": " + ec.message());
    const std::string stem = fs::path(mask).stem().string();
    fs::path to = dir / fs::path(mask).filename();
    for (int n = 2; fs::exists(to, ec); ++n) to = dir / (stem + "_" + std::to_string(n) + ".png");
    fs::copy_file(mask, to, ec);
    TM_CHECK(!ec, "save: cannot copy the mask " + mask + " to " + to.string() + ": " + ec.message());
    moved[mask] = to.string();
    sources.push_back(mask);
  }
  if (!moved.empty()) doc_.renameMasks(moved);
  return sources;
}

bool Editor::applyCutoutMask() {
  if (!cutout_.cut || !cutout_.cut->started() || cutout_.job.valid()) return false;
  const int photo = cutout_.photo;
  const Project& p = doc_.project();
  if (photo < 0 || photo >= static_cast<int>(p.photos.size())) return false;
  try {
    cv::Mat mask = cutout_.cut->mask();
    TM_CHECK(cv::countNonZero(mask) > 0, "cut-out: the mask is empty (no foreground): nothing to use");
    // A mask is in its photo file's own pixels: undo the mirror the pane shows.
    if (p.photos[photo].mirror) cv::flip(mask, mask, 1);
    const std::string path = newMaskPath(photo);
    writeMaskPng(mask, path);
    if (!edit([&] { doc_.setPhotoMask(photo, path); })) return false;
    setStatus("mask of photo " + std::to_string(photo) + " written to " + path +
              (p.file.empty() ? " (moved beside the project when you save it)" : ""));
    return true;
  } catch (const Error& e) {
    reportError(e.what());
    return false;
  }
}

void Editor::cutoutCanvas(int i, const PaneView& view, bool hovered) {
  ImDrawList* draw = ImGui::GetWindowDrawList();
  const PhotoSlot& slot = photos_[i];
  if (!slot.photo) return;
  const Photo& photo = *slot.photo;
  ImGuiIO& io = ImGui::GetIO();
  const Vec2 mouse(io.MousePos.x, io.MousePos.y);
  const Vec2 at = view.toPhoto(mouse);
  const bool mine = cutout_.photo == i;

  // The cut-out so far: the background tinted, the rectangle, the strokes.
  if (mine && !cutout_.mask.empty()) {
    if (cutout_.overlayDirty) {
      // Made with the mask on the helper thread after a step; here after an undo, a redo or a new session.
      if (cutout_.overlayImage.empty()) cutout_.overlayImage = cutoutOverlay(cutout_.mask);
      if (!cutout_.overlay) cutout_.overlay = std::make_unique<Texture>();
      cutout_.overlay->uploadAlpha(cutout_.overlayImage);
      cutout_.overlayImage.release();
      cutout_.overlayDirty = false;
    }
    draw->AddImage(imTexture(*cutout_.overlay), im(view.toScreen(Vec2(0, 0))),
                   im(view.toScreen(Vec2(photo.width, photo.height))), ImVec2(0, 0), ImVec2(1, 1), kCutoutTint);
  }
  const float zoom = float(view.zoom);
  if (mine && cutout_.rect)
    draw->AddRect(
        im(view.toScreen(Vec2(cutout_.rect->x, cutout_.rect->y))),
        im(view.toScreen(Vec2(cutout_.rect->x + cutout_.rect->width, cutout_.rect->y + cutout_.rect->height))),
        IM_COL32(255, 220, 60, 255), 0, 0, 2);
  auto drawPath = [&](const std::vector<Vec2>& pts, float radius, ImU32 colour) {
    const float width = std::max(1.5f, 2 * radius * zoom);
    if (pts.size() == 1) draw->AddCircleFilled(im(view.toScreen(pts[0])), width / 2, colour);
    for (size_t k = 0; k + 1 < pts.size(); ++k)
      draw->AddLine(im(view.toScreen(pts[k])), im(view.toScreen(pts[k + 1])), colour, width);
  };
  if (mine)
    for (const CutoutStroke& s : cutout_.strokes) drawPath(s.points, float(s.radius), strokeColour(s, false));
  const bool brush = cutoutMode_ == CutoutMode::Add || cutoutMode_ == CutoutMode::Erase;
  const bool fg = cutoutMode_ == CutoutMode::Foreground || cutoutMode_ == CutoutMode::Add;
  if (mine && cutout_.drawing) {
    if (cutoutMode_ == CutoutMode::Rect && !cutout_.path.empty())
      draw->AddRect(im(view.toScreen(cutout_.dragStart)), im(view.toScreen(cutout_.path.back())),
                    IM_COL32(255, 220, 60, 200), 0, 0, 1.5f);
    else
      drawPath(cutout_.path, cutoutRadius_, strokeColour(CutoutStroke{{}, 0, fg}, brush));
  }
  if (hovered && cutoutMode_ != CutoutMode::Rect)
    draw->AddCircle(im(mouse), std::max(2.0f, cutoutRadius_ * zoom), IM_COL32(255, 255, 255, 200), 0, 1.0f);
  // Strokes drawn while GrabCut runs, waiting for it: shown fainter until they are applied.
  if (mine)
    for (const CutoutStep& q : cutout_.queue) {
      if (q.mode == CutoutMode::Rect) {
        draw->AddRect(im(view.toScreen(Vec2(q.rect.x, q.rect.y))),
                      im(view.toScreen(Vec2(q.rect.x + q.rect.width, q.rect.y + q.rect.height))),
                      IM_COL32(255, 220, 60, 120), 0, 0, 1.5f);
      } else {
        const bool qBrush = q.mode == CutoutMode::Add || q.mode == CutoutMode::Erase;
        drawPath(q.stroke.points, float(q.stroke.radius),
                 strokeColour(q.stroke, qBrush) & IM_COL32(255, 255, 255, 110));
      }
    }
  if (mine && cutout_.job.valid() && canvasRects_.count(i)) {
    // The busy state, in the pane where the user is drawing: a band across its top with a moving bar.
    const Rect& c = canvasRects_[i];
    const float bandH = ImGui::GetFontSize() + px(8);
    const ImVec2 b0(float(c.x), float(c.y)), b1(float(c.x + c.w), float(c.y) + bandH);
    draw->AddRectFilled(b0, b1, IM_COL32(40, 34, 10, 210));
    const float t = float(std::fmod(ImGui::GetTime() * 0.8, 1.0));
    const float barW = float(c.w) * 0.2f, barX = float(c.x) + t * (float(c.w) + barW) - barW;
    draw->AddRectFilled(ImVec2(std::max(b0.x, barX), b1.y - px(3)), ImVec2(std::min(b1.x, barX + barW), b1.y),
                        IM_COL32(255, 200, 60, 255));
    const std::string text = std::string(cutout_.jobGrabCut ? "GrabCut running (" : "making the mask (") +
                             cutout_.jobLabel + ")" +
                             (cutout_.queue.empty() ? std::string(": keep drawing, strokes are queued")
                                                    : ", then " + std::to_string(cutout_.queue.size()) + " queued");
    draw->AddText(ImVec2(b0.x + px(8), b0.y + px(4)), IM_COL32(255, 230, 120, 255), text.c_str());
  }
  if (hovered && !cutout_.drawing) {
    // The mode at the cursor, so that a drag never does something other than the user expects.
    draw->AddText(ImVec2(float(mouse.x()) + px(14), float(mouse.y()) + px(10)), IM_COL32(255, 255, 255, 220),
                  kModeText[static_cast<int>(cutoutMode_)]);
  }

  // Input: press, drag, release.
  const auto clamped = [&](Vec2 q) {
    return Vec2(std::clamp(q.x(), 0.0, double(photo.width)), std::clamp(q.y(), 0.0, double(photo.height)));
  };
  if (hovered && ImGui::IsMouseClicked(ImGuiMouseButton_Left)) {
    activePhoto_ = i;
    // While GrabCut runs, the user draws on: the step is queued (cutoutStep) and applied after it.
    if (mine || startCutout(i, cutoutMode_ != CutoutMode::Rect)) {
      cutout_.drawing = true;
      cutout_.dragStart = clamped(at);
      cutout_.path = {cutout_.dragStart};
    } else if (cutout_.job.valid()) {
      setStatus("cut-out: GrabCut is running on photo " + std::to_string(cutout_.photo) +
                "; draw on that photo, or wait for it");
    }
  }
  if (!mine || !cutout_.drawing) return;
  if (ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
    const Vec2 q = clamped(at);
    if ((view.toScreen(q) - view.toScreen(cutout_.path.back())).norm() >= 2) cutout_.path.push_back(q);
    return;
  }
  // Released.
  cutout_.drawing = false;
  const std::vector<Vec2> path = std::move(cutout_.path);
  cutout_.path.clear();
  CutoutStep step;
  step.mode = cutoutMode_;
  if (cutoutMode_ == CutoutMode::Rect) {
    const Vec2 a = cutout_.dragStart, b = path.back();
    step.rect =
        cv::Rect2d(std::min(a.x(), b.x()), std::min(a.y(), b.y()), std::abs(b.x() - a.x()), std::abs(b.y() - a.y()));
    if (step.rect.width < 3 || step.rect.height < 3) {
      setStatus("cut-out: drag a rectangle around the object");
      return;
    }
    // The next drag refines this cut: strokes, not another rectangle that would start over (the
    // rectangle mode is one click away, and a new rectangle is an undoable step too).
    cutoutMode_ = CutoutMode::Foreground;
    cutoutStep(step);
    if (!cutout_.job.valid() || cutout_.queue.empty())
      setStatus("cut-out: GrabCut from the rectangle; now strokes refine it (mode: foreground)");
    return;
  }
  step.stroke = CutoutStroke{path, cutoutRadius_, fg};
  cutoutStep(step);
}

}  // namespace montage
