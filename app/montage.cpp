// `montage`: the command-line face of TextureMontage.
//   montage info FILE                       validation report of a mesh, photo, model or project
//   montage synth --mesh M ... --out DIR    synthetic ground-truth scene
//   montage eval --result R --truth M ...   compare a result with the ground truth
//   montage render MODEL --out PNG          headless shaded render
//   montage run PROJECT --out DIR           run the pipeline and export
//   montage bench                           per-stage times and peak memory
//   montage mask PHOTO --rect x,y,w,h ...   cut-out mask (GrabCut) of a photo
#include <sys/resource.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/mesh_io.h"
#include "bench/eval.h"
#include "base/util.h"
#include "image/cutout.h"
#include "geometry/mesh.h"
#include "io/model.h"
#include "image/photo.h"
#include "pipeline.h"
#include "io/project.h"
#include "bench/render.h"
#include "bench/synth.h"

namespace fs = std::filesystem;
using namespace montage;

namespace {

// A one-line progress display on stderr: rewritten in place on a terminal, one line per stage
// otherwise (so logs stay readable).
class ProgressLine {
 public:
  ProgressLine() : tty_(isatty(STDERR_FILENO)) {}
  ~ProgressLine() { finish(); }
  void operator()(const std::string& stage, double fraction, const std::string& what) {
    if (tty_) {
      std::fprintf(stderr, "\r\033[K[%s] %3d%% %s", stage.c_str(), int(fraction * 100 + 0.5), what.c_str());
      std::fflush(stderr);
      open_ = true;
    } else if (stage != lastStage_) {
      std::fprintf(stderr, "[%s] %s\n", stage.c_str(), what.c_str());
    }
    lastStage_ = stage;
  }
  void finish() {
    if (open_) std::fprintf(stderr, "\n");
    open_ = false;
  }

 private:
  bool tty_;
  bool open_ = false;
  std::string lastStage_;
};

double peakMemoryMiB() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;  // ru_maxrss is in KiB on Linux
}

int cmdInfo(const std::string& file) {
  const std::string ext = lowerExtension(file);
  if (ext == ".json") {
    Project project = loadProject(file);
    std::printf(
        "project %s\n  mesh: %s\n  photos: %zu\n  feature points: %zu\n  chains: %zu\n  strokes: %zu\n"
        "  clones: %zu\n",
        file.c_str(), project.mesh.c_str(), project.photos.size(), project.points.size(), project.chains.size(),
        project.strokes.size(), project.clones.size());
    auto scene = loadScene(project);
    std::printf("%s", scene->meshReport.summary().c_str());
    for (size_t i = 0; i < scene->photos.size(); ++i)
      std::printf("  photo %zu: %s (%dx%d%s)\n", i, scene->photos[i]->path.c_str(), scene->photos[i]->width,
                  scene->photos[i]->height, scene->photos[i]->hasBackground ? ", with background mask" : "");
    std::printf("project is valid\n");
    return 0;
  }
  if (isImageExtension(ext)) {
    Photo photo = loadPhoto(file);
    const double fg = cv::countNonZero(photo.alpha > 0) / double(photo.width * photo.height);
    double maxDistance = 0;
    cv::minMaxLoc(photo.distance, nullptr, &maxDistance);
    std::printf("photo %s\n  size: %d x %d\n  foreground: %.1f%% (%s)\n  max distance to foreground: %.1f px\n",
                file.c_str(), photo.width, photo.height, 100 * fg,
                photo.hasBackground ? "from alpha" : "no alpha: whole photo is foreground", maxDistance);
    for (const std::string& w : foregroundWarnings(photo)) std::printf("  warning: %s\n", w.c_str());
    return 0;
  }
  if (ext == ".glb" || ext == ".gltf") {
    TexturedModel model = loadModel(file);
    std::printf("model %s\n  vertices: %d\n  faces: %d\n  materials: %zu\n  textured: %s\n", file.c_str(),
                model.mesh.numVertices(), model.mesh.numFaces(), model.materials.size(),
                model.textured() ? "yes" : "no");
    return 0;
  }
  LoadedMesh loaded = loadMesh(file);
  std::printf("%s", loaded.report.summary().c_str());
  return loaded.report.usable() ? 0 : 1;
}

TexturedModel loadTruth(const std::string& meshPath, const std::string& texturePath) {
  auto mesh = requireUsable(loadMesh(meshPath));
  TM_CHECK(mesh->hasUV(), located(meshPath, "has no texture coordinates (vt): a ground truth or --texture needs them"));
  return modelFromMesh(*mesh, readImageRgba8(texturePath));
}

