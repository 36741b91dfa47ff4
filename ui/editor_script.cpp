// Scripts (synthetic input through ImGui's IO, so a script clicks exactly where a user would),
// screenshots, the state dump tests read, and the frame-time benchmarks.
#include <imgui.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <set>

#include "editor.h"
#include "gl.h"
#include "gl_util.h"
#include "image/codec.h"
#include "overlay_gl.h"
#include "plain_words.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

double now() {
  return glfwGetTime();
}

int glfwKeyOf(const std::string& key) {
  if (key.size() == 1 && std::isalpha(static_cast<unsigned char>(key[0]))) return GLFW_KEY_A + (key[0] - 'a');
  if (key.size() == 1 && std::isdigit(static_cast<unsigned char>(key[0]))) return GLFW_KEY_0 + (key[0] - '0');
  static const std::pair<const char*, int> kNamed[] = {
      {"delete", GLFW_KEY_DELETE}, {"enter", GLFW_KEY_ENTER}, {"escape", GLFW_KEY_ESCAPE},
      {"tab", GLFW_KEY_TAB},       {"space", GLFW_KEY_SPACE}, {"backspace", GLFW_KEY_BACKSPACE},
      {"home", GLFW_KEY_HOME},     {"end", GLFW_KEY_END},     {"left", GLFW_KEY_LEFT},
      {"right", GLFW_KEY_RIGHT},   {"up", GLFW_KEY_UP},       {"down", GLFW_KEY_DOWN}};
  for (const auto& [name, code] : kNamed)
    if (key == name) return code;
  if (key.size() >= 2 && key[0] == 'f') return GLFW_KEY_F1 + std::stoi(key.substr(1)) - 1;
  return GLFW_KEY_UNKNOWN;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

bool optionFlag(const std::string& value, const std::string& where) {
  if (value == "on" || value == "1" || value == "true") return true;
  if (value == "off" || value == "0" || value == "false") return false;
  throw Error(where + ": expected on or off, not '" + value + "'");
}

}  // namespace

// --- Synthetic input -----------------------------------------------------------------------------

void Editor::queueClick(double x, double y, int button) {
  InputStep move;
  move.hasPointer = true;
  move.x = x;
  move.y = y;
  InputStep press = move;
  press.buttons[button] = true;
  inputQueue_.push_back(move);
  inputQueue_.push_back(press);
  inputQueue_.push_back(move);
  inputQueue_.push_back(move);  // one more frame so the release is handled before the next action
}

void Editor::queueFirst(const std::function<void()>& queue) {
  std::deque<InputStep> rest;
  rest.swap(inputQueue_);
  queue();
  inputQueue_.insert(inputQueue_.end(), rest.begin(), rest.end());
}

void Editor::queueButtonClick(const std::string& label, const std::string& where, int attempts) {
  // A panel may still be laying out (a photo loading, the worker's bar appearing): aim, and press only when the
  // button is still under the pointer in the frame after the move, as a user's eye would check.
  InputStep aim;
  aim.call = [this, label, where, attempts] {
    TM_CHECK(attempts > 0, where + ": button '" + label + "' kept moving");
    TM_CHECK(buttonRects_.count(label), where + ": button '" + label + "' left the screen");
    const Rect r = buttonRects_.at(label);
    const double x = r.x + r.w / 2, y = r.y + r.h / 2;
    InputStep move;
    move.hasPointer = true;
    move.x = x;
    move.y = y;
    InputStep check;
    check.call = [this, label, where, attempts, x, y] {
      const auto it = buttonRects_.find(label);
      const bool stayed = it != buttonRects_.end() && it->second.contains(x, y);
      queueFirst([&] { stayed ? queueClick(x, y) : queueButtonClick(label, where, attempts - 1); });
    };
    queueFirst([&] { inputQueue_.push_back(move), inputQueue_.push_back(std::move(check)); });
  };
  inputQueue_.push_back(std::move(aim));
}

void Editor::queueDrag(double x0, double y0, double x1, double y1, int button, int steps) {
  InputStep s;
  s.hasPointer = true;
  s.x = x0;
  s.y = y0;
  inputQueue_.push_back(s);
  s.buttons[button] = true;
  inputQueue_.push_back(s);
  for (int k = 1; k <= steps; ++k) {
    s.x = x0 + (x1 - x0) * k / steps;
    s.y = y0 + (y1 - y0) * k / steps;
    inputQueue_.push_back(s);
  }
  s.buttons[button] = false;
  inputQueue_.push_back(s);
  inputQueue_.push_back(s);
}

void Editor::queueKey(const KeyCombo& combo) {
  InputStep down;
  down.keys.push_back(glfwKeyOf(combo.key));
  down.ctrl = combo.ctrl;
  down.shift = combo.shift;
  down.alt = combo.alt;
  inputQueue_.push_back(down);
  inputQueue_.push_back(InputStep{});  // release
  inputQueue_.push_back(InputStep{});
}

