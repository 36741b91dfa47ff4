// The Coverage tab (issue 14, guidance to full coverage): every unmapped region of the last result with its
// area, why it is empty and the fix (core's analyseCoverage, mapping/coverage.h), "where to click next",
// a "Fly to" button per region that centres it in the 3D view and outlines it, and the rejected pairs
// grouped by reason with the expected ones (around no empty region) hidden unless asked for.
#include <imgui.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "editor.h"
#include "navigation.h"
#include "pipeline.h"

namespace montage {

namespace {

void pushLineVertex(std::vector<float>& out, const Vec3& p, const Vec4f& c) {
  out.insert(out.end(), {float(p.x()), float(p.y()), float(p.z()), c[0], c[1], c[2], c[3]});
}

}  // namespace

const CoverageReport* Editor::coverage() {
  if (!resultUsable() || !result_->mapping) {
    coverage_.reset();
    coverageFor_ = nullptr;
    coverageRegionOf_.clear();
    return nullptr;
  }
  if (coverageFor_ != result_.get()) {
    coverage_ = std::make_shared<const CoverageReport>(coverageOf(*result_));
    coverageFor_ = result_.get();
    // Mesh faces (the ids holeModes use: the partition's parents) to regions, once per result.
    const auto& parent = result_->mapping->partition->faceParent;
    coverageRegionOf_.assign(parent.empty() ? 0 : *std::max_element(parent.begin(), parent.end()) + 1, -1);
    for (size_t r = 0; r < coverage_->regions.size(); ++r)
      for (int f : coverage_->regions[r].faces)
        if (f < static_cast<int>(parent.size())) coverageRegionOf_[parent[f]] = static_cast<int>(r);
    coverageRegion_ = -1;  // region indices are per result
    linesDirty_ = true;
  }
  return coverage_.get();
}

void Editor::flyToRegion(int index) {
  const CoverageReport* report = coverage();
  if (!report || index < 0 || index >= static_cast<int>(report->regions.size())) return;
  const CoverageRegion& region = report->regions[index];
  const Mesh& mesh = result_->mapping->partition->mesh;
  // Look at the region along its mean normal (from outside), then fit its extent.
  Vec3 normal = Vec3::Zero();
  for (int f : region.faces) normal += mesh.faceArea(f) * mesh.faceNormal(f);
  if (normal.norm() > 1e-12 * std::max(region.area, 1e-30)) camera_.lookFrom(region.centre, normal.normalized());
  framePoint(camera_, region.centre, std::max(region.radius, 1e-3 * camera_.sceneRadius), std::max(1, int(viewRect_.w)),
             std::max(1, int(viewRect_.h)));
  coverageRegion_ = index;
  linesDirty_ = true;
  char text[96];
  std::snprintf(text, sizeof(text), "coverage: region %d (%.1f%% of the surface)", index, 100 * region.share);
  setStatus(text);
}

void Editor::appendCoverageLines(std::vector<float>& lines) {
  const CoverageReport* report = coverage();
  if (!report || coverageRegion_ < 0 || coverageRegion_ >= static_cast<int>(report->regions.size())) return;
  const CoverageRegion& region = report->regions[coverageRegion_];
  const Mesh& mesh = result_->mapping->partition->mesh;
  // The region's edges (its inside faint, its border bright): one line per edge.
  std::set<std::pair<int, int>> inside, border;
  std::map<std::pair<int, int>, int> uses;
  for (int f : region.faces) {
    const auto v = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k) ++uses[{std::min(v[k], v[(k + 1) % 3]), std::max(v[k], v[(k + 1) % 3])}];
  }
  const Vec4f faint(0.95f, 0.2f, 0.95f, 0.55f), bright(1.0f, 0.3f, 1.0f, 1.0f);
  for (const auto& [e, n] : uses) {
    pushLineVertex(lines, mesh.position(e.first), n == 1 ? bright : faint);
    pushLineVertex(lines, mesh.position(e.second), n == 1 ? bright : faint);
  }
}