struct SynthArgs {
  std::string mesh, texture, out;
  SynthOptions options;
};

int cmdSynth(const SynthArgs& args) {
  auto mesh = requireUsable(loadMesh(args.mesh));
  SurfaceColor color;
  std::shared_ptr<TexturedModel> truth;
  if (!args.texture.empty()) {
    truth = std::make_shared<TexturedModel>(loadTruth(args.mesh, args.texture));
    color = [truth](int f, const Vec3& b) { return truth->colorAt(f, b); };
  } else {
    Vec3 lo, hi;
    mesh->bounds(lo, hi);
    const double scale = 0.25 * (hi - lo).norm();
    const Mesh* m = mesh.get();
    color = [m, scale](int f, const Vec3& b) {
      const auto q = m->facePositions(f);
      return solidPattern(b[0] * q[0] + b[1] * q[1] + b[2] * q[2], scale);
    };
  }
  ProgressLine line;
  SynthScene scene = synthesize(*mesh, fs::absolute(args.mesh).lexically_normal().string(), color, args.options,
                                [&](double f) { line("synth", f, "rendering views"); });
  line.finish();
  writeSynthScene(scene, args.out);
  std::printf("wrote %zu photos, %zu feature points (of %zu sampled) to %s\n", scene.photos.size(),
              scene.project.points.size(), scene.featureVertices.size(), args.out.c_str());
  return 0;
}

int cmdEval(const std::string& resultPath, const std::string& truthMesh, const std::string& truthTexture,
            const std::string& jsonPath, int samples) {
  TexturedModel result = loadModel(resultPath);
  TexturedModel truth = loadTruth(truthMesh, truthTexture);
  EvalOptions options;
  options.samples = samples;
  EvalResult eval = evaluate(result, truth, options);
  std::printf("%s", eval.summary().c_str());
  if (!jsonPath.empty()) writeFileAtomic(jsonPath, eval.toJson().dump(2) + "\n");
  return 0;
}

int cmdRender(const std::string& modelPath, const std::string& out, const RenderOptions& options) {
  TexturedModel model = loadModel(modelPath);
  cv::Mat rgba = renderModel(model, options);
  cv::Mat bgra;
  cv::cvtColor(rgba, bgra, cv::COLOR_RGBA2BGRA);
  if (fs::path(out).has_parent_path()) fs::create_directories(fs::path(out).parent_path());
  TM_CHECK(cv::imwrite(out, bgra), located(out, "cannot write the image"));
  std::printf("wrote %s (%dx%d)\n", out.c_str(), rgba.cols, rgba.rows);
  return 0;
}

// One line per stage; long lists (per-region figures) are shown as their length, report.json has them.
void printStages(const PipelineResult& result) {
  for (const auto& s : result.stages) {
    nlohmann::json counts = s.counts;
    for (auto& [key, value] : counts.items())
      if (value.is_array() && value.dump().size() > 80) value = std::to_string(value.size()) + " items";
    std::printf("  %-9s %8.3f s%s  %s\n", stageName(s.stage), s.seconds, s.cached ? " (cached)" : "",
                counts.dump().c_str());
  }
}

int cmdRun(const std::string& projectPath, const std::string& out) {
  // A missing photo or mask disables only that photo (the pipeline skips it with a warning); the mesh
  // must be there.
  std::vector<MissingFile> missing;
  Project project = loadProjectAllowingMissing(projectPath, missing);
  for (const MissingFile& m : missing) {
    TM_CHECK(m.field != "mesh", located(projectPath, "mesh: file '" + m.path + "' not found"));
    std::printf("  warning: %s: %s not found\n", m.field.c_str(), m.path.c_str());
  }
  Pipeline pipeline;
  ProgressLine line;
  JobControl job(nullptr, [&](StageId s, double f, const std::string& what) { line(stageName(s), f, what); });
  PipelineResult result = pipeline.run(project, job);
  line.finish();
  writeRunOutputs(result, out);
  printStages(result);
  for (const auto& w : result.warnings) std::printf("  warning: %s\n", w.c_str());
  std::printf("wrote %s/model.obj, model.glb, report.json\n", out.c_str());
  return 0;
}

struct BenchArgs {
  std::string mesh, texture, work;
  SynthOptions synth;
};

