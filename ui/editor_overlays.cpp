// Overlays at interactive frame rates: the 3D view's feature markers (depth-offset point sprites, the
// hover and selection respecting depth), id labels only where they do not overlap (plus the hover and
// the selection) with visibility from the depth buffer instead of a ray cast per feature and frame,
// and the photo panes' markers, curves and rejected pairs from vertex buffers drawn through an ImGui
// callback, rebuilt only when the document, the result, the selection or the hovered point changes.
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <algorithm>
#include <cmath>

#include "editor.h"
#include "gl.h"
#include "gl_util.h"
#include "mapping/camera.h"
#include "overlay_buffers.h"
#include "overlay_gl.h"

namespace montage {

namespace {

Vec4f mul4(const Mat4f& m, const Vec4f& v) {
  Vec4f out;
  for (int r = 0; r < 4; ++r) out[r] = m[r] * v[0] + m[4 + r] * v[1] + m[8 + r] * v[2] + m[12 + r] * v[3];
  return out;
}

constexpr float kMarkerSize = 8.0f, kHighlightSize = 13.0f;

// The shader's offset (markers.vert), for the depth test of labels.
Vec4f markerEye(const Mat4f& view, const Vec3& p, float size, float pixelAngle) {
  Vec4f eye = mul4(view, Vec4f(float(p.x()), float(p.y()), float(p.z()), 1));
  const float offset = size * pixelAngle * std::max(-eye.z(), 0.0f);
  const float d = eye.head<3>().norm();
  eye.head<3>() *= std::max(0.0f, 1.0f - offset / std::max(d, 1e-9f));
  return eye;
}

void paneCallback(const ImDrawList*, const ImDrawCmd* cmd) {
  const auto* d = static_cast<const OverlayGl::PaneDraw*>(cmd->UserCallbackData);
  const auto it = d->gl->panes.find(d->photo);
  if (it == d->gl->panes.end() || !it->second.vbo) return;
  const OverlayGl::Pane& pane = it->second;
  const ImDrawData* data = d->gl->target ? d->gl->target : ImGui::GetDrawData();
  const ImVec2 pos = data->DisplayPos, size = data->DisplaySize, scale = data->FramebufferScale;
  const float fbHeight = size.y * scale.y;
  const ImVec4 c = cmd->ClipRect;
  glEnable(GL_SCISSOR_TEST);
  glScissor(int((c.x - pos.x) * scale.x), int(fbHeight - (c.w - pos.y) * scale.y), int((c.z - c.x) * scale.x),
            int((c.w - c.y) * scale.y));
  glEnable(GL_PROGRAM_POINT_SIZE);
  const ShaderProgram& s = *d->gl->paneShader;
  s.use();
  glUniform2f(s.uniform("uOrigin"), d->originX, d->originY);
  glUniform1f(s.uniform("uZoom"), d->zoom);
  glUniform2f(s.uniform("uDisplayPos"), pos.x, pos.y);
  glUniform2f(s.uniform("uDisplaySize"), size.x, size.y);
  glUniform1i(s.uniform("uPoints"), 0);
  glUniform1f(s.uniform("uScale"), d->scale);
  if (d->camera) {
    if (pane.cameraVbo) pane.cameraVbo->draw(GL_LINES, 0, 2 * (pane.wire + pane.silhouette));
    return;
  }
  pane.vbo->draw(GL_LINES, 0, pane.lines);
  glUniform1i(s.uniform("uPoints"), 1);
  pane.vbo->draw(GL_POINTS, pane.lines, pane.points);
}

// Appends `segments` as solid GL_LINES vertices (kPaneVertexFloats each) of colour `rgba`.
void appendSegments(std::vector<float>& data, const std::vector<std::pair<Vec2, Vec2>>& segments, const Vec4f& rgba) {
  for (const auto& [a, b] : segments)
    for (const Vec2& q : {a, b})
      data.insert(data.end(), {float(q.x()), float(q.y()), rgba[0], rgba[1], rgba[2], rgba[3], -1.0f});
}

}  // namespace

void Editor::initOverlays() {
  overlayGl_ = std::make_unique<OverlayGl>();
  overlayGl_->markerShader = std::make_unique<ShaderProgram>("markers.vert", "markers.frag");
  overlayGl_->paneShader = std::make_unique<ShaderProgram>("pane.vert", "pane.frag");
  overlayGl_->highlightVbo = std::make_unique<VertexBuffer>();
}

void Editor::drawPaneOverlay(int photo, const PaneView& view, int focusPoint) {
  updatePaneOverlay(photo, focusPoint);
  addPaneDraw(ImGui::GetWindowDrawList(), photo, view, false);
}

void Editor::addPaneDraw(ImDrawList* draw, int photo, const PaneView& view, bool camera) {
  OverlayGl& gl = *overlayGl_;
  OverlayGl::PaneDraw d{&gl, photo, float(view.origin.x()), float(view.origin.y()), float(view.zoom), scale_};
  d.camera = camera;
  gl.draws.push_back(d);
  draw->AddCallback(paneCallback, &gl.draws.back());
  draw->AddCallback(ImDrawCallback_ResetRenderState, nullptr);
}

void Editor::updatePaneOverlay(int photo, int focusPoint) {
  OverlayGl& gl = *overlayGl_;
  const Partition* part = resultUsable() && result_->mapping ? result_->mapping->partition.get() : nullptr;
  PaneOverlayOptions o;
  o.curves = showCurves_;
  o.rejected = showRejected_;
  o.features = true;
  o.selectedPoint = selectedPoint_;
  o.focusPoint = focusPoint;
  OverlayGl::Pane& pane = gl.panes[photo];
  // The selection and the hovered point only matter when not every rejected pair is drawn.
  const bool focusMatters = o.rejected && !pane.allRejectedDrawn;
  char key[256];
  std::snprintf(key, sizeof(key), "%ld %p %ld %d%d %d %d", doc_.revision(), static_cast<const void*>(part),
                resultGeneration_, o.curves, o.rejected, focusMatters ? o.selectedPoint : -2,
                focusMatters ? o.focusPoint : -2);
  if (pane.key != key || !pane.vbo) {
    const PaneOverlay geometry = buildPaneOverlay(doc_.project(), part, photo, o);
    std::vector<float> data = geometry.lines;
    data.insert(data.end(), geometry.points.begin(), geometry.points.end());
    if (!pane.vbo) pane.vbo = std::make_unique<VertexBuffer>();
    pane.vbo->upload(data, {{0, 2}, {1, 4}, {2, 1}});
    pane.lines = static_cast<int>(geometry.lines.size() / kPaneVertexFloats);
    pane.points = static_cast<int>(geometry.points.size() / kPaneVertexFloats);
    pane.rejectedInPhoto = geometry.rejectedInPhoto;
    const bool wasAll = pane.allRejectedDrawn;
    pane.allRejectedDrawn = geometry.allRejectedDrawn;
    // The key depends on whether every pair is drawn: recompute it once that is known.
    pane.key = wasAll == pane.allRejectedDrawn ? std::string(key) : std::string();
    ++gl.paneBuilds;
  }
}

void Editor::drawCameraWire(int photo, const PaneView& view) {
  if (updateCameraWire(photo)) addPaneDraw(ImGui::GetWindowDrawList(), photo, view, true);
}

bool Editor::updateCameraWire(int photo) {
  buildCameraLines();
  if (photo < 0 || photo >= static_cast<int>(cameraLines_.size())) return false;
  OverlayGl& gl = *overlayGl_;
  OverlayGl::Pane& pane = gl.panes[photo];
  char key[64];
  std::snprintf(key, sizeof(key), "%p %ld", cameraLinesFor_, resultGeneration_);
  if (pane.cameraKey != key || !pane.cameraVbo) {
    const CameraLines& lines = cameraLines_[photo];
    std::vector<float> data;
    data.reserve((lines.wire.size() + lines.silhouette.size()) * 2 * kPaneVertexFloats);
    appendSegments(data, lines.wire, Vec4f(120.0f, 220.0f, 255.0f, 45.0f) / 255.0f);
    appendSegments(data, lines.silhouette, Vec4f(60.0f, 230.0f, 255.0f, 220.0f) / 255.0f);
    if (!pane.cameraVbo) pane.cameraVbo = std::make_unique<VertexBuffer>();
    pane.cameraVbo->upload(data, {{0, 2}, {1, 4}, {2, 1}});
    pane.wire = static_cast<int>(lines.wire.size());
    pane.silhouette = static_cast<int>(lines.silhouette.size());
    pane.cameraKey = key;
    ++gl.cameraBuilds;
  }
  return pane.wire + pane.silhouette > 0;
}

void Editor::drawPaneCached(int photo, const Rect& r, const PaneView& view, unsigned photoTexture, unsigned maskTexture,
                            const std::string& content, int focusPoint) {
  OverlayGl& gl = *overlayGl_;
  updatePaneOverlay(photo, focusPoint);
  const CameraFit* fit = showCamera_ ? photoFit(photo) : nullptr;
  const bool wire = fit && fit->fits && updateCameraWire(photo);
  OverlayGl::Pane& pane = gl.panes[photo];
  const ImVec2 fbScale = ImGui::GetIO().DisplayFramebufferScale;
  const int w = std::max(1, int(std::lround(r.w * fbScale.x))), h = std::max(1, int(std::lround(r.h * fbScale.y)));
  const ImVec2 lo(float(r.x), float(r.y)), hi(float(r.x + r.w), float(r.y + r.h));
  char head[256];
  std::snprintf(head, sizeof(head), "%u %u %.9g %.9g %.17g %.17g %.17g %d %d %g %d|", photoTexture, maskTexture, r.x,
                r.y, view.origin.x(), view.origin.y(), view.zoom, w, h, scale_, wire);
  const std::string key = head + content + "|" + pane.key + "|" + (wire ? pane.cameraKey : std::string());
  if (!pane.cache) pane.cache = std::make_unique<Framebuffer>();
  if (pane.cacheKey != key || pane.cache->width() != w || pane.cache->height() != h) {
    pane.cache->resize(w, h);
    if (!gl.cacheList) gl.cacheList = std::make_unique<ImDrawList>(ImGui::GetDrawListSharedData());
    ImDrawList& list = *gl.cacheList;
    list._ResetForNewFrame();
    list.PushTextureID(ImGui::GetIO().Fonts->TexID);
    list.PushClipRect(lo, hi);
    list.AddRectFilled(lo, hi, IM_COL32(28, 29, 32, 255));
    const ImVec2 p0(float(view.toScreen(Vec2(0, 0)).x()), float(view.toScreen(Vec2(0, 0)).y()));
    const Photo& ph = *photos_[photo].photo;
    const Vec2 q1 = view.toScreen(Vec2(ph.width, ph.height));
    const ImVec2 p1(float(q1.x()), float(q1.y()));
    list.AddImage(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(photoTexture)), p0, p1);
    if (maskTexture) list.AddImage(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(maskTexture)), p0, p1);
    // Drawn synchronously below: the callbacks' data may live on the stack.
    OverlayGl::PaneDraw d{&gl, photo, float(view.origin.x()), float(view.origin.y()), float(view.zoom), scale_};
    OverlayGl::PaneDraw camera = d;
    camera.camera = true;
    list.AddCallback(paneCallback, &d);
    list.AddCallback(ImDrawCallback_ResetRenderState, nullptr);
    if (wire) {
      list.AddCallback(paneCallback, &camera);
      list.AddCallback(ImDrawCallback_ResetRenderState, nullptr);
    }
    list.PopClipRect();
    list.PopTextureID();
    ImDrawList* lists[] = {&list};
    ImDrawData data;
    data.Valid = true;
    data.CmdLists = lists;
    data.CmdListsCount = 1;
    data.TotalVtxCount = list.VtxBuffer.Size;
    data.TotalIdxCount = list.IdxBuffer.Size;
    data.DisplayPos = lo;
    data.DisplaySize = ImVec2(float(r.w), float(r.h));
    data.FramebufferScale = fbScale;
    pane.cache->bind();
    gl.target = &data;
    ImGui_ImplOpenGL3_RenderDrawData(&data);
    gl.target = nullptr;
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    pane.cacheKey = key;
    ++gl.cacheRenders;
  }
  // GL's rows run bottom-up: flip v.
  ImGui::GetWindowDrawList()->AddImage(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(pane.cache->colorTexture())),
                                       lo, hi, ImVec2(0, 1), ImVec2(1, 0));
}