void Editor::coverageTab() {
  const CoverageReport* report = coverage();
  if (!report) {
    ImGui::TextWrapped("No result yet: the regions left empty show here once the pipeline has run.");
    return;
  }
  const Project& p = doc_.project();
  ImGui::Text("mapped: %.1f%% of the surface", 100 * report->mappedShare);
  ImGui::TextWrapped(
      "%zu empty region(s)%s", report->regions.size(),
      report->smallRegions > 0
          ? (", and " + std::to_string(report->smallRegions) + " slivers (" +
             std::to_string(int(1000 * report->smallArea / report->totalArea) / 10.0).substr(0, 4) + "%) not listed")
                .c_str()
          : "");
  // Where to click next: the region whose clicks map the most area.
  if (!report->next.empty()) {
    const int index = report->next.front();
    const CoverageRegion& region = report->regions[index];
    const auto cause =
        std::find_if(region.causes.begin(), region.causes.end(), [](const RegionCause& c) { return c.click.valid(); });
    ImGui::Separator();
    ImGui::TextColored(ImVec4(1.0f, 0.85f, 0.3f, 1), "Where to click next: region %d (%.1f%%)", index,
                       100 * region.share);
    ImGui::TextWrapped("%s: %s", cause->why.c_str(), cause->fix.c_str());
    std::string around;
    for (size_t i = 0; i < region.points.size() && i < 12; ++i)
      around += (i ? ", " : "") + resultPointName(region.points[i]);
    if (region.points.size() > 12) around += ", ...";
    ImGui::TextWrapped("features around it: %s", around.empty() ? "none" : around.c_str());
    if (button("Fly there")) flyToRegion(index);
    ImGui::SameLine();
    const CoverageClick click = cause->click;
    if (click.vertex < (input_.mesh ? input_.mesh->numVertices() : 0) && click.photo < int(p.photos.size()) &&
        button("Select it")) {
      selectVertex(click.vertex);
      activePhoto_ = click.photo;
      setStatus(clickWords(click) + ": click where it shows in photo " + std::to_string(click.photo));
    }
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("select the vertex and show the photo to click it in");
  }
  ImGui::Separator();
  if (report->regions.empty()) ImGui::TextWrapped("Every listed part of the surface maps to a photo.");
  for (size_t i = 0; i < report->regions.size(); ++i) {
    const CoverageRegion& region = report->regions[i];
    ImGui::PushID(static_cast<int>(i));
    if (button(("Fly to region " + std::to_string(i)).c_str())) flyToRegion(static_cast<int>(i));
    ImGui::SameLine();
    const bool highlighted = coverageRegion_ == static_cast<int>(i);
    if (highlighted) ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1.0f, 0.45f, 1.0f, 1));
    ImGui::Text("%.1f%%, %zu faces", 100 * region.share, region.faces.size());
    if (highlighted) ImGui::PopStyleColor();
    holeFillCombo(static_cast<int>(i));
    for (const RegionCause& c : region.causes) {
      ImGui::Bullet();
      ImGui::TextWrapped(
          "%s%s: %s", region.causes.size() > 1 ? (std::to_string(int(100 * c.area / region.area)) + "%: ").c_str() : "",
          c.why.c_str(), c.fix.c_str());
    }
    ImGui::PopID();
  }
  // Rejected pairs by reason; pairs around no empty region are the expected far crossings.
  const auto& rejected = result_->mapping->partition->rejected;
  if (!rejected.empty() && ImGui::CollapsingHeader("Rejected pairs by reason")) {
    ImGui::Checkbox("show expected pairs (around no empty region)", &showExpectedRejected_);
    for (const RejectedGroup& g : report->rejected) {
      const int shown = showExpectedRejected_ ? int(g.pairs.size()) : int(g.pairs.size()) - g.expected;
      const std::string head = std::string(kRejectReasonNames[int(g.reason)]) + ": " + std::to_string(g.pairs.size()) +
                               " (" + std::to_string(g.expected) + " expected)##" + std::to_string(int(g.reason));
      if (!ImGui::TreeNode(head.c_str())) continue;
      ImGui::TextWrapped("%s", g.words.c_str());
      for (int k = 0; k < shown && k < 200; ++k) {
        const RejectedPair& r = rejected[g.pairs[k]];
        ImGui::BulletText("%s-%s: %s", resultPointName(r.fromPoint).c_str(), resultPointName(r.toPoint).c_str(),
                          rejectedWords(r).c_str());
      }
      if (shown == 0) ImGui::TextDisabled("none around an empty region");
      ImGui::TreePop();
    }
  }
}

// How an empty region is filled (issue 34: harmonic and RBF stay choices per hole): the project's inpainting
// option, or a mode of its own (Project::holeModes, on one of its faces; an undoable edit), and for texture the
// photo region its texture comes from, drawn with the clone tool's polygon.
const HoleMode* Editor::regionHoleMode(int region) const {
  const HoleMode* entry = nullptr;
  for (const HoleMode& h : doc_.project().holeModes)
    if (h.face >= 0 && h.face < static_cast<int>(coverageRegionOf_.size()) && coverageRegionOf_[h.face] == region)
      entry = &h;  // the last entry wins, as in the pipeline
  return entry;
}

std::vector<int> Editor::regionFaces(int region) const {
  std::vector<int> faces;
  for (int f = 0; f < static_cast<int>(coverageRegionOf_.size()); ++f)
    if (coverageRegionOf_[f] == region) faces.push_back(f);
  return faces;
}

void Editor::pickHoleTexture(int region) {
  std::vector<int> faces = regionFaces(region);
  if (faces.empty()) return;
  cancelInProgress();
  tool_ = Tool::Clone;
  exemplarHole_ = std::move(faces);
  exemplarRegion_ = region;
  setStatus("texture for region " + std::to_string(region) +
            ": click the corners of a photo region, then the first corner again (or Enter); Escape cancels");
}

