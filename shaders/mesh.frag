#version 330 core
// Shading of the 3D view: a head light (ambient + diffuse, both sides lit like `montage render`),
// the face's photo texture when textured plus the corner colours (the preview tier: a photo face's seam
// levelling offset, an inpainted face's colours), an overlay colour blended on top, and a wireframe from the
// barycentric coordinates (constant width in pixels thanks to fwidth).
in vec3 vNormalEye;
in vec3 vPositionEye;
in vec2 vUv;
in vec3 vBary;
in vec4 vOverlay;
in vec3 vColor;

uniform sampler2D uTexture;
uniform bool uTextured;     // sample uTexture (else uBaseColor)
uniform vec3 uBaseColor;    // sRGB, untextured faces
uniform bool uWireframe;
uniform float uOverlayWeight;  // 0 hides the overlay
uniform float uCornerColorWeight;  // 1 adds vColor (the preview's offsets and inpainted colours), 0 not

out vec4 fragColor;

void main() {
  vec3 base = clamp((uTextured ? texture(uTexture, vUv).rgb : uBaseColor) + uCornerColorWeight * vColor, 0.0, 1.0);
  vec3 n = normalize(vNormalEye);
  float lambert = abs(dot(n, normalize(-vPositionEye)));
  // Textures are photos that already hold their lighting: shade them gently so they read true.
  float shade = uTextured ? 0.55 + 0.45 * lambert : 0.35 + 0.65 * lambert;
  vec3 color = base * shade;
  color = mix(color, vOverlay.rgb * (0.6 + 0.4 * lambert), vOverlay.a * uOverlayWeight);
  if (uWireframe) {
    vec3 d = fwidth(vBary);
    vec3 a = smoothstep(vec3(0.0), d * 1.2, vBary);
    float edge = 1.0 - min(min(a.x, a.y), a.z);
    color = mix(color, vec3(0.08, 0.08, 0.1), edge * 0.8);
  }
  fragColor = vec4(color, 1.0);
}
