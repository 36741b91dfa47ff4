// 3D-view navigation commands (navigation.h does the maths): frame all / selected, view presets, the
// orthographic toggle and the mouse-binding preference, with their keys and View-menu entries.
#include <imgui.h>

#include "editor.h"
#include "gl.h"
#include "navigation.h"

namespace montage {

void Editor::frameAll() {
  if (!input_.mesh) return;
  frameBox(camera_, input_.lo, input_.hi, std::max(1, int(viewRect_.w)), std::max(1, int(viewRect_.h)));
}

void Editor::frameSelected() {
  if (!input_.mesh) return;
  if (selectedVertex_ < 0 || selectedVertex_ >= input_.mesh->numVertices()) {
    setStatus("frame selected: select a vertex first (click the mesh)");
    return;
  }
  // A neighbourhood of a tenth of the mesh's size around the vertex.
  framePoint(camera_, input_.mesh->position(selectedVertex_), 0.1 * camera_.sceneRadius, std::max(1, int(viewRect_.w)),
             std::max(1, int(viewRect_.h)));
}

void Editor::setViewPreset(ViewPreset preset) {
  applyPreset(camera_, preset);
  setStatus(std::string("view: ") + kViewPresetNames[int(preset)]);
}

void Editor::navigationShortcuts() {
  auto pressed = [this](int key) { return keyPressed(key); };
  // Blender's numeric keypad, and Ctrl + 1/3/7 for keyboards without one (1-9 alone choose photos).
  const bool ctrl = ctrlHeld();
  if (pressed(GLFW_KEY_KP_1) || (ctrl && pressed(GLFW_KEY_1))) setViewPreset(ViewPreset::Front);
  if (pressed(GLFW_KEY_KP_3) || (ctrl && pressed(GLFW_KEY_3))) setViewPreset(ViewPreset::Right);
  if (pressed(GLFW_KEY_KP_7) || (ctrl && pressed(GLFW_KEY_7))) setViewPreset(ViewPreset::Top);
  if (ctrl) return;
  if (pressed(GLFW_KEY_KP_5) || pressed(GLFW_KEY_O)) setOrthographic(camera_, !isOrthographic(camera_));
  if (pressed(GLFW_KEY_HOME)) frameAll();
  if (pressed(GLFW_KEY_KP_DECIMAL) || pressed(GLFW_KEY_PERIOD)) frameSelected();
}

void Editor::navigationMenu() {
  menuSeparator();
  if (menuItem("Frame all", "F, Home")) frameAll();
  if (menuItem("Frame selected", ".", false, selectedVertex_ >= 0)) frameSelected();
  if (menuItem("Front", "Ctrl+1, Numpad 1")) setViewPreset(ViewPreset::Front);
  if (menuItem("Right side", "Ctrl+3, Numpad 3")) setViewPreset(ViewPreset::Right);
  if (menuItem("Top", "Ctrl+7, Numpad 7")) setViewPreset(ViewPreset::Top);
  bool ortho = isOrthographic(camera_);
  if (menuToggle("Orthographic", "O, Numpad 5", &ortho)) setOrthographic(camera_, ortho);
  menuToggle("Orbit about the point under the cursor", nullptr, &orbitAtPick_);
  menuToggle("Reduced resolution while navigating", nullptr, &reducedNavigation_);
  if (beginMenu("Mouse")) {
    if (menuItem("MeshLab: left orbits, right/middle pan", nullptr, bindings_ == MouseBindings::MeshLab))
      bindings_ = MouseBindings::MeshLab;
    if (menuItem("Blender: middle orbits, Shift+middle pans, left picks", nullptr, bindings_ == MouseBindings::Blender))
      bindings_ = MouseBindings::Blender;
    endMenu();
  }
}

}  // namespace montage
