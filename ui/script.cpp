#include "script.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "base/common.h"

namespace montage {

const std::vector<ScriptVerb>& scriptVerbs() {
  static const std::vector<ScriptVerb> verbs = {
      {"wait_frames", 1, 1, "N", "render N frames"},
      {"wait_worker", 0, 1, "[SECONDS]",
       "wait until the worker is idle (the final bake done) and the view shows the current document (default "
       "timeout 300 s)"},
      {"wait_result", 0, 1, "[SECONDS]",
       "wait until the first result (the preview) of the current document is shown (default timeout 300 s)"},
      {"wait_busy", 0, 2, "[SECONDS] [preview|final]",
       "wait until the worker runs the newest snapshot, in the named tier if one is given (default timeout 60 s)"},
      {"wait_idle", 0, 1, "[SECONDS]",
       "wait until the worker runs nothing (after a Cancel: the job has stopped); default timeout 60 s"},
      {"wait_autosave", 0, 1, "[SECONDS]", "wait until the current document has been autosaved"},
      {"sleep", 1, 1, "SECONDS", "keep rendering frames for SECONDS of wall time"},
      {"real_input", 1, 2, "FILE [SECONDS]",
       "until FILE exists, the real mouse and keyboard (a person, xdotool) drive the editor, frames coming on events "
       "as without a script; the script checks what they did after (default timeout 300 s)"},
      {"tool", 1, 1, "point|line|polygon|stroke|clone|cutout", "choose a tool (same as the Tools panel)"},
      {"view", 1, 2, "textured|shaded|wireframe|patches|empty|paths|features|stretch|seams|grid|balanced [on|off]",
       "change a display setting (balanced: photo panes show the colour-balanced photos)"},
      {"view_vertex", 1, 1, "V", "turn the 3D view so that vertex V faces the camera"},
      {"frame", 0, 0, "", "fit the whole mesh in the 3D view (key F)"},
      {"click_vertex", 1, 1, "V",
       "click where vertex V appears in the 3D view (the ray-cast pick); fails unless V gets selected"},
      {"click_3d", 2, 2, "X Y", "click at pixel (X, Y) of the 3D view, origin top-left"},
      {"drag_3d", 4, 5, "X0 Y0 X1 Y1 [left|right|middle]", "drag in the 3D view (left orbits, right/middle pan)"},
      {"scroll_3d", 1, 3, "STEPS [X Y]",
       "mouse wheel over the 3D view at pixel (X, Y) (default: centre; positive zooms in)"},
      {"hover_3d", 2, 2, "X Y", "move the pointer to pixel (X, Y) of the 3D view (no button)"},
      {"view_preset", 1, 1, "front|back|left|right|top|bottom", "look along a world axis"},
      {"ortho", 1, 1, "on|off", "orthographic view"},
      {"frame_selected", 0, 0, "", "centre the selected vertex (key .)"},
      {"mouse", 1, 1, "meshlab|blender", "3D-view mouse bindings"},
      {"photo", 1, 1, "P", "show photo P in the image pane"},
      {"tab", 1, 1, "points|chains|photos|strokes|history|pipeline|coverage", "show that tab of the Document panel"},
      {"click_photo", 3, 3, "P X Y", "click at pixel (X, Y) of photo P (photo pixel coordinates)"},
      {"drag_photo", 5, 5, "P X0 Y0 X1 Y1", "drag with the left button from (X0, Y0) to (X1, Y1) in photo P"},
      {"key", 1, 1, "COMBO", "press a key combination: ctrl+z, ctrl+shift+z, delete, enter, escape, w, f1..."},
      {"click_button", 1, 1, "LABEL", "click the button labelled LABEL (as shown, without ## suffix)"},
      {"select_vertex", 1, 1, "V", "select mesh vertex V without picking"},
      {"set_option", 2, 2, "NAME VALUE", "change a pipeline option, e.g. stretchSearches 16 (one undo step)"},
      {"open", 1, 1, "PATH", "open a project (.json) or a mesh"},
      {"add_photos", 1, 1, "PATH", "add a photo, or every image in a folder"},
      {"drop", 1, 64, "PATH...", "drop files on the window: a project or mesh opens, images are added"},
      {"relink", 2, 2, "P|mesh PATH", "point photo P (or the mesh) at another file, as Relink... does"},
      {"photo_flag", 3, 3, "P mirror|lock on|off", "tick photo P's mirror or colour-lock box (Photos tab)"},
      {"cutout_mode", 1, 3, "rect|foreground|background|add|erase [RADIUS] [FEATHER]",
       "what a drag in a photo does with the cut-out tool; stroke radius and feather in photo pixels"},
      {"cutout_delay", 1, 1, "SECONDS", "each job of the cut-out tool (GrabCut, a brush step, a feather change) waits this long first (tests)"},
      {"wait_cutout", 0, 1, "[SECONDS]",
       "wait until the cut-out's GrabCut has finished and no drawn step waits for it (default 120 s)"},
      {"save", 0, 1, "[PATH]", "save the project (to PATH: save as)"},
      {"export", 1, 1, "PATH", "export the current result (.obj or .glb)"},
      {"screenshot", 1, 1, "PNG", "save the window as a PNG after the next frame"},
      {"state", 1, 1, "JSON", "write the editor's state (document, selection, worker, layout) as JSON"},
      {"menu", 1, 1, "MENU/ITEM",
       "choose a menu item as a click would, e.g. File/Save, \"View/Photos in a grid\" (fails when it is disabled)"},
      {"menu_list", 1, 1, "JSON",
       "write every menu item (path, enabled) of the menu bar as it is now, submenus walked, nothing chosen"},
      {"dialog_filter", 1, 1, "NAME", "choose the open file dialog's type filter by its name (e.g. Meshes)"},
      {"drag_splitter", 3, 3, "left|tools|view DX DY",
       "drag a splitter bar by (DX, DY) pixels: left column | 3D view, Tools / Document, 3D view | photos"},
      {"close", 0, 0, "", "close the window like its close button (asks when there are unsaved changes)"},
      {"quit", 0, 0, "", "exit now, cleanly, without asking (removes the autosave)"},
  };
  return verbs;
}

std::string ScriptAction::where() const {
  return file + ":" + std::to_string(line) + ": " + verb;
}

double ScriptAction::number(size_t i) const {
  TM_CHECK(i < args.size(), where() + ": argument " + std::to_string(i + 1) + " is missing");
  const std::string& s = args[i];
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  TM_CHECK(!s.empty() && end == s.c_str() + s.size() && std::isfinite(v),
           where() + ": argument " + std::to_string(i + 1) + " must be a number, not '" + s + "'");
  return v;
}

int ScriptAction::integer(size_t i) const {
  const double v = number(i);
  TM_CHECK(v == std::floor(v) && std::abs(v) < 2e9,
           where() + ": argument " + std::to_string(i + 1) + " must be an integer, not '" + args[i] + "'");
  return static_cast<int>(v);
}

namespace {

// Splits a line into words; quotes group blanks; '#' outside quotes starts a comment.
std::vector<std::string> splitWords(const std::string& line, const std::string& where) {
  std::vector<std::string> words;
  std::string word;
  bool inWord = false, quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '\\' && i + 1 < line.size() && (line[i + 1] == '"' || line[i + 1] == '\\')) {
        word += line[++i];
      } else if (c == '"') {
        quoted = false;
      } else {
        word += c;
      }
    } else if (c == '"') {
      quoted = inWord = true;
    } else if (c == '#') {
      break;
    } else if (std::isspace(static_cast<unsigned char>(c))) {
      if (inWord) words.push_back(word);
      word.clear();
      inWord = false;
    } else {
      word += c;
      inWord = true;
    }
  }
  TM_CHECK(!quoted, where + ": unterminated quote");
  if (inWord) words.push_back(word);
  return words;
}

}  // namespace

