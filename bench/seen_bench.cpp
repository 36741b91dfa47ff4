// Seen faces left to inpainting (issue 34, item 3), on a synthetic scene (`montage synth`): runs the pipeline
// on the scene's project and prints the inpainted share of the surface against the projection oracle's (the
// pipeline's own visibility and view selection through the true cameras) and against what no photo sees at all
// (bench/sight.h: in front, facing, unoccluded, on the photo's alpha through a true camera). Faces inpainted
// although a photo sees most of them are sorted by why the photo of best sight refused them. With --before, the
// faces this run maps but the earlier run (its DIR/refined.glb) inpainted are scored both ways against the truth.
// DIR/seen_layer.glb: for `montage render --layer`, the faces inpainted although seen as "inpainted", the others
// no photo sees as "empty".
//   tm_seen_bench SCENE_DIR --truth MESH [--truth-texture PNG] [--out DIR: refined.glb, seen.json]
//                 [--before DIR] [--no-oracle]

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "base/cpu_time.h"
#include "base/util.h"
#include "bench/eval.h"
#include "bench/sight.h"
#include "bench/synth.h"
#include "geometry/mesh.h"
#include "image/photo.h"
#include "io/mesh_io.h"
#include "io/model.h"
#include "io/project.h"
#include "io/scene.h"
#include "mapping/projection.h"
#include "pipeline.h"

using namespace montage;
namespace fs = std::filesystem;

