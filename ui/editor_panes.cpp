// Image panes: each photo on an InvisibleButton canvas with ImDrawList overlays, hit-tested in photo
// pixel coordinates (photo.h: origin top-left, y down). Zoom and pan, the background mask, feature
// points (click to attach the selected vertex, drag to move), chains, the partition's curves and the
// rejected pairs with their reasons on hover.
#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>

#include "editor.h"
#include "gl_util.h"
#include "image/photo.h"
#include "mapping/partition.h"
#include "overlay_buffers.h"
#include "overlay_gl.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

ImVec2 im(const Vec2& v) {
  return ImVec2(float(v.x()), float(v.y()));
}

std::optional<Vec2> positionIn(const Project& p, int point, int photo) {
  if (point < 0 || point >= static_cast<int>(p.points.size())) return std::nullopt;
  for (const PhotoPoint& a : p.points[point].at)
    if (a.photo == photo) return Vec2(a.x, a.y);
  return std::nullopt;
}

double segmentDistance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

void dashedLine(ImDrawList* draw, const Vec2& a, const Vec2& b, ImU32 color, float dash = 5) {
  const double length = (b - a).norm();
  if (length < 1e-6) return;
  const Vec2 d = (b - a) / length;
  for (double s = 0; s < length; s += 2 * dash)
    draw->AddLine(im(a + s * d), im(a + std::min(length, s + dash) * d), color, 1.0f);
}

}  // namespace

int Editor::hitPosition(int photo, const PaneView& view, double sx, double sy, double radius) const {
  const Project& p = doc_.project();
  int best = -1;
  double bestDistance = radius;
  for (size_t k = 0; k < p.points.size(); ++k)
    for (const PhotoPoint& a : p.points[k].at) {
      if (a.photo != photo) continue;
      const double d = (view.toScreen(Vec2(a.x, a.y)) - Vec2(sx, sy)).norm();
      if (d <= bestDistance) {
        bestDistance = d;
        best = static_cast<int>(k);
      }
    }
  return best;
}

void Editor::photosPanel() {
  const Project& p = doc_.project();
  canvasRects_.clear();
  overlayGl_->draws.clear();
  paneRect_ = Rect{ImGui::GetCursorScreenPos().x, ImGui::GetCursorScreenPos().y, ImGui::GetContentRegionAvail().x,
                   ImGui::GetContentRegionAvail().y};
  if (p.photos.empty()) {
    ImGui::TextWrapped(p.mesh.empty() ? "Open a project or a mesh first."
                                      : "No photos yet: add the photos of the object (File > Add photos folder).");
    if (!p.mesh.empty() && button("Add photos folder...")) requestAddPhotos(true);
    return;
  }
  // The toolbar wraps onto a second line when the pane is narrow (nothing clips).
  ImGui::Checkbox("grid", &gridPanes_);
  sameLineIfFits(ImGui::CalcTextSize("Fit").x + ImGui::GetStyle().FramePadding.x * 2);
  if (button("Fit")) {
    for (auto& slot : photos_) slot.tabView.fitted = slot.gridView.fitted = false;
  }
  for (auto [label, value] : {std::pair<const char*, bool*>{"mask", &showMask_},
                              {"curves", &showCurves_},
                              {"rejected", &showRejected_},
                              {"ids", &showPaneIds_}}) {
    sameLineIfFits(checkboxWidth(label));
    ImGui::Checkbox(label, value);
  }
  cameraToolbar();
  weakBannerRect_ = Rect{};
  weakFitBanner();  // editor_camera.cpp

  if (gridPanes_) {
    const int n = static_cast<int>(p.photos.size());
    const int cols = static_cast<int>(std::ceil(std::sqrt(double(n))));
    const int rows = (n + cols - 1) / cols;
    const ImVec2 origin = ImGui::GetCursorScreenPos();
    const ImVec2 avail = ImGui::GetContentRegionAvail();
    const float cw = std::floor((avail.x - 4 * (cols - 1)) / cols), ch = std::floor((avail.y - 4 * (rows - 1)) / rows);
    for (int i = 0; i < n; ++i) {
      const Rect r{origin.x + (i % cols) * (cw + 4), origin.y + (i / cols) * (ch + 4), cw, ch};
      photoCanvas(i, r, photos_[i].gridView, true);
    }
    ImGui::SetCursorScreenPos(ImVec2(origin.x, origin.y + avail.y));
    return;
  }
  if (!ImGui::BeginTabBar("##photos", ImGuiTabBarFlags_FittingPolicyScroll)) return;
  // A tab chosen by the program (keys 1-9, a feature clicked in the list) is selected with
  // SetSelected, which ImGui applies on the next frame; until then the shown tab stays.
  const bool switching = activePhoto_ != shownTab_;
  for (int i = 0; i < static_cast<int>(p.photos.size()); ++i) {
    const std::string label =
        std::to_string(i) + ": " + fs::path(p.photos[i].path).filename().string() + "##tab" + std::to_string(i);
    const ImGuiTabItemFlags flags = switching && i == activePhoto_ ? ImGuiTabItemFlags_SetSelected : 0;
    if (ImGui::BeginTabItem(label.c_str(), nullptr, flags)) {
      if (!switching) activePhoto_ = i;
      shownTab_ = i;
      const ImVec2 lo = ImGui::GetCursorScreenPos();
      const ImVec2 avail = ImGui::GetContentRegionAvail();
      photoCanvas(i, Rect{lo.x, lo.y, std::floor(avail.x), std::floor(avail.y)}, photos_[i].tabView, false);
      ImGui::EndTabItem();
    }
  }
  ImGui::EndTabBar();
}

