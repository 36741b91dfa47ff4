#version 330 core
// The 3D view's mesh: one vertex per face corner, so that faces can carry their own UVs, material
// and overlay colour. Positions are in model units; uMvp = projection * view.
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in vec2 aUv;
layout(location = 3) in vec3 aBary;     // (1,0,0), (0,1,0), (0,0,1) at the three corners: wireframe
layout(location = 4) in vec4 aOverlay;  // per-face overlay colour, alpha = blend weight
layout(location = 5) in vec3 aColor;    // added to the texture or base colour (the preview's seam levelling
                                        // offsets and inpainted colours; 0 for baked models)

uniform mat4 uMvp;
uniform mat4 uView;

out vec3 vNormalEye;
out vec3 vPositionEye;
out vec2 vUv;
out vec3 vBary;
out vec4 vOverlay;
out vec3 vColor;

void main() {
  gl_Position = uMvp * vec4(aPosition, 1.0);
  vPositionEye = (uView * vec4(aPosition, 1.0)).xyz;
  vNormalEye = mat3(uView) * aNormal;
  vUv = aUv;
  vBary = aBary;
  vOverlay = aOverlay;
  vColor = aColor;
}