void Editor::scriptStep() {
  frameInput_ = InputStep{};
  // The first frames load the document's mesh and photos and lay out the panels that actions refer to.
  if (frameNumber_ < 2) return;
  for (;;) {
    // A wait blocks everything after it, including queued input.
    if (waitUntil_) {
      if (!waitUntil_()) {
        if (now() > waitDeadline_) {
          waitUntil_ = nullptr;
          throw Error(waitWhat_ + ": timed out");
        }
        return;
      }
      waitUntil_ = nullptr;
    }
    if (!inputQueue_.empty()) {
      InputStep step = std::move(inputQueue_.front());
      inputQueue_.pop_front();
      if (step.call) {
        step.call();
        continue;
      }
      frameInput_ = std::move(step);
      return;
    }
    if (scriptPos_ >= script_.size()) {
      scripted_ = false;  // the script ended without quit: the editor goes on, interactive
      return;
    }
    runAction(script_[scriptPos_++]);
    if (quit_) return;
  }
}

void Editor::applySyntheticInput(ImGuiIO& io) {
  if (frameInput_.hasPointer) {
    heldX_ = frameInput_.x;
    heldY_ = frameInput_.y;
  }
  io.MousePos = ImVec2(float(heldX_), float(heldY_));
  for (int b = 0; b < 3; ++b) io.MouseDown[b] = frameInput_.buttons[b];
  io.MouseWheel += frameInput_.wheel;
  for (int key : syntheticKeys_) io.KeysDown[key] = false;
  syntheticKeys_.clear();
  for (int key : frameInput_.keys)
    if (key >= 0 && key < 512) {
      io.KeysDown[key] = true;
      syntheticKeys_.push_back(key);
    }
  io.KeyCtrl = frameInput_.ctrl;
  io.KeyShift = frameInput_.shift;
  io.KeyAlt = frameInput_.alt;
}

// --- Script actions -------------------------------------------------------------------------------

void Editor::waitFor(const std::string& what, double seconds, std::function<bool()> condition, bool onEvents) {
  waitOnEvents_ = onEvents;
  waitWhat_ = what;
  waitDeadline_ = now() + seconds;
  waitUntil_ = std::move(condition);
}

