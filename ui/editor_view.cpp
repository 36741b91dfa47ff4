// The 3D view: an offscreen framebuffer shown as an ImGui image, orbit/pan/zoom, vertex picking by
// ray cast, stroke drawing and clone-target painting, and the overlays (features with ids, partition
// paths, face colourings, the clone preview).
#include <imgui.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "editor.h"
#include "geometry/predicates.h"
#include "gl.h"
#include "gl_util.h"
#include "io/mesh_io.h"
#include "mapping/partition.h"
#include "navigation.h"
#include "overlay_gl.h"
#include "overlays.h"
#include "surface/inpaint.h"

namespace montage {

namespace {

ImTextureID toImTexture(GLuint id) {
  return reinterpret_cast<ImTextureID>(static_cast<intptr_t>(id));
}

// FNV-1a over the pixels: identifies a material texture's content, so that a new result whose
// textures are the same photos reuses the uploaded GL textures instead of uploading them again.
std::uint64_t contentHash(const cv::Mat& image) {
  std::uint64_t h = 1469598103934665603ull ^ (std::uint64_t(image.cols) << 32 | std::uint64_t(image.rows));
  for (int y = 0; y < image.rows; ++y) {
    const auto* row = image.ptr<std::uint64_t>(y);
    const size_t words = image.cols * image.elemSize() / 8;
    for (size_t i = 0; i < words; ++i) h = (h ^ row[i]) * 1099511628211ull;
  }
  return h;
}

void pushVertex(std::vector<float>& out, const Vec3& p, const Vec4f& c) {
  out.insert(out.end(), {float(p.x()), float(p.y()), float(p.z()), c[0], c[1], c[2], c[3]});
}

}  // namespace

Camera Editor::viewCamera() const {
  return camera_.camera(std::max(1, int(viewRect_.w)), std::max(1, int(viewRect_.h)));
}

VertexPick Editor::pickAt(double screenX, double screenY) const {
  if (!input_.mesh || !input_.bvh) return {};
  // Picking uses the input mesh (vertex ids as in the file, which the project refers to); the
  // displayed result adds Steiner vertices but lies on the same surface. Mouse positions are whole
  // pixels (ImGui floors them); the ray goes through that pixel's centre (photo.h convention).
  return pickVertex(*input_.mesh, *input_.bvh, viewCamera(), std::floor(screenX - viewRect_.x) + 0.5,
                    std::floor(screenY - viewRect_.y) + 0.5);
}

void Editor::view3d() {
  const ImVec2 pos = ImGui::GetCursorScreenPos();
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  viewRect_ = Rect{pos.x, pos.y, std::max(1.0f, std::floor(avail.x)), std::max(1.0f, std::floor(avail.y))};
  // Adaptive resolution: the camera's movement up to now decides this frame's framebuffer size (here,
  // before the image below refers to its texture; renderScene draws it at the end of the frame).
  const Vec3 eye = camera_.eye();
  char cameraKey[256];
  std::snprintf(cameraKey, sizeof(cameraKey), "%.17g %.17g %.17g %.17g %.17g %.17g %.17g", eye.x(), eye.y(), eye.z(),
                camera_.target.x(), camera_.target.y(), camera_.target.z(), camera_.fovYDeg);
  viewMotion_.update(viewCameraKey_ != cameraKey, frameNumber_, glfwGetTime());
  viewCameraKey_ = cameraKey;
  const int W = int(viewRect_.w), H = int(viewRect_.h);
  viewDivisor_ = reducedNavigation_ && viewMotion_.moving() ? navigationDivisor(W, H) : 1;
  try {
    // The whole view at 1/d per axis (rounded up; the image stretches it back over the view's pixels).
    viewFbo_->resize((W + viewDivisor_ - 1) / viewDivisor_, (H + viewDivisor_ - 1) / viewDivisor_);
    viewFbo_->setLinearFilter(viewDivisor_ > 1);
  } catch (const Error& e) {
    ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "%s", e.what());
    return;
  }
  // GL's rows run bottom-up: flip v.
  ImGui::Image(toImTexture(viewFbo_->colorTexture()), ImVec2(float(viewRect_.w), float(viewRect_.h)), ImVec2(0, 1),
               ImVec2(1, 0));
  ImDrawList* draw = ImGui::GetWindowDrawList();
  if (!input_.mesh) {
    const char* text = input_.error.empty() ? "Open a project or a mesh (File > Open, Ctrl+O)" : input_.error.c_str();
    draw->AddText(ImGui::GetFont(), ImGui::GetFontSize(), ImVec2(pos.x + px(16), pos.y + px(16)),
                  IM_COL32(220, 220, 220, 255), text, nullptr, std::max(40.0f, avail.x - px(32)));
    return;
  }
  if (frameWhenShown_) {
    frameWhenShown_ = false;
    frameAll();
  }
  if (pendingView_.present) {
    // The camera the project was saved with, over the framing (the scene's sphere stays the mesh's).
    camera_.target = pendingView_.target;
    camera_.distance = pendingView_.distance;
    camera_.yawDeg = pendingView_.yawDeg;
    camera_.pitchDeg = pendingView_.pitchDeg;
    camera_.fovYDeg = pendingView_.fovYDeg;
    pendingView_ = ViewState{};
  }
  view3dInput(viewRect_);
  drawViewLabels(viewRect_);
}

