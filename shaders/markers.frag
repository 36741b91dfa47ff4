#version 330 core
// A round marker with a dark rim (readable on any texture).
in vec4 vColor;
uniform float uPointSize;
out vec4 fragColor;
void main() {
  vec2 p = gl_PointCoord * 2.0 - 1.0;
  float r = length(p);
  if (r > 1.0) discard;
  float rim = 1.0 - 2.5 / max(uPointSize, 3.0);
  fragColor = r > rim ? vec4(0.0, 0.0, 0.0, 0.85) : vColor;
}
