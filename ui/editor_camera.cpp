// Camera feedback in the image panes (issue 11): for a photo whose clicks fit a camera, the mesh's
// projected wireframe and silhouette over the photo, each click's residual as a short line (x10),
// outlier clicks marked, the selected vertex's predicted position, and the proposed correspondences
// (click to accept, shift+click to decline). The caption says which path each photo takes.
#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "editor.h"
#include "mapping/camera.h"
#include "mapping/projection.h"
#include "plain_words.h"

namespace montage {

namespace {

constexpr int kMaxWireEdges = 40000;   // per photo; beyond, every k-th edge is drawn
constexpr double kResidualScale = 10;  // residual lines are drawn this many times longer
constexpr double kMaxResidualScreen = 60;

ImVec2 im(const Vec2& v) {
  return ImVec2(float(v.x()), float(v.y()));
}

}  // namespace

const CameraFit* Editor::photoFit(int photo) const {
  if (!resultUsable() || !result_->cameras) return nullptr;
  const auto& fits = result_->cameras->fits;
  return photo >= 0 && photo < static_cast<int>(fits.size()) ? &fits[photo] : nullptr;
}

void Editor::buildCameraLines() {
  const void* key = result_.get();
  if (cameraLinesFor_ == key) return;
  cameraLinesFor_ = key;
  cameraLines_.clear();
  if (!resultUsable() || !result_->projection || !result_->mapping) return;
  const Mesh& mesh = result_->mapping->partition->mesh;
  const auto& views = result_->projection->result.views;
  cameraLines_.resize(views.size());
  for (size_t p = 0; p < views.size(); ++p) {
    const CameraFit* fit = photoFit(static_cast<int>(p));
    if (!views[p] || views[p]->vertexVisible.empty() || !fit || !fit->fits) continue;
    const PhotoView& view = *views[p];
    const Vec3 eye = fit->camera.pinhole.center();
    const TriMesh& tri = mesh.tri;
    const int edges = static_cast<int>(tri.n_edges());
    const int step = std::max(1, edges / kMaxWireEdges);
    CameraLines& lines = cameraLines_[p];
    for (auto eh : tri.edges()) {
      const auto h = tri.halfedge_handle(eh, 0);
      const int a = tri.from_vertex_handle(h).idx(), b = tri.to_vertex_handle(h).idx();
      if (!view.vertexVisible[a] || !view.vertexVisible[b]) continue;
      const auto f0 = tri.face_handle(h), f1 = tri.opposite_face_handle(h);
      auto facing = [&](OpenMesh::FaceHandle f) {
        if (!f.is_valid()) return false;
        const auto q = mesh.facePositions(f.idx());
        return mesh.faceNormal(f.idx()).dot(eye - (q[0] + q[1] + q[2]) / 3) > 0;
      };
      const bool silhouette = !f0.is_valid() || !f1.is_valid() || facing(f0) != facing(f1);
      if (silhouette) {
        lines.silhouette.push_back({view.vertexUV[a], view.vertexUV[b]});
      } else if (eh.idx() % step == 0) {
        lines.wire.push_back({view.vertexUV[a], view.vertexUV[b]});
      }
    }
  }
}

std::vector<int> Editor::pendingProposals(int photo) const {
  std::vector<int> out;
  if (!resultUsable()) return out;
  const auto& declined = doc_.project().declinedProposals;
  for (size_t k = 0; k < result_->proposals.size(); ++k) {
    const Proposal& pr = result_->proposals[k];
    if (pr.photo != photo || doc_.pointAt(pr.vertex, pr.photo) >= 0) continue;
    if (std::find(declined.begin(), declined.end(), DeclinedProposal{pr.vertex, pr.photo}) != declined.end()) continue;
    out.push_back(static_cast<int>(k));
  }
  return out;
}

void Editor::cameraToolbar() {
  sameLineIfFits(checkboxWidth("camera"));
  ImGui::Checkbox("camera", &showCamera_);
  if (!showCamera_) return;
  // The button keeps its place and width while the camera is shown and some photo fits one (the last
  // result's say while a run goes on), greyed when nothing waits: the tab row below never jumps under
  // the cursor as the last proposal is accepted.
  if (resultUsable()) {
    proposalsButton_ = false;
    for (int i = 0; i < static_cast<int>(doc_.project().photos.size()); ++i)
      if (const CameraFit* fit = photoFit(i); fit && fit->fits && !fit->subject) proposalsButton_ = true;
  }
  if (!proposalsButton_) return;
  const std::vector<int> pending = pendingProposals(activePhoto_);
  const std::string label = pending.empty()       ? "No proposals"
                            : pending.size() == 1 ? "Accept 1 proposal"
                                                  : "Accept " + std::to_string(pending.size()) + " proposals";
  const ImVec2 size(ImGui::CalcTextSize("Accept 9999 proposals").x + ImGui::GetStyle().FramePadding.x * 2, 0);
  sameLineIfFits(size.x);
  ImGui::BeginDisabled(pending.empty());
  const bool pressed = button((label + "##accept_proposals").c_str(), &size, label);
  ImGui::EndDisabled();
  if (pressed && !pending.empty()) {
    doc_.beginGroup("Accept proposals in photo " + std::to_string(activePhoto_));
    for (int k : pending) {
      const Proposal& pr = result_->proposals[k];
      edit([&] { doc_.setPosition(pr.vertex, pr.photo, pr.pixel.x(), pr.pixel.y()); });
    }
    doc_.endGroup();
  }
}

void Editor::cameraOverlay(int photo, const PaneView& view, ImDrawList* draw, const Vec2& mouse, bool hovered,
                           std::string& tooltip) {
  hoverProposal_ = hovered ? -1 : hoverProposal_;
  if (!showCamera_) return;
  const CameraFit* fit = photoFit(photo);
  if (!fit || !fit->fits) return;
  // Wireframe and silhouette of the mesh as the camera sees it: a vertex buffer built once per result
  // (editor_overlays.cpp), in the pane's cache unless it is drawn live.
  if (!paneCached_) drawCameraWire(photo, view);
  // Residuals (x10) and outliers.
  for (size_t i = 0; i < fit->clicks.size(); ++i) {
    if (!std::isfinite(fit->residual[i])) continue;
    const Vec2 s = view.toScreen(fit->clicks[i].pixel);
    Vec2 d = kResidualScale * view.zoom * (fit->reprojected[i] - fit->clicks[i].pixel);
    if (d.norm() > kMaxResidualScreen) d *= kMaxResidualScreen / d.norm();
    const bool outlier = !fit->inlier[i];
    // Orange, so that a residual never reads as one of the partition's (yellow) curves.
    draw->AddLine(im(s), im(s + d), outlier ? IM_COL32(255, 60, 50, 255) : IM_COL32(255, 150, 40, 240), px(2.5f));
    if (outlier) {
      draw->AddCircle(im(s), px(9.0f), IM_COL32(255, 60, 50, 255), 0, px(2.0f));
      draw->AddLine(im(s + Vec2(-6, -6)), im(s + Vec2(6, 6)), IM_COL32(255, 60, 50, 255), 2.0f);
      draw->AddLine(im(s + Vec2(-6, 6)), im(s + Vec2(6, -6)), IM_COL32(255, 60, 50, 255), 2.0f);
    }
    if (hovered && (mouse - s).norm() < 8) {
      char text[160];
      std::snprintf(text, sizeof text, "residual %.2f px%s", fit->residual[i],
                    outlier ? " (outlier: above the camera's threshold)" : "");
      tooltip += (tooltip.empty() ? "" : "\n") + std::string(text);
    }
  }
  // The selected vertex where the camera predicts it.
  const auto& fields = result_->projection ? result_->projection->result.fields : std::vector<CorrectionField>{};
  const Mesh& mesh = result_->mapping->partition->mesh;
  // Not where the user has clicked that vertex already: the click is the answer.
  if (selectedVertex_ >= 0 && selectedVertex_ < mesh.numVertices() && photo < static_cast<int>(fields.size()) &&
      doc_.pointAt(selectedVertex_, photo) < 0) {
    Vec2 px;
    if (predictPixel(*fit, fields[photo], mesh.position(selectedVertex_), px)) {
      const ImVec2 s = im(view.toScreen(px));
      const ImU32 c = IM_COL32(80, 255, 200, 255);
      draw->AddCircle(s, this->px(7.0f), c, 0, this->px(1.5f));
      draw->AddLine(ImVec2(s.x - 12, s.y), ImVec2(s.x - 4, s.y), c, 1.5f);
      draw->AddLine(ImVec2(s.x + 4, s.y), ImVec2(s.x + 12, s.y), c, 1.5f);
      draw->AddLine(ImVec2(s.x, s.y - 12), ImVec2(s.x, s.y - 4), c, 1.5f);
      draw->AddLine(ImVec2(s.x, s.y + 4), ImVec2(s.x, s.y + 12), c, 1.5f);
      draw->AddText(ImVec2(s.x + 10, s.y + 6), c, ("predicted " + std::to_string(selectedVertex_)).c_str());
    }
  }
}

void Editor::proposalMarkers(int photo, const PaneView& view, ImDrawList* draw, const Vec2& mouse, bool hovered,
                             std::string& tooltip) {
  if (!showCamera_) return;
  const CameraFit* fit = photoFit(photo);
  if (!fit || !fit->fits) return;
  // Proposals (not yet clicked, not declined), drawn after the points so that none hides under another's
  // marker.
  for (int k : pendingProposals(photo)) {
    const Proposal& pr = result_->proposals[k];
    const Vec2 s = view.toScreen(pr.pixel);
    const bool over = hovered && (mouse - s).norm() < 7;
    const ImU32 c = over ? IM_COL32(255, 120, 255, 255) : IM_COL32(235, 90, 235, 230);
    draw->AddQuadFilled(im(s + Vec2(0, -7)), im(s + Vec2(7, 0)), im(s + Vec2(0, 7)), im(s + Vec2(-7, 0)),
                        IM_COL32(0, 0, 0, 140));
    draw->AddQuad(im(s + Vec2(0, -6)), im(s + Vec2(6, 0)), im(s + Vec2(0, 6)), im(s + Vec2(-6, 0)), c,
                  over ? 2.5f : 1.5f);
    if (over) {
      hoverProposal_ = k;
      tooltip = "proposed: point #" + resultPointName(pr.point) + " (vertex " + std::to_string(pr.vertex) +
                "), clicked in photo " + std::to_string(pr.from) + "\nclick: accept, shift+click: decline";
    }
  }
}

bool Editor::clickProposal(int photo, bool decline) {
  if (hoverProposal_ < 0 || !resultUsable() || hoverProposal_ >= static_cast<int>(result_->proposals.size()))
    return false;
  const Proposal pr = result_->proposals[hoverProposal_];
  if (pr.photo != photo) return false;
  hoverProposal_ = -1;
  if (decline) {
    edit([&] { doc_.declineProposal(pr.vertex, pr.photo); });
    setStatus("declined the proposal of vertex " + std::to_string(pr.vertex) + " in photo " + std::to_string(photo));
  } else {
    int index = -1;
    if (edit([&] { index = doc_.setPosition(pr.vertex, pr.photo, pr.pixel.x(), pr.pixel.y()); })) {
      selectedPoint_ = index;
      selectedVertex_ = pr.vertex;
    }
    setStatus("accepted the proposal of vertex " + std::to_string(pr.vertex) + " in photo " + std::to_string(photo));
  }
  return true;
}

std::vector<std::pair<int, std::vector<std::string>>> Editor::weakFits() const {
  std::vector<std::pair<int, std::vector<std::string>>> out;
  for (int i = 0; i < static_cast<int>(doc_.project().photos.size()); ++i)
    if (const CameraFit* fit = photoFit(i))
      if (auto concerns = weakFitConcerns(*fit); !concerns.empty()) out.emplace_back(i, std::move(concerns));
  return out;
}

void Editor::weakFitBanner() {
  const auto weak = weakFits();
  if (weak.empty()) return;
  // An orange banner over the panes: a fit that passes but should not be trusted is named, with why and
  // what to do, instead of passing silently (the silhouette overlay was the only sign).
  std::string text = weak.size() == 1 ? "Weak camera fit, check it before trusting it:"
                                      : "Weak camera fits, check them before trusting them:";
  for (const auto& [photo, concerns] : weak) {
    text += "\nphoto " + std::to_string(photo) + " (" +
            std::filesystem::path(doc_.project().photos[photo].path).filename().string() + "): ";
    for (size_t k = 0; k < concerns.size(); ++k) text += (k ? "; " : "") + concerns[k];
  }
  const ImVec2 lo = ImGui::GetCursorScreenPos();
  const float width = ImGui::GetContentRegionAvail().x;
  const float pad = px(4);
  const ImVec2 size = ImGui::CalcTextSize(text.c_str(), nullptr, false, width - 2 * pad);
  ImDrawList* draw = ImGui::GetWindowDrawList();
  draw->AddRectFilled(lo, ImVec2(lo.x + width, lo.y + size.y + 2 * pad), IM_COL32(150, 80, 10, 235), px(3));
  ImGui::SetCursorScreenPos(ImVec2(lo.x + pad, lo.y + pad));
  ImGui::PushTextWrapPos(ImGui::GetCursorPos().x + width - 2 * pad);
  ImGui::TextColored(ImVec4(1, 0.93f, 0.8f, 1), "%s", text.c_str());
  ImGui::PopTextWrapPos();
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("click: show photo %d with its camera (its silhouette shows how far off the fit is)",
                      weak.front().first);
  if (ImGui::IsItemClicked()) {
    activePhoto_ = weak.front().first;
    showCamera_ = true;
  }
  ImGui::SetCursorScreenPos(ImVec2(lo.x, lo.y + size.y + 2 * pad + ImGui::GetStyle().ItemSpacing.y));
  weakBannerRect_ = Rect{lo.x, lo.y, width, size.y + 2 * pad};
}

const SubjectChoice* Editor::subjectChoice(int photo) const {
  if (!resultUsable() || !result_->projection) return nullptr;
  for (const SubjectChoice& c : result_->projection->result.subjects)
    if (c.photo == photo) return &c;
  return nullptr;
}

std::string Editor::cameraCaption(int photo) const {
  const CameraFit* fit = photoFit(photo);
  if (!fit) return "";
  char text[200];
  if (fit->subject) {
    const SubjectChoice* choice = subjectChoice(photo);
    if (!fit->fits || !choice || !choice->warp) return "  another subject: the paper's map";
    std::snprintf(text, sizeof text, "  another subject: camera (f %.0f px, clicks %.2f px median off it) + warp",
                  fit->camera.focal(), fit->medianResidual);
    return text;
  }
  if (!fit->fits) return "  paper's path";
  std::snprintf(text, sizeof text, "  projection: f %.0f px, %d/%zu agree, median %.2f px, max %.2f px",
                fit->camera.focal(), fit->inliers, fit->clicks.size(), fit->medianResidual, fit->maxResidual);
  std::string caption = text;
  // The noise the correction's `noise` mode leaves to the camera (a click moves the texture beyond 3x it).
  if (doc_.project().options.correction == CorrectionMode::Noise && fit->noisePx > 0.005) {
    std::snprintf(text, sizeof text, ", clicks' noise %.2f px", fit->noisePx);
    caption += text;
  }
  // A photo without a cut-out whose camera was refined on the silhouette found around the mesh's outline.
  if (fit->silhouetteFound) caption += ", on the silhouette found";
  return caption;
}

}  // namespace montage