int Editor::paneRejectedCount(int photo, bool* all) const {
  const auto it = overlayGl_->panes.find(photo);
  if (it == overlayGl_->panes.end()) return 0;
  if (all) *all = it->second.allRejectedDrawn;
  return it->second.rejectedInPhoto;
}

void Editor::readViewDepth(const Mat4f& view, const Mat4f& projection) {
  OverlayGl& gl = *overlayGl_;
  const Project& p = doc_.project();
  featureVisible_.assign(p.points.size(), 0);
  if (!showFeatures_ || !showIds_ || p.points.empty()) return;
  const int W = viewFbo_->width(), H = viewFbo_->height();
  gl.depth.resize(size_t(W) * H);
  gl.depthWidth = W;
  gl.depthHeight = H;
  glReadPixels(0, 0, W, H, GL_DEPTH_COMPONENT, GL_FLOAT, gl.depth.data());
  const Camera cam = viewCamera();
  const float pixelAngle = float(1.0 / cam.fy);
  for (size_t i = 0; i < p.points.size(); ++i) {
    const int v = p.points[i].vertex;
    if (v < 0 || v >= input_.mesh->numVertices()) continue;
    const Vec4f clip = mul4(projection, markerEye(view, input_.mesh->position(v), px(kMarkerSize), pixelAngle));
    if (clip.w() <= 0) continue;
    const Vec3f ndc = clip.head<3>() / clip.w();
    const int x = int(std::floor((ndc.x() * 0.5f + 0.5f) * W)), y = int(std::floor((ndc.y() * 0.5f + 0.5f) * H));
    if (x < 0 || y < 0 || x >= W || y >= H) continue;
    featureVisible_[i] = ndc.z() * 0.5f + 0.5f <= gl.depth[size_t(y) * W + x] + 1e-6f;
  }
}

