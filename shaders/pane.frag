#version 330 core
in vec4 vColor;
in float vDash;  // screen pixels along a dashed line, -1 solid
uniform bool uPoints;
out vec4 fragColor;
void main() {
  if (uPoints) {
    vec2 p = gl_PointCoord * 2.0 - 1.0;
    float r = length(p);
    if (r > 1.0) discard;
    fragColor = r > 0.68 ? vec4(0.0, 0.0, 0.0, 0.8) : vColor;
    return;
  }
  if (vDash >= 0.0 && mod(vDash, 10.0) > 5.0) discard;
  fragColor = vColor;
}
