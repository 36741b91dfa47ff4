// libFuzzer target: the glTF model reader (.glb when the input starts with "glTF", .gltf otherwise),
// with tinygltf behind our own checks (GLB layout, JSON depth, URIs confined to the folder, images
// through our decoder). The scratch folder holds a.bin (64 bytes) and t.png (4x4) for external URIs.
#include <string>

#include "fuzz_support.h"
#include "image/codec.h"
#include "io/model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = [] {
    const std::string d = montage::fuzz::scratch("model_gltf");
    std::string bin;
    for (int i = 0; i < 16; ++i) bin += std::string("\0\0\0\0", 4).replace(0, 1, 1, char(i * 8));
    montage::fuzz::writeFile(d + "/a.bin", bin);
    montage::writePng(d + "/t.png", cv::Mat(4, 4, CV_8UC4, cv::Scalar(1, 2, 3, 255)));
    return d;
  }();
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  const std::string path = dir + (bytes.compare(0, 4, "glTF") == 0 ? "/model.glb" : "/model.gltf");
  montage::fuzz::writeFile(path, bytes);
  try {
    const montage::TexturedModel model = montage::loadModel(path);
    if (model.textured() && model.uv.size() != size_t(model.mesh.numFaces())) __builtin_trap();
    if (!model.faceSource.empty() && model.faceSource.size() != size_t(model.mesh.numFaces())) __builtin_trap();
    if (model.textured() && model.mesh.numFaces() > 0) (void)model.colorAt(0, montage::Vec3(1, 1, 1) / 3);
  } catch (const montage::Error&) {
  }
  return 0;
}