void Editor::drawMarkers(const Mat4f& view, const Mat4f& projection) {
  if (!input_.mesh) return;
  const ShaderProgram& s = *overlayGl_->markerShader;
  const Camera cam = viewCamera();
  // Sizes in the framebuffer's pixels: smaller while it is reduced (navigating), so that the markers
  // keep their size on screen; the offset towards the camera (size times pixel angle) is unchanged.
  const float fbScale = float(viewFbo_->width() / std::max(1.0, viewRect_.w));
  s.use();
  glUniformMatrix4fv(s.uniform("uView"), 1, GL_FALSE, view.data());
  glUniformMatrix4fv(s.uniform("uProjection"), 1, GL_FALSE, projection.data());
  glUniform1f(s.uniform("uPixelAngle"), float(1.0 / cam.fy) / fbScale);
  glUniform1f(s.uniform("uPixelWorld"), 0.0f);
  glUniform1f(s.uniform("uPixelScale"), fbScale);
  glEnable(GL_PROGRAM_POINT_SIZE);
  if (showFeatures_) {
    glUniform1f(s.uniform("uPointSize"), px(kMarkerSize) * fbScale);
    pointVbo_->draw(GL_POINTS, 0, pointVertices_);
  }
  // The hovered and the selected vertex: bigger markers, depth-tested like the others (a vertex
  // behind the surface is not shown through it).
  std::vector<float> data;
  data.reserve(2 * 7);
  auto add = [&](int v, const Vec4f& c) {
    if (v < 0 || v >= input_.mesh->numVertices()) return;
    const Vec3 q = input_.mesh->position(v);
    data.insert(data.end(), {float(q.x()), float(q.y()), float(q.z()), c[0], c[1], c[2], c[3]});
  };
  add(hoverVertex_, Vec4f(1.0f, 1.0f, 1.0f, 1));
  add(selectedVertex_, Vec4f(1.0f, 0.45f, 0.05f, 1));
  if (data.empty()) return;
  overlayGl_->highlightVbo->upload(data, {{0, 3}, {1, 4}});
  glUniform1f(s.uniform("uPointSize"), px(kHighlightSize) * fbScale);
  overlayGl_->highlightVbo->draw(GL_POINTS, 0, static_cast<int>(data.size() / 7));
}