int cmdBench(BenchArgs args) {
  using Clock = std::chrono::steady_clock;
  if (args.mesh.empty()) args.mesh = (fs::path(TM_SOURCE_DIR) / "assets/demo/demo_mesh.obj").string();
  if (args.work.empty()) args.work = (fs::temp_directory_path() / "tm_bench").string();
  std::printf("bench: %s, %d views, %d features, %d px\n", args.mesh.c_str(), args.synth.views, args.synth.features,
              args.synth.size);
  auto t0 = Clock::now();
  SynthArgs synth{args.mesh, args.texture, (fs::path(args.work) / "scene").string(), args.synth};
  cmdSynth(synth);
  const double synthSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
  std::printf("  %-8s %8.3f s\n", "synth", synthSeconds);

  Project project = loadProject((fs::path(args.work) / "scene/project.json").string());
  Pipeline pipeline;
  PipelineResult result = pipeline.run(project);
  printStages(result);
  t0 = Clock::now();
  writeRunOutputs(result, (fs::path(args.work) / "out").string());
  std::printf("  %-8s %8.3f s\n", "export", std::chrono::duration<double>(Clock::now() - t0).count());
  t0 = Clock::now();
  PipelineResult again = pipeline.run(project);
  std::printf("  rerun with nothing changed: %.3f s\n", std::chrono::duration<double>(Clock::now() - t0).count());
  std::printf("  peak memory: %.1f MiB\n", peakMemoryMiB());
  return 0;
}

struct MaskArgs {
  std::string photo, fg, bg, out;
  std::vector<double> rect;
  CutoutOptions options;
};

// Reads a stroke image (non-zero = stroke) for `montage mask`.
cv::Mat readStrokes(const std::string& path) {
  if (path.empty()) return {};
  cv::Mat rgba = readImageRgba8(path), grey;
  cv::cvtColor(rgba, grey, cv::COLOR_RGBA2GRAY);
  std::vector<cv::Mat> channels;
  cv::split(rgba, channels);
  return (grey > 0) & (channels[3] > 0);  // transparent pixels are not strokes
}