void Editor::view3dInput(const Rect& r) {
  ImGui::SetCursorScreenPos(ImVec2(float(r.x), float(r.y)));
  ImGui::InvisibleButton(
      "##view3d", ImVec2(float(r.w), float(r.h)),
      ImGuiButtonFlags_MouseButtonLeft | ImGuiButtonFlags_MouseButtonRight | ImGuiButtonFlags_MouseButtonMiddle);
  const bool hovered = ImGui::IsItemHovered();
  ImGuiIO& io = ImGui::GetIO();
  const ImVec2 mouse = io.MousePos;
  hoverVertexNext_ = -1;
  if (hovered && !viewPressed_) {
    // One ray cast when the pointer moved (not one per feature and frame).
    if (mouse.x != hoverPickX_ || mouse.y != hoverPickY_ || camera_.eye() != hoverPickEye_) {
      hoverPickX_ = mouse.x;
      hoverPickY_ = mouse.y;
      hoverPickEye_ = camera_.eye();
      hoverPick_ = pickAt(mouse.x, mouse.y).vertex;
    }
    hoverVertexNext_ = hoverPick_;
  }
  const int W = std::max(1, int(r.w)), H = std::max(1, int(r.h));
  const double vx = std::floor(mouse.x - r.x) + 0.5, vy = std::floor(mouse.y - r.y) + 0.5;
  if (hovered && io.MouseWheel != 0) {
    // Zoom to the cursor: about the surface point under it (or the target's plane there).
    const VertexPick pick = pickAt(mouse.x, mouse.y);
    zoomAbout(camera_, anchorAt(camera_, W, H, vx, vy, pick.face >= 0 ? &pick.point : nullptr), io.MouseWheel);
  }
  const bool strokeTool = tool_ == Tool::Stroke && !io.KeyShift;
  const bool paintTool = tool_ == Tool::Clone && clonePolygonClosed_ && !io.KeyShift;
  const double t = ImGui::GetTime();
  for (int b = 0; b < 3 && !viewPressed_; ++b)
    if (hovered && ImGui::IsMouseClicked(b)) {
      viewPressed_ = true;
      viewPressButton_ = b;
      viewDragged_ = false;
      pressX_ = mouse.x;
      pressY_ = mouse.y;
      clickDrag_.press(mouse.x, mouse.y, t);
      orbitPivot_ = camera_.target;
      if (orbitAtPick_ && dragAction(bindings_, b, io.KeyShift, io.KeyCtrl) == DragAction::Orbit) {
        const VertexPick pick = pickAt(mouse.x, mouse.y);
        if (pick.face >= 0) orbitPivot_ = pick.point;
      }
      if (b == 0 && strokeTool) {
        stroke_.clear();
        strokeAt(mouse.x, mouse.y);
      }
      if (b == 0 && paintTool) paintCloneAt(mouse.x, mouse.y, io.KeyCtrl);
    }
  if (!viewPressed_) return;
  const int b = viewPressButton_;
  if (ImGui::IsMouseDown(b)) {
    // A click until the pointer moved far enough, or slowly enough (ClickDrag); then the whole
    // movement since the press counts, so nothing is lost to the decision.
    const bool wasDragging = clickDrag_.dragging();
    viewDragged_ = clickDrag_.move(mouse.x, mouse.y, t);
    ImVec2 d = io.MouseDelta;
    if (viewDragged_ && !wasDragging) d = ImVec2(float(mouse.x - pressX_), float(mouse.y - pressY_));
    if (d.x == 0 && d.y == 0) return;
    if (b == 0 && strokeTool) {
      strokeAt(mouse.x, mouse.y);
    } else if (b == 0 && paintTool) {
      paintCloneAt(mouse.x, mouse.y, io.KeyCtrl);
    } else if (viewDragged_) {
      switch (dragAction(bindings_, b, io.KeyShift, io.KeyCtrl)) {
        case DragAction::Orbit:
          orbitAbout(camera_, orbitPivot_, d.x, d.y);
          break;
        case DragAction::Pan:
          camera_.pan(d.x, d.y, int(r.h));
          break;
        case DragAction::None:
          break;
      }
    }
    return;
  }
  viewDragged_ = !clickDrag_.releaseIsClick(mouse.x, mouse.y, t);
  viewPressed_ = false;
  if (b != 0) return;
  if (strokeTool) {
    if (stroke_.size() >= 2) {
      const Stroke stroke{stroke_};
      if (edit([&] { doc_.addStroke(stroke); })) setStatus("stroke of " + std::to_string(stroke_.size()) + " vertices");
    } else if (!stroke_.empty()) {
      hint("stroke: drag across the surface to draw one");
    }
    stroke_.clear();
    linesDirty_ = true;
  } else if (!paintTool && !viewDragged_) {
    const VertexPick pick = pickAt(mouse.x, mouse.y);
    selectVertex(pick.vertex);
    if (pick.vertex >= 0) {
      setStatus("vertex " + std::to_string(pick.vertex) +
                (selectedPoint_ >= 0 ? " (feature point #" + pointName(selectedPoint_) + ")"
                                     : ": now click where it is in a photo"));
    }
  }
}

