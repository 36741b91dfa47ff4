// libFuzzer target: the project reader and every validation behind `montage info` and `run` (JSON,
// fields, indices, the project against its mesh and photos, clones, warnings), plus the save/load
// round trip: what loads must save and load back to the same document. The files a project names
// exist in a scratch folder: mesh.obj (a 6x6 grid, 36 vertices, 50 faces), a.png (64x48 with a
// background) and b.png (32x32, no background); the seeds name them.
#include <string>

#include "fuzz_support.h"
#include "image/codec.h"
#include "pipeline.h"

namespace {

std::string setUp() {
  const std::string dir = montage::fuzz::scratch("project");
  std::string obj;
  for (int j = 0; j < 6; ++j)
    for (int i = 0; i < 6; ++i) obj += "v " + std::to_string(i) + " " + std::to_string(j) + " 0\n";
  for (int j = 0; j < 5; ++j)
    for (int i = 0; i < 5; ++i) {
      const int a = j * 6 + i + 1, b = a + 1, c = a + 6, d = c + 1;
      obj += "f " + std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(d) + "\n";
      obj += "f " + std::to_string(a) + " " + std::to_string(d) + " " + std::to_string(c) + "\n";
    }
  montage::fuzz::writeFile(dir + "/mesh.obj", obj);
  cv::Mat a(48, 64, CV_8UC4, cv::Scalar(0, 0, 0, 0));
  a(cv::Rect(8, 8, 40, 30)).setTo(cv::Scalar(20, 120, 220, 255));
  montage::writePng(dir + "/a.png", a);
  montage::writePng(dir + "/b.png", cv::Mat(32, 32, CV_8UC3, cv::Scalar(90, 80, 70)));
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = setUp();
  static montage::Pipeline pipeline;  // keeps the mesh and photos: each input costs the validation only
  const std::string text(reinterpret_cast<const char*>(data), size);
  montage::Project project;
  try {
    project = montage::parseProject(text, dir + "/p.json");
  } catch (const montage::Error&) {
    return 0;
  }
  // Save and load back: the same document.
  try {
    const std::string saved = montage::projectToJson(project, dir + "/p.json");
    const montage::Project again = montage::parseProject(saved, dir + "/p.json");
    if (!again.sameDocument(project)) __builtin_trap();
  } catch (const montage::Error&) {
    // Only a value that JSON cannot hold may refuse to save; none can come out of a loaded file.
    __builtin_trap();
  }
  try {
    bool cached = false;
    const auto scene = pipeline.loadScene(project, {}, cached);
    for (const std::string& w : scene->warnings)
      if (w.empty()) __builtin_trap();
  } catch (const montage::Error&) {
  }
  return 0;
}
