// libFuzzer target: the mesh readers (one binary per format, TM_FUZZ_FORMAT = "obj", "ply", "off" or
// "stl") and the mesh building and validation behind them. Only montage::Error may come out; anything
// else (another exception, a sanitizer report, a hang, a crash) is a finding.
#include <cstdint>
#include <string>

#include "geometry/mesh.h"
#include "io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  try {
    montage::LoadedMesh loaded = montage::parseMesh(bytes, TM_FUZZ_FORMAT, "fuzz." TM_FUZZ_FORMAT);
    const std::string summary = loaded.report.summary();
    if (!loaded.mesh) return 0;
    const montage::Mesh& mesh = *loaded.mesh;
    // Invariants every later stage relies on.
    if (mesh.faceOrigin.size() != size_t(mesh.numFaces())) __builtin_trap();
    if (mesh.hasUV() && mesh.cornerUV.size() != size_t(mesh.numFaces())) __builtin_trap();
    for (int f = 0; f < mesh.numFaces(); ++f)
      for (int v : mesh.faceVertices(f))
        if (v < 0 || v >= mesh.numVertices()) __builtin_trap();
    if (loaded.report.usable()) {
      montage::Vec3 lo, hi;
      mesh.bounds(lo, hi);
      if (!(lo.allFinite() && hi.allFinite())) __builtin_trap();  // a usable mesh has finite, bounded coordinates
    }
  } catch (const montage::Error&) {
  }
  return 0;
}