void Editor::strokeAt(double screenX, double screenY) {
  const VertexPick pick = pickAt(screenX, screenY);
  if (pick.vertex < 0) return;
  if (stroke_.empty()) {
    stroke_.push_back(pick.vertex);
  } else if (pick.vertex != stroke_.back()) {
    // Consecutive stroke vertices must be mesh neighbours: join them by the shortest edge path
    // (the core's Dijkstra), so a fast mouse still gives a connected polyline.
    const std::vector<int> path = shortestPath(*input_.mesh, stroke_.back(), pick.vertex);
    if (path.size() >= 2) stroke_.insert(stroke_.end(), path.begin() + 1, path.end());
  }
  linesDirty_ = true;
}

void Editor::paintCloneAt(double screenX, double screenY, bool erase) {
  const VertexPick pick = pickAt(screenX, screenY);
  if (pick.face < 0) return;
  const double radius = cloneBrush_ * (input_.hi - input_.lo).norm();
  for (int f = 0; f < input_.mesh->numFaces(); ++f)
    if ((input_.faceCentroids[f] - pick.point).norm() <= radius) {
      if (erase) {
        cloneFaces_.erase(f);
      } else {
        cloneFaces_.insert(f);
      }
    }
  if (cloneAnchorVertex_ < 0 && !erase) cloneAnchorVertex_ = pick.vertex;
  if (cloneFaces_.empty()) cloneAnchorVertex_ = -1;
  cloneDirty_ = overlayDirty_ = true;
}