void Editor::runAction(const ScriptAction& a) {
  const std::string where = a.where();
  const Project& p = doc_.project();
  auto requireMesh = [&] { TM_CHECK(input_.mesh, where + ": no mesh is loaded"); };
  auto requireVertex = [&](int v) {
    requireMesh();
    TM_CHECK(v >= 0 && v < input_.mesh->numVertices(), where + ": vertex " + std::to_string(v) +
                                                           " is not in the mesh (" +
                                                           std::to_string(input_.mesh->numVertices()) + " vertices)");
  };
  auto requirePhoto = [&](int photo) {
    TM_CHECK(photo >= 0 && photo < static_cast<int>(p.photos.size()), where + ": photo " + std::to_string(photo) +
                                                                          " does not exist (" +
                                                                          std::to_string(p.photos.size()) + " photos)");
  };
  const double timeout = a.args.empty() ? 0 : (a.verb.rfind("wait_", 0) == 0 ? a.number(0) : 0);

  if (a.verb == "wait_frames") {
    const long target = frameNumber_ + a.integer(0);
    waitFor(where, std::numeric_limits<double>::infinity(), [this, target] { return frameNumber_ >= target; });
  } else if (a.verb == "wait_worker") {
    waitFor(
        where + " (the worker did not finish)", a.args.empty() ? 300 : timeout,
        [this] {
          if (doc_.project().mesh.empty()) return true;
          if (doc_.inGroup() || submittedRevision_ != doc_.revision() || worker_->status().busy) return false;
          // Done when the newest submission came back (its final result, or an error) and its buffers are
          // uploaded.
          const bool answered =
              (resultGeneration_ == submittedGeneration_ && result_ && result_->tier == Tier::Final) ||
              lastErrorGeneration_ == submittedGeneration_;
          return answered && !meshDirty_ && uploadedModel_ != nullptr;
        },
        true);
  } else if (a.verb == "wait_result") {
    // The first result of the newest submission is shown (the preview; the final bake may still run).
    waitFor(
        where + " (no result came back)", a.args.empty() ? 300 : timeout,
        [this] {
          if (doc_.project().mesh.empty()) return true;
          if (doc_.inGroup() || submittedRevision_ != doc_.revision()) return false;
          const bool answered =
              resultGeneration_ == submittedGeneration_ || lastErrorGeneration_ == submittedGeneration_;
          return answered && !meshDirty_ && uploadedModel_ != nullptr;
        },
        true);
  } else if (a.verb == "wait_busy") {
    int tier = -1;  // any
    if (a.args.size() > 1) {
      const auto it = std::find(kTierNames.begin(), kTierNames.end(), a.text(1));
      TM_CHECK(it != kTierNames.end(), where + ": unknown tier '" + a.text(1) + "' (preview, final, quick)");
      tier = static_cast<int>(it - kTierNames.begin());
    }
    waitFor(where + " (the worker never started)", a.args.empty() ? 60 : timeout, [this, tier] {
      const WorkerStatus s = worker_->status();
      return s.busy && s.generation == submittedGeneration_ && (tier < 0 || static_cast<int>(s.tier) == tier);
    });
  } else if (a.verb == "wait_idle") {
    waitFor(where + " (the worker is still running)", a.args.empty() ? 60 : timeout, [this] {
      if (worker_->status().busy) return false;
      if (cancelAt_ >= 0) cancelSeconds_ = now() - cancelAt_, cancelAt_ = -1;  // how long a Cancel took
      return true;
    });
  } else if (a.verb == "wait_autosave") {
    waitFor(where + " (no autosave was written)", a.args.empty() ? 300 : timeout,
            [this] { return autosavedRevision_ == doc_.revision(); });
  } else if (a.verb == "sleep") {
    const double until = now() + a.number(0);
    waitFor(where, a.number(0) + 1, [this, until] { return now() >= until; });
  } else if (a.verb == "real_input") {
    const double seconds = a.args.size() > 1 ? a.number(1) : 300;
    waitRealInput_ = true;
    waitFor(
        where + " (" + a.text(0) + " never appeared)", seconds,
        [this, file = a.text(0)] {
          std::error_code ec;
          if (!fs::exists(file, ec)) return false;
          waitRealInput_ = false;
          return true;
        },
        true);
  } else if (a.verb == "tool") {
    const auto it = std::find(kToolNames.begin(), kToolNames.end(), a.text(0));
    TM_CHECK(it != kToolNames.end(),
             where + ": unknown tool '" + a.text(0) + "' (point, line, polygon, stroke, clone, cutout)");
    cancelInProgress();
    tool_ = Tool(it - kToolNames.begin());
  } else if (a.verb == "view") {
    const std::string& what = a.text(0);
    const bool on = a.args.size() < 2 || optionFlag(a.text(1), where);
    if (what == "textured")
      textured_ = on;
    else if (what == "shaded")
      textured_ = !on;
    else if (what == "wireframe")
      wireframe_ = on;
    else if (what == "paths")
      showPaths_ = on;
    else if (what == "features")
      showFeatures_ = on;
    else if (what == "patches")
      coloring_ = on ? FaceColoring::Patches : FaceColoring::None;
    else if (what == "empty")
      coloring_ = on ? FaceColoring::Empty : FaceColoring::None;
    else if (what == "stretch")
      coloring_ = on ? FaceColoring::Stretch : FaceColoring::None;
    else if (what == "seams")
      coloring_ = on ? FaceColoring::SeamError : FaceColoring::None;
    else if (what == "grid")
      gridPanes_ = on;
    else if (what == "balanced")
      showBalanced_ = on;
    else
      throw Error(where + ": unknown display setting '" + what + "'");
    overlayDirty_ = true;
  } else if (a.verb == "view_vertex") {
    const int v = a.integer(0);
    requireVertex(v);
    const std::vector<Vec3f> normals = vertexNormals(*input_.mesh);
    camera_.lookFrom(input_.mesh->position(v), normals[v].cast<double>());
  } else if (a.verb == "frame") {
    requireMesh();
    frameAll();
  } else if (a.verb == "frame_selected") {
    requireMesh();
    frameSelected();
  } else if (a.verb == "view_preset") {
    const auto it = std::find(kViewPresetNames.begin(), kViewPresetNames.end(), a.text(0));
    TM_CHECK(it != kViewPresetNames.end(), where + ": unknown preset '" + a.text(0) + "'");
    setViewPreset(ViewPreset(it - kViewPresetNames.begin()));
  } else if (a.verb == "tab") {
    static const std::set<std::string> tabs = {"points",  "chains",   "photos",  "strokes",
                                               "history", "pipeline", "coverage"};
    TM_CHECK(tabs.count(a.text(0)), where + ": unknown tab '" + a.text(0) +
                                        "' (points, chains, photos, strokes, history, pipeline, coverage)");
    requestedTab_ = a.text(0);
    waitFor(where, 10, [this] { return requestedTab_.empty(); });  // selected in the next frame
  } else if (a.verb == "ortho") {
    setOrthographic(camera_, optionFlag(a.text(0), where));
  } else if (a.verb == "mouse") {
    const auto it = std::find(kMouseBindingNames.begin(), kMouseBindingNames.end(), a.text(0));
    TM_CHECK(it != kMouseBindingNames.end(), where + ": mouse bindings are meshlab or blender");
    bindings_ = MouseBindings(it - kMouseBindingNames.begin());
  } else if (a.verb == "hover_3d") {
    requireMesh();
    InputStep s;
    s.hasPointer = true;
    s.x = viewRect_.x + a.number(0);
    s.y = viewRect_.y + a.number(1);
    inputQueue_.push_back(s);
    inputQueue_.push_back(s);
  } else if (a.verb == "click_vertex") {
    const int v = a.integer(0);
    requireVertex(v);
    Vec2 px;
    const Camera cam = viewCamera();
    TM_CHECK(cam.project(input_.mesh->position(v), px) && px.x() >= 0 && px.y() >= 0 && px.x() < cam.width &&
                 px.y() < cam.height,
             where + ": vertex " + std::to_string(v) + " is outside the 3D view (try view_vertex " + std::to_string(v) +
                 ")");
    const double x = viewRect_.x + px.x(), y = viewRect_.y + px.y();
    queueClick(x, y);
    InputStep check;
    check.call = [this, v, x, y, where] {
      TM_CHECK(selectedVertex_ == v, where + ": the click at (" + std::to_string(x) + ", " + std::to_string(y) +
                                         ") picked vertex " + std::to_string(selectedVertex_) + ", not " +
                                         std::to_string(v) + " (hidden? try view_vertex first)");
    };
    inputQueue_.push_back(std::move(check));
  } else if (a.verb == "click_3d" || a.verb == "drag_3d" || a.verb == "scroll_3d") {
    requireMesh();
    if (a.verb == "click_3d") {
      queueClick(viewRect_.x + a.number(0), viewRect_.y + a.number(1));
    } else if (a.verb == "drag_3d") {
      int button = 0;
      if (a.args.size() > 4) {
        const std::string& b = a.text(4);
        TM_CHECK(b == "left" || b == "right" || b == "middle", where + ": button must be left, right or middle");
        button = b == "left" ? 0 : b == "right" ? 1 : 2;
      }
      queueDrag(viewRect_.x + a.number(0), viewRect_.y + a.number(1), viewRect_.x + a.number(2),
                viewRect_.y + a.number(3), button);
    } else {
      InputStep s;
      s.hasPointer = true;
      s.x = viewRect_.x + (a.args.size() >= 3 ? a.number(1) : viewRect_.w / 2);
      s.y = viewRect_.y + (a.args.size() >= 3 ? a.number(2) : viewRect_.h / 2);
      inputQueue_.push_back(s);
      s.wheel = static_cast<float>(a.number(0));
      inputQueue_.push_back(s);
      s.wheel = 0;
      inputQueue_.push_back(s);
    }
  } else if (a.verb == "photo" || a.verb == "click_photo" || a.verb == "drag_photo") {
    const int photo = a.integer(0);
    requirePhoto(photo);
    activePhoto_ = photo;
    if (a.verb == "photo") return;
    std::vector<double> xy;
    for (size_t k = 1; k < a.args.size(); ++k) xy.push_back(a.number(k));
    // The pane shows the photo a frame or two after it is chosen (tab switch); then click.
    waitFor(where + " (the photo pane did not appear)", 10, [this, photo] {
      return canvasRects_.count(photo) && photos_[photo].photo && (gridPanes_ || shownTab_ == photo) &&
             (gridPanes_ ? photos_[photo].gridView : photos_[photo].tabView).fitted;
    });
    InputStep call;
    call.call = [this, photo, xy, where, drag = a.verb == "drag_photo"] {
      const PaneView& view = gridPanes_ ? photos_[photo].gridView : photos_[photo].tabView;
      const Rect& r = canvasRects_.at(photo);
      std::vector<Vec2> screen;
      for (size_t k = 0; k + 1 < xy.size(); k += 2) {
        screen.push_back(view.toScreen(Vec2(xy[k], xy[k + 1])));
        TM_CHECK(r.contains(screen.back().x(), screen.back().y()), where + ": photo point (" + std::to_string(xy[k]) +
                                                                       ", " + std::to_string(xy[k + 1]) +
                                                                       ") is not visible in the pane");
      }
      // The clicks right here in the queue, before whatever follows.
      queueFirst([&] {
        drag ? queueDrag(screen[0].x(), screen[0].y(), screen[1].x(), screen[1].y(), 0)
             : queueClick(screen[0].x(), screen[0].y());
      });
    };
    inputQueue_.push_back(std::move(call));
  } else if (a.verb == "key") {
    queueKey(parseKeyCombo(a.text(0)));
  } else if (a.verb == "click_button") {
    const std::string label = a.text(0);
    waitFor(where + " (no button '" + label + "' on screen)", 10,
            [this, label] { return buttonRects_.count(label) > 0; });
    queueButtonClick(label, where, 20);
  } else if (a.verb == "select_vertex") {
    const int v = a.integer(0);
    requireVertex(v);
    selectVertex(v);
  } else if (a.verb == "set_option") {
    // The same names as the project file's "options" object (docs/project-format.md).
    auto json = nlohmann::json::parse(projectToJson(p, ""));
    auto& options = json["options"];
    const std::string& name = a.text(0);
    TM_CHECK(options.contains(name), where + ": unknown option '" + name + "'");
    if (options[name].is_string()) {
      options[name] = a.text(1);
    } else if (options[name].is_boolean()) {
      options[name] = optionFlag(a.text(1), where);
    } else if (options[name].is_number_integer()) {
      options[name] = a.integer(1);
    } else {
      options[name] = a.number(1);
    }
    // Round-trip through the project reader, so the option's range is checked as in a file.
    const std::string tmp = (fs::temp_directory_path() / ("tm_option_" + std::to_string(getpid()) + ".json")).string();
    writeFileAtomic(tmp, json.dump());
    Project parsed;
    try {
      parsed = loadProject(tmp);
    } catch (const Error& e) {
      fs::remove(tmp);
      throw Error(where + ": " + e.what());
    }
    fs::remove(tmp);
    TM_CHECK(edit([&] { doc_.setOptions(parsed.options, "Change option " + name); }), where + ": refused");
  } else if (a.verb == "open") {
    TM_CHECK(openFile(a.text(0)), where + ": " + (lastProblem_.empty() ? "failed" : lastProblem_));
    checkRecovery();
  } else if (a.verb == "add_photos") {
    const size_t before = p.photos.size();
    addPhotosFrom(a.text(0));
    TM_CHECK(doc_.project().photos.size() > before,
             where + ": " + (lastProblem_.empty() ? "no photo added" : lastProblem_));
  } else if (a.verb == "drop") {
    dropped_.insert(dropped_.end(), a.args.begin(), a.args.end());  // as GLFW's drop callback does
  } else if (a.verb == "relink") {
    bool ok = false;
    if (a.text(0) == "mesh") {
      ok = relinkMesh(a.text(1));
    } else {
      requirePhoto(a.integer(0));
      ok = relinkPhoto(a.integer(0), a.text(1));
    }
    TM_CHECK(ok, where + ": " + (lastProblem_.empty() ? "refused" : lastProblem_));
  } else if (a.verb == "photo_flag") {
    const int photo = a.integer(0);
    requirePhoto(photo);
    const bool on = optionFlag(a.text(2), where);
    bool ok = false;
    if (a.text(1) == "mirror") {
      const int width =
          photo < static_cast<int>(photos_.size()) && photos_[photo].photo ? photos_[photo].photo->width : 0;
      ok = edit([&] { doc_.setPhotoMirror(photo, on, width); });
    } else if (a.text(1) == "lock") {
      ok = edit([&] { doc_.setColorLocked(photo, on); });
    } else {
      throw Error(where + ": unknown flag '" + a.text(1) + "' (mirror, lock)");
    }
    TM_CHECK(ok, where + ": " + (lastProblem_.empty() ? "refused" : lastProblem_));
  } else if (a.verb == "photo_mode") {
    const int photo = a.integer(0);
    requirePhoto(photo);
    const auto it = std::find(kPhotoModeNames.begin(), kPhotoModeNames.end(), a.text(1));
    TM_CHECK(it != kPhotoModeNames.end(), where + ": unknown photo mode '" + a.text(1) + "' (auto, object, subject)");
    TM_CHECK(edit([&] { doc_.setPhotoMode(photo, PhotoMode(it - kPhotoModeNames.begin())); }),
             where + ": " + (lastProblem_.empty() ? "refused" : lastProblem_));
  } else if (a.verb == "cutout_mode") {
    const auto it = std::find(kCutoutModeNames.begin(), kCutoutModeNames.end(), a.text(0));
    TM_CHECK(it != kCutoutModeNames.end(),
             where + ": unknown cut-out mode '" + a.text(0) + "' (rect, foreground, background, add, erase)");
    cutoutMode_ = CutoutMode(it - kCutoutModeNames.begin());
    if (a.args.size() > 1) cutoutRadius_ = static_cast<float>(a.number(1));
    if (a.args.size() > 2) cutoutFeather_ = static_cast<float>(a.number(2));
  } else if (a.verb == "cutout_delay") {
    cutoutDelay_ = a.number(0);
  } else if (a.verb == "wait_cutout") {
    waitFor(where + " (GrabCut did not finish)", a.args.empty() ? 120 : timeout,
            [this] { return !cutout_.job.valid() && cutout_.queue.empty(); });
  } else if (a.verb == "save") {
    const std::string path = a.args.empty() ? p.file : a.text(0);
    TM_CHECK(!path.empty(), where + ": the project has no file yet: give a path");
    TM_CHECK(saveTo(path), where + ": " + (lastProblem_.empty() ? "failed" : lastProblem_));
  } else if (a.verb == "export") {
    TM_CHECK(exportTo(a.text(0)), where + ": " + (lastProblem_.empty() ? "failed" : lastProblem_));
  } else if (a.verb == "screenshot") {
    pendingScreenshot_ = a.text(0);
    waitFor(where, 30, [this] { return pendingScreenshot_.empty(); });
  } else if (a.verb == "state") {
    writeState(a.text(0));
  } else if (a.verb == "menu") {
    requestedMenu_ = a.text(0);
    menuFailed_.clear();
    waitFor(where, 10, [this] { return requestedMenu_.empty(); });  // the next frame's menu bar answers
    InputStep check;
    check.call = [this, where] {
      TM_CHECK(menuFailed_.empty(), where + ": no enabled menu item '" + menuFailed_ + "'");
    };
    inputQueue_.push_back(std::move(check));
  } else if (a.verb == "menu_list") {
    menuListFile_ = a.text(0);
    waitFor(where, 10, [this] { return menuListFile_.empty(); });  // the next frame's menu bar writes it
  } else if (a.verb == "dialog_filter") {
    TM_CHECK(dialogs_.active(), where + ": no file dialog is open");
    TM_CHECK(dialogs_.chooseFilter(a.text(0)), where + ": the dialog has no filter '" + a.text(0) + "'");
  } else if (a.verb == "drag_splitter") {
    // Press on the bar's centre, move by (DX, DY), release: as a user drags it.
    const std::string bar = a.text(0);
    TM_CHECK(splitterRects_.count(bar), where + ": no splitter '" + bar + "' (left, tools, view)");
    const Rect r = splitterRects_.at(bar);
    queueDrag(r.x + r.w / 2, r.y + r.h / 2, r.x + r.w / 2 + a.number(1), r.y + r.h / 2 + a.number(2), 0);
  } else if (a.verb == "close") {
    requestClose();
  } else if (a.verb == "quit") {
    quit_ = true;
  } else {
    throw Error(where + ": not implemented");
  }
}

