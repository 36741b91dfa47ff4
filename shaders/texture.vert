#version 330 core
// The clone tool's projected preview: target faces textured from the source photo with the
// preview's UVs; corners outside the source polygon fade out.
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec2 aUv;
layout(location = 2) in float aInside;
uniform mat4 uMvp;
out vec2 vUv;
out float vInside;
void main() {
  gl_Position = uMvp * vec4(aPosition, 1.0);
  gl_Position.z -= 0.0003 * gl_Position.w;
  vUv = aUv;
  vInside = aInside;
}
