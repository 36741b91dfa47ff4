// `montage`: the command-line face of TextureMontage.
//   montage info FILE                       validation report of a mesh, photo, model or project
//   montage synth --mesh M ... --out DIR    synthetic ground-truth scene
//   montage eval --result R --truth M ...   compare a result with the ground truth (and the projection oracle)
//   montage render MODEL --out PNG          headless shaded render
//   montage run PROJECT --out DIR           run the pipeline and export
//   montage bench                           per-stage times and peak memory
//   montage mask PHOTO --rect x,y,w,h ...   cut-out mask (GrabCut) of a photo
// Options of every command: --threads N, --strict. Exit codes (docs/command-line.md): 0 done, 1 error,
// 2 usage, 3 done with warnings under --strict.
#include <sys/resource.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <opencv2/imgproc.hpp>

#include "base/fileio.h"
#include "base/process_tuning.h"
#include "base/util.h"
#include "bench/deform.h"
#include "bench/eval.h"
#include "bench/render.h"
#include "bench/synth.h"
#include "geometry/mesh.h"
#include "image/codec.h"
#include "image/cutout.h"
#include "image/photo.h"
#include "io/mesh_io.h"
#include "io/model.h"
#include "io/project.h"
#include "pipeline.h"

namespace fs = std::filesystem;
using namespace montage;

