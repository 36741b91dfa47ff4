// Deformed copies of a mesh for known-truth scenes of another subject (issue 33): photos of the mesh bent,
// twisted, scaled unevenly, with its limbs moved or its head turned, clicked onto the undeformed mesh. The copy
// keeps the topology and the vertex ids, so the true correspondence is the identity on vertices.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "base/common.h"

namespace montage {

struct Mesh;
struct TexturedModel;

enum class DeformKind { None, Bend, Twist, Scale, Limbs, Turn };
inline constexpr std::array<const char*, 6> kDeformKindNames = {"none", "bend", "twist", "scale", "limbs", "turn"};

// A deformation in the mesh's own frame: `a` its bounding box's longest axis, `up` +Y (or, when +Y is the longest
// axis, the box's second-longest), `side` = a x up; u = the coordinate along `a` from the box centre, in [-1, 1].
//   bend:  a circular bend in the (a, up) plane, `amount` x 90 degrees end to end, lengths along `a` kept;
//   twist: a rotation about `a` growing linearly along it, `amount` x 90 degrees end to end;
//   scale: `amount` along `a`, 1/sqrt(amount) across (volume kept); scale:1 is the identity;
//   limbs: both ends beyond |u| = 0.5 rotated about `side` through the plane's centre, `amount` x 35 degrees (both
//          downwards), blended over a band of 0.2 in u (a smoothstep of the angle);
//   turn:  the end beyond u = 0.3 turned about `up` through the plane's centre, `amount` x 40 degrees, blended
//          over a band of 0.2 in u (a head turned).
// `amount` 0 is the identity for every kind but scale.
struct Deformation {
  DeformKind kind = DeformKind::None;
  double amount = 1;
  std::string text() const;  // "KIND:AMOUNT", as parseDeformation reads it
};

// "KIND" or "KIND:AMOUNT" (KIND one of kDeformKindNames; amount default 1.3 for scale, 1 otherwise). Throws
// montage::Error naming the text when the kind is unknown or the amount not a finite number (scale: > 0).
Deformation parseDeformation(const std::string& text);

// The deformed positions, #V, in the mesh's vertex order.
std::vector<Vec3> deformPositions(const Mesh& mesh, const Deformation& deformation);

// A copy of `mesh` (topology, ids, UVs and materials as they are) with its positions replaced; `positions` #V.
std::unique_ptr<Mesh> withPositions(const Mesh& mesh, const std::vector<Vec3>& positions);

// Moves every vertex of `model` that lies on the surface of `photographed` to the same surface point of `rest`
// (the closest point of `photographed`: its face and barycentrics, taken on `rest`). `photographed` and `rest`
// have the same faces (withPositions). The model keeps its UVs, materials and face sources: a texture made on the
// deformed mesh becomes a texture of the undeformed one.
void moveToRest(TexturedModel& model, const Mesh& photographed, const Mesh& rest);

}  // namespace montage