// --- State, screenshots -------------------------------------------------------------------------

void Editor::writeState(const std::string& path) const {
  using nlohmann::json;
  const Project& p = doc_.project();
  auto rect = [](const Rect& r) { return json{{"x", r.x}, {"y", r.y}, {"w", r.w}, {"h", r.h}}; };
  json state;
  state["pid"] = static_cast<long long>(getpid());
  state["frame"] = frameNumber_;
  state["file"] = p.file;
  state["mesh"] = p.mesh;
  state["revision"] = doc_.revision();
  state["modified"] = doc_.modified();
  state["counts"] = {{"photos", p.photos.size()},
                     {"points", p.points.size()},
                     {"chains", p.chains.size()},
                     {"strokes", p.strokes.size()},
                     {"clones", p.clones.size()}};
  state["history"] = {{"steps", doc_.history().size()}, {"position", doc_.position()}};
  state["selected_vertex"] = selectedVertex_;
  state["selected_point"] = selectedPoint_;
  state["labels"] = drawnLabels_;
  std::vector<int> ids;  // the Points list's ids, in its order
  for (size_t i = 0; i < p.points.size(); ++i) ids.push_back(pointId(p, int(i)));
  state["point_ids"] = ids;
  state["tool"] = kToolNames[static_cast<int>(tool_)];
  const WorkerStatus ws = worker_->status();
  std::vector<long> outcomeGenerations;
  std::vector<std::string> outcomeTiers;
  for (const auto& [generation, tier] : outcomes_)
    outcomeGenerations.push_back(generation), outcomeTiers.push_back(kTierNames[static_cast<int>(tier)]);
  const auto latencyParts = [](const LatencyParts& l) {
    return json{{"queue", l.queue}, {"pipeline", l.pipeline}, {"model", l.model},
                {"take", l.take},   {"draw", l.draw},         {"frames", l.frames}};
  };
  state["worker"] = {{"busy", ws.busy},
                     {"submitted_generation", submittedGeneration_},
                     {"result_generation", resultGeneration_},
                     {"outcome_generations", outcomeGenerations},
                     {"outcome_tiers", outcomeTiers},
                     {"preview_latency_seconds", shownLatency_[0]},  // last edit -> preview drawn
                     {"final_latency_seconds", shownLatency_[1]},    // last edit -> final drawn
                     {"quick_latency_seconds", shownLatency_[2]},    // last edit -> quick preview drawn
                     {"latency_parts", json::array({latencyParts(shownParts_[0]), latencyParts(shownParts_[1]),
                                                    latencyParts(shownParts_[2])})},
                     {"last_error", lastError_}};
  if (result_) {
    json stages = json::array();
    for (const StageRecord& s : result_->stages)
      stages.push_back({{"stage", stageName(s.stage)}, {"seconds", s.seconds}, {"cached", s.cached}});
    json perPhoto = json::array();
    if (result_->mapping) {
      std::vector<int> count(p.photos.size(), 0);
      for (int photo : result_->mapping->map.facePhoto)
        if (photo >= 0 && photo < static_cast<int>(count.size())) ++count[photo];
      perPhoto = count;
    }
    state["result"] = {{"matches_document", resultCurrent()},
                       {"tier", kTierNames[int(result_->tier)]},
                       {"faces_per_photo", perPhoto},
                       {"project", json::parse(projectToJson(result_->scene->document(), ""))},
                       {"faces", result_->model ? result_->model->mesh.numFaces() : 0},
                       {"stages", stages},
                       {"warnings", result_->warnings}};
  } else {
    state["result"] = nullptr;
  }
  state["errors"] = errors_;
  state["errors_window"] = showErrors_;
  state["hint"] = hint_;
  state["recent"] = recent_.files();
  state["cancelled"] = cancelled_;
  state["cancel_seconds"] = cancelSeconds_;
  state["scale"] = scale_;
  state["active_photo"] = activePhoto_;
  // The active photo's pane zoom (tabs), and the buttons drawn on screen with the part of each not clipped.
  state["pane_zoom"] = activePhoto_ < int(photos_.size()) ? photos_[activePhoto_].tabView.zoom : 0.0;
  json buttons = json::object();
  for (const auto& [name, r] : buttonRects_) buttons[name] = rect(r);
  state["buttons"] = buttons;
  state["tab"] = listsTab_;
  json tabs = json::object();  // the Document panel's tab buttons, whole (not clipped to the panel)
  for (const auto& [name, r] : tabRects_) tabs[name] = rect(r);
  state["tabs"] = tabs;
  state["grid"] = gridPanes_;
  state["frame_ms"] = frameMs_;
  state["weak_fits"] = json::array();
  for (const auto& [photo, concerns] : weakFits())
    state["weak_fits"].push_back({{"photo", photo}, {"concerns", concerns}});
  state["warnings_plain"] = json::array();
  if (result_)
    for (const std::string& w : result_->warnings) {
      const PlainWarning plain = plainWarning(w);
      state["warnings_plain"].push_back({{"text", plain.text}, {"original", plain.original}});
    }
  // The 3D view's framebuffer: reduced while the camera moves (navigation.h), full size once still.
  state["view3d"] = {{"size", {int(viewRect_.w), int(viewRect_.h)}},
                     {"render", {viewFbo_ ? viewFbo_->width() : 0, viewFbo_ ? viewFbo_->height() : 0}},
                     {"divisor", viewDivisor_},
                     {"moving", viewMotion_.moving()},
                     {"reduced_navigation", reducedNavigation_},
                     {"reduced_redraws", reducedRedraws_},
                     {"full_redraws", fullRedraws_},
                     {"reduced_size", {reducedSize_[0], reducedSize_[1]}}};
  state["pane_cache_renders"] = overlayGl_ ? overlayGl_->cacheRenders : 0;  // photo panes rendered into their cache
  if (ws.busy) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - ws.started).count();
    state["progress"] = {{"tier", kTierNames[int(ws.tier)]},
                         {"stage", stageName(ws.stage)},
                         {"overall", progress_.overall(ws.tier, ws.stage, ws.fraction)},
                         {"seconds_left", progress_.secondsLeft(ws.tier, ws.stage, ws.fraction, elapsed)},
                         {"measured", progress_.measured(ws.tier)}};
  }
  state["font_size"] = ImGui::GetFontSize();
  json parts = json::object();
  for (const auto& [name, r] : statusParts_) parts[name] = rect(r);
  state["status_bar"] = parts;
  state["dialog"] = dialogs_.active() ? json{{"purpose", dialogs_.purpose()},
                                             {"folder", dialogs_.folder()},
                                             {"filter", dialogs_.filterName()},
                                             {"listed", dialogs_.listed()}}
                                      : json(nullptr);
  json photos = json::array();
  for (size_t i = 0; i < p.photos.size(); ++i) {
    const PhotoSlot* slot = i < photos_.size() ? &photos_[i] : nullptr;
    json entry = {{"path", p.photos[i].path},
                  {"mask", p.photos[i].mask},
                  {"mirror", p.photos[i].mirror},
                  {"color_locked", p.photos[i].colorLocked},
                  {"mode", kPhotoModeNames[size_t(p.photos[i].mode)]},
                  {"loaded", slot && slot->photo != nullptr},
                  {"error", slot ? slot->error : ""}};
    if (slot && slot->photo) entry["size"] = {slot->photo->width, slot->photo->height};
    if (resultUsable() && result_->cameras && i < result_->cameras->fits.size()) {
      // What the last result took the photo for, why, and how it mapped it.
      const CameraFit& fit = result_->cameras->fits[i];
      int outliers = 0;
      for (size_t k = 0; k < fit.inlier.size(); ++k) outliers += fit.fits && !fit.inlier[k];
      const auto& projected = result_->projection ? result_->projection->result.projected : std::vector<char>{};
      entry["shows"] = fit.subject ? "subject" : "object";
      entry["decision"] = fit.decision;
      entry["outliers"] = outliers;
      entry["projected"] = i < projected.size() && projected[i];
    }
    photos.push_back(entry);
  }
  state["photos"] = photos;
  json missing = json::array();
  for (const MissingFile& m : missing_) missing.push_back({{"field", m.field}, {"path", m.path}});
  state["missing"] = missing;
  state["missing_window"] = missingPopup_;
  // The cut-out's mask by content (FNV-1a of its bytes): undo must give back exactly the mask before.
  std::uint64_t maskHash = 1469598103934665603ull;
  if (!cutout_.mask.empty()) {
    const cv::Mat m = cutout_.mask.isContinuous() ? cutout_.mask : cutout_.mask.clone();
    for (size_t k = 0; k < m.total() * m.elemSize(); ++k) maskHash = (maskHash ^ m.data[k]) * 1099511628211ull;
  }
  size_t undoMaskBytes = 0;  // what the undo and redo steps' masks hold
  for (const auto* stack : {&cutout_.undo, &cutout_.redo})
    for (const CutoutState& step : *stack) undoMaskBytes += step.mask.bytes();
  state["cutout"] = {{"photo", cutout_.photo},
                     {"running", cutout_.job.valid()},
                     {"job", cutout_.job.valid() ? cutout_.jobLabel : ""},
                     {"started", cutout_.cut && cutout_.cut->started()},
                     {"foreground_pixels", cutout_.mask.empty() ? 0 : cv::countNonZero(cutout_.mask)},
                     {"mask_hash", std::to_string(maskHash)},
                     {"mode", kCutoutModeNames[static_cast<int>(cutoutMode_)]},
                     {"strokes", cutout_.strokes.size()},
                     {"rect", bool(cutout_.rect)},
                     {"undo_steps", cutout_.undo.size()},
                     {"redo_steps", cutout_.redo.size()},
                     {"undo_mask_bytes", undoMaskBytes},
                     {"queued", cutout_.queue.size()},
                     {"steps_applied", cutout_.stepsApplied},
                     {"undo_label", cutoutOwnsUndo() ? cutoutUndoLabel() : ""},
                     {"drawing", cutout_.drawing}};
  state["dragging_point"] = dragging_;
  if (result_ && result_->balanced) {
    json transforms = json::array();
    for (size_t i = 0; i < result_->balanced->balance.transforms.size(); ++i) {
      const ColorTransform& t = result_->balanced->balance.transforms[i];
      transforms.push_back({{"gain", {t.gain[0], t.gain[1], t.gain[2]}},
                            {"offset", {t.offset[0], t.offset[1], t.offset[2]}},
                            {"reference", bool(result_->balanced->balance.reference[i])}});
    }
    state["balance"] = transforms;
  }
  state["layout"] = {{"window", rect(windowRect_)},
                     {"view3d", rect(viewRect_)},
                     {"photos", rect(paneRect_)},
                     {"weak_fit_banner", rect(weakBannerRect_)}};
  for (const auto& [name, r] : splitterRects_) state["layout"]["splitters"][name] = rect(r);
  state["coverage"] = coverageState();
  state["autosave"] = {{"path", autosavePath()}, {"written_revision", autosavedRevision_}};
  // Navigation: the camera, the hover, the surface point under the pointer and the mesh's extent
  // on screen (view pixels), for the navigation tests.
  state["camera"] = {{"target", {camera_.target.x(), camera_.target.y(), camera_.target.z()}},
                     {"distance", camera_.distance},
                     {"yaw", camera_.yawDeg},
                     {"pitch", camera_.pitchDeg},
                     {"fov", camera_.fovYDeg},
                     {"orthographic", isOrthographic(camera_)}};
  state["hover_vertex"] = hoverVertex_;
  const Camera cam = viewCamera();
  auto pixelOf = [&](int v) -> json {
    Vec2 px;
    if (!input_.mesh || v < 0 || v >= input_.mesh->numVertices() || !cam.project(input_.mesh->position(v), px))
      return nullptr;
    return {px.x(), px.y()};
  };
  state["hover_vertex_pixel"] = pixelOf(hoverVertex_);
  state["selected_vertex_pixel"] = pixelOf(selectedVertex_);
  const VertexPick under = pickAt(heldX_, heldY_);
  state["pointer"] = {{"x", heldX_ - viewRect_.x}, {"y", heldY_ - viewRect_.y}};
  state["pointer_hit"] = under.face >= 0 ? json{under.point.x(), under.point.y(), under.point.z()} : json(nullptr);
  if (input_.mesh) {
    double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
    for (int v = 0; v < input_.mesh->numVertices(); ++v) {
      Vec2 px;
      if (!cam.project(input_.mesh->position(v), px)) continue;
      x0 = std::min(x0, px.x()), y0 = std::min(y0, px.y()), x1 = std::max(x1, px.x()), y1 = std::max(y1, px.y());
    }
    state["mesh_screen_bounds"] = {x0, y0, x1, y1};
  }
  if (fs::path(path).has_parent_path()) fs::create_directories(fs::path(path).parent_path());
  writeFileAtomic(path, state.dump(2) + "\n");
}

