#version 330 core
in vec2 vUv;
in float vInside;
uniform sampler2D uTexture;
out vec4 fragColor;
void main() {
  if (vUv.x < 0.0 || vUv.y < 0.0 || vUv.x > 1.0 || vUv.y > 1.0) discard;
  fragColor = vec4(texture(uTexture, vUv).rgb, 0.35 + 0.6 * vInside);
}