void Editor::uploadMesh() {
  ++uploadCount_;
  meshDirty_ = false;
  overlayDirty_ = true;
  const TexturedModel* model = shownModel();
  const Mesh* mesh = model ? &model->mesh : input_.mesh.get();
  uploadedModel_ = model ? static_cast<const void*>(model) : static_cast<const void*>(mesh);
  materialRanges_.clear();
  gpuFaceOrder_.clear();
  if (!mesh) return;
  const int F = mesh->numFaces();
  gpuFaceOrder_.resize(F);
  for (int f = 0; f < F; ++f) gpuFaceOrder_[f] = f;
  auto materialOf = [&](int f) {
    return model && f < static_cast<int>(model->faceMaterial.size()) ? model->faceMaterial[f] : -1;
  };
  std::stable_sort(gpuFaceOrder_.begin(), gpuFaceOrder_.end(),
                   [&](int a, int b) { return materialOf(a) < materialOf(b); });
  const std::vector<Vec3f> normals = vertexNormals(*mesh);
  std::vector<float> data;
  data.reserve(size_t(F) * 3 * 14);
  const bool cornerColors = model && static_cast<int>(model->cornerColor.size()) == F;
  const float bary[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int i = 0; i < F; ++i) {
    const int f = gpuFaceOrder_[i];
    const auto corners = mesh->faceVertices(f);
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = mesh->position(corners[k]);
      const Vec3f& n = normals[corners[k]];
      // The model's UVs have v up (OBJ); textures are uploaded with the image's top row first.
      Vec2f uv(0, 0);
      if (model && model->textured()) uv = Vec2f(model->uv[f][k].x(), 1.0f - model->uv[f][k].y());
      const Vec3f c = cornerColors ? model->cornerColor[f][k] : Vec3f::Zero();
      data.insert(data.end(), {float(p.x()), float(p.y()), float(p.z()), n.x(), n.y(), n.z(), uv.x(), uv.y(),
                               bary[k][0], bary[k][1], bary[k][2], c.x(), c.y(), c.z()});
    }
    const int m = materialOf(f);
    if (materialRanges_.empty() || materialRanges_.back().first != m) materialRanges_.push_back({m, {i * 3, 0}});
    materialRanges_.back().second.second += 3;
  }
  meshVbo_->upload(data, {{0, 3}, {1, 3}, {2, 2}, {3, 3}, {5, 3}});

  // Textures by content: the photos of the previous results stay on the GPU.
  std::map<std::uint64_t, std::unique_ptr<Texture>> cache;
  std::map<const unsigned char*, std::pair<cv::Mat, std::uint64_t>> hashes;
  materialTextureIds_.assign(model ? model->materials.size() : 0, 0);
  for (size_t m = 0; model && m < model->materials.size(); ++m) {
    const cv::Mat& tex = model->materials[m].texture;
    if (tex.empty() || tex.type() != CV_8UC4) continue;
    std::optional<std::uint64_t> key;
    for (const auto* pool : {&textureHashes_, &spareHashes_})
      if (const auto known = pool->find(tex.data); !key && known != pool->end()) {
        const cv::Mat& held = known->second.first;
        if (held.size == tex.size && held.step[0] == tex.step[0]) key = known->second.second;
      }
    if (!key) key = contentHash(tex);
    hashes[tex.data] = {tex, *key};
    auto it = cache.find(*key);
    if (it == cache.end()) {
      std::unique_ptr<Texture>* kept = nullptr;
      for (auto* pool : {&textureCache_, &spareTextures_}) {
        const auto old = pool->find(*key);
        if (!kept && old != pool->end() && old->second) kept = &old->second;
      }
      if (kept) {
        it = cache.emplace(*key, std::move(*kept)).first;
      } else {
        auto texture = std::make_unique<Texture>();
        texture->upload(tex);
        it = cache.emplace(*key, std::move(texture)).first;
      }
    }
    materialTextureIds_[m] = it->second->id();
  }
  // The last model's textures this one does not use are kept for one more upload; older ones are freed.
  spareTextures_.clear();
  for (auto& [key, texture] : textureCache_)
    if (texture) spareTextures_.emplace(key, std::move(texture));
  textureCache_ = std::move(cache);
  spareHashes_ = std::move(textureHashes_);
  textureHashes_ = std::move(hashes);
}