namespace {

// Exit codes (docs/command-line.md).
constexpr int kExitDone = 0, kExitError = 1, kExitUsage = 2, kExitWarnings = 3;

// A mistake in the command line itself found after parsing (a bad --set): exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// What every command shares: --strict makes warnings count (exit 3) and unknown project fields errors.
struct Common {
  bool strict = false;
  int threads = 0;  // 0: all cores
};

// Under --strict, the fields a project names that this build does not know are an error (they are a
// warning otherwise: projectWarnings names them).
void refuseUnknownFields(const Common& common, const Project& project, const std::string& path) {
  if (!common.strict || project.unknownFields.empty()) return;
  std::string list;
  for (const std::string& f : project.unknownFields) list += (list.empty() ? "" : "; ") + f;
  throw Error(located(path, std::to_string(project.unknownFields.size()) + " field" +
                                (project.unknownFields.size() == 1 ? "" : "s") +
                                " this build does not know (an error under --strict): " + list));
}

// The exit code of a command that finished with `warnings` warnings.
int doneWith(const Common& common, size_t warnings) {
  if (!common.strict || warnings == 0) return kExitDone;
  std::fprintf(stderr, "montage: done with %zu warning%s (--strict: exit code %d)\n", warnings,
               warnings == 1 ? "" : "s", kExitWarnings);
  return kExitWarnings;
}

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

// printf to stdout through printable(): names and text from input files never reach the terminal raw.
#if defined(__GNUC__)
__attribute__((format(printf, 1, 2)))
#endif
void say(const char* format, ...) {
  va_list args, copy;
  va_start(args, format);
  va_copy(copy, args);
  std::string text(size_t(std::max(0, std::vsnprintf(nullptr, 0, format, copy))), '\0');
  va_end(copy);
  std::vsnprintf(text.data(), text.size() + 1, format, args);
  va_end(args);
  std::fputs(printable(text, true).c_str(), stdout);
}

nlohmann::json meshReportJson(const MeshReport& r) {
  nlohmann::json findings = nlohmann::json::array();
  for (const MeshFinding& f : r.findings)
    findings.push_back({{"severity", f.severity == MeshFinding::Severity::Error ? "error" : "warning"},
                        {"what", f.what},
                        {"count", f.count},
                        {"elements", f.elements}});
  return {{"path", r.path},
          {"format", r.format},
          {"input_vertices", r.inputVertices},
          {"input_faces", r.inputFaces},
          {"vertices", r.vertices},
          {"faces", r.faces},
          {"edges", r.edges},
          {"components", r.components},
          {"boundary_loops", r.boundaryLoops},
          {"genus", r.genus},
          {"has_uv", r.hasUV},
          {"diagonal", r.diagonal},
          {"usable", r.usable()},
          {"findings", findings}};
}

// Holes whose texture comes from a photo region the user picked.
size_t holeTextures(const Project& project) {
  size_t n = 0;
  for (const HoleMode& h : project.holeModes) n += h.exemplar.has_value();
  return n;
}

// `montage info --json`: the same report as one JSON object on stdout ("kind", "file", "valid",
// "warnings" and what the kind has); docs/command-line.md lists the fields.

// A photo's EXIF camera for `montage info`: "Canon EOS 80D, 18 mm (29 mm on 35 mm film), focal length 2345 px".
std::string cameraText(const ExifCamera& camera, cv::Size size) {
  const double focal = camera.focalPx(size);
  char px[64] = "";
  if (focal > 0) std::snprintf(px, sizeof px, ", focal length %.0f px (a prior of the camera fit)", focal);
  return camera.describe() + px;
}

nlohmann::json exifJson(const ExifCamera& camera, cv::Size size) {
  if (camera.empty()) return nullptr;
  return {{"make", camera.make},
          {"model", camera.model},
          {"focal_mm", camera.focalMm},
          {"focal_35mm", camera.focal35mm},
          {"focal_px", camera.focalPx(size)}};
}

int cmdInfoJson(const std::string& file, const Common& common) {
  const std::string ext = lowerExtension(file);
  nlohmann::json j = {{"file", file}};
  std::vector<std::string> warnings;
  bool valid = true;
  if (ext == ".json") {
    Project project = loadProject(file);
    refuseUnknownFields(common, project, file);
    auto scene = loadScene(project);
    nlohmann::json photos = nlohmann::json::array();
    for (size_t i = 0; i < scene->photos.size(); ++i) {
      const Photo& photo = *scene->photos[i];
      if (auto skipped = scene->skippedPhotos.find(int(i)); skipped != scene->skippedPhotos.end()) {
        photos.push_back({{"path", photo.path}, {"mask", photo.maskPath}, {"skipped", skipped->second}});
        warnings.push_back("photo " + std::to_string(i) + " skipped: " + skipped->second);
        continue;
      }
      photos.push_back({{"path", photo.path},
                        {"mask", photo.maskPath},
                        {"mirror", photo.mirrored},
                        {"width", photo.width},
                        {"height", photo.height},
                        {"background_mask", photo.hasBackground},
                        {"working_width", photo.rgb.cols},
                        {"working_height", photo.rgb.rows},
                        {"camera", exifJson(photo.exif, cv::Size(photo.width, photo.height))}});
    }
    j["kind"] = "project";
    j["mesh"] = meshReportJson(scene->meshReport);
    j["photos"] = photos;
    j["counts"] = {{"points", project.points.size()},         {"chains", project.chains.size()},
                   {"strokes", project.strokes.size()},       {"clones", project.clones.size()},
                   {"hole_modes", project.holeModes.size()}, {"hole_textures", holeTextures(project)}};
    j["unknown_fields"] = project.unknownFields;
    warnings.insert(warnings.end(), scene->warnings.begin(), scene->warnings.end());
  } else if (isImageExtension(ext)) {
    const PhotoStats stats = photoStats(file);
    const ImageHeader header = readImageFileHeader(file);
    j["kind"] = "photo";
    j["width"] = stats.width, j["height"] = stats.height;
    j["exif_orientation"] = header.orientation, j["icc_profile"] = header.iccProfile;
    j["camera"] = exifJson(header.camera, cv::Size(stats.width, stats.height));
    j["channels"] = stats.channels, j["bits_per_channel"] = stats.bitsPerChannel;
    j["foreground"] = stats.foreground, j["alpha"] = stats.hasBackground;
    j["max_distance_px"] = stats.maxDistance, j["max_distance_error_px"] = stats.maxDistanceError;
    warnings = foregroundWarnings(stats.hasBackground, stats.borderForeground);
  } else {
    TM_CHECK(!isOtherImageExtension(ext), located(file, unsupportedPhotoFormat(ext)));
    LoadedMesh loaded = loadMesh(file);  // a GLB or glTF: the mesh as the pipeline loads it, then the model
    j["kind"] = "mesh";
    j["mesh"] = meshReportJson(loaded.report);
    valid = loaded.report.usable();
    for (const MeshFinding& f : loaded.report.findings)
      if (f.severity == MeshFinding::Severity::Warning) warnings.push_back(f.what);
    if (valid && (ext == ".glb" || ext == ".gltf")) {
      const TexturedModel model = loadModel(file);
      j["kind"] = "model";
      j["model"] = {{"vertices", model.mesh.numVertices()}, {"faces", model.mesh.numFaces()},
                    {"materials", model.materials.size()}, {"textured", model.textured()}};
    }
  }
  j["valid"] = valid;
  j["warnings"] = warnings;
  std::printf("%s\n", j.dump(2).c_str());
  return valid ? doneWith(common, warnings.size()) : kExitError;
}

int cmdInfo(const std::string& file, const Common& common) {
  const std::string ext = lowerExtension(file);
  if (ext == ".json") {
    Project project = loadProject(file);
    refuseUnknownFields(common, project, file);
    say("project %s\n  mesh: %s\n  photos: %zu\n  feature points: %zu\n  chains: %zu\n  strokes: %zu\n"
        "  clones: %zu\n",
        file.c_str(), project.mesh.c_str(), project.photos.size(), project.points.size(), project.chains.size(),
        project.strokes.size(), project.clones.size());
    if (!project.holeModes.empty())
      say("  hole modes: %zu (%zu textured from a photo region)\n", project.holeModes.size(), holeTextures(project));
    auto scene = loadScene(project);  // the validation `run` does, too
    say("%s", scene->meshReport.summary().c_str());
    std::vector<std::string> warnings = scene->warnings;
    for (size_t i = 0; i < scene->photos.size(); ++i) {
      const Photo& photo = *scene->photos[i];
      if (auto skipped = scene->skippedPhotos.find(int(i)); skipped != scene->skippedPhotos.end()) {
        say("  photo %zu: %s: cannot be read, a run skips it (%s)\n", i, photo.path.c_str(), skipped->second.c_str());
        warnings.push_back("photo " + std::to_string(i) + " skipped: " + skipped->second);
        continue;
      }
      say("  photo %zu: %s (%dx%d%s", i, photo.path.c_str(), photo.width, photo.height,
          photo.hasBackground ? ", with background mask" : "");
      if (photo.scale != 1) say(", kept at %dx%d (working resolution)", photo.rgb.cols, photo.rgb.rows);
      if (!photo.exif.empty()) say(", %s", cameraText(photo.exif, cv::Size(photo.width, photo.height)).c_str());
      say(")\n");
    }
    for (const std::string& w : scene->warnings) say("  warning: %s\n", w.c_str());
    say("project is valid%s\n", warnings.empty() ? "" : " (with the warnings above)");
    return doneWith(common, warnings.size());
  }
  if (isImageExtension(ext)) {
    const PhotoStats stats = photoStats(file);
    say("photo %s\n  size: %d x %d, %d channel%s of %d bits\n  foreground: %.1f%% (%s)\n"
        "  max distance to foreground: %.1f px",
        file.c_str(), stats.width, stats.height, stats.channels, stats.channels == 1 ? "" : "s", stats.bitsPerChannel,
        100 * stats.foreground, stats.hasBackground ? "from alpha" : "no alpha: whole photo is foreground",
        stats.maxDistance);
    if (stats.maxDistanceError > 0)
      say(" (within %.1f px: measured at 1/%d resolution)", stats.maxDistanceError, stats.distanceScale);
    say("\n");
    const ImageHeader header = readImageFileHeader(file);
    if (header.orientation != 1)
      say("  EXIF orientation %d: turned as photo apps show it (clicks and masks are in the shown frame)\n",
          header.orientation);
    if (header.iccProfile) say("  colour profile: embedded, converted to sRGB\n");
    if (!header.camera.empty())
      say("  camera: %s\n", cameraText(header.camera, cv::Size(stats.width, stats.height)).c_str());
    const std::vector<std::string> warnings = foregroundWarnings(stats.hasBackground, stats.borderForeground);
    for (const std::string& w : warnings) say("  warning: %s\n", w.c_str());
    return doneWith(common, warnings.size());
  }
  if (ext == ".glb" || ext == ".gltf") {
    // The mesh as the pipeline loads it (every instance, skins and morph targets noted), then the model.
    const LoadedMesh loaded = loadMesh(file);
    say("%s", loaded.report.summary().c_str());
    if (!loaded.report.usable()) return kExitError;
    TexturedModel model = loadModel(file);
    say("model %s\n  vertices: %d (welded)\n  faces: %d\n  materials: %zu\n  textured: %s\n", file.c_str(),
        model.mesh.numVertices(), model.mesh.numFaces(), model.materials.size(), model.textured() ? "yes" : "no");
    size_t warnings = 0;
    for (const MeshFinding& f : loaded.report.findings) warnings += f.severity == MeshFinding::Severity::Warning;
    return doneWith(common, warnings);
  }
  TM_CHECK(!isOtherImageExtension(ext), located(file, unsupportedPhotoFormat(ext)));
  LoadedMesh loaded = loadMesh(file);
  say("%s", loaded.report.summary().c_str());
  if (!loaded.report.usable()) return kExitError;
  size_t warnings = 0;
  for (const MeshFinding& f : loaded.report.findings) warnings += f.severity == MeshFinding::Severity::Warning;
  return doneWith(common, warnings);
}

TexturedModel loadTruth(const std::string& meshPath, const std::string& texturePath) {
  auto mesh = requireUsable(loadMesh(meshPath));
  TM_CHECK(mesh->hasUV(), located(meshPath, "has no texture coordinates (vt): a ground truth or --texture needs them"));
  return modelFromMesh(*mesh, readImageRgba8(texturePath));
}

struct SynthArgs {
  std::string mesh, texture, out;
  SynthOptions options;
  std::string deform;  // --deform KIND[:AMOUNT], parsed into options.deform
};

int cmdSynth(const SynthArgs& args) {
  TM_CHECK(!args.out.empty(), "synth: --out: the path is empty (give a folder such as out/scene)");
  std::error_code ec;
  TM_CHECK(!fs::exists(args.out, ec) || fs::is_directory(args.out, ec),
           located(args.out, "synth: --out: is a file, not a folder"));
  auto mesh = requireUsable(loadMesh(args.mesh));
  SynthOptions options = args.options;
  if (!args.deform.empty()) options.deform = parseDeformation(args.deform);
  SurfaceColor color;
  std::shared_ptr<TexturedModel> truth;
  if (!args.texture.empty()) {
    truth = std::make_shared<TexturedModel>(loadTruth(args.mesh, args.texture));
    color = [truth](int f, const Vec3& b) { return truth->colorAt(f, b); };
  } else {
    color = meshPattern(*mesh);
  }
  ProgressLine line;
  SynthScene scene = synthesize(*mesh, fs::absolute(args.mesh).lexically_normal().string(), color, options,
                                [&](double f) { line("synth", f, "rendering views"); });
  line.finish();
  writeSynthScene(scene, args.out);
  std::printf("wrote %zu photos%s, %zu feature points (of %zu sampled) to %s\n", scene.photos.size(),
              scene.photographed ? (" of the mesh deformed (" + options.deform.text() + ", deformed.obj)").c_str() : "",
              scene.project.points.size(), scene.featureVertices.size(), args.out.c_str());
  return 0;
}

int cmdEval(const std::string& resultPath, const std::string& truthMesh, const std::string& truthTexture,
            const std::string& jsonPath, int samples, const std::string& oracleDir) {
  if (!jsonPath.empty()) prepareOutputFile(jsonPath, "--json");
  TexturedModel result = loadModel(resultPath);
  // Without a texture every figure would describe the material colours (it once read "100% photo",
  // 11 dB): refuse instead.
  bool anyTexture = false;
  for (const Material& m : result.materials) anyTexture = anyTexture || !m.texture.empty();
  TM_CHECK(result.textured() && anyTexture,
           located(resultPath, std::string("the result has no texture (") +
                                   (result.textured() ? "texture coordinates but no material with a texture image"
                                                      : "no texture coordinates") +
                                   "): there is nothing to evaluate; give the model.obj or model.glb of a run"));
  // Without a texture the truth is synth's solid pattern of the truth mesh.
  std::unique_ptr<Mesh> patterned;
  TexturedModel truth;
  EvalOptions options;
  options.samples = samples;
  if (truthTexture.empty()) {
    patterned = requireUsable(loadMesh(truthMesh));
    truth.mesh = *patterned;
    options.truthColor = meshPattern(*patterned);
  } else {
    truth = loadTruth(truthMesh, truthTexture);
  }
  // With --oracle, the oracle is evaluated first: the samples it textures from a photo (what the photos see
  // through the true cameras) are where the result's "seen" figures are taken, whatever the result does there.
  EvalResult o;
  std::string oracleWhat;
  if (!oracleDir.empty()) {
    // The projection oracle: the scene textured through its true cameras (its ceiling).
    const Project project = loadProject((fs::path(oracleDir) / "project.json").string());
    const std::string camerasPath = (fs::path(oracleDir) / "cameras.json").string();
    const std::vector<PhotoCamera> cameras = readSynthCameras(camerasPath);
    // A scene of the mesh deformed: the true correspondence, through the deformed mesh (bench/deform.h).
    const std::string deformed = readSynthDeformedMesh(camerasPath);
    ProgressLine line;
    JobControl job(nullptr, [&](StageId s, double f, const std::string& what) { line(stageName(s), f, what); });
    const PipelineResult oracle = deformed.empty() ? projectionOracle(project, cameras, job)
                                                   : deformedProjectionOracle(project, cameras, deformed, job);
    line.finish();
    o = evaluate(*oracle.model, truth, options);
    o.seenSamples = o.coveredSamples, o.psnrSeen = o.psnrCovered, o.deltaESeen = o.deltaECovered;
    options.seen = o.coveredSample;
    oracleWhat = deformed.empty() ? "projection oracle" : "true correspondence (the photos show the mesh deformed)";
  }
  EvalResult eval = evaluate(result, truth, options);
  std::printf("%s", eval.summary().c_str());
  nlohmann::json json = eval.toJson();
  if (!oracleDir.empty()) {
    std::printf("%s (true cameras of %s):\n", oracleWhat.c_str(), oracleDir.c_str());
    std::printf("%s", o.summary().c_str());
    const double unseen = o.coverageInpainted + o.coverageEmpty;
    std::printf(
        "against the oracle: covered PSNR %+.2f dB, covered Delta E %+.3f; inpainted %.2f%%, the oracle "
        "(no photo sees it) %.2f%%: %+.2f points\n",
        eval.psnrCovered - o.psnrCovered, eval.deltaECovered - o.deltaECovered,
        100 * (eval.coverageInpainted + eval.coverageEmpty), 100 * unseen,
        100 * (eval.coverageInpainted + eval.coverageEmpty - unseen));
    std::printf(
        "seen by the photos (the oracle's %d photo-textured samples): PSNR %.2f dB (oracle %.2f, %+.2f dB), "
        "Delta E %.3f (oracle %.3f, %+.3f)\n",
        o.seenSamples, eval.psnrSeen, o.psnrSeen, eval.psnrSeen - o.psnrSeen, eval.deltaESeen, o.deltaESeen,
        eval.deltaESeen - o.deltaESeen);
    json = {{"result", eval.toJson()},
            {"oracle", o.toJson()},
            {"psnr_covered_gap", eval.psnrCovered - o.psnrCovered},
            {"delta_e_covered_gap", eval.deltaECovered - o.deltaECovered},
            {"psnr_seen", eval.psnrSeen},
            {"delta_e_seen", eval.deltaESeen},
            {"psnr_seen_gap", eval.psnrSeen - o.psnrSeen},
            {"delta_e_seen_gap", eval.deltaESeen - o.deltaESeen},
            {"unseen_share", unseen},
            {"inpainted_share", eval.coverageInpainted + eval.coverageEmpty}};
  }
  if (!jsonPath.empty()) writeFileAtomic(jsonPath, json.dump(2) + "\n");
  return 0;
}

struct RenderArgs {
  std::string model, out, size;
  int turntable = 0;   // views of a turntable; 0 = one render
  bool layer = false;  // render the source-photo layer instead of the texture
  RenderOptions options;
};

// "W" or "WxH" (pixels, 16..8192 each).
void parseRenderSize(const std::string& text, RenderOptions& options) {
  if (text.empty()) return;
  int w = 0, h = 0;
  char x = 0, extra = 0;
  const int n = std::sscanf(text.c_str(), "%d%c%d%c", &w, &x, &h, &extra);
  const bool ok = (n == 1) || (n == 3 && (x == 'x' || x == 'X'));
  if (n == 1) h = w;
  TM_CHECK(ok && w >= 16 && w <= 8192 && h >= 16 && h <= 8192,
           "--size: " + text + " is not W or WxH with sides in 16..8192 pixels (e.g. 1024 or 800x600)");
  options.size = w;
  options.height = h;
}

// The layer render: every texture of the model replaced by its atlas's source layer in colours (the
// file <model stem>_atlas_source.png beside the model, as `montage run` writes it), with a legend.
std::vector<std::pair<cv::Vec4b, std::string>> useSourceLayer(TexturedModel& model, const std::string& modelPath) {
  const fs::path path = fs::path(modelPath).parent_path() / (fs::path(modelPath).stem().string() + "_atlas_source.png");
  TM_CHECK(fs::is_regular_file(path),
           located(modelPath, "--layer needs the source layer " + path.string() + " (written by montage run)"));
  const cv::Mat source = readImageFile(path.string());
  TM_CHECK(source.type() == CV_8UC1, located(path.string(), "the source layer is not an 8-bit grey image"));
  const cv::Mat colours = colorizeSourceLayer(source);
  for (Material& m : model.materials)
    if (!m.texture.empty()) {
      TM_CHECK(
          m.texture.size() == source.size(),
          located(path.string(), "the source layer is " + std::to_string(source.cols) + "x" +
                                     std::to_string(source.rows) + " but the texture of material '" + m.name + "' is " +
                                     std::to_string(m.texture.cols) + "x" + std::to_string(m.texture.rows)));
      m.texture = colours;
    }
  std::vector<std::pair<cv::Vec4b, std::string>> legend;
  for (int code : sourceLayerCodes(source))
    legend.emplace_back(sourceLayerColor(code), code == 254   ? "inpainted"
                                                : code == 253 ? "empty (no photo, not inpainted)"
                                                              : "photo " + std::to_string(code - 1));
  return legend;
}

int cmdRender(const RenderArgs& args) {
  TM_CHECK(std::isfinite(args.options.yawDeg) && std::isfinite(args.options.pitchDeg),
           "render: --yaw and --pitch must be finite numbers of degrees (got " + std::to_string(args.options.yawDeg) +
               " and " + std::to_string(args.options.pitchDeg) + ")");
  prepareOutputFile(args.out, "--out");
  TM_CHECK(lowerExtension(args.out) == ".png",
           located(args.out, "--out: the render is written as PNG; name a .png file"));
  TexturedModel model = loadModel(args.model);
  RenderOptions options = args.options;
  parseRenderSize(args.size, options);
  std::vector<std::pair<cv::Vec4b, std::string>> legend;
  if (args.layer) {
    legend = useSourceLayer(model, args.model);
    options.shading = false;  // flat colours read better in a legend's key
  }
  if (args.turntable <= 0) {
    cv::Mat rgba = renderModel(model, options);
    if (!legend.empty()) drawLegend(rgba, legend);
    writePng(args.out, rgba, kPngFast, false);
    std::printf("wrote %s (%dx%d)\n", args.out.c_str(), rgba.cols, rgba.rows);
    return 0;
  }
  std::vector<cv::Mat> views = renderTurntable(model, args.turntable, options);
  const fs::path out(args.out);
  const std::string stem = (out.parent_path() / out.stem()).string();
  for (size_t k = 0; k < views.size(); ++k) {
    char suffix[32];
    std::snprintf(suffix, sizeof suffix, "_%02zu.png", k);
    writePng(stem + suffix, views[k], kPngFast, false);
  }
  cv::Mat sheet = contactSheet(views);
  if (!legend.empty()) drawLegend(sheet, legend);
  writePng(args.out, sheet, kPngFast, false);
  std::printf("wrote %zu views %s_00.png .. and the contact sheet %s (%dx%d)\n", views.size(), stem.c_str(),
              args.out.c_str(), sheet.cols, sheet.rows);
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

// `--set KEY=VALUE` applied to `options` in order; a malformed one, an unknown key or a bad value is a
// UsageError naming it.
void applySets(const std::vector<std::string>& sets, PipelineOptions& options) {
  for (const std::string& set : sets) {
    const size_t eq = set.find('=');
    if (eq == std::string::npos || eq == 0)
      throw UsageError("--set " + printable(set) + ": expected KEY=VALUE, e.g. --set atlasSize=2048");
    try {
      setProjectOption(options, set.substr(0, eq), set.substr(eq + 1), "--set " + set);
    } catch (const Error& e) {
      throw UsageError(e.what());
    }
  }
}

int cmdRun(const std::string& projectPath, const std::string& out, int pngCompression,
           const std::vector<std::string>& sets, const Common& common) {
  // The command line first: a bad --set is a usage error whatever the project holds.
  PipelineOptions checked;
  applySets(sets, checked);
  // --out is checked and locked before the pipeline: a bad folder or a second run on it is refused at
  // once, not after minutes of work. A missing photo or mask disables only that photo (the pipeline
  // skips it with a warning); the mesh must be there.
  std::vector<MissingFile> missing;
  Project project = loadProjectAllowingMissing(projectPath, missing);
  for (const MissingFile& m : missing) {
    TM_CHECK(m.field != "mesh", located(projectPath, "mesh: file '" + m.path + "' not found"));
    say("  warning: %s: %s not found\n", m.field.c_str(), m.path.c_str());
  }
  refuseUnknownFields(common, project, projectPath);
  applySets(sets, project.options);
  if (pngCompression >= 0) project.options.pngCompression = pngCompression;
  OutputFolder folder(out);
  Pipeline pipeline(Pipeline::Keep::ThisRunOnly);  // one run: nothing is kept for a next one
  ProgressLine line;
  JobControl job(nullptr, [&](StageId s, double f, const std::string& what) { line(stageName(s), f, what); });
  PipelineResult result = pipeline.run(project, job);
  line.finish();
  writeRunOutputs(result, folder);
  printStages(result);
  for (const auto& w : result.warnings) std::printf("  warning: %s\n", printable(w).c_str());
  std::printf("wrote %s/model.obj, model.glb, report.json\n", printable(folder.path()).c_str());
  std::fflush(stdout);
  return doneWith(common, missing.size() + result.warnings.size());
}

struct BenchArgs {
  std::string mesh, texture, work;
  SynthOptions synth;
};

int cmdBench(BenchArgs args) {
  using Clock = std::chrono::steady_clock;
  if (args.mesh.empty()) args.mesh = (fs::path(TM_SOURCE_DIR) / "assets/demo/cat.obj").string();
  if (args.work.empty()) args.work = (fs::temp_directory_path() / "tm_bench").string();
  std::printf("bench: %s, %d views, %d features, %d px\n", args.mesh.c_str(), args.synth.views, args.synth.features,
              args.synth.size);
  auto t0 = Clock::now();
  SynthArgs synth{args.mesh, args.texture, (fs::path(args.work) / "scene").string(), args.synth, {}};
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
  montage::tuneProcess(argv);
  CLI::App app{"TextureMontage: texture a mesh from a few photos (Zhou et al. 2005)", "montage"};
  app.set_version_flag("--version", "montage " TM_VERSION " (project format versions " +
                                        std::to_string(Project::kOldestVersion) + " to " +
                                        std::to_string(Project::kVersion) + ")");
  app.require_subcommand(1);
  Common common;
  app.add_option("--threads", common.threads,
                 "threads the work uses at most (TBB, OpenCV, OpenBLAS); default: every core. Results do not "
                 "depend on it")
      ->check(CLI::Range(1, 4096));
  app.add_flag("--strict", common.strict,
               "warnings count: exit code 3 when a command finished with warnings, and fields of a project this "
               "build does not know are an error");
  app.footer("Exit codes: 0 done, 1 error, 2 usage, 3 done with warnings under --strict (docs/command-line.md).");

  std::string infoFile;
  bool infoJson = false;
  auto* info = app.add_subcommand("info", "Validation report of a mesh, photo, model or project");
  info->add_option("FILE", infoFile,
                   "mesh (" + montage::meshExtensionList() +
                       "), photo (.png .jpg .jpeg .tif .tiff .bmp), model (.glb .gltf) or project (.json)")
      ->required();
  info->add_flag("--json", infoJson, "print the report as one JSON object (docs/command-line.md)");

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
  synthCmd
      ->add_option("--click-noise", synth.options.clickNoisePx,
                   "standard deviation of a seeded Gaussian error added to every click, pixels")
      ->check(CLI::Range(0.0, 1000.0));
  synthCmd->add_option("--k1", synth.options.k1, "radial lens distortion of every view (OpenCV's k1; e.g. -0.25 barrel)")
      ->check(CLI::Range(-1.0, 1.0));
  synthCmd->add_option("--k2", synth.options.k2, "radial lens distortion, fourth-order term (OpenCV's k2)")
      ->check(CLI::Range(-1.0, 1.0));
  synthCmd
      ->add_option("--deform", synth.deform,
                   "photos of the mesh deformed (another subject with a known truth), clicks on the mesh: "
                   "bend, twist, scale, limbs or turn, with :AMOUNT (default 1; scale 1.3, scale:1 = none)")
      ->type_name("KIND[:AMOUNT]");
  synthCmd->add_option("--out", synth.out, "output folder")->required();

  std::string evalResult, evalTruth, evalTexture, evalJson;
  int evalSamples = EvalOptions{}.samples;
  auto* evalCmd = app.add_subcommand("eval", "Compare a textured result with the ground truth");
  evalCmd->add_option("--result", evalResult, "result model (.obj or .glb)")->required();
  evalCmd->add_option("--truth", evalTruth, "ground-truth mesh with UVs")->required();
  evalCmd->add_option("--truth-texture", evalTexture,
                      "ground-truth texture (default: synth's solid pattern of --truth)");
  evalCmd->add_option("--json", evalJson, "also write the figures as JSON");
  evalCmd->add_option("--samples", evalSamples, "surface samples")->check(CLI::Range(100, 100000000));
  std::string evalOracle;
  evalCmd->add_option("--oracle", evalOracle,
                      "synthetic scene folder (project.json, cameras.json): also evaluate the projection oracle, "
                      "the scene textured through its true cameras");

  RenderArgs renderArgs;
  auto* render = app.add_subcommand("render", "Headless shaded render of a model to PNG (one view or a turntable)");
  render->add_option("MODEL", renderArgs.model, "model (.obj .glb or any mesh)")->required();
  render->add_option("--out", renderArgs.out, "PNG to write (with --turntable: the contact sheet; views beside it)")
      ->required();
  render->add_option("--yaw", renderArgs.options.yawDeg, "orbit angle, degrees (first view of a turntable)");
  render->add_option("--pitch", renderArgs.options.pitchDeg, "elevation, degrees");
  render->add_option("--size", renderArgs.size, "image size in pixels: W (square) or WxH, e.g. 1024 or 800x600")
      ->type_name("W|WxH");
  render
      ->add_option("--turntable", renderArgs.turntable,
                   "N views around the model: OUT_00.png .. OUT_<N-1>.png and a contact sheet OUT")
      ->check(CLI::Range(1, 360));
  render->add_flag("--layer", renderArgs.layer,
                   "render the source-photo layer (one colour per photo, inpainted, empty) with a legend instead "
                   "of the texture; needs <model>_atlas_source.png beside the model");

  std::string runProject, runOut;
  int runPng = -1;
  auto* run = app.add_subcommand("run", "Run the pipeline on a project and export model.obj, model.glb, report.json");
  run->add_option("PROJECT", runProject, "project file (.json)")->required();
  run->add_option("--out", runOut, "output folder")->required();
  run->add_option("--png-compression", runPng,
                  "zlib level of the atlas PNG, overriding the project's option: 1 fast (previews) .. 9 smallest")
      ->check(CLI::Range(0, 9));
  std::vector<std::string> runSets;
  run->add_option("--set", runSets,
                  "set a project option for this run, checked as in the project file (repeatable): "
                  "--set atlasSize=2048 --set inpaintMode=synthesis")
      ->type_name("KEY=VALUE")
      ->take_first()
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);

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
  maskCmd
      ->add_option("--working-size", mask.options.workingSide,
                   "GrabCut runs at most this many pixels a side (0 = full resolution)")
      ->check(CLI::Range(0, 16384));
  maskCmd->add_option("--out", mask.out, "mask PNG to write (8-bit grey: 0 background, 255 foreground)")->required();

  // --threads and --strict are accepted after the command too (montage run P --out D --threads 1).
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) sub->fallthrough();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; any other mistake in the command line is a usage error.
    return app.exit(e) == 0 ? kExitDone : kExitUsage;
  }
  try {
    std::unique_ptr<ThreadLimit> threads;
    if (common.threads > 0) threads = std::make_unique<ThreadLimit>(common.threads);
    if (*info) return infoJson ? cmdInfoJson(infoFile, common) : cmdInfo(infoFile, common);
    if (*synthCmd) return cmdSynth(synth);
    if (*evalCmd) return cmdEval(evalResult, evalTruth, evalTexture, evalJson, evalSamples, evalOracle);
    if (*render) return cmdRender(renderArgs);
    if (*run) return cmdRun(runProject, runOut, runPng, runSets, common);
    if (*benchCmd) return cmdBench(bench);
    if (*maskCmd) return cmdMask(mask);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "usage error: %s\nRun with --help for more information.\n", printable(e.what()).c_str());
    return kExitUsage;
  } catch (const std::exception& e) {  // montage::Error and anything else: one line, exit status 1
    std::fprintf(stderr, "error: %s\n", printable(e.what()).c_str());
    if (*info && infoJson)  // a script reading stdout gets an answer too
      std::printf("%s\n", nlohmann::json({{"file", infoFile}, {"valid", false}, {"error", printable(e.what())}})
                               .dump(2)
                               .c_str());
    return kExitError;
  }
  return kExitDone;
}