namespace {

// Area share of the faces the bake inpainted or left empty.
double inpaintedShare(const PipelineResult& r) {
  const Mesh& mesh = r.mapping->partition->mesh;
  double total = 0, holes = 0;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    total += mesh.faceArea(f);
    if (r.baked->atlas.faceSource[f] < 0) holes += mesh.faceArea(f);
  }
  return total > 0 ? holes / total : 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::string sceneDir, truthMesh, truthTexture, outDir, beforeDir;
  bool oracle = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--truth") truthMesh = next();
    else if (a == "--truth-texture") truthTexture = next();
    else if (a == "--out") outDir = next();
    else if (a == "--before") beforeDir = next();
    else if (a == "--no-oracle") oracle = false;
    else sceneDir = a;
  }
  if (sceneDir.empty() || truthMesh.empty()) {
    std::fprintf(stderr, "usage: tm_seen_bench SCENE_DIR --truth MESH [--truth-texture PNG] [--out DIR] "
                         "[--before DIR] [--no-oracle]\n");
    return 2;
  }
  try {
    const Project project = loadProject(sceneDir + "/project.json");
    const std::vector<PhotoCamera> cameras = readSynthCameras(sceneDir + "/cameras.json");
    const auto start = Clock::now();
    const double cpu0 = cpuSeconds();
    const PipelineResult r = Pipeline(Pipeline::Keep::ThisRunOnly).run(project);
    const double wall = secondsSince(start), cpu = cpuSeconds() - cpu0;
    const Mesh& mesh = r.mapping->partition->mesh;
    std::vector<const Photo*> photos;
    for (const auto& p : r.scene->photos) photos.push_back(p.get());
    const Sight sight = cameraSight(mesh, cameras, photos);
    const double inpainted = inpaintedShare(r);
    double oracleShare = -1;
    EvalResult oracleEval;
    TexturedModel truth;
    std::unique_ptr<Mesh> patterned;
    EvalOptions eo;
    if (truthTexture.empty()) {
      patterned = requireUsable(loadMesh(truthMesh));
      truth.mesh = *patterned;
      eo.truthColor = meshPattern(*patterned);
    } else {
      auto m = requireUsable(loadMesh(truthMesh));
      truth = modelFromMesh(*m, readImageRgba8(truthTexture));
    }
    if (oracle) {
      const PipelineResult o = projectionOracle(project, cameras);
      oracleShare = inpaintedShare(o);
      oracleEval = evaluate(*o.model, truth, eo);
    }
    // The faces inpainted although photos see most of them, by the reason the photos' views refused them.
    const ProjectionResult& pr = r.projection->result;
    const double total = [&] {
      double t = 0;
      for (int f = 0; f < mesh.numFaces(); ++f) t += mesh.faceArea(f);
      return t;
    }();
    std::map<std::string, double> why;
    double seenInpainted = 0;
    for (int f = 0; f < mesh.numFaces(); ++f) {
      if (r.baked->atlas.faceSource[f] >= 0 || sight.faceSeen[f] < 0.5) continue;
      const double a = mesh.faceArea(f) / total;
      seenInpainted += a;
      bool quality = false, background = false, flipped = false, corner = false, facing = false;
      for (const auto& view : pr.views) {
        if (!view) continue;
        quality = quality || view->faceQuality[f] > 0;
        background = background || view->faceRefused[f] == 2;
        flipped = flipped || view->faceRefused[f] == 1;
        const auto c = mesh.faceVertices(f);
        const Vec3 eye = cameras[view->photo].pinhole.center();
        const auto q = mesh.facePositions(f);
        const bool faces = mesh.faceNormal(f).dot((eye - (q[0] + q[1] + q[2]) / 3).normalized()) >= 0.05;
        facing = facing || faces;
        if (faces && !(view->vertexVisible[c[0]] && view->vertexVisible[c[1]] && view->vertexVisible[c[2]]))
          corner = true;
      }
      const std::string reason = quality      ? "a view could texture it (dropped later)"
                                 : background ? "refused: UVs on the background"
                                 : flipped    ? "refused: flipped"
                                 : !facing    ? "grazing (cosine < 0.05 in every view)"
                                 : corner     ? "a corner hidden or off the silhouette"
                                              : "an inner sample hidden";
      why[reason] += a;
    }
    const EvalResult now = evaluate(*r.model, truth, eo);
    std::printf("%s: %d faces, run %.1f s wall, %.1f s CPU\n", sceneDir.c_str(), mesh.numFaces(), wall, cpu);
    std::printf("inpainted %.2f%%, oracle %.2f%%, no photo sees %.2f%% (%+.2f points)\n", 100 * inpainted,
                100 * oracleShare, 100 * sight.unseenShare, 100 * (inpainted - sight.unseenShare));
    std::printf("inpainted although seen (half a face or more): %.2f%%\n", 100 * seenInpainted);
    for (const auto& [reason, share] : why) std::printf("  %-45s %.2f%%\n", reason.c_str(), 100 * share);
    std::printf("covered PSNR %.2f dB, Delta E %.3f; whole PSNR %.2f dB, Delta E %.3f\n", now.psnrCovered,
                now.deltaECovered, now.psnrAll, now.deltaEAll);
    if (oracle)
      std::printf("oracle covered PSNR %.2f dB, Delta E %.3f; whole PSNR %.2f dB, Delta E %.3f\n",
                  oracleEval.psnrCovered, oracleEval.deltaECovered, oracleEval.psnrAll, oracleEval.deltaEAll);
    nlohmann::json j = {{"scene", sceneDir},
                        {"faces", mesh.numFaces()},
                        {"wall", wall},
                        {"cpu", cpu},
                        {"inpainted", inpainted},
                        {"oracle_inpainted", oracleShare},
                        {"unseen", sight.unseenShare},
                        {"seen_inpainted", seenInpainted},
                        {"why", why},
                        {"psnr_covered", now.psnrCovered},
                        {"delta_e_covered", now.deltaECovered},
                        {"psnr_all", now.psnrAll},
                        {"delta_e_all", now.deltaEAll}};
    if (oracle) j["oracle_psnr_covered"] = oracleEval.psnrCovered, j["oracle_delta_e_covered"] = oracleEval.deltaECovered;
    if (!beforeDir.empty()) {
      // Samples this run textures from a photo that the earlier run inpainted: both ways against the truth.
      const TexturedModel before = loadModel(beforeDir + "/refined.glb");
      const EvalResult b = evaluate(before, truth, eo);
      EvalOptions changed = eo;
      changed.seen.assign(now.coveredSample.size(), 0);
      for (size_t i = 0; i < changed.seen.size() && i < b.coveredSample.size(); ++i)
        changed.seen[i] = now.coveredSample[i] && !b.coveredSample[i];
      const EvalResult x = evaluate(*r.model, truth, changed), y = evaluate(before, truth, changed);
      std::printf("newly mapped: %d samples; mapped PSNR %.2f dB, Delta E %.3f; inpainted before PSNR %.2f dB, "
                  "Delta E %.3f\n",
                  x.seenSamples, x.psnrSeen, x.deltaESeen, y.psnrSeen, y.deltaESeen);
      std::printf("before: covered PSNR %.2f dB, Delta E %.3f; whole PSNR %.2f dB, Delta E %.3f\n", b.psnrCovered,
                  b.deltaECovered, b.psnrAll, b.deltaEAll);
      j["newly_mapped"] = {{"samples", x.seenSamples}, {"psnr_mapped", x.psnrSeen}, {"delta_e_mapped", x.deltaESeen},
                           {"psnr_inpainted", y.psnrSeen}, {"delta_e_inpainted", y.deltaESeen}};
    }
    if (!outDir.empty()) {
      fs::create_directories(outDir);
      exportGlb(*r.model, outDir + "/refined.glb");
      // For `montage render --layer`: faces inpainted although seen show as "inpainted", faces no photo sees as
      // "empty".
      TexturedModel layer = *r.model;
      for (int f = 0; f < mesh.numFaces() && f < static_cast<int>(layer.faceSource.size()); ++f)
        if (layer.faceSource[f] < 0) layer.faceSource[f] = sight.faceSeen[f] >= 0.5 ? kSourceInpainted : kSourceEmpty;
      exportGlb(layer, outDir + "/seen_layer.glb");
      std::ofstream(outDir + "/seen.json") << j.dump(2) << "\n";
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