void Editor::uploadOverlay() {
  ++uploadCount_;
  overlayDirty_ = false;
  const TexturedModel* model = shownModel();
  const int F = static_cast<int>(gpuFaceOrder_.size());
  std::vector<Vec4f> face(F, Vec4f::Zero());
  if (model && model->mesh.numFaces() == F) {
    switch (coloring_) {
      case FaceColoring::Patches:
        face = patchOverlay(*model);
        break;
      case FaceColoring::Empty:
        face = emptyOverlay(*model);
        break;
      case FaceColoring::Stretch:
        if (static_cast<int>(stretch_.size()) == F) face = stretchOverlay(stretch_);
        break;
      case FaceColoring::SeamError:
        if (result_->seams && static_cast<int>(result_->seams->faceError.size()) == F)
          face = seamErrorOverlay(result_->seams->faceError);
        break;
      case FaceColoring::None:
        break;
    }
  }
  if (!cloneFaces_.empty()) {
    // Clone targets are input faces; the displayed result's faces map to them by faceParent.
    const std::vector<int>* parent = model && result_->mapping ? &result_->mapping->partition->faceParent : nullptr;
    const Scene* scene = result_ ? result_->scene.get() : nullptr;
    for (int f = 0; f < F; ++f) {
      int input = parent && f < static_cast<int>(parent->size()) ? (*parent)[f] : f;
      if (parent && scene && scene->welded()) input = scene->mesh->faceOrigin[input];  // the loaded mesh's face
      if (cloneFaces_.count(input)) face[f] = Vec4f(0.2f, 0.9f, 0.9f, 0.45f);
    }
  }
  std::vector<float> data;
  data.reserve(size_t(F) * 12);
  for (int i = 0; i < F; ++i) {
    const Vec4f& c = face[gpuFaceOrder_[i]];
    for (int k = 0; k < 3; ++k) data.insert(data.end(), {c[0], c[1], c[2], c[3]});
  }
  meshVbo_->uploadSeparate(4, 4, data);
}

