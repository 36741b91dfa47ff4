#include "layout.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "autosave.h"
#include "base/fileio.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

std::string storeOf(const std::string& path) {
  return path.empty() ? (fs::path(editorStateDir()) / "layout.json").string() : path;
}

struct Sizes {
  double left, view, toolsH, mainH;
};

Sizes sizes(const LayoutPrefs& prefs, double W, double H, double top, double bottom, double scale) {
  Sizes s{};
  s.mainH = std::max(1.0, H - top - bottom);
  const double defaultLeft = std::clamp(std::floor(W * 0.24), 280 * scale, 400 * scale);
  // Minimum sizes: a column wide enough for its buttons, a view and photo panes that still show something.
  const double minLeft = std::min(200 * scale, W / 3), minPane = std::min(120 * scale, W / 4);
  const double maxLeft = std::max(minLeft, W - 2 * minPane);
  s.left = std::floor(std::clamp(prefs.left > 0 ? prefs.left * scale : defaultLeft, minLeft, maxLeft));
  const double rest = W - s.left;
  s.view = std::floor(std::clamp(rest * prefs.view, std::min(minPane, rest / 2), std::max(rest / 2, rest - minPane)));
  const double minTools = std::min(80 * scale, s.mainH / 3);
  s.toolsH = std::floor(std::clamp(s.mainH * prefs.tools, minTools, s.mainH - minTools));
  return s;
}

}  // namespace

std::string LayoutPrefs::toJson() const {
  nlohmann::json j = {{"left", left}, {"tools", tools}, {"view", view},
                      {"grid", grid}, {"mouse", mouse}, {"reduced_navigation", reducedNavigation}};
  return j.dump(2);
}

PanelLayout computeLayout(const LayoutPrefs& prefs, double W, double H, double top, double bottom, double scale) {
  const Sizes s = sizes(prefs, W, H, top, bottom, scale);
  PanelLayout l;
  l.tools = {0, top, s.left, s.toolsH};
  l.document = {0, top + s.toolsH, s.left, s.mainH - s.toolsH};
  l.view = {s.left, top, s.view, s.mainH};
  l.photos = {s.left + s.view, top, W - s.left - s.view, s.mainH};
  const double t = std::round(6 * scale);  // bar thickness, centred on the boundary
  l.leftBar = {s.left - t / 2, top, t, s.mainH};
  l.toolsBar = {0, top + s.toolsH - t / 2, s.left, t};
  l.viewBar = {s.left + s.view - t / 2, top, t, s.mainH};
  return l;
}

bool dragSplitter(LayoutPrefs& prefs, const std::string& bar, double dx, double dy, double W, double H, double top,
                  double bottom, double scale) {
  const Sizes s = sizes(prefs, W, H, top, bottom, scale);
  if (bar == "left") {
    const double photos = W - s.left - s.view;
    prefs.left = (s.left + dx) / scale;
    const Sizes moved = sizes(prefs, W, H, top, bottom, scale);  // the left width after its limits
    const double rest = W - moved.left;
    prefs.view = rest > 0 ? std::clamp((rest - photos) / rest, 0.0, 1.0) : 0.5;
  } else if (bar == "view") {
    const double rest = W - s.left;
    prefs.view = rest > 0 ? std::clamp((s.view + dx) / rest, 0.0, 1.0) : 0.5;
  } else if (bar == "tools") {
    prefs.tools = std::clamp((s.toolsH + dy) / s.mainH, 0.0, 1.0);
  } else {
    return false;
  }
  return true;
}

LayoutPrefs loadLayout(const std::string& path) {
  LayoutPrefs prefs;
  std::ifstream in(storeOf(path));
  if (!in) return prefs;
  std::stringstream text;
  text << in.rdbuf();
  const nlohmann::json j = nlohmann::json::parse(text.str(), nullptr, false);
  if (!j.is_object()) return prefs;
  auto number = [&](const char* key, double& out, double lo, double hi) {
    if (j.contains(key) && j[key].is_number()) out = std::clamp(j[key].get<double>(), lo, hi);
  };
  number("left", prefs.left, 0, 1e5);
  number("tools", prefs.tools, 0, 1);
  number("view", prefs.view, 0, 1);
  if (j.contains("grid") && j["grid"].is_boolean()) prefs.grid = j["grid"].get<bool>();
  if (j.contains("mouse") && j["mouse"].is_string()) prefs.mouse = j["mouse"].get<std::string>();
  if (j.contains("reduced_navigation") && j["reduced_navigation"].is_boolean())
    prefs.reducedNavigation = j["reduced_navigation"].get<bool>();
  return prefs;
}

void saveLayout(const LayoutPrefs& prefs, const std::string& path) {
  const std::string store = storeOf(path);
  try {
    std::error_code ec;
    fs::create_directories(fs::path(store).parent_path(), ec);
    writeFileAtomic(store, prefs.toJson() + "\n");
  } catch (const std::exception&) {
    // Best effort, as the recent list.
  }
}

}  // namespace montage