std::vector<ScriptAction> parseScript(const std::string& text, const std::string& file) {
  std::vector<ScriptAction> actions;
  std::istringstream in(text);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::string where = file + ":" + std::to_string(number);
    std::vector<std::string> words = splitWords(line, where);
    if (words.empty()) continue;
    ScriptAction action;
    action.file = file;
    action.line = number;
    action.verb = words[0];
    action.args.assign(words.begin() + 1, words.end());
    const ScriptVerb* verb = nullptr;
    for (const auto& v : scriptVerbs())
      if (action.verb == v.name) verb = &v;
    TM_CHECK(verb, where + ": unknown action '" + action.verb + "' (docs/editor.md lists the actions)");
    const int n = static_cast<int>(action.args.size());
    TM_CHECK(
        n >= verb->minArgs && n <= verb->maxArgs,
        action.where() + ": expected " +
            (verb->minArgs == verb->maxArgs ? std::to_string(verb->minArgs)
                                            : std::to_string(verb->minArgs) + " to " + std::to_string(verb->maxArgs)) +
            " argument(s) (" + verb->usage + "), got " + std::to_string(n));
    if (action.verb == "key") parseKeyCombo(action.args[0]);  // report a bad key at parse time, with the line
    actions.push_back(std::move(action));
  }
  return actions;
}

std::vector<ScriptAction> loadScript(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  TM_CHECK(in, located(path, "cannot open the script"));
  std::ostringstream text;
  text << in.rdbuf();
  return parseScript(text.str(), path);
}

KeyCombo parseKeyCombo(const std::string& text) {
  static const char* kNames[] = {"delete", "enter", "escape", "tab",  "space", "backspace", "home", "end",
                                 "left",   "right", "up",     "down", "f1",    "f2",        "f3",   "f4",
                                 "f5",     "f6",    "f7",     "f8",   "f9",    "f10",       "f11",  "f12"};
  KeyCombo combo;
  std::string rest = text;
  for (char& c : rest) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  std::vector<std::string> parts;
  std::string part;
  for (char c : rest) {
    if (c == '+' && !part.empty()) {
      parts.push_back(part);
      part.clear();
    } else {
      part += c;
    }
  }
  parts.push_back(part);
  for (size_t i = 0; i + 1 < parts.size(); ++i) {
    if (parts[i] == "ctrl")
      combo.ctrl = true;
    else if (parts[i] == "shift")
      combo.shift = true;
    else if (parts[i] == "alt")
      combo.alt = true;
    else
      throw Error("key '" + text + "': unknown modifier '" + parts[i] + "' (ctrl, shift, alt)");
  }
  combo.key = parts.back();
  bool known = combo.key.size() == 1 && std::isalnum(static_cast<unsigned char>(combo.key[0]));
  for (const char* n : kNames) known = known || combo.key == n;
  TM_CHECK(known, "key '" + text + "': unknown key '" + combo.key + "'");
  return combo;
}

}  // namespace montage
