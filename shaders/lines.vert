#version 330 core
// Lines and points drawn over the mesh in the 3D view: partition paths, strokes, features.
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec4 aColor;
uniform mat4 uMvp;
uniform float uPointSize;
out vec4 vColor;
void main() {
  gl_Position = uMvp * vec4(aPosition, 1.0);
  // Pull towards the camera a little so lines on the surface win the depth test against it.
  gl_Position.z -= 0.0005 * gl_Position.w;
  gl_PointSize = uPointSize;
  vColor = aColor;
}