void Editor::photoCanvas(int i, const Rect& r, PaneView& view, bool showName) {
  canvasRects_[i] = r;
  PhotoSlot& slot = photos_[i];
  const Project& p = doc_.project();
  ImDrawList* draw = ImGui::GetWindowDrawList();
  ImGui::SetCursorScreenPos(ImVec2(float(r.x), float(r.y)));
  ImGui::PushID(i);
  ImGui::InvisibleButton(
      "##canvas", ImVec2(float(std::max(1.0, r.w)), float(std::max(1.0, r.h))),
      ImGuiButtonFlags_MouseButtonLeft | ImGuiButtonFlags_MouseButtonRight | ImGuiButtonFlags_MouseButtonMiddle);
  ImGui::PopID();
  const bool hovered = ImGui::IsItemHovered();
  const ImVec2 lo(float(r.x), float(r.y)), hi(float(r.x + r.w), float(r.y + r.h));
  draw->PushClipRect(lo, hi, true);
  if (!slot.photo) {
    draw->AddRectFilled(lo, hi, IM_COL32(28, 29, 32, 255));
    // The error wraps within the pane; the buttons follow it.
    const char* text = slot.error.empty() ? "loading..." : slot.error.c_str();
    const float wrap = std::max(40.0f, float(r.w) - px(20));
    draw->AddText(ImGui::GetFont(), ImGui::GetFontSize(), ImVec2(lo.x + px(10), lo.y + px(10)),
                  IM_COL32(255, 120, 110, 255), text, nullptr, wrap);
    const float textH = ImGui::CalcTextSize(text, nullptr, false, wrap).y;
    draw->PopClipRect();
    if (!slot.error.empty()) {
      // A photo that cannot load: the others still texture; offer to point it at its file again.
      ImGui::SetCursorScreenPos(ImVec2(lo.x + px(10), lo.y + px(16) + textH));
      ImGui::PushID(i);
      if (button("Relink...", nullptr, "relink photo " + std::to_string(i) + " (pane)"))
        dialogs_.request(DialogKind::OpenFile, "Relink photo " + std::to_string(i),
                         {{"Images", {"*.png", "*.jpg", "*.jpeg", "*.tif", "*.tiff", "*.bmp"}}},
                         "relink_photo:" + std::to_string(i), fs::path(p.photos[i].path).parent_path().string());
      ImGui::SameLine();
      if (button("Remove photo", nullptr, "remove photo " + std::to_string(i) + " (pane)"))
        edit([&] { doc_.removePhoto(i); });
      ImGui::PopID();
    }
    return;
  }
  const Photo& photo = *slot.photo;
  if (!view.fitted) view.fit(photo.width, photo.height, Vec2(r.x, r.y), Vec2(r.w, r.h));
  // Before / after the colour balance: the file's colours, or the last result's balanced photo.
  if (showBalanced_) uploadBalanced(slot, i);
  const bool after = showBalanced_ && slot.balanced && slot.balancedFrom;
  const Texture& shown = after ? *slot.balanced : *slot.texture;
  const bool cutting = tool_ == Tool::Cutout;
  const bool mask = showMask_ && photo.hasBackground && slot.mask && !(cutting && cutout_.photo == i);
  ImGuiIO& io = ImGui::GetIO();
  const Vec2 mouse(io.MousePos.x, io.MousePos.y);
  const Vec2 mousePhoto = view.toPhoto(mouse);
  std::string tooltip;
  const int hover = hovered ? hitPosition(i, view, mouse.x(), mouse.y(), px(8)) : -1;
  // The photo, the mask, the partition curves (accepted pairs), rejected pairs and feature markers (a
  // vertex buffer in photo coordinates drawn by a GL callback, rebuilt only when they change) and the
  // camera lines: from the pane's cache (editor_overlays.cpp), except with the cut-out tool, which draws
  // between the mask and the markers.
  paneCached_ = !cutting;
  if (paneCached_) {
    char content[64];
    std::snprintf(content, sizeof(content), "%d %p", after, static_cast<const void*>(slot.balancedFrom));
    drawPaneCached(i, r, view, shown.id(), mask ? slot.mask->id() : 0, slot.key + content, hover);
  } else {
    draw->AddRectFilled(lo, hi, IM_COL32(28, 29, 32, 255));
    draw->AddImage(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(shown.id())), im(view.toScreen(Vec2(0, 0))),
                   im(view.toScreen(Vec2(photo.width, photo.height))));
    if (mask)
      draw->AddImage(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(slot.mask->id())),
                     im(view.toScreen(Vec2(0, 0))), im(view.toScreen(Vec2(photo.width, photo.height))));
    cutoutCanvas(i, view, hovered);
    drawPaneOverlay(i, view, hover);
  }
  if (resultUsable() && result_->mapping && showRejected_) {
    const Partition& part = *result_->mapping->partition;
    bool all = true;
    const int inPhoto = paneRejectedCount(i, &all);
    if (!all)
      draw->AddText(
          ImVec2(float(r.x + 6), float(r.y + 4)), IM_COL32(255, 140, 130, 230),
          (std::to_string(inPhoto) + " rejected pairs: those of the selected or hovered point shown").c_str());
    if (hovered) {
      // The reason of the rejected pair under the cursor.
      double best = 5;
      const RejectedPair* near = nullptr;
      Vec2 ha, hb;
      for (const RejectedPair& rj : part.rejected) {
        if (rj.photo >= 0 && rj.photo != i) continue;
        if (!all && rj.fromPoint != selectedPoint_ && rj.toPoint != selectedPoint_ && rj.fromPoint != hover &&
            rj.toPoint != hover)
          continue;
        const auto a = positionIn(p, rj.fromPoint, i), b = positionIn(p, rj.toPoint, i);
        if (!a || !b) continue;
        const Vec2 sa = view.toScreen(*a), sb = view.toScreen(*b);
        const double d = segmentDistance(mouse, sa, sb);
        if (d < best) best = d, near = &rj, ha = sa, hb = sb;
      }
      if (near) {
        draw->AddLine(im(ha), im(hb), IM_COL32(255, 90, 80, 255), 2.5f);
        tooltip = "pair " + resultPointName(near->fromPoint) + "-" + resultPointName(near->toPoint) + " rejected" +
                  (near->photo >= 0 ? " in photo " + std::to_string(near->photo) : "") + ": " +
                  kRejectReasonNames[int(near->reason)] + (near->detail.empty() ? "" : "\n" + near->detail);
      }
    }
  }

  cameraOverlay(i, view, draw, mouse, hovered, tooltip);  // editor_camera.cpp

  // Chains of the document, and the one being drawn.
  for (const FeatureChain& chain : p.chains) {
    if (chain.photo != i) continue;
    const size_t n = chain.points.size();
    for (size_t k = 0; k + (chain.closed ? 0 : 1) < n; ++k) {
      const auto a = positionIn(p, chain.points[k], i), b = positionIn(p, chain.points[(k + 1) % n], i);
      if (a && b) draw->AddLine(im(view.toScreen(*a)), im(view.toScreen(*b)), IM_COL32(90, 200, 255, 255), 2.0f);
    }
  }
  if (chainPhoto_ == i && !chain_.empty()) {
    for (size_t k = 0; k + 1 < chain_.size(); ++k) {
      const auto a = positionIn(p, chain_[k], i), b = positionIn(p, chain_[k + 1], i);
      if (a && b) draw->AddLine(im(view.toScreen(*a)), im(view.toScreen(*b)), IM_COL32(150, 230, 255, 255), 2.0f);
    }
    if (const auto last = positionIn(p, chain_.back(), i); last && hovered)
      dashedLine(draw, view.toScreen(*last), mouse, IM_COL32(150, 230, 255, 200));
  }
  if (clonePhoto_ == i && !clonePolygon_.empty()) {
    for (size_t k = 0; k + 1 < clonePolygon_.size(); ++k)
      draw->AddLine(im(view.toScreen(clonePolygon_[k])), im(view.toScreen(clonePolygon_[k + 1])),
                    IM_COL32(80, 240, 230, 255), 2.0f);
    if (clonePolygonClosed_) {
      draw->AddLine(im(view.toScreen(clonePolygon_.back())), im(view.toScreen(clonePolygon_.front())),
                    IM_COL32(80, 240, 230, 255), 2.0f);
    } else if (hovered) {
      dashedLine(draw, view.toScreen(clonePolygon_.back()), mouse, IM_COL32(80, 240, 230, 200));
    }
    for (const Vec2& q : clonePolygon_) draw->AddCircleFilled(im(view.toScreen(q)), 3.5f, IM_COL32(80, 240, 230, 255));
  }
  // Photo regions that holes take their texture from (the Coverage tab's "photo..." beside a region's fill).
  for (const HoleMode& h : p.holeModes) {
    if (!h.exemplar || h.exemplar->photo != i || h.exemplar->polygon.size() < 3) continue;
    const auto& poly = h.exemplar->polygon;
    std::vector<ImVec2> screen;
    for (const Vec2& q : poly) screen.push_back(im(view.toScreen(q)));
    // Dashes over a dark line, the coverage highlight's colour: visible on any photo.
    draw->AddPolyline(screen.data(), int(screen.size()), IM_COL32(20, 20, 30, 200), ImDrawFlags_Closed, 3.5f);
    for (size_t k = 0; k < poly.size(); ++k)
      dashedLine(draw, view.toScreen(poly[k]), view.toScreen(poly[(k + 1) % poly.size()]),
                 IM_COL32(255, 115, 255, 255));
    const ImVec2 at(screen.front().x + 4, screen.front().y + 2), size = ImGui::CalcTextSize("hole texture");
    draw->AddRectFilled(at, ImVec2(at.x + size.x, at.y + size.y), IM_COL32(20, 20, 30, 170));
    draw->AddText(at, IM_COL32(255, 115, 255, 255), "hole texture");
  }

  // Feature points: rings for the selection and the hover (here or in the 3D view), ids for those and
  // for every other point whose label overlaps none already drawn.
  if (hover >= 0) hoverVertexNext_ = p.points[hover].vertex;
  std::vector<LabelCandidate> labels;
  std::vector<int> labelPoint;
  for (size_t k = 0; k < p.points.size(); ++k) {
    const auto at = positionIn(p, static_cast<int>(k), i);
    if (!at) continue;
    const ImVec2 s = im(view.toScreen(*at));
    if (s.x < lo.x - 20 || s.y < lo.y - 20 || s.x > hi.x + 20 || s.y > hi.y + 20) continue;
    const bool selected = static_cast<int>(k) == selectedPoint_;
    const bool hot = static_cast<int>(k) == hover || (hoverVertex_ >= 0 && p.points[k].vertex == hoverVertex_);
    if (selected) draw->AddCircle(s, px(8.5f), IM_COL32(255, 140, 30, 255), 0, px(2.5f));
    if (hot) draw->AddCircle(s, px(7.0f), IM_COL32(255, 255, 255, 220), 0, px(2.0f));
    if (showPaneIds_ || selected || hot) {
      const std::string id = pointName(int(k));
      const ImVec2 size = ImGui::CalcTextSize(id.c_str());
      LabelCandidate l;
      l.lo = Vec2(s.x + px(5), s.y - px(16));
      l.size = Vec2(size.x + 1, size.y);
      l.always = selected || hot;
      labels.push_back(l);
      labelPoint.push_back(static_cast<int>(k));
    }
  }
  for (int n : placeLabels(labels)) {
    const std::string id = pointName(labelPoint[n]);
    const ImVec2 at(float(labels[n].lo.x()), float(labels[n].lo.y()));
    draw->AddText(ImVec2(at.x + 1, at.y + 1), IM_COL32(0, 0, 0, 200), id.c_str());
    draw->AddText(at, labels[n].always ? IM_COL32(255, 230, 120, 255) : IM_COL32(255, 255, 255, 230), id.c_str());
  }
  if (hover >= 0) {
    std::string photos;
    for (const PhotoPoint& a : p.points[hover].at) photos += " " + std::to_string(a.photo);
    tooltip = "point #" + pointName(hover) + ": vertex " + std::to_string(p.points[hover].vertex) + ", photos" + photos;
  }
  proposalMarkers(i, view, draw, mouse, hovered, tooltip);  // editor_camera.cpp
  // Where a click will put the selected vertex.
  const bool placing = (tool_ == Tool::Point || tool_ == Tool::Line || tool_ == Tool::Polygon) && selectedVertex_ >= 0;
  if (hovered && placing && hover < 0 && photo.inside(mousePhoto.x(), mousePhoto.y()) && !dragging_) {
    const ImVec2 m = im(mouse);
    draw->AddLine(ImVec2(m.x - 9, m.y), ImVec2(m.x + 9, m.y), IM_COL32(255, 140, 30, 220), 1.5f);
    draw->AddLine(ImVec2(m.x, m.y - 9), ImVec2(m.x, m.y + 9), IM_COL32(255, 140, 30, 220), 1.5f);
    const std::string label = "vertex " + std::to_string(selectedVertex_);
    draw->AddText(ImVec2(m.x + 8, m.y + 6), IM_COL32(255, 160, 60, 255), label.c_str());
  }
  // Caption.
  char caption[256];
  std::snprintf(caption, sizeof(caption), "%s%s%dx%d  %.0f%%%s%s%s", showName ? std::to_string(i).c_str() : "",
                showName ? ": " : "", photo.width, photo.height, view.zoom * 100, photo.mirrored ? "  mirrored" : "",
                after ? "  balanced" : "", cameraCaption(i).c_str());
  // Wrapped at the pane's width: a long camera caption takes two lines instead of being cut.
  const float wrap = std::max(px(60), float(r.w) - px(12));
  const ImVec2 cs = ImGui::CalcTextSize(caption, nullptr, false, wrap);
  draw->AddRectFilled(ImVec2(lo.x, hi.y - cs.y - 6), ImVec2(lo.x + cs.x + 12, hi.y), IM_COL32(0, 0, 0, 150));
  draw->AddText(ImGui::GetFont(), ImGui::GetFontSize(), ImVec2(lo.x + 6, hi.y - cs.y - 3),
                i == activePhoto_ ? IM_COL32(255, 255, 255, 255) : IM_COL32(180, 180, 180, 255), caption, nullptr,
                wrap);
  if (i == activePhoto_ && showName) draw->AddRect(lo, hi, IM_COL32(255, 140, 30, 200), 0, 0, 2.0f);
  draw->PopClipRect();
  if (!tooltip.empty() && !dragging_) ImGui::SetTooltip("%s", tooltip.c_str());

  // --- Interaction.
  if (hovered && io.MouseWheel != 0) view.zoomAt(mouse, std::pow(1.2, io.MouseWheel));
  if (hovered &&
      (ImGui::IsMouseDragging(ImGuiMouseButton_Right, 0) || ImGui::IsMouseDragging(ImGuiMouseButton_Middle, 0)))
    view.origin += Vec2(io.MouseDelta.x, io.MouseDelta.y);

  const auto clamped = [&](Vec2 q) {
    return Vec2(std::clamp(q.x(), 0.0, double(photo.width)), std::clamp(q.y(), 0.0, double(photo.height)));
  };
  if (hovered && ImGui::IsMouseClicked(ImGuiMouseButton_Left)) {
    activePhoto_ = i;
    const bool inside = photo.inside(mousePhoto.x(), mousePhoto.y());
    if (hover < 0 && clickProposal(i, io.KeyShift)) return;  // a proposal accepted or declined (editor_camera.cpp)
    switch (tool_) {
      case Tool::Point:
        if (hover >= 0) {
          selectedPoint_ = hover;
          selectedVertex_ = p.points[hover].vertex;
          dragPoint_ = hover;
          dragPhoto_ = i;
          pressX_ = mouse.x();
          pressY_ = mouse.y();
        } else if (selectedVertex_ < 0) {
          hint("pick a vertex in the 3D view first (left click on the mesh), then click here");
        } else if (!inside) {
          hint("that is outside the photo");
        } else {
          // Placing and the drag that may follow are one undo step.
          doc_.beginGroup("Place vertex " + std::to_string(selectedVertex_) + " in photo " + std::to_string(i));
          int index = -1;
          if (edit([&] { index = doc_.setPosition(selectedVertex_, i, mousePhoto.x(), mousePhoto.y()); })) {
            selectedPoint_ = index;
            dragPoint_ = index;
            dragPhoto_ = i;
            dragging_ = true;
            pressX_ = mouse.x();
            pressY_ = mouse.y();
          } else {
            doc_.endGroup();
          }
        }
        break;
      case Tool::Line:
      case Tool::Polygon: {
        int index = hover;
        if (index < 0 && selectedVertex_ >= 0 && inside)
          edit([&] { index = doc_.setPosition(selectedVertex_, i, mousePhoto.x(), mousePhoto.y()); });
        if (index < 0) {
          // (A refused placement has said why already.)
          if (selectedVertex_ < 0 || !inside)
            hint(selectedVertex_ < 0 ? "click a point of this photo, or pick a vertex in the 3D view first"
                                     : "that is outside the photo");
          break;
        }
        if (chainPhoto_ != i) {
          chain_.clear();
          chainPhoto_ = i;
        }
        selectedPoint_ = index;
        selectedVertex_ = doc_.project().points[index].vertex;
        if (tool_ == Tool::Polygon && chain_.size() >= 3 && index == chain_.front()) {
          finishChain();
        } else if (std::find(chain_.begin(), chain_.end(), index) != chain_.end()) {
          hint("point " + pointName(index) + " is already in the chain");
        } else {
          chain_.push_back(index);
        }
        break;
      }
      case Tool::Clone:
        if (clonePolygonClosed_) {
          hint("clone: paint the target region on the mesh, or Cancel to draw another polygon");
        } else {
          if (clonePhoto_ != i) {
            clonePolygon_.clear();
            clonePhoto_ = i;
          }
          if (clonePolygon_.size() >= 3 && (view.toScreen(clonePolygon_.front()) - mouse).norm() < 8) {
            closeClonePolygon();
          } else {
            clonePolygon_.push_back(clamped(mousePhoto));
          }
        }
        break;
      case Tool::Stroke:
        hint("the stroke tool draws on the mesh: left-drag in the 3D view");
        break;
      case Tool::Cutout:  // cutoutCanvas handles it
        break;
    }
  }
  if (dragPhoto_ == i && dragPoint_ >= 0) {
    if (ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
      if (!dragging_ && std::hypot(mouse.x() - pressX_, mouse.y() - pressY_) > 2) {
        doc_.beginGroup("Move point " + pointName(dragPoint_));
        dragging_ = true;
      }
      if (dragging_ && dragPoint_ < static_cast<int>(doc_.project().points.size())) {
        const Vec2 q = clamped(mousePhoto);
        const auto current = positionIn(doc_.project(), dragPoint_, i);
        if (current && (*current - q).norm() > 0) edit([&] { doc_.movePosition(dragPoint_, i, q.x(), q.y()); });
      }
    } else {
      if (dragging_) doc_.endGroup();
      dragging_ = false;
      dragPoint_ = dragPhoto_ = -1;
    }
  }
}

}  // namespace montage
