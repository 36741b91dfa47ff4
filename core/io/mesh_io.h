// Mesh files: our own OBJ, PLY, OFF and STL parsers (Assimp's for FBX, Collada, 3DS, 3MF) into a triangle soup, then
// buildMesh (geometry/mesh.h) with its validation report; and a plain OBJ writer.
#pragma once

#include <string>
#include <vector>

#include "geometry/mesh.h"
#include "io/mesh_io.h"

namespace montage {

// The mesh formats loadMesh reads, as lowerExtension gives them (".obj"...), and as a list for messages
// (".obj .ply ... .3mf" with the default separator).
const std::vector<std::string>& meshExtensions();
bool isMeshExtension(const std::string& ext);
bool isAssimpExtension(const std::string& ext);  // ".fbx", ".dae", ".3ds", ".3mf": read through Assimp
std::string meshExtensionList(const char* separator = " ");

// Reads OBJ, PLY (ascii, binary), OFF or STL (ascii, binary) with our own parsers, FBX, Collada (.dae), 3DS and
// 3MF through Assimp, by extension; glTF (.glb, .gltf) through loadGltfMesh (io/model.h). An Assimp scene with
// skins, morph targets, a second UV set or vertex colours is read in glTF form (io/assimp_gltf.h), so that the GLB
// export can carry them.
// Polygons are fan triangulated. Faces that cannot enter a manifold half-edge mesh are dropped and reported one by
// one. Throws montage::Error naming the file, line and reason when the file cannot be read or parsed.
// A mesh that parses but cannot be processed (no faces, non-finite coordinates) comes back with
// Error findings; use requireUsable() where processing must not go on.
LoadedMesh loadMesh(const std::string& path, const MeshLoadOptions& options = {});
// The same from the bytes of a file already in memory: `format` is "obj", "ply", "off", "stl", "fbx", "dae",
// "3ds" or "3mf",
// `name` names the source in messages (the fuzz targets use it).
LoadedMesh parseMesh(const std::string& bytes, const std::string& format, const std::string& name,
                     const MeshLoadOptions& options = {});

// Writes positions and faces (and UVs, if any) as OBJ. Throws montage::Error on I/O failure.
void saveMeshObj(const Mesh& mesh, const std::string& path);

// A file's normal at a corner of face f as Mesh::cornerNormal keeps it (the exports write it, so it must be a
// direction): `normal` (unit length) when it has one, else the face's normal, else +z (a degenerate face).
Vec3f usableNormal(const Mesh& mesh, int f, const Vec3& normal);

}  // namespace montage
