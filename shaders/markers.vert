#version 330 core
// Feature markers of the 3D view (round point sprites). Each is moved towards the camera along its
// view ray by its own diameter in world units, so the disc sits on the surface instead of being cut
// by it where the surface curves towards the camera (slopes up to ~60 degrees), while a part of the
// mesh in front of it still hides it. The screen position does not change.
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec4 aColor;
uniform mat4 uView;
uniform mat4 uProjection;
uniform float uPointSize;     // diameter in pixels
uniform float uPixelAngle;    // perspective: world size of one pixel at eye distance 1 (0 when orthographic)
uniform float uPixelWorld;    // orthographic: world size of one pixel (0 when perspective)
out vec4 vColor;
void main() {
  vec4 eye = uView * vec4(aPosition, 1.0);
  float offset = uPointSize * (uPixelAngle * max(-eye.z, 0.0) + uPixelWorld);
  if (uPixelWorld > 0.0) {
    eye.z += offset;
  } else {
    float d = length(eye.xyz);
    eye.xyz *= max(0.0, 1.0 - offset / max(d, 1e-9));
  }
  gl_Position = uProjection * eye;
  gl_PointSize = uPointSize;
  vColor = aColor;
}