void Editor::uploadLines() {
  ++uploadCount_;
  linesDirty_ = false;
  linesRevision_ = doc_.revision();
  std::vector<float> lines;
  if (!input_.mesh) return;
  // Partition paths (on the partition's mesh, whose first vertices are the input's).
  pathLineVertices_ = 0;
  if (resultUsable() && result_->mapping) {
    const Partition& part = *result_->mapping->partition;
    for (const MeshPath& path : part.paths) {
      const Vec4f color = path.fromChain ? Vec4f(1.0f, 0.55f, 0.1f, 1) : Vec4f(1.0f, 0.92f, 0.25f, 1);
      for (size_t i = 0; i + 1 < path.vertices.size(); ++i) {
        pushVertex(lines, part.mesh.position(path.vertices[i]), color);
        pushVertex(lines, part.mesh.position(path.vertices[i + 1]), color);
      }
    }
    pathLineVertices_ = static_cast<int>(lines.size() / 7);
  }
  // Strokes of the document, and the one being drawn.
  auto addStroke = [&](const std::vector<int>& vertices, const Vec4f& color) {
    for (size_t i = 0; i + 1 < vertices.size(); ++i) {
      if (vertices[i] >= input_.mesh->numVertices() || vertices[i + 1] >= input_.mesh->numVertices()) continue;
      pushVertex(lines, input_.mesh->position(vertices[i]), color);
      pushVertex(lines, input_.mesh->position(vertices[i + 1]), color);
    }
  };
  for (const Stroke& s : doc_.project().strokes) addStroke(s.vertices, Vec4f(0.2f, 0.85f, 1.0f, 1));
  addStroke(stroke_, Vec4f(0.6f, 1.0f, 1.0f, 1));
  appendCoverageLines(lines);
  lineVertices_ = static_cast<int>(lines.size() / 7);
  lineVbo_->upload(lines, {{0, 3}, {1, 4}});

  // Feature points: green when in two or more photos (they can pair), white otherwise.
  std::vector<float> points;
  for (const FeaturePoint& pt : doc_.project().points) {
    if (pt.vertex < 0 || pt.vertex >= input_.mesh->numVertices()) continue;
    pushVertex(points, input_.mesh->position(pt.vertex),
               pt.at.size() >= 2 ? Vec4f(0.3f, 0.95f, 0.4f, 1) : Vec4f(0.95f, 0.95f, 0.95f, 1));
  }
  pointVertices_ = static_cast<int>(points.size() / 7);
  pointVbo_->upload(points, {{0, 3}, {1, 4}});
}

CloneOp Editor::currentCloneOp() const {
  CloneOp op;
  op.photo = clonePhoto_;
  op.polygon = clonePolygon_;
  op.targetFaces.assign(cloneFaces_.begin(), cloneFaces_.end());
  Vec2 c = Vec2::Zero();
  for (const Vec2& q : clonePolygon_) c += q;
  op.anchor = c / double(clonePolygon_.size());  // the polygon's centre lands on the anchor vertex
  op.anchorVertex = cloneAnchorVertex_;
  op.pixelsPerUnit = clonePixelsPerUnit_;
  op.rotationDeg = cloneRotationDeg_;
  return op;
}

void Editor::updateClonePreview() {
  ++uploadCount_;
  cloneDirty_ = false;
  cloneVertices_ = 0;
  if (!input_.mesh || !clonePolygonClosed_ || cloneFaces_.empty() || clonePhoto_ < 0 ||
      clonePhoto_ >= static_cast<int>(photos_.size()) || !photos_[clonePhoto_].photo)
    return;
  const CloneOp op = currentCloneOp();
  // The paper's quick preview: the photo projected onto the target (the same map the clone's Poisson
  // solve uses), without the solve. An impossible clone (anchor off the target...) shows nothing.
  CloneProjection preview;
  try {
    preview = projectClone(*input_.mesh, {}, op, "clone");
  } catch (const Error&) {
    return;
  }
  const Photo& photo = *photos_[clonePhoto_].photo;
  std::vector<float> data;
  for (size_t i = 0; i < preview.faces.size(); ++i) {
    const auto corners = input_.mesh->faceVertices(preview.faces[i]);
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = input_.mesh->position(corners[k]);
      const Vec2& uv = preview.cornerPixel[i][k];
      data.insert(data.end(), {float(p.x()), float(p.y()), float(p.z()), float(uv.x() / photo.width),
                               float(uv.y() / photo.height), insidePolygon(clonePolygon_, uv) ? 1.0f : 0.0f});
    }
  }
  cloneVertices_ = static_cast<int>(data.size() / 6);
  cloneVbo_->upload(data, {{0, 3}, {1, 2}, {2, 1}});
}