void Editor::holeFillCombo(int region) {
  const HoleMode* entry = regionHoleMode(region);
  std::optional<InpaintMode> fill;
  if (entry) fill = entry->mode;
  const std::string byDefault =
      std::string("default (") + kInpaintModeNames[size_t(doc_.project().options.inpaintMode)] + ")";
  ImGui::SetNextItemWidth(ImGui::CalcTextSize("default (structure)").x + ImGui::GetFrameHeight() * 2);
  if (ImGui::BeginCombo("fill", fill ? kInpaintModeNames[size_t(*fill)] : byDefault.c_str())) {
    std::optional<std::optional<InpaintMode>> chosen;
    if (ImGui::Selectable(byDefault.c_str(), !fill)) chosen = std::optional<InpaintMode>();
    for (size_t m = 0; m < kInpaintModeNames.size(); ++m)
      if (ImGui::Selectable(kInpaintModeNames[m], fill && size_t(*fill) == m)) chosen = InpaintMode(m);
    ImGui::EndCombo();
    if (chosen && *chosen != fill) {
      const std::vector<int> faces = regionFaces(region);
      if (!faces.empty()) edit([&] { doc_.setHoleFill(faces, faces.front(), *chosen); });
    }
  }
  scriptButton("fill " + std::to_string(region));
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("how this part is filled: texture continues the photos around it; harmonic and rbf blend "
                      "their colours smoothly; off leaves it empty");
  // Texture: from the photos around the hole, or from a photo region the user draws; beside the fill when it
  // fits (one row per region keeps the list short). The entry again: a choice above replaced the document.
  entry = regionHoleMode(region);
  if ((entry ? entry->mode : doc_.project().options.inpaintMode) != InpaintMode::Texture) return;
  const std::string id = std::to_string(region);
  const auto buttonWidth = [](const std::string& label) {
    return ImGui::CalcTextSize(label.c_str()).x + ImGui::GetStyle().FramePadding.x * 2;
  };
  if (const HoleExemplar* exemplar = entry && entry->exemplar ? &*entry->exemplar : nullptr) {
    const std::string again = "photo " + std::to_string(exemplar->photo) + "...";
    sameLineIfFits(buttonWidth(again) + ImGui::GetStyle().ItemSpacing.x + buttonWidth("x"));
    if (button((again + "##" + id).c_str(), nullptr, "texture from " + id)) pickHoleTexture(region);
    if (ImGui::IsItemHovered())
      ImGui::SetTooltip("its texture comes from a region of photo %d (outlined there): click to draw another",
                        exemplar->photo);
    ImGui::SameLine();
    if (button(("x##around" + id).c_str(), nullptr, "texture around " + id)) {
      const std::vector<int> faces = regionFaces(region);
      if (!faces.empty()) edit([&] { doc_.setHoleExemplar(faces, faces.front(), std::nullopt); });
    }
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("take its texture from the photos around it again");
    return;
  }
  sameLineIfFits(buttonWidth("photo..."));
  if (button(("photo...##" + id).c_str(), nullptr, "texture from " + id)) pickHoleTexture(region);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip(
        "texture it from a region you draw in any photo (another subject's too), instead of the "
        "photos around it");
}

nlohmann::json Editor::coverageState() const {
  using nlohmann::json;
  if (!coverage_ || coverageFor_ != result_.get()) return nullptr;
  const Camera cam = viewCamera();
  json regions = json::array();
  for (size_t i = 0; i < coverage_->regions.size(); ++i) {
    const CoverageRegion& r = coverage_->regions[i];
    Vec2 px;
    const bool front = cam.project(r.centre, px);
    // Whether a pick at the view's centre lands on this region (a face of the input it lies in).
    bool centred = false;
    if (front) {
      const VertexPick pick = pickAt(viewRect_.x + viewRect_.w / 2, viewRect_.y + viewRect_.h / 2);
      const auto& parent = result_->mapping->partition->faceParent;
      const Scene& scene = *result_->scene;
      for (int f : r.faces)
        centred = centred || (f < int(parent.size()) &&
                              (scene.welded() ? scene.mesh->faceOrigin[parent[f]] : parent[f]) == pick.face);
    }
    regions.push_back({{"share", r.share},
                       {"faces", r.faces.size()},
                       {"why", r.causes.empty() ? "" : r.causes[0].why},
                       {"fix", r.causes.empty() ? "" : r.causes[0].fix},
                       {"centre_pixel", front ? json{px.x(), px.y()} : json(nullptr)},
                       {"at_view_centre", centred},
                       {"fill",
                        [&]() -> json {
                          const HoleMode* entry = regionHoleMode(static_cast<int>(i));
                          return entry ? json(kInpaintModeNames[size_t(entry->mode)]) : json("default");
                        }()},
                       {"exemplar_photo", [&]() -> json {
                          const HoleMode* entry = regionHoleMode(static_cast<int>(i));
                          return entry && entry->exemplar ? json(entry->exemplar->photo) : json(nullptr);
                        }()}});
  }
  return {{"mapped_share", coverage_->mappedShare},
          {"regions", regions},
          {"highlighted", coverageRegion_},
          {"next", coverage_->next.empty() ? -1 : coverage_->next.front()}};
}

}  // namespace montage