void Editor::takeScreenshot(const std::string& path) {
  int w = 0, h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  cv::Mat rgba = readWindowPixels(w, h), rgb;
  cv::cvtColor(rgba, rgb, cv::COLOR_RGBA2RGB);
  std::error_code ec;
  if (fs::path(path).has_parent_path()) fs::create_directories(fs::path(path).parent_path(), ec);
  writePng(path, rgb, kPngFast, false);
  std::printf("wrote %s (%dx%d)\n", path.c_str(), w, h);
}

// --- Benchmarks -----------------------------------------------------------------------------------

void Editor::benchOrbitStep() {
  if (options_.benchOverlays) return benchOverlaysStep();
  const int warmup = 10;
  if (!input_.mesh) return;
  ++benchFrame_;
  if (benchFrame_ <= warmup) return;
  // The previous frame, complete (the frame loop glFinish-es in benchmark mode).
  const bool busy = worker_->status().busy;
  if (benchFrame_ > warmup + 1) {
    benchTimes_.push_back(lastFrameSeconds_ * 1000);
    if (benchWasBusy_) benchBusyTimes_.push_back(lastFrameSeconds_ * 1000);
  }
  benchWasBusy_ = busy;
  camera_.yawDeg += 360.0 / std::max(1, options_.benchFrames);
  if (options_.benchWorker && !busy && submittedRevision_ == doc_.revision() && !doc_.inGroup()) {
    // Keep the worker busy: a new seed reruns the mapping stages, like an edit would.
    PipelineOptions o = doc_.project().options;
    o.seed += 1;
    doc_.setOptions(o, "benchmark: new seed");
  }
  const bool enough = options_.benchWorker ? static_cast<int>(benchBusyTimes_.size()) >= options_.benchFrames ||
                                                 benchFrame_ > 40 * options_.benchFrames
                                           : static_cast<int>(benchTimes_.size()) >= options_.benchFrames;
  if (enough) quit_ = true;
}

void Editor::benchReport() {
  if (options_.benchOverlays) return benchOverlaysReport();
  auto report = [](const char* what, const std::vector<double>& t) {
    if (t.empty()) {
      std::printf("%s: no frames\n", what);
      return;
    }
    const double mean = std::accumulate(t.begin(), t.end(), 0.0) / t.size();
    std::printf("%s: %zu frames, mean %.2f ms (%.1f fps), median %.2f ms, p95 %.2f ms, max %.2f ms\n", what, t.size(),
                mean, 1000 / mean, percentile(t, 0.5), percentile(t, 0.95), *std::max_element(t.begin(), t.end()));
  };
  int w = 0, h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  const char* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  std::printf("bench: %s, window %dx%d, 3D view %.0fx%.0f, %d faces, renderer %s\n", doc_.project().mesh.c_str(), w, h,
              viewRect_.w, viewRect_.h, input_.mesh ? input_.mesh->numFaces() : 0, renderer ? renderer : "?");
  report("orbit, all frames", benchTimes_);
  if (options_.benchWorker) report("orbit while the worker runs", benchBusyTimes_);
}

}  // namespace montage
