#version 330 core
// Photo-pane overlays (feature markers, partition curves, rejected pairs) drawn inside ImGui's pass
// from a vertex buffer in photo pixel coordinates: the pane's zoom and pan are uniforms.
layout(location = 0) in vec2 aPhoto;
layout(location = 1) in vec4 aColor;
layout(location = 2) in float aExtra;  // lines: arc length in photo pixels (dashed), -1 solid; points: diameter
uniform vec2 uOrigin;       // screen position of photo point (0, 0), pixels
uniform float uZoom;        // screen pixels per photo pixel
uniform vec2 uDisplayPos;   // ImGui display rectangle (screen pixels)
uniform vec2 uDisplaySize;
uniform bool uPoints;
uniform float uScale;      // UI scale (HiDPI): marker diameters
out vec4 vColor;
out float vDash;
void main() {
  vec2 s = uOrigin + uZoom * aPhoto;
  vec2 ndc = 2.0 * (s - uDisplayPos) / uDisplaySize - 1.0;
  gl_Position = vec4(ndc.x, -ndc.y, 0.0, 1.0);
  gl_PointSize = uPoints ? aExtra * uScale : 1.0;
  vColor = aColor;
  vDash = uPoints || aExtra < 0.0 ? -1.0 : aExtra * uZoom;
}
