// A scene Assimp read (FBX, Collada, 3DS, 3MF) as a GLB document: internal to core/io (mesh_io.cpp converts in the
// reader's child process; the model reader and the write-back export then read the GLB as any other).
#pragma once

#include <string>

struct aiScene;

namespace montage::gltf {

// Whether the scene holds what only its glTF form carries into the export: a mesh with a skin, morph targets, a
// second UV set or vertex colours (the plain reader keeps the first UV set and the normals).
bool assimpSceneNeedsGltf(const aiScene& scene);

// The scene as GLB bytes: its node hierarchy (names, transforms), a mesh per node that shows meshes (a primitive per
// Assimp mesh of triangles: positions, normals, every UV set, vertex colours, the four largest joint weights,
// morph targets as displacements, the material), a skin per skinned node with the bones' offset matrices as its
// inverse bind matrices, materials' names and diffuse colours (not their textures), and node animations. The scene
// is expected triangulated. Throws montage::Error when nothing of it is a triangle or a bone has no node.
std::string assimpSceneAsGlb(const aiScene& scene);

}  // namespace montage::gltf
