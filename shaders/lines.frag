#version 330 core
in vec4 vColor;
uniform bool uRoundPoints;  // discard outside a disc when drawing GL_POINTS
out vec4 fragColor;
void main() {
  if (uRoundPoints) {
    vec2 p = gl_PointCoord * 2.0 - 1.0;
    if (dot(p, p) > 1.0) discard;
  }
  fragColor = vColor;
}
