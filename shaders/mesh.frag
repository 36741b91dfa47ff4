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
// The material's transform of its texture (the preview's colour balance of a photo: Material::transform),
// in linear light when uLinearGain.
uniform vec3 uGain;
uniform vec3 uOffset;
uniform bool uLinearGain;

out vec4 fragColor;

vec3 srgbToLinear(vec3 c) {
  return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(vec3(0.04045), c));
}
vec3 linearToSrgb(vec3 l) {
  return mix(l * 12.92, 1.055 * pow(l, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), l));
}

vec3 textureColor() {
  vec3 c = texture(uTexture, vUv).rgb;
  if (uGain == vec3(1.0) && uOffset == vec3(0.0)) return c;
  if (!uLinearGain) return clamp(uGain * c + uOffset, 0.0, 1.0);
  return linearToSrgb(clamp(uGain * srgbToLinear(c) + uOffset, 0.0, 1.0));
}

void main() {
  vec3 base = clamp((uTextured ? textureColor() : uBaseColor) + uCornerColorWeight * vColor, 0.0, 1.0);
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
