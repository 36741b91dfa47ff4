// The editor's panel layout (GL-free): a left column (Tools over Document), the 3D view and the photo
// panes, split by three bars the user drags (ImGui 1.86 has no docking). The layout, the photo grid-or-tabs
// choice, the mouse bindings and the navigation resolution are remembered in editorStateDir()/layout.json. Sizes are
// window pixels; `scale` is the UI scale (HiDPI), and the remembered left width is in unscaled pixels.
#pragma once

#include <string>

namespace montage {

struct LayoutRect {
  double x = 0, y = 0, w = 0, h = 0;
};

struct PanelLayout {
  LayoutRect tools, document, view, photos;
  LayoutRect leftBar, toolsBar, viewBar;  // the splitters: left column | view, Tools / Document, view | photos
};

struct LayoutPrefs {
  double left = 0;                // left column width, unscaled pixels; 0: 24% of the window, 280 to 400
  double tools = 0.42;            // Tools panel's share of the left column's height
  double view = 0.5;              // 3D view's share of the width right of the left column
  bool grid = false;              // photo panes in a grid (else tabs)
  std::string mouse = "meshlab";  // 3D-view mouse bindings (kMouseBindingNames)
  bool reducedNavigation = true;  // 3D view at reduced resolution while the camera moves (navigation.h)
  std::string toJson() const;
  bool operator==(const LayoutPrefs& o) const { return toJson() == o.toJson(); }
};

// The panels of a W x H window whose menu bar takes `top` and status bar `bottom` pixels. Every panel
// keeps a minimum size (the splitters stop there).
PanelLayout computeLayout(const LayoutPrefs& prefs, double W, double H, double top, double bottom, double scale);
// Moves splitter `bar` ("left", "tools" or "view") by (dx, dy) pixels; returns false for another name.
// Dragging the left bar resizes the left column and the 3D view (the photos keep their width).
bool dragSplitter(LayoutPrefs& prefs, const std::string& bar, double dx, double dy, double W, double H, double top,
                  double bottom, double scale);

// Reads the remembered layout (defaults when there is none or it does not parse); saves it (best effort:
// a read-only state folder only loses the layout). "" = editorStateDir()/layout.json.
LayoutPrefs loadLayout(const std::string& path = "");
void saveLayout(const LayoutPrefs& prefs, const std::string& path = "");

}  // namespace montage