void Editor::renderScene() {
  if (!input_.mesh || viewRect_.w < 2 || viewRect_.h < 2) return;
  const void* wanted =
      resultUsable() ? static_cast<const void*>(shownModel()) : static_cast<const void*>(input_.mesh.get());
  if (meshDirty_ || wanted != uploadedModel_) uploadMesh();
  if (overlayDirty_) uploadOverlay();
  if (linesDirty_ || linesRevision_ != doc_.revision()) uploadLines();
  if (cloneDirty_) updateClonePreview();

  // Redraw only when something the picture depends on changed: an idle editor, or one waiting for
  // the worker, spends its frames on the panels only.
  const Vec3 eye = camera_.eye();
  char key[512];
  std::snprintf(key, sizeof(key),
                "%.17g %.17g %.17g %.17g %.17g %.17g %.17g %d %d %p %ld %ld %d%d%d%d%d %d %d %d %zu %d", eye.x(),
                eye.y(), eye.z(), camera_.target.x(), camera_.target.y(), camera_.target.z(), camera_.fovYDeg,
                viewFbo_->width(), viewFbo_->height(), uploadedModel_, linesRevision_, uploadCount_, textured_,
                wireframe_, showPaths_, showFeatures_ * 2 + showIds_, int(coloring_), selectedVertex_, hoverVertex_,
                cloneVertices_, stroke_.size(), int(cloneFaces_.size()));
  if (sceneKey_ == key) return;
  sceneKey_ = key;
  if (viewDivisor_ > 1) {
    ++reducedRedraws_;
    reducedSize_[0] = viewFbo_->width();
    reducedSize_[1] = viewFbo_->height();
  } else {
    ++fullRedraws_;
  }

  viewFbo_->bind();
  glClearColor(0.17f, 0.18f, 0.20f, 1);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDisable(GL_CULL_FACE);
  glDisable(GL_BLEND);
  const Camera cam = viewCamera();
  const Mat4f view = glViewMatrix(cam);
  const Mat4f mvp = multiply(glProjectionMatrix(cam, camera_.nearPlane(), camera_.farPlane()), view);

  meshShader_->use();
  glUniformMatrix4fv(meshShader_->uniform("uMvp"), 1, GL_FALSE, mvp.data());
  glUniformMatrix4fv(meshShader_->uniform("uView"), 1, GL_FALSE, view.data());
  glUniform1i(meshShader_->uniform("uTexture"), 0);
  glUniform1i(meshShader_->uniform("uWireframe"), wireframe_ ? 1 : 0);
  glUniform1f(meshShader_->uniform("uOverlayWeight"), 1.0f);
  const TexturedModel* model = shownModel();
  glActiveTexture(GL_TEXTURE0);
  for (const auto& [material, range] : materialRanges_) {
    GLuint texture = 0;
    Vec3f base(0.72f, 0.72f, 0.72f);
    ColorTransform transform;
    if (model && material >= 0 && material < static_cast<int>(model->materials.size())) {
      if (material < static_cast<int>(materialTextureIds_.size())) texture = materialTextureIds_[material];
      base = model->materials[material].diffuse;
      transform = model->materials[material].transform;
    }
    const bool textured = textured_ && texture != 0;
    glUniform1i(meshShader_->uniform("uTextured"), textured ? 1 : 0);
    glUniform1f(meshShader_->uniform("uCornerColorWeight"), textured_ ? 1.0f : 0.0f);
    if (!textured_) base = Vec3f(0.72f, 0.72f, 0.72f);
    glUniform3f(meshShader_->uniform("uBaseColor"), base.x(), base.y(), base.z());
    glUniform3f(meshShader_->uniform("uGain"), transform.gain.x(), transform.gain.y(), transform.gain.z());
    glUniform3f(meshShader_->uniform("uOffset"), transform.offset.x(), transform.offset.y(), transform.offset.z());
    glUniform1i(meshShader_->uniform("uLinearGain"), transform.linear ? 1 : 0);
    glBindTexture(GL_TEXTURE_2D, texture);
    meshVbo_->draw(GL_TRIANGLES, range.first, range.second);
  }

  if (cloneVertices_ > 0 && clonePhoto_ >= 0 && clonePhoto_ < static_cast<int>(photos_.size()) &&
      photos_[clonePhoto_].texture) {
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    textureShader_->use();
    glUniformMatrix4fv(textureShader_->uniform("uMvp"), 1, GL_FALSE, mvp.data());
    glUniform1i(textureShader_->uniform("uTexture"), 0);
    glBindTexture(GL_TEXTURE_2D, photos_[clonePhoto_].texture->id());
    cloneVbo_->draw(GL_TRIANGLES, 0, cloneVertices_);
    glDisable(GL_BLEND);
  }

  const Mat4f projection = glProjectionMatrix(cam, camera_.nearPlane(), camera_.farPlane());
  readViewDepth(view, projection);  // before the lines and markers write depth
  lineShader_->use();
  glUniformMatrix4fv(lineShader_->uniform("uMvp"), 1, GL_FALSE, mvp.data());
  glUniform1i(lineShader_->uniform("uRoundPoints"), 0);
  if (showPaths_) lineVbo_->draw(GL_LINES, 0, pathLineVertices_);
  lineVbo_->draw(GL_LINES, pathLineVertices_, lineVertices_ - pathLineVertices_);
  drawMarkers(view, projection);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void Editor::drawViewLabels(const Rect& r) {
  ImDrawList* draw = ImGui::GetWindowDrawList();
  const Camera cam = viewCamera();
  const Project& p = doc_.project();
  drawFeatureLabels(r, cam);
  // Stroke directions: an arrowhead at the end of each stroke.
  draw->PushClipRect(ImVec2(float(r.x), float(r.y)), ImVec2(float(r.x + r.w), float(r.y + r.h)), true);
  for (const Stroke& s : p.strokes) {
    if (s.vertices.size() < 2) continue;
    const int a = s.vertices[s.vertices.size() - 2], b = s.vertices.back();
    if (a >= input_.mesh->numVertices() || b >= input_.mesh->numVertices()) continue;
    Vec2 pa, pb;
    if (!cam.project(input_.mesh->position(a), pa) || !cam.project(input_.mesh->position(b), pb)) continue;
    Vec2 d = pb - pa;
    if (d.norm() < 1e-6) continue;
    d.normalize();
    const Vec2 n(-d.y(), d.x());
    const Vec2 tip = pb + 6 * d, l = pb - 6 * d + 5 * n, rr = pb - 6 * d - 5 * n;
    draw->AddTriangleFilled(ImVec2(float(r.x + tip.x()), float(r.y + tip.y())),
                            ImVec2(float(r.x + l.x()), float(r.y + l.y())),
                            ImVec2(float(r.x + rr.x()), float(r.y + rr.y())), IM_COL32(50, 215, 255, 255));
  }
  draw->PopClipRect();
  // What the view shows, so the user knows whether the preview is current.
  const bool busy = worker_->status().busy;
  const char* what = nullptr;
  if (!resultUsable())
    what = busy ? "input mesh - pipeline running" : "input mesh - no result";
  else if (!resultCurrent())
    what = busy ? "result of an earlier edit - updating" : "result of an earlier edit";
  else if (result_->model)
    what = "result - up to date";
  else if (result_->tier == Tier::Quick)  // holes filled smoothly; the preview with their own fills follows
    what = busy ? "quick preview - holes smooth, their texture coming" : "quick preview - holes smooth";
  else
    what = busy ? "preview - up to date, final bake running" : "preview - up to date";
  // Wrapped within the view when it is narrow.
  const float wrap = std::max(40.0f, float(r.w) - px(16));
  const ImVec2 size = ImGui::CalcTextSize(what, nullptr, false, wrap);
  draw->AddRectFilled(ImVec2(float(r.x), float(r.y)),
                      ImVec2(float(r.x + size.x + px(16)), float(r.y + size.y + px(10))), IM_COL32(0, 0, 0, 140));
  draw->AddText(ImGui::GetFont(), ImGui::GetFontSize(), ImVec2(float(r.x + px(8)), float(r.y + px(5))),
                IM_COL32(210, 210, 210, 255), what, nullptr, wrap);
}

}  // namespace montage
