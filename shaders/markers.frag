#version 330 core
// A round marker with a dark rim (readable on any texture).
in vec4 vColor;
uniform float uPointSize;
uniform float uPixelScale;  // framebuffer pixels per view pixel (below 1 while navigating at reduced size)
out vec4 fragColor;
void main() {
  vec2 p = gl_PointCoord * 2.0 - 1.0;
  float r = length(p);
  if (r > 1.0) discard;
  float rim = 1.0 - 2.5 * uPixelScale / max(uPointSize, 3.0 * uPixelScale);
  fragColor = r > rim ? vec4(0.0, 0.0, 0.0, 0.85) : vColor;
}