int cmdMask(const MaskArgs& args) {
  TM_CHECK(args.rect.size() == 4, "--rect: expected x,y,w,h (4 numbers), not " + std::to_string(args.rect.size()));
  const Photo photo = loadPhoto(args.photo);
  const auto start = Clock::now();
  Cutout cut(photo.rgb, args.options);
  cut.setRect(cv::Rect2d(args.rect[0], args.rect[1], args.rect[2], args.rect[3]));
  const cv::Mat fg = readStrokes(args.fg), bg = readStrokes(args.bg);
  try {
    if (!fg.empty() || !bg.empty()) cut.addStrokeMasks(fg, bg);
  } catch (const Error& e) {
    throw Error(located(args.fg.empty() ? args.bg : args.fg, e.what()));
  }
  const cv::Mat mask = cut.mask();
  const double seconds = secondsSince(start);
  writeMaskPng(mask, args.out);
  const double share = cv::countNonZero(mask) / double(mask.total());
  std::printf("wrote %s (%dx%d): foreground %.1f%% of the photo, border %.1f%%, %.2f s\n", args.out.c_str(), mask.cols,
              mask.rows, 100 * share, 100 * borderForegroundShare(mask), seconds);
  Photo masked = loadPhoto(args.photo, args.out);
  for (const std::string& w : foregroundWarnings(masked)) std::printf("  warning: %s\n", w.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"TextureMontage: texture a mesh from a few photos (Zhou et al. 2005)", "montage"};
  app.require_subcommand(1);

  std::string infoFile;
  auto* info = app.add_subcommand("info", "Validation report of a mesh, photo, model or project");
  info->add_option("FILE", infoFile,
                   "mesh (.obj .ply .off .stl), photo (.png .jpg .tif .bmp), model (.glb) or project (.json)")
      ->required();

  SynthArgs synth;
  auto* synthCmd = app.add_subcommand("synth", "Render a synthetic ground-truth scene: photos, features, project.json");
  synthCmd->add_option("--mesh", synth.mesh, "mesh to render")->required();
  synthCmd->add_option("--texture", synth.texture, "its texture (needs UVs); default: a 3D solid pattern");
  synthCmd->add_option("--views", synth.options.views, "number of photos")->check(CLI::Range(1, 64));
  synthCmd->add_option("--features", synth.options.features, "number of feature vertices")
      ->check(CLI::Range(0, 100000));
  synthCmd->add_option("--seed", synth.options.seed, "random seed");
  synthCmd->add_option("--size", synth.options.size, "photo size in pixels")->check(CLI::Range(16, 8192));
  synthCmd->add_option("--exposure", synth.options.exposures, "exposure gain per view on linear colour (cycled)")
      ->delimiter(',')
      ->check(CLI::PositiveNumber);
  synthCmd->add_option("--out", synth.out, "output folder")->required();

  std::string evalResult, evalTruth, evalTexture, evalJson;
  int evalSamples = EvalOptions{}.samples;
  auto* evalCmd = app.add_subcommand("eval", "Compare a textured result with the ground truth");
  evalCmd->add_option("--result", evalResult, "result model (.obj or .glb)")->required();
  evalCmd->add_option("--truth", evalTruth, "ground-truth mesh with UVs")->required();
  evalCmd->add_option("--truth-texture", evalTexture, "ground-truth texture")->required();
  evalCmd->add_option("--json", evalJson, "also write the figures as JSON");
  evalCmd->add_option("--samples", evalSamples, "surface samples")->check(CLI::Range(100, 100000000));

  std::string renderModelPath, renderOut;
  RenderOptions renderOptions;
  auto* render = app.add_subcommand("render", "Headless shaded render of a model to PNG");
  render->add_option("MODEL", renderModelPath, "model (.obj .glb or any mesh)")->required();
  render->add_option("--out", renderOut, "PNG to write")->required();
  render->add_option("--yaw", renderOptions.yawDeg, "orbit angle, degrees");
  render->add_option("--pitch", renderOptions.pitchDeg, "elevation, degrees");
  render->add_option("--size", renderOptions.size, "image size, pixels")->check(CLI::Range(16, 8192));

  std::string runProject, runOut;
  auto* run = app.add_subcommand("run", "Run the pipeline on a project and export model.obj, model.glb, report.json");
  run->add_option("PROJECT", runProject, "project file (.json)")->required();
  run->add_option("--out", runOut, "output folder")->required();

  BenchArgs bench;
  auto* benchCmd =
      app.add_subcommand("bench", "Synthesise a scene, run the pipeline, print stage times and peak memory");
  benchCmd->add_option("--mesh", bench.mesh, "mesh (default: the bundled demo mesh)");
  benchCmd->add_option("--texture", bench.texture, "its texture (default: solid pattern)");
  benchCmd->add_option("--views", bench.synth.views, "photos");
  benchCmd->add_option("--features", bench.synth.features, "feature vertices");
  benchCmd->add_option("--size", bench.synth.size, "photo size");
  benchCmd->add_option("--work", bench.work, "scratch folder (default: $TMPDIR/tm_bench)");

  MaskArgs mask;
  auto* maskCmd = app.add_subcommand(
      "mask", "Cut a photo's foreground out (GrabCut from a rectangle and strokes) into a mask PNG for the project");
  maskCmd->add_option("PHOTO", mask.photo, "photo to cut out")->required();
  maskCmd->add_option("--rect", mask.rect, "x,y,w,h: a rectangle around the object (photo pixels)")
      ->delimiter(',')
      ->required();
  maskCmd->add_option("--fg", mask.fg, "image of foreground strokes (non-zero pixels), the photo's size");
  maskCmd->add_option("--bg", mask.bg, "image of background strokes (non-zero pixels), the photo's size");
  maskCmd->add_option("--feather", mask.options.featherPx, "feathered edge width, pixels (default 0: hard edge)")
      ->check(CLI::Range(0.0, 1000.0));
  maskCmd->add_option("--iterations", mask.options.iterations, "GrabCut iterations")->check(CLI::Range(1, 100));
  maskCmd->add_option("--working-size", mask.options.workingSide,
                      "GrabCut runs at most this many pixels a side (0 = full resolution)")
      ->check(CLI::Range(0, 16384));
  maskCmd->add_option("--out", mask.out, "mask PNG to write (8-bit grey: 0 background, 255 foreground)")->required();

  CLI11_PARSE(app, argc, argv);
  try {
    if (*info) return cmdInfo(infoFile);
    if (*synthCmd) return cmdSynth(synth);
    if (*evalCmd) return cmdEval(evalResult, evalTruth, evalTexture, evalJson, evalSamples);
    if (*render) return cmdRender(renderModelPath, renderOut, renderOptions);
    if (*run) return cmdRun(runProject, runOut);
    if (*benchCmd) return cmdBench(bench);
    if (*maskCmd) return cmdMask(mask);
  } catch (const std::exception& e) {  // montage::Error and anything else: one line, exit status 1
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
