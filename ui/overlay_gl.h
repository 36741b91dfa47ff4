// GL state of the editor's overlays (editor_overlays.cpp): the 3D view's marker shader and the depth
// it read back after drawing the mesh, and per photo pane a vertex buffer of its markers, curves and
// rejected pairs, rebuilt only when what it shows changes, and one of the camera feedback's wireframe, and
// the pane's cached image. Destroyed with the other GL objects.
#pragma once

#include <deque>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "gl_util.h"

struct ImDrawData;
struct ImDrawList;

namespace montage {

struct OverlayGl {
  std::unique_ptr<ShaderProgram> markerShader, paneShader;
  std::unique_ptr<VertexBuffer> highlightVbo;  // hovered and selected vertex markers
  struct Pane {
    std::unique_ptr<VertexBuffer> vbo;
    std::string key;  // what the buffer holds
    int lines = 0, points = 0;
    int rejectedInPhoto = 0;
    bool allRejectedDrawn = true;
    // The camera feedback's wireframe then silhouette (GL_LINES), rebuilt once per result.
    std::unique_ptr<VertexBuffer> cameraVbo;
    std::string cameraKey;
    int wire = 0, silhouette = 0;
    // The pane's background, photo, mask, the buffer above and the camera lines, rendered into a
    // texture only when one of them (or the pane's zoom, pan or size) changes, and otherwise shown as
    // one textured quad: the 3D view moving does not make llvmpipe redraw them every frame.
    std::unique_ptr<Framebuffer> cache;
    std::string cacheKey;  // what `cache` holds
  };
  std::map<int, Pane> panes;  // by photo
  // One ImGui draw callback per pane drawn this frame (stable addresses until ImGui renders).
  struct PaneDraw {
    OverlayGl* gl = nullptr;
    int photo = -1;
    float originX = 0, originY = 0, zoom = 1;
    float scale = 1;      // UI scale: marker diameters
    bool camera = false;  // the camera feedback's lines instead of the markers, curves and pairs
  };
  std::deque<PaneDraw> draws;
  const ImDrawData* target = nullptr;     // the draw data being rendered into a pane's cache (else ImGui's)
  std::unique_ptr<ImDrawList> cacheList;  // builds the cache's draw data (reused)
  std::vector<float> depth;               // 3D view depth after the mesh (GL rows, bottom-up), for id visibility
  int depthWidth = 0, depthHeight = 0;
  long paneBuilds = 0;    // buffers rebuilt so far (tests: panning rebuilds nothing)
  long cameraBuilds = 0;  // camera wireframe buffers rebuilt so far
  long cacheRenders = 0;  // pane caches rendered so far (tests: the 3D view moving renders none)
};

}  // namespace montage
