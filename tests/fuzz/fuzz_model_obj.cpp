// libFuzzer target: the OBJ + MTL model reader (montage eval and render read results this way). The
// input is the OBJ text, then a line "%%", then the MTL text; they are written as model.obj and
// model.mtl beside a 4x4 texture tex.png, and read with loadModel. Only montage::Error may come out.
#include <string>

#include "fuzz_support.h"
#include "image/codec.h"
#include "io/model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = [] {
    const std::string d = montage::fuzz::scratch("model_obj");
    montage::writePng(d + "/tex.png", cv::Mat(4, 4, CV_8UC3, cv::Scalar(10, 200, 30)));
    return d;
  }();
  const std::string text(reinterpret_cast<const char*>(data), size);
  const size_t split = text.find("\n%%\n");
  montage::fuzz::writeFile(dir + "/model.obj", text.substr(0, split));
  montage::fuzz::writeFile(dir + "/model.mtl", split == std::string::npos ? "" : text.substr(split + 4));
  try {
    const montage::TexturedModel model = montage::loadModel(dir + "/model.obj");
    if (model.faceMaterial.size() != size_t(model.mesh.numFaces())) __builtin_trap();
    for (int m : model.faceMaterial)
      if (m < 0 || m >= int(model.materials.size())) __builtin_trap();
    if (model.textured() && model.mesh.numFaces() > 0) (void)model.colorAt(0, montage::Vec3(1, 1, 1) / 3);
  } catch (const montage::Error&) {
  }
  return 0;
}