void Editor::drawFeatureLabels(const Rect& r, const Camera& cam) {
  const Project& p = doc_.project();
  drawnLabels_.clear();
  if (!showFeatures_ || !showIds_ || !input_.mesh) return;
  ImDrawList* draw = ImGui::GetWindowDrawList();
  std::vector<LabelCandidate> labels;
  std::vector<int> point;
  std::vector<Vec2> anchor;
  for (size_t i = 0; i < p.points.size() && i < featureVisible_.size(); ++i) {
    const int v = p.points[i].vertex;
    // The selected and the hovered point are labelled even where labels crowd, but like every label only
    // where the point is in sight: a point behind the surface has no label drawn through it.
    const bool always = int(i) == selectedPoint_ || (v >= 0 && v == hoverVertex_);
    if (!featureVisible_[i]) continue;
    if (v < 0 || v >= input_.mesh->numVertices()) continue;
    Vec2 px;
    if (!cam.project(input_.mesh->position(v), px)) continue;
    const std::string id = pointName(int(i));
    const ImVec2 size = ImGui::CalcTextSize(id.c_str());
    LabelCandidate l;
    l.lo = Vec2(r.x + px.x() + this->px(5), r.y + px.y() - this->px(15));
    l.size = Vec2(size.x + 1, size.y);
    l.always = always;
    labels.push_back(l);
    point.push_back(static_cast<int>(i));
  }
  draw->PushClipRect(ImVec2(float(r.x), float(r.y)), ImVec2(float(r.x + r.w), float(r.y + r.h)), true);
  for (int k : placeLabels(labels)) {
    const int i = point[k];
    const std::string id = pointName(i);
    drawnLabels_.push_back(pointId(p, i));
    const ImVec2 at(float(labels[k].lo.x()), float(labels[k].lo.y()));
    draw->AddText(ImVec2(at.x + 1, at.y + 1), IM_COL32(0, 0, 0, 200), id.c_str());
    draw->AddText(at,
                  i == selectedPoint_                  ? IM_COL32(255, 150, 40, 255)
                  : p.points[i].vertex == hoverVertex_ ? IM_COL32(255, 255, 120, 255)
                                                       : IM_COL32(255, 255, 255, 230),
                  id.c_str());
  }
  draw->PopClipRect();
}

}  // namespace montage
