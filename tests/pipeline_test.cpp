// The pipeline object (stages, caching, cancel, report) and the `montage` command line end to end.
#include "pipeline.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>

#include "atlas/preview_model.h"
#include "bench/eval.h"
#include "bench/render.h"
#include "bench/synth.h"
#include "io/mesh_io.h"
#include "io/model.h"
#include "io/project_warnings.h"
#include "surface/preview.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace montage;

namespace {

std::string demoProject() {
  return test::assetsDir() + "/demo/project.json";
}

}  // namespace

TEST(Pipeline, RunsDemoAndReportsEveryStage) {
  Project project = loadProject(demoProject());
  Pipeline pipeline;
  std::vector<StageId> seen;
  JobControl job(nullptr, [&](StageId s, double, const std::string&) {
    if (seen.empty() || seen.back() != s) seen.push_back(s);
  });
  PipelineResult result = pipeline.run(project, job);
  const std::vector<StageId> order = {StageId::Load,       StageId::Camera,  StageId::Partition, StageId::Map,
                                      StageId::Projection, StageId::Balance, StageId::Seams,     StageId::Level,
                                      StageId::Inpaint,    StageId::Bake};
  ASSERT_EQ(result.stages.size(), order.size());
  for (size_t i = 0; i < order.size(); ++i) EXPECT_EQ(result.stages[i].stage, order[i]);
  EXPECT_EQ(seen, order);
  ASSERT_TRUE(result.model);
  ASSERT_TRUE(result.mapping);
  // Later stages work on the partition's mesh: the input plus its Steiner vertices.
  const Mesh& mesh = result.mapping->partition->mesh;
  EXPECT_GE(mesh.numVertices(), result.scene->mesh->numVertices());
  EXPECT_EQ(result.model->mesh.numFaces(), mesh.numFaces());
  // The exported model is the input mesh as loaded (exportTopology "original", the default).
  ASSERT_TRUE(result.exported);
  EXPECT_EQ(result.exported->mesh.numFaces(), result.scene->mesh->numFaces());
  EXPECT_EQ(result.exported->mesh.numVertices(), result.scene->mesh->numVertices());
  EXPECT_EQ(result.mapping->map.numFaces(), mesh.numFaces());
  EXPECT_GT(result.mapping->map.numMapped(), 0);
  EXPECT_EQ(result.stages[0].counts["photos"].get<int>(), static_cast<int>(project.photos.size()));
  EXPECT_GT(project.points.size(), 0u);
}

TEST(Pipeline, SecondRunReusesOutputsAndAFeatureEditRerunsOnlyTheMap) {
  Project project = loadProject(demoProject());
  Pipeline pipeline;
  PipelineResult first = pipeline.run(project);
  EXPECT_FALSE(first.stages[0].cached);
  EXPECT_FALSE(first.stages[1].cached);

  PipelineResult second = pipeline.run(project);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(second.stages[i].cached) << stageName(second.stages[i].stage);
  EXPECT_EQ(second.scene->mesh.get(), first.scene->mesh.get());  // the very same loaded mesh

  project.points.pop_back();
  PipelineResult third = pipeline.run(project);
  EXPECT_TRUE(third.stages[0].cached);
  for (int i = 1; i < 4; ++i) EXPECT_FALSE(third.stages[i].cached) << stageName(third.stages[i].stage);
}

TEST(Pipeline, SeamOptionEditRerunsTheSeamsNotTheMap) {
  Project project = loadProject(demoProject());
  Pipeline pipeline;
  PipelineResult first = pipeline.run(project);
  ASSERT_TRUE(first.seams);
  EXPECT_EQ(first.report()["seams"]["faces"].size(), first.report()["seams"]["face_delta_e"].size());
  project.options.seamLambda = 0.5;
  PipelineResult second = pipeline.run(project);
  const int seams = static_cast<int>(StageId::Seams);
  for (int i = 0; i < seams; ++i) EXPECT_TRUE(second.stages[i].cached) << stageName(second.stages[i].stage);
  ASSERT_EQ(second.stages[seams].stage, StageId::Seams);
  EXPECT_FALSE(second.stages[seams].cached);
  EXPECT_FALSE(second.stages[seams + 1].cached);  // level reads the seamed map
  EXPECT_NE(second.seams.get(), first.seams.get());
}

TEST(Pipeline, CancelStopsTheRun) {
  Project project = loadProject(demoProject());
  std::atomic<bool> cancel{true};
  Pipeline pipeline;
  EXPECT_THROW(pipeline.run(project, JobControl(&cancel, {})), Cancelled);
  cancel = false;
  EXPECT_NO_THROW(pipeline.run(project, JobControl(&cancel, {})));
}

// Issue 36: the pipeline declared once. Keys, reuse and cancellation come from the declaration.
TEST(StageGraph, KeysFollowTheDeclaredReadsAndFields) {
  StageGraph graph;
  const int a = graph.add({"a", {}, {"/options/x"}, "", 0.5});
  const int b = graph.add({"b", {a}, {"/options/y"}, "", 0.25});
  const int c = graph.add({"c", {}, {"/photos/*/locked"}, "", 0.25, true});
  EXPECT_THROW(graph.add({"d", {7}, {}, "", 0}), Error);            // reads a stage not declared before it
  EXPECT_THROW(graph.add({"e", {}, {"options/x"}, "", 0}), Error);  // not a JSON pointer
  const std::vector<double> preview = graph.typicalShares(true);
  EXPECT_NEAR(preview[a], 2.0 / 3, 1e-12);
  EXPECT_EQ(preview[c], 0);  // final only

  nlohmann::json doc = {{"options", {{"x", 1}, {"y", 2}}}, {"photos", {{{"locked", false}}, {{"path", "p"}}}}};
  const auto keys = [&](const nlohmann::json& d) {
    StageRun run(graph, d, {});
    std::vector<std::string> k;
    for (int i : {a, b, c}) k.push_back(run.begin(i));
    return k;
  };
  const std::vector<std::string> k0 = keys(doc);
  nlohmann::json changed = doc;
  changed["options"]["y"] = 3;  // b reads it; a does not
  std::vector<std::string> k1 = keys(changed);
  EXPECT_EQ(k1[0], k0[0]);
  EXPECT_NE(k1[1], k0[1]);
  EXPECT_EQ(k1[2], k0[2]);
  changed = doc;
  changed["options"]["x"] = 5;  // a reads it, and b reads a
  k1 = keys(changed);
  EXPECT_NE(k1[0], k0[0]);
  EXPECT_NE(k1[1], k0[1]);
  changed = doc;
  changed["photos"][1]["locked"] = true;  // "*": every photo's, a missing one reads as null
  EXPECT_NE(keys(changed)[2], k0[2]);

  // A memo serves its key; a stage cancelled while it makes its output leaves the memo as it was.
  StageMemo<int> memo;
  int made = 0;
  const auto make = [&] { return std::make_shared<const int>(++made); };
  {
    StageRun run(graph, doc, {});
    run.begin(a);
    EXPECT_EQ(*run.get(a, memo, make), 1);
    run.record(a, {{"n", 1}});
    EXPECT_FALSE(run.kept(a));
    ASSERT_EQ(run.records().size(), 1u);
    EXPECT_EQ(run.records()[0].name, "a");
  }
  {
    StageRun run(graph, doc, {});
    run.begin(a);
    EXPECT_EQ(*run.get(a, memo, make), 1);
    EXPECT_TRUE(run.kept(a));
    run.record(a, {});
    EXPECT_TRUE(run.records()[0].cached);
    EXPECT_EQ(run.records()[0].seconds, 0);
  }
  {
    StageRun run(graph, changed, {});
    run.begin(a);
    // Same x: the memo serves although photos changed (a does not read them).
    EXPECT_TRUE(run.get(a, memo, make) && run.kept(a));
  }
  nlohmann::json other = doc;
  other["options"]["x"] = 9;
  {
    StageRun run(graph, other, {});
    run.begin(a);
    EXPECT_THROW(run.get(a, memo, [&]() -> std::shared_ptr<const int> { throw Cancelled(); }), Cancelled);
  }
  StageRun again(graph, doc, {});
  again.begin(a);
  EXPECT_EQ(*again.get(a, memo, make), 1);  // the memo still holds the first output and its key
  EXPECT_EQ(made, 1);
}

// Every option the project format has is read by a declared stage (a field of its declaration), or by the
// load stage through the files' contents: an option no stage declares would leave stale outputs in place.
TEST(StageGraph, EveryProjectOptionIsDeclaredByTheStageThatReadsIt) {
  const StageGraph& graph = pipelineStages();
  ASSERT_EQ(graph.size(), int(kStageNames.size()));
  std::set<std::string> declared;
  for (int i = 0; i < graph.size(); ++i) {
    EXPECT_EQ(graph[i].name, kStageNames[size_t(i)]);
    for (const std::string& f : graph[i].fields) declared.insert(f);
  }
  const nlohmann::json document = nlohmann::json::parse(projectToJson(loadProject(demoProject()), ""));
  for (const auto& [name, value] : document["options"].items()) {
    if (name == "maxPhotoSide" || name == "weldIdenticalPositions") continue;  // load: in the contents' key
    EXPECT_TRUE(declared.count("/options/" + name)) << "option '" << name << "' is read by no declared stage";
  }
  for (const std::string& f : declared) {
    const std::string top = f.substr(0, f.find('/', 1));
    EXPECT_TRUE(document.contains(top.substr(1))) << f;
    if (top == "/options") EXPECT_TRUE(document["options"].contains(f.substr(9))) << f << " is not an option";
  }
}

// The check: a stage added to the declaration is run, keyed, reported and cancellable like the
// pipeline's own.
TEST(Pipeline, AnAddedStageIsKeyedReportedAndCancellable) {
  Project project = loadProject(demoProject());
  Pipeline pipeline;
  int calls = 0;
  std::atomic<bool> cancel{false};
  bool cancelInside = false;
  std::vector<std::string> seenStages;
  int lintIndex = -1;
  const int lint =
      pipeline.addStage({"lint", {int(StageId::Inpaint)}, {"/options/atlasSize"}, "", 0.05, true},
                        [&](const PipelineResult& soFar, const JobControl& job) {
                          ++calls;
                          EXPECT_TRUE(soFar.colors);
                          EXPECT_EQ(soFar.stages.back().name, "bake");
                          if (cancelInside) cancel = true;
                          job.progress(static_cast<StageId>(lintIndex), 0.5);
                          return nlohmann::json{{"inpainted_regions", soFar.colors->inpaint.regions.size()}};
                        });
  EXPECT_EQ(lint, int(kStageNames.size()));
  lintIndex = lint;
  const JobControl job(&cancel, [&](StageId s, double, const std::string&) {
    if (int(s) == lint && (seenStages.empty() || seenStages.back() != "lint")) seenStages.push_back("lint");
  });

  PipelineResult first = pipeline.run(project, job);
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(seenStages.size(), 1u);  // its start and its own progress, reported as its index
  nlohmann::json report = first.report();
  ASSERT_EQ(report["stages"].size(), 11u);
  EXPECT_EQ(report["stages"][9]["stage"], "bake");
  EXPECT_EQ(report["stages"][10]["stage"], "lint");
  EXPECT_EQ(report["stages"][10]["counts"]["inpainted_regions"], first.colors->inpaint.regions.size());
  EXPECT_FALSE(report["stages"][10]["cached"].get<bool>());

  // What it reads changed (atlasSize): the bake and it rerun, the inpainting is kept.
  project.options.atlasSize = 512;
  PipelineResult second = pipeline.run(project, job);
  EXPECT_EQ(calls, 2);
  EXPECT_TRUE(second.stages[int(StageId::Inpaint)].cached);
  EXPECT_FALSE(second.stages[int(StageId::Bake)].cached);
  EXPECT_FALSE(second.stages.back().cached);
  // What it does not read (the gutter): the bake reruns, it is kept.
  project.options.gutter = 3;
  PipelineResult third = pipeline.run(project, job);
  EXPECT_EQ(calls, 2);
  EXPECT_FALSE(third.stages[int(StageId::Bake)].cached);
  EXPECT_TRUE(third.stages.back().cached);
  EXPECT_EQ(third.stages.back().name, "lint");
  EXPECT_EQ(third.stages.back().counts, second.stages.back().counts);
  // Final only: the preview stops before it (another document state: a final result serves a preview request).
  project.options.gutter = 5;
  PipelineResult preview = pipeline.run(project, job, Tier::Preview);
  EXPECT_EQ(preview.stages.back().name, "inpaint");
  EXPECT_EQ(calls, 2);

  // Cancelled inside it: the run throws, and the next run makes it again (nothing half-made is kept); the
  // stages before it are kept.
  project.options.atlasSize = 256;
  cancelInside = true;
  EXPECT_THROW(pipeline.run(project, job), Cancelled);
  EXPECT_EQ(calls, 3);
  cancelInside = false;
  cancel = false;
  PipelineResult resumed = pipeline.run(project, job);
  EXPECT_EQ(calls, 4);
  EXPECT_TRUE(resumed.stages[int(StageId::Bake)].cached);
  EXPECT_FALSE(resumed.stages.back().cached);
  // Cancelled between the bake's last progress report and its start: its start is a cancellation point, so it
  // never runs; the next run keeps the bake and makes it.
  project.options.atlasSize = 1024;
  const JobControl cancelAfterBake(&cancel, [&](StageId s, double f, const std::string&) {
    if (s == StageId::Bake && f == 1.0) cancel = true;
  });
  EXPECT_THROW(pipeline.run(project, cancelAfterBake), Cancelled);
  EXPECT_EQ(calls, 4);
  cancel = false;
  PipelineResult after = pipeline.run(project, job);
  EXPECT_EQ(calls, 5);
  EXPECT_TRUE(after.stages[int(StageId::Bake)].cached);
}

TEST(Pipeline, NoFeaturesGivesOneEmptyPatchWithAReason) {
  Project project = loadProject(demoProject());
  project.points.clear();
  project.chains.clear();
  PipelineResult result = Pipeline().run(project);
  EXPECT_EQ(result.mapping->map.numMapped(), 0);
  ASSERT_FALSE(result.mapping->map.notes.empty());
  EXPECT_NE(result.mapping->map.notes[0].find("no features"), std::string::npos);
}

TEST(Pipeline, BadVertexIdIsRejectedWithItsField) {
  Project project = loadProject(demoProject());
  ASSERT_FALSE(project.points.empty());
  project.points[0].vertex = 10'000'000;
  try {
    Pipeline().run(project);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("points[0].vertex"), std::string::npos) << e.what();
  }
}

TEST(Pipeline, WritesModelAndReport) {
  Project project = loadProject(demoProject());
  PipelineResult result = Pipeline().run(project);
  const std::string dir = test::tempDir("pipeline_out");
  writeRunOutputs(result, dir);
  for (const char* name : {"model.obj", "model.mtl", "model_atlas.png", "model_atlas_source.png",
                           "model_atlas_holes.png", "model.glb", "report.json"})
    EXPECT_TRUE(fs::exists(fs::path(dir) / name)) << name;
  nlohmann::json report = test::readJson(dir + "/report.json");
  ASSERT_EQ(report["stages"].size(), kStageNames.size());
  std::map<std::string, nlohmann::json> stage;
  for (size_t i = 0; i < kStageNames.size(); ++i) {
    EXPECT_EQ(report["stages"][i]["stage"], kStageNames[i]);
    stage[kStageNames[i]] = report["stages"][i];
  }
  EXPECT_TRUE(stage["seams"]["counts"].contains("delta_e_after"));
  // The balance stage reports a transform per photo (the demo's two photos share seams).
  EXPECT_EQ(stage["balance"]["counts"]["gain"].size(), project.photos.size());
  EXPECT_EQ(stage["balance"]["counts"]["offset"].size(), project.photos.size());
  EXPECT_TRUE(stage["balance"]["counts"].contains("mismatch_after"));
  EXPECT_TRUE(report.contains("seams"));
  // The demo has holes: they are inpainted, and the model says which faces were.
  EXPECT_GT(stage["inpaint"]["counts"]["regions"].size(), 0u);
  int inpainted = 0;
  for (int s : result.model->faceSource) inpainted += s == kSourceInpainted;
  EXPECT_GT(inpainted, 0);
  EXPECT_GT(report["surface"]["inpainted_share"].get<double>(), 0.0);
  EXPECT_EQ(report["mesh"]["faces"].get<int>(), result.scene->mesh->numFaces());
  // The rejected pairs and their reasons reach the user.
  EXPECT_EQ(report["map"]["rejected_total"].get<size_t>(), result.mapping->partition->rejected.size());
  ASSERT_FALSE(report["map"]["rejected_pairs"].empty());
  EXPECT_FALSE(report["map"]["rejected_pairs"][0]["reason"].get<std::string>().empty());
  // One atlas: a single textured material, every face's UVs inside [0,1]^2.
  ASSERT_EQ(result.exported->materials.size(), 1u);
  // The automatic atlas size: a multiple of 256 that holds the photos at their own resolution.
  const int atlasSize = result.model->materials[0].texture.cols;
  EXPECT_EQ(atlasSize % 256, 0);
  EXPECT_EQ(stage["bake"]["counts"]["size"].get<int>(), atlasSize);
  EXPECT_DOUBLE_EQ(stage["bake"]["counts"]["scale"].get<double>(), 1.0);
  const int exportedSize = result.exported->materials[0].texture.cols;
  EXPECT_EQ(exportedSize % 256, 0);
  for (const auto& uv : result.exported->uv)
    for (const Vec2f& t : uv) EXPECT_TRUE(t.minCoeff() >= 0 && t.maxCoeff() <= 1) << t.transpose();
  EXPECT_GT(stage["bake"]["counts"]["utilisation"].get<double>(), 0.3);
  for (const char* name : {"model.glb", "model.obj"}) {
    TexturedModel back = loadModel(dir + "/" + name);
    EXPECT_EQ(back.mesh.numFaces(), result.exported->mesh.numFaces()) << name;
    ASSERT_EQ(back.materials.size(), 1u) << name;
    EXPECT_EQ(back.materials[0].texture.cols, exportedSize) << name;
  }
}

// The command line, end to end.
TEST(MontageCli, RunInfoRenderOnTheDemo) {
  const std::string out = test::tempDir("cli_run");
  std::string log;
  ASSERT_EQ(test::runCommand(test::montageExe() + " run " + demoProject() + " --out " + out, &log), 0) << log;
  EXPECT_TRUE(fs::exists(out + "/report.json"));
  ASSERT_EQ(test::runCommand(test::montageExe() + " info " + demoProject(), &log), 0) << log;
  EXPECT_NE(log.find("project is valid"), std::string::npos) << log;
  ASSERT_EQ(
      test::runCommand(test::montageExe() + " render " + out + "/model.obj --size 64 --out " + out + "/r.png", &log), 0)
      << log;
  EXPECT_TRUE(fs::exists(out + "/r.png"));
}

TEST(MontageCli, BadInputExitsNonZeroNamingTheFile) {
  const std::string dir = test::tempDir("cli_bad");
  const std::string bad = dir + "/broken.obj";
  std::ofstream(bad) << "v 0 0 0\nv 1 0 0\nf 1 2 7\n";
  std::string log;
  EXPECT_NE(test::runCommand(test::montageExe() + " info " + bad, &log), 0);
  EXPECT_NE(log.find("broken.obj"), std::string::npos) << log;
  EXPECT_NE(test::runCommand(test::montageExe() + " run " + dir + "/missing.json --out " + dir, &log), 0);
  EXPECT_NE(log.find("missing.json"), std::string::npos) << log;
}

TEST(MontageCli, EvalOfSpotAgainstItselfAndAgainstFlatGrey) {
  TM_REQUIRE_SHARED(mesh, "meshes/spot/spot_triangulated.obj");
  const std::string texture = test::sharedFile("meshes/spot/spot_texture.png");
  const std::string dir = test::tempDir("cli_eval");
  // The ground truth exported as a textured model, and a flat-grey copy of it.
  LoadedMesh loaded = loadMesh(mesh);
  cv::Mat bgr = cv::imread(texture, cv::IMREAD_COLOR), rgba;
  cv::cvtColor(bgr, rgba, cv::COLOR_BGR2RGBA);
  exportObj(modelFromMesh(*loaded.mesh, rgba), dir + "/truth", "model");
  exportObj(modelFromMesh(*loaded.mesh, cv::Mat(64, 64, CV_8UC4, cv::Scalar(128, 128, 128, 255))), dir + "/grey",
            "model");
  const std::string args = " --truth " + mesh + " --truth-texture " + texture + " --samples 50000 --json ";
  std::string log;
  ASSERT_EQ(test::runCommand(test::montageExe() + " eval --result " + dir + "/truth/model.obj" + args + dir + "/t.json",
                             &log),
            0)
      << log;
  ASSERT_EQ(
      test::runCommand(test::montageExe() + " eval --result " + dir + "/grey/model.obj" + args + dir + "/g.json", &log),
      0)
      << log;
  nlohmann::json truth = test::readJson(dir + "/t.json"), grey = test::readJson(dir + "/g.json");
  EXPECT_GE(truth["psnr_all"].get<double>(), 60.0) << truth.dump();
  EXPECT_EQ(truth["flipped_triangles"].get<int>(), 0);
  EXPECT_LT(grey["psnr_all"].get<double>(), 20.0) << grey.dump();
}

// Issue 3's end-to-end check on a ground-truth scene: spot rendered from 4 views; more features give
// better coverage and a closer match to the truth.
TEST(PipelineSpot, CoverageAndPsnrRiseWithFeatures) {
  TM_REQUIRE_SHARED(meshPath, "meshes/spot/spot_triangulated.obj");
  const std::string texturePath = test::sharedFile("meshes/spot/spot_texture.png");
  const auto mesh = requireUsable(loadMesh(meshPath));
  const TexturedModel truth = modelFromMesh(*mesh, readImageRgba8(texturePath));
  const SurfaceColor color = [&](int f, const Vec3& b) { return truth.colorAt(f, b); };
  std::vector<double> psnr;
  for (int features : {50, 150, 300}) {
    SynthOptions options;
    options.views = 4;
    options.features = features;
    options.size = 1024;
    const std::string dir = test::tempDir("spot_scene");
    writeSynthScene(synthesize(*mesh, meshPath, color, options), dir);
    Project project = loadProject(dir + "/project.json");
    project.options.cameraMode = CameraMode::Off;  // the paper's path (camera_test measures the projection path)
    const PipelineResult result = Pipeline().run(project);
    EXPECT_EQ(result.mapping->stats.flippedFaces, 0);
    EvalOptions evalOptions;
    evalOptions.samples = 100000;
    const EvalResult eval = evaluate(*result.model, truth, evalOptions);
    std::printf("spot, 4 views, %d features: coverage %.1f%%, PSNR covered %.2f dB, all %.2f dB, flips %d\n", features,
                100 * eval.coveragePhoto, eval.psnrCovered, eval.psnrAll, eval.flippedTriangles);
    EXPECT_EQ(eval.flippedTriangles, 0);
    if (features == 150) EXPECT_GE(eval.coveragePhoto, 0.60);
    psnr.push_back(eval.psnrCovered);
  }
  EXPECT_LT(psnr[0], psnr[1]);
  EXPECT_LT(psnr[1], psnr[2]);
}

// ---------------------------------------------------------------------------------------------
// The live loop: incremental runs equal runs from scratch; undo finds its result; the preview looks
// like the final bake.

namespace {

// Deletes point `index`, dropping it from chains (a chain left with fewer than two points goes).
void deletePoint(Project& p, int index) {
  p.points.erase(p.points.begin() + index);
  for (FeatureChain& c : p.chains) {
    c.points.erase(std::remove(c.points.begin(), c.points.end(), index), c.points.end());
    for (int& i : c.points) i -= i > index;
  }
  p.chains.erase(
      std::remove_if(p.chains.begin(), p.chains.end(), [](const FeatureChain& c) { return c.points.size() < 2; }),
      p.chains.end());
}

}  // namespace

// ---- One validation for info and run, warnings, working resolution (issue 15) ----

namespace {

// A demo point's vertex that has a position in photo 0, and a vertex the demo does not use.
int unusedVertex(const Project& p, int after) {
  for (int v = after;; ++v) {
    bool used = false;
    for (const FeaturePoint& f : p.points) used = used || f.vertex == v;
    if (!used) return v;
  }
}

}  // namespace

TEST(PipelineIncremental, RandomEditsEqualRunsFromScratch) {
  const Project base = loadProject(demoProject());
  std::mt19937 rng(20261201);
  Pipeline incremental;
  std::vector<Project> history = {base};
  std::vector<FeaturePoint> removed;
  int moves = 0, adds = 0, deletes = 0, undos = 0, reusedCells = 0, finals = 0;
  for (int step = 0; step < 24; ++step) {
    Project doc = history.back();
    const int kind = std::uniform_int_distribution<int>(0, 9)(rng);
    std::string what;
    if (kind < 2 && history.size() > 1) {  // undo
      history.pop_back();
      doc = history.back();
      what = "undo";
      ++undos;
    } else if (kind < 4 && !removed.empty() &&
               std::none_of(doc.points.begin(), doc.points.end(),
                            [&](const FeaturePoint& q) { return q.vertex == removed.back().vertex; })) {
      // add a deleted point back, a few pixels away
      FeaturePoint p = removed.back();
      removed.pop_back();
      for (PhotoPoint& at : p.at) at.x += std::uniform_real_distribution<double>(-2, 2)(rng);
      doc.points.push_back(p);
      what = "add";
      ++adds;
    } else if (kind < 6 && doc.points.size() > 20) {  // delete
      const int i = std::uniform_int_distribution<int>(0, int(doc.points.size()) - 1)(rng);
      removed.push_back(doc.points[i]);
      deletePoint(doc, i);
      what = "delete";
      ++deletes;
    } else {  // drag one click by a few pixels
      const int i = std::uniform_int_distribution<int>(0, int(doc.points.size()) - 1)(rng);
      if (doc.points[i].at.empty()) continue;
      PhotoPoint& at = doc.points[i].at[0];
      at.x = std::clamp(at.x + std::uniform_real_distribution<double>(-4, 4)(rng), 1.0, 1000.0);
      at.y = std::clamp(at.y + std::uniform_real_distribution<double>(-4, 4)(rng), 1.0, 1000.0);
      what = "move";
      ++moves;
    }
    if (what != "undo") history.push_back(doc);
    // As the editor does: the quick preview and the preview after each edit (they may start from the last
    // run: camera, view selection, seams), the final every third step; the final equals a fresh run's (whose
    // preview starts from nothing, so its mapping is the final's).
    const PipelineResult quick = incremental.run(doc, {}, Tier::Quick);
    const PipelineResult preview = incremental.run(doc, {}, Tier::Preview);
    for (const PipelineResult* r : {&quick, &preview})
      for (const StageRecord& s : r->stages)
        if (s.stage == StageId::Map && !s.cached) reusedCells += s.counts["cells_reused"].get<int>();
    if (step % 3 != 2) continue;
    const PipelineResult inc = incremental.run(doc, {}, Tier::Final);
    const PipelineResult fresh = Pipeline().run(doc, {}, Tier::Preview);
    test::expectSameMapping(*inc.mapping, *fresh.mapping, "step " + std::to_string(step) + " (" + what + ")");
    ++finals;
  }
  std::printf("%d moves, %d adds, %d deletes, %d undos; %d cells reused in all\n", moves, adds, deletes, undos,
              reusedCells);
  EXPECT_GE(moves + adds + deletes + undos, 20);
  EXPECT_GT(moves, 0);
  EXPECT_GT(deletes, 0);
  EXPECT_GT(undos, 0);
  EXPECT_GT(reusedCells, 0);  // the incremental runs did reuse cells
  EXPECT_GE(finals, 6);
}

// Issue 36: the editor shows a quick preview first (every hole harmonic), then the preview refines it; the
// refinement reruns only the inpainting.
TEST(PipelineTiers, AQuickPreviewFillsHolesHarmonicallyAndThePreviewRedoesOnlyTheInpainting) {
  Project project = loadProject(demoProject());
  ASSERT_EQ(project.options.inpaintMode, InpaintMode::Texture);  // the default
  EXPECT_TRUE(quickDiffers(project));
  Pipeline pipeline;
  const PipelineResult quick = pipeline.run(project, {}, Tier::Quick);
  EXPECT_EQ(quick.tier, Tier::Quick);
  ASSERT_FALSE(quick.colors->inpaint.regions.empty());
  for (const InpaintRegion& r : quick.colors->inpaint.regions)
    if (r.kind == InpaintRegion::Kind::Hole) EXPECT_EQ(r.mode, InpaintMode::Harmonic) << r.note;
  EXPECT_EQ(quick.stages[int(StageId::Inpaint)].counts["tier"], "quick");

  const PipelineResult preview = pipeline.run(project, {}, Tier::Preview);
  for (const StageRecord& s : preview.stages)
    EXPECT_EQ(s.cached, s.stage < StageId::Inpaint) << s.name;  // the same mapping, levelling included
  int textured = 0;
  for (const InpaintRegion& r : preview.colors->inpaint.regions) textured += r.mode == InpaintMode::Texture;
  EXPECT_GT(textured, 0);
  EXPECT_EQ(preview.mapping.get(), quick.mapping.get());
  // A request for the quick preview of this state now gets the preview (the better result); a preview
  // request never gets a quick one.
  const PipelineResult again = pipeline.run(project, {}, Tier::Quick);
  EXPECT_EQ(again.tier, Tier::Preview);
  EXPECT_EQ(again.colors.get(), preview.colors.get());
  project.points[3].at[0].x += 2;
  const PipelineResult quick2 = pipeline.run(project, {}, Tier::Quick);
  EXPECT_EQ(pipeline.run(project, {}, Tier::Preview).tier, Tier::Preview);
  EXPECT_EQ(quick2.tier, Tier::Quick);

  // Its model (ui/worker.cpp: smoothInpaint) shows the inpainted faces by their corners' colours, no atlas:
  // rendered as the shader draws it, it is the atlas model of the same result within what a smooth fill
  // varies inside a face.
  std::vector<cv::Mat> textures;
  for (const auto& p : quick2.balanced->sources) textures.push_back(previewTexture(*p));
  const Mesh& mesh = quick2.mapping->partition->mesh;
  const auto model = [&](bool smooth) {
    return previewModel(mesh, quick2.mapping->map, quick2.balanced->scene->photos, textures,
                        &quick2.colors->levelling, &quick2.colors->inpaint, quick2.balanced->balance.transforms, {},
                        smooth);
  };
  const TexturedModel smooth = model(true), atlas = model(false);
  EXPECT_EQ(smooth.materials[textures.size()].texture.total(), 1u);  // no atlas
  EXPECT_GT(atlas.materials[textures.size()].texture.total(), 1u);
  const auto drawn = [](const TexturedModel& m) {
    return [&m](int f, const Vec3& b) {
      Vec3f c = m.colorAt(f, b);
      for (int k = 0; k < 3; ++k) c += float(b[k]) * m.cornerColor[f][k];
      return Vec3f(c.cwiseMax(0.f).cwiseMin(1.f));
    };
  };
  RenderOptions view;
  view.size = 384;
  const cv::Mat a = renderSurface(mesh, drawn(smooth), view), b = renderSurface(mesh, drawn(atlas), view);
  double sum = 0;
  long n = 0;  // over the surface's pixels (the background is exact grey)
  for (int y = 0; y < a.rows; ++y)
    for (int x = 0; x < a.cols; ++x) {
      const cv::Vec4b pa = a.at<cv::Vec4b>(y, x), pb = b.at<cv::Vec4b>(y, x);
      if (pb[0] == 235 && pb[1] == 235 && pb[2] == 235) continue;
      for (int c = 0; c < 3; ++c) sum += (pa[c] - pb[c]) * (pa[c] - pb[c]) / (255.0 * 255.0);
      ++n;
    }
  ASSERT_GT(n, 1000);
  const double psnr = 10 * std::log10(3.0 * n / std::max(sum, 1e-12));
  std::printf("quick preview model, corner colours against its atlas: %.1f dB\n", psnr);
  EXPECT_GT(psnr, 35);

  // Harmonic everywhere: the quick preview would be the preview.
  project.options.inpaintMode = InpaintMode::Harmonic;
  EXPECT_FALSE(quickDiffers(project));
  project.holeModes.push_back({0, InpaintMode::Rbf, {}});
  EXPECT_TRUE(quickDiffers(project));
}

TEST(PipelineIncremental, UndoReturnsTheIdenticalResult) {
  const Project a = loadProject(demoProject());
  Project b = a;
  b.points[3].at[0].x += 2;
  Pipeline pipeline;
  const PipelineResult first = pipeline.run(a, {}, Tier::Preview);
  const PipelineResult edited = pipeline.run(b, {}, Tier::Preview);
  EXPECT_NE(edited.mapping.get(), first.mapping.get());
  const PipelineResult undone = pipeline.run(a, {}, Tier::Preview);
  EXPECT_EQ(undone.mapping.get(), first.mapping.get());  // the very same objects, not a recomputation
  EXPECT_EQ(undone.colors.get(), first.colors.get());
  for (const StageRecord& s : undone.stages) EXPECT_TRUE(s.cached) << stageName(s.stage);
  // A final result serves a later preview request of its state; a preview does not serve a final one.
  const PipelineResult final = pipeline.run(b, {}, Tier::Final);
  EXPECT_TRUE(final.model);
  EXPECT_EQ(pipeline.run(b, {}, Tier::Preview).model.get(), final.model.get());
  EXPECT_EQ(pipeline.findResult(a, Tier::Final), nullptr);
}

namespace {

// Renders `preview` (as PreviewSurface reads it, and as the editor's preview model draws it) and the
// final bake of the same document from three sides, and checks their PSNR away from silhouettes. Returns
// how many faces the preview inpainted.
int expectPreviewLooksLikeFinal(const PipelineResult& preview, const PipelineResult& final, const std::string& label) {
  EXPECT_FALSE(preview.model);
  EXPECT_TRUE(final.model);
  if (!final.model) return 0;
  std::vector<const Photo*> photos;
  for (const auto& p : preview.balanced->scene->photos) photos.push_back(p.get());
  const PreviewSurface surface(preview.mapping->map, photos, &preview.colors->levelling, &preview.colors->inpaint);
  const Mesh& mesh = preview.mapping->partition->mesh;
  // The preview model the editor draws (the photos before colour balance sampled through their UVs, their
  // balance applied as they are read, plus the corner colours, as shaders/mesh.frag does; ui/worker.cpp
  // builds it so), checked against the final bake as well.
  std::vector<cv::Mat> textures;
  for (const auto& p : preview.balanced->sources) textures.push_back(previewTexture(*p));
  const TexturedModel gpu =
      previewModel(mesh, preview.mapping->map, preview.balanced->scene->photos, textures, &preview.colors->levelling,
                   &preview.colors->inpaint, preview.balanced->balance.transforms);
  auto gpuColor = [&](int f, const Vec3& b) {
    Vec3f c = gpu.colorAt(f, b);
    for (int k = 0; k < 3; ++k) c += float(b[k]) * gpu.cornerColor[f][k];
    return Vec3f(c.cwiseMax(0.f).cwiseMin(1.f));
  };
  for (double yaw : {30.0, 150.0, 270.0}) {
    RenderOptions options;
    options.size = 512;
    options.yawDeg = yaw;
    const cv::Mat a = renderSurface(
        mesh, [&](int f, const Vec3& b) { return surface.color(f, b); }, options);
    const cv::Mat g = renderSurface(mesh, gpuColor, options);
    const cv::Mat b = renderModel(*final.model, options);
    // Pixels away from silhouettes: the surface on all 8 neighbours too (the background is exact grey).
    cv::Mat onSurface;
    cv::inRange(b, cv::Scalar(235, 235, 235, 255), cv::Scalar(235, 235, 235, 255), onSurface);
    cv::bitwise_not(onSurface, onSurface);
    cv::erode(onSurface, onSurface, cv::Mat::ones(3, 3, CV_8U));
    double sum = 0, sumGpu = 0;
    long n = 0;
    for (int y = 0; y < a.rows; ++y)
      for (int x = 0; x < a.cols; ++x) {
        if (!onSurface.at<uchar>(y, x)) continue;
        for (int k = 0; k < 3; ++k) {
          const double d = (a.at<cv::Vec4b>(y, x)[k] - b.at<cv::Vec4b>(y, x)[k]) / 255.0;
          const double e = (g.at<cv::Vec4b>(y, x)[k] - b.at<cv::Vec4b>(y, x)[k]) / 255.0;
          sum += d * d;
          sumGpu += e * e;
        }
        ++n;
      }
    EXPECT_GT(n, 1000);
    const double psnr = 10 * std::log10(3.0 * n / std::max(sum, 1e-12));
    const double psnrGpu = 10 * std::log10(3.0 * n / std::max(sumGpu, 1e-12));
    std::printf("%s, yaw %.0f: preview vs final PSNR %.2f dB (the editor's preview model: %.2f dB) over %ld pixels\n",
                label.c_str(), yaw, psnr, psnrGpu, n);
    EXPECT_GE(psnr, 35.0) << label << ", yaw " << yaw;
    EXPECT_GE(psnrGpu, 35.0) << label << ", yaw " << yaw;
    if (const char* dir = std::getenv("TM_TEST_IMAGES")) {  // to look at: preview | final
      cv::Mat side;
      cv::hconcat(a, b, side);
      cv::cvtColor(side, side, cv::COLOR_RGBA2BGRA);
      cv::imwrite(std::string(dir) + "/preview_final_" + label + "_" + std::to_string(int(yaw)) + ".png", side);
    }
  }
  int holesSeen = 0;
  for (int r : preview.colors->inpaint.faceRegion) holesSeen += r >= 0;
  return holesSeen;
}

}  // namespace

// Every inpainting mode: the preview inpaints on a coarser refinement, which must not change the look.
TEST(PipelineTiers, PreviewLooksLikeTheFinalBake) {
  for (InpaintMode mode : {InpaintMode::Harmonic, InpaintMode::Rbf, InpaintMode::Synthesis, InpaintMode::Structure}) {
    SCOPED_TRACE(kInpaintModeNames[size_t(mode)]);
    Project project = loadProject(demoProject());
    project.options.inpaintMode = mode;
    Pipeline pipeline;
    const PipelineResult preview = pipeline.run(project, {}, Tier::Preview);
    const PipelineResult final = pipeline.run(project, {}, Tier::Final);
    EXPECT_EQ(preview.mapping.get(), final.mapping.get());  // both tiers come from one mapping
    // The demo has inpainted faces: the comparison covers them.
    EXPECT_GT(expectPreviewLooksLikeFinal(preview, final, kInpaintModeNames[size_t(mode)]), 0);
  }
}

// After a drag the preview does not retry the flattening of a large hole whose band folded in the last run and
// which keeps nine in ten of its faces (SynthesisMemo::flatteningFailedNear): those LSCM retries were most of a
// preview's cost while the first clicks leave large holes. The final tries again, and the two still look alike.
TEST(PipelineTiers, ADraggedPreviewDoesNotRetryALargeHoleThatDidNotFlatten) {
  Project project = loadProject(demoProject());
  project.options.inpaintMode = InpaintMode::Structure;
  Pipeline pipeline;
  const PipelineResult first = pipeline.run(project, {}, Tier::Preview);
  const InpaintRegion* big = nullptr;
  for (const InpaintRegion& g : first.colors->inpaint.regions)
    if (!big || g.unknowns > big->unknowns) big = &g;
  ASSERT_NE(big, nullptr);
  ASSERT_EQ(big->note, "synthesis: the hole and its band do not flatten without folds");  // tried, and failed
  for (FeaturePoint& p : project.points)
    for (PhotoPoint& at : p.at) at.x += 2;  // every click 2 px right: the holes' borders move a little
  const PipelineResult dragged = pipeline.run(project, {}, Tier::Preview);
  const PipelineResult draggedFinal = pipeline.run(project, {}, Tier::Final);
  int near = 0, retried = 0;
  for (const InpaintRegion& g : dragged.colors->inpaint.regions) {
    if (g.unknowns < big->unknowns / 2) continue;  // the large holes
    std::printf("dragged preview, %d unknowns: %s (%.3f s guidance)\n", g.unknowns, g.note.c_str(), g.guidanceSeconds);
    near += g.note.find("nine in ten") != std::string::npos;
    retried += g.note == "synthesis: the hole and its band do not flatten without folds";
  }
  EXPECT_GT(near, 0);  // the drag changed the large hole, and the memo knew it anyway
  EXPECT_EQ(retried, 0);
  for (const InpaintRegion& g : draggedFinal.colors->inpaint.regions)
    EXPECT_EQ(g.note.find("nine in ten"), std::string::npos) << g.note;  // the final tries again
  EXPECT_GT(expectPreviewLooksLikeFinal(dragged, draggedFinal, "dragged_structure"), 0);
}

// After edits the preview keeps syntheses whose charts still cover their holes (SynthesisMemo), while
// the final synthesises them again (and, after edits, fits cameras, selects views and moves seams from
// scratch where the preview started from the last run): the two must still look alike. The demo's one hole does not
// flatten (its synthesis falls back to rbf), so this runs on a synthetic turtle scene whose unseen parts leave holes
// that do.
TEST(PipelineTiers, PreviewAfterEditsKeepsSynthesesAndLooksLikeTheFinalBake) {
  const auto mesh = requireUsable(loadMesh(test::testDataDir() + "/turtle.obj"));
  SynthOptions options;
  options.views = 3;
  options.features = 120;
  options.size = 512;
  const std::string dir = test::tempDir("preview_after_edits");
  writeSynthScene(synthesize(*mesh, test::testDataDir() + "/turtle.obj", meshPattern(*mesh), options), dir);
  Project project = loadProject(dir + "/project.json");
  project.options.inpaintMode = InpaintMode::Structure;
  Pipeline pipeline;
  pipeline.run(project, {}, Tier::Preview);
  project.points[3].at[0].x += 3;  // a drag
  pipeline.run(project, {}, Tier::Preview);
  deletePoint(project, 5);
  const PipelineResult preview = pipeline.run(project, {}, Tier::Preview);
  int chartsKept = 0, synthesised = 0;
  for (const InpaintRegion& r : preview.colors->inpaint.regions) {
    chartsKept += r.synthesisKept == SynthesisKept::Chart;
    synthesised += r.note.find("texel chart") != std::string::npos;
  }
  std::printf("after a drag and a delete: %d of %d synthesised holes kept a chart\n", chartsKept, synthesised);
  EXPECT_GT(chartsKept, 0);
  const PipelineResult final = pipeline.run(project, {}, Tier::Final);
  for (const InpaintRegion& r : final.colors->inpaint.regions) EXPECT_NE(r.synthesisKept, SynthesisKept::Chart);
  EXPECT_GT(expectPreviewLooksLikeFinal(preview, final, "structure_after_edits"), 0);
}

// ---- Meshes split at UV seams (issue 33) ----

namespace {

std::string turtlePath() {
  return test::testDataDir() + "/turtle.obj";
}

// A synthetic scene (512 px photos) of `photographed`, the turtle or a twin of it with its vertex ids; the project
// names the turtle's file.
Project turtleScene(const Mesh& photographed, int views, int features, const std::string& name) {
  SynthOptions options;
  options.views = views;
  options.features = features;
  options.size = 512;
  const std::string dir = test::tempDir(name);
  writeSynthScene(synthesize(photographed, turtlePath(), meshPattern(photographed), options), dir);
  return loadProject(dir + "/project.json");
}

// `mesh` with each vertex on the line between faces whose centroid lies at x > 0 and the others copied (appended),
// the copy taking the x > 0 faces' corners: the surface falls apart along that seam, as a mesh split at UV seams
// does (positions repeat). copyOf[v] is the copy of vertex v, or -1.
std::unique_ptr<Mesh> splitAtSeam(const Mesh& mesh, std::vector<int>& copyOf) {
  std::vector<Vec3> positions;
  for (int v = 0; v < mesh.numVertices(); ++v) positions.push_back(mesh.position(v));
  auto right = [&](int f) {
    const auto q = mesh.facePositions(f);
    return (q[0] + q[1] + q[2]).x() > 0;
  };
  std::vector<char> sides(mesh.numVertices(), 0);  // bit 1: a face at x > 0, bit 2: another
  for (int f = 0; f < mesh.numFaces(); ++f)
    for (int v : mesh.faceVertices(f)) sides[v] |= right(f) ? 1 : 2;
  copyOf.assign(mesh.numVertices(), -1);
  for (int v = 0; v < mesh.numVertices(); ++v)
    if (sides[v] == 3) copyOf[v] = static_cast<int>(positions.size()), positions.push_back(mesh.position(v));
  std::vector<std::array<int, 3>> faces;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    auto fv = mesh.faceVertices(f);
    if (right(f))
      for (int& v : fv)
        if (copyOf[v] >= 0) v = copyOf[v];
    faces.push_back(fv);
  }
  return requireUsable(buildMesh(positions, faces));
}

double photoShare(const PipelineResult& r) {
  return r.report()["surface"]["photo_share"].get<double>();
}

}  // namespace

TEST(PipelineWeld, AMeshSplitAtSeamsMapsAsItsWeldedTwinAndExportsItsOwnVertices) {
  const auto mesh = requireUsable(loadMesh(turtlePath()));
  const Project whole = turtleScene(*mesh, 3, 90, "weld");
  const std::string dir = fs::path(whole.file).parent_path().string();

  std::vector<int> copyOf;
  const auto split = splitAtSeam(*mesh, copyOf);
  const int seamCopies = split->numVertices() - mesh->numVertices();
  ASSERT_GT(seamCopies, 20);  // the seam's vertices
  const std::string splitPath = dir + "/turtle_split.obj";
  saveMeshObj(*split, splitPath);
  ASSERT_GT(loadMesh(splitPath).report.components, 1);
  // The same clicks on the split mesh; a vertex on the seam is named by its copy.
  Project apart = whole;
  apart.mesh = splitPath;
  int renamed = 0;
  for (FeaturePoint& p : apart.points)
    if (copyOf[p.vertex] >= 0) p.vertex = copyOf[p.vertex], ++renamed;
  ASSERT_GE(renamed, 2);

  for (CameraMode camera : {CameraMode::Auto, CameraMode::Off}) {
    SCOPED_TRACE(kCameraModeNames[size_t(camera)]);
    Project a = whole, b = apart;
    a.options.cameraMode = b.options.cameraMode = camera;
    const PipelineResult onWhole = Pipeline().run(a);
    const PipelineResult onSplit = Pipeline().run(b);
    ASSERT_TRUE(onSplit.scene->welded());
    test::expectSameMapping(*onWhole.mapping, *onSplit.mapping, "split vs whole");
    EXPECT_NEAR(photoShare(onSplit), photoShare(onWhole), 0.005);
    std::printf("camera %s: photo share %.1f%% whole, %.1f%% split at a seam (%d copies)\n",
                kCameraModeNames[size_t(camera)], 100 * photoShare(onWhole), 100 * photoShare(onSplit), seamCopies);
    // The export keeps the split mesh's own vertices, in its order.
    ASSERT_TRUE(onSplit.exported);
    ASSERT_EQ(onSplit.exported->mesh.numVertices(), split->numVertices());
    for (int v = 0; v < split->numVertices(); v += 7) EXPECT_EQ(onSplit.exported->mesh.position(v), split->position(v));
    // Proposals name vertices of the split mesh (the first of those at a position) as the document does.
    for (const Proposal& pr : onSplit.proposals) {
      ASSERT_LT(pr.vertex, split->numVertices());
      EXPECT_EQ(split->position(pr.vertex),
                onSplit.mapping->partition->mesh.position(onSplit.scene->vertexOf->at(pr.vertex)));
    }
    if (camera == CameraMode::Off) {
      // Unwelded, the paper's path stops at the seam: regions touching it stay empty.
      b.options.weldIdenticalPositions = false;
      const PipelineResult unwelded = Pipeline().run(b);
      EXPECT_FALSE(unwelded.scene->welded());
      std::printf("  unwelded: photo share %.1f%%\n", 100 * photoShare(unwelded));
      EXPECT_LT(photoShare(unwelded), photoShare(onWhole) - 0.02);
    }
  }
}

// ---- Photos of another subject with a known truth (issue 33) ----

namespace {

// The turtle bent, stretched and sheared: a subject of the same kind as the turtle, its proportions not (the same
// vertex ids, so the true correspondence is known).
std::unique_ptr<Mesh> deformedTwin(const Mesh& mesh) {
  Vec3 lo = mesh.position(0), hi = lo;
  for (int v = 0; v < mesh.numVertices(); ++v) lo = lo.cwiseMin(mesh.position(v)), hi = hi.cwiseMax(mesh.position(v));
  const Vec3 centre = (lo + hi) / 2, half = (hi - lo) / 2;
  const double size = half.norm();
  std::vector<Vec3> positions;
  for (int v = 0; v < mesh.numVertices(); ++v) {
    const Vec3 q = (mesh.position(v) - centre).cwiseQuotient(half);  // in [-1, 1]^3
    Vec3 p = mesh.position(v) - centre;
    p.x() *= 1.25;                                              // longer
    p.y() *= 0.8;                                               // flatter
    p.y() += 0.25 * size * q.x() * q.x();                       // bent
    p.z() += 0.15 * size * q.x() + 0.1 * size * q.y() * q.x();  // sheared and twisted
    positions.push_back(centre + p);
  }
  std::vector<std::array<int, 3>> faces;
  for (int f = 0; f < mesh.numFaces(); ++f) faces.push_back(mesh.faceVertices(f));
  return requireUsable(buildMesh(positions, faces));
}

// Where the mapping puts vertex v in photo k: the mean of its corners' UVs on the faces mapped from k; NaN when no
// such face holds it.
Vec2 mappedAt(const Mapping& mapping, int v, int k) {
  const Mesh& mesh = mapping.partition->mesh;
  Vec2 sum = Vec2::Zero();
  int n = 0;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    if (mapping.map.facePhoto[f] != k) continue;
    const auto fv = mesh.faceVertices(f);
    for (int c = 0; c < 3; ++c)
      if (fv[c] == v) sum += mapping.map.cornerUV[f][c], ++n;
  }
  return n ? Vec2(sum / n) : Vec2(NAN, NAN);
}

}  // namespace

TEST(PipelineSubject, HeldOutClicksOfADeformedTwinLandWhereThePapersMapAloneMissesThem) {
  // Photos of a deformed turtle, clicked onto the turtle: photos of another subject whose true correspondence is
  // known. A quarter of the clicks are held out; each should land, in the mapping, at its true place in the photo.
  const auto mesh = requireUsable(loadMesh(turtlePath()));
  const Project all = turtleScene(*deformedTwin(*mesh), 2, 96, "subject_heldout");
  Project clicked = all;
  clicked.points.clear();
  std::vector<FeaturePoint> heldOut;
  for (size_t i = 0; i < all.points.size(); ++i) (i % 4 == 3 ? heldOut : clicked.points).push_back(all.points[i]);
  std::printf("%zu points, %zu held out\n", all.points.size(), heldOut.size());
  ASSERT_GE(heldOut.size(), 8u);
  for (PhotoRef& photo : clicked.photos) photo.mode = PhotoMode::Subject;

  // The subject's size in each photo: the diagonal of its clicks' bounding box.
  std::vector<Eigen::AlignedBox2d> extent(all.photos.size());
  for (const FeaturePoint& p : all.points)
    for (const PhotoPoint& q : p.at) extent[q.photo].extend(Vec2(q.x, q.y));
  // Per held-out click: the distance from where the mapping puts its vertex to the click, as a share of the
  // subject's size in that photo (1 when the mapping does not map the vertex from that photo).
  auto errors = [&](const PipelineResult& r) {
    std::vector<double> e;
    for (const FeaturePoint& p : heldOut)
      for (const PhotoPoint& q : p.at) {
        const Vec2 uv = mappedAt(*r.mapping, r.scene->meshVertex(p.vertex), q.photo);  // the document's id
        const double size = extent[q.photo].diagonal().norm();
        e.push_back(uv.allFinite() ? (uv - Vec2(q.x, q.y)).norm() / size : 1.0);
      }
    std::sort(e.begin(), e.end());
    return e;
  };
  const PipelineResult subject = Pipeline().run(clicked);
  Project paperOnly = clicked;
  paperOnly.options.cameraMode = CameraMode::Off;
  const PipelineResult paper = Pipeline().run(paperOnly);
  const std::vector<double> warped = errors(subject), pieces = errors(paper);
  auto median = [](const std::vector<double>& e) { return e[e.size() / 2]; };
  auto mapped = [](const std::vector<double>& e) {
    return std::count_if(e.begin(), e.end(), [](double x) { return x < 1; });
  };
  auto mappedMedian = [&](const std::vector<double>& e) {  // over the clicks mapped from their photo
    return median(std::vector<double>(e.begin(), e.begin() + std::max<long>(1, mapped(e))));
  };
  std::printf(
      "held-out clicks (%zu): camera and warp median %.1f%% of the subject's size, %ld mapped (median over "
      "those %.1f%%); paper's map alone median %.1f%%, %ld mapped (median over those %.1f%%)\n",
      warped.size(), 100 * median(warped), mapped(warped), 100 * mappedMedian(warped), 100 * median(pieces),
      mapped(pieces), 100 * mappedMedian(pieces));
  ASSERT_EQ(subject.cameras->subjects, int(clicked.photos.size()));
  for (const CameraFit& fit : subject.cameras->fits) {  // a camera fitted to every click: none dropped
    EXPECT_TRUE(fit.subject);
    EXPECT_EQ(fit.inliers, int(fit.clicks.size()));
  }
  constexpr double kThreshold = 0.025;
  EXPECT_EQ(mapped(warped), long(warped.size()));
  EXPECT_LT(median(warped), kThreshold);
  EXPECT_GT(median(pieces), kThreshold);
}

TEST(PipelineValidation, InfoAndRunRejectTheSameClone) {
  // `info` said "project is valid" for a clone that `run` then rejected.
  Project project = loadProject(demoProject());
  const auto loaded = loadScene(project);
  const Scene& scene = *loaded;
  CloneOp clone;
  clone.photo = 0;
  clone.polygon = {Vec2(10, 10), Vec2(60, 10), Vec2(30, 50)};
  clone.targetFaces = {0, 1, 2};
  clone.anchorVertex = scene.mesh->faceVertices(0)[0];
  clone.anchor = Vec2(700, 700);  // the photo maps far from the polygon
  clone.pixelsPerUnit = 1;
  project.clones = {clone};
  const std::string atLoad = test::errorOf([&] { loadScene(project); });
  EXPECT_NE(atLoad.find("clones[0]: the polygon maps onto no point of the target region inside the photo"),
            std::string::npos)
      << atLoad;
  project.clones[0].anchorVertex = scene.mesh->faceVertices(500)[0];  // not a corner of the target
  const std::string anchor = test::errorOf([&] { loadScene(project); });
  EXPECT_NE(anchor.find("clones[0].anchorVertex"), std::string::npos) << anchor;
  Pipeline pipeline;
  EXPECT_EQ(test::errorOf([&] { pipeline.run(project); }), anchor);  // run stops at the same check
}

TEST(PipelineValidation, WarningsNameThePointsAndChains) {
  Project project = loadProject(demoProject());
  const auto scene = loadScene(project);
  // The demo's own clicks: a few outline points lie a few pixels off the tiger's cut-out (warned, by name).
  const size_t before = scene->warnings.size();
  for (const std::string& w : scene->warnings)
    EXPECT_NE(w.find("lies on the background of photo"), std::string::npos) << w;
  const Photo& photo = *scene->photos[0];
  // The centre of photo 0's foreground, and a square of four new points around it.
  cv::Mat points;
  cv::findNonZero(photo.alpha > 0, points);
  const cv::Rect box = cv::boundingRect(points);
  const Vec2 c(box.x + box.width / 2.0, box.y + box.height / 2.0);
  const Vec2 corner[4] = {c + Vec2(-8, -8), c + Vec2(8, -8), c + Vec2(8, 8), c + Vec2(-8, 8)};
  const int first = static_cast<int>(project.points.size());
  int v = 0;
  for (const Vec2& q : corner) {
    v = unusedVertex(project, v + 1);
    project.points.push_back({v, {{0, q.x(), q.y()}}});
  }
  v = unusedVertex(project, v + 1);
  project.points.push_back({v, {{0, 1.5, 1.5}}});  // the photo's corner: background
  // Two crossing lines (the square's diagonals) and a bow tie (0, 1, 3, 2 crosses itself).
  project.chains = {{0, {first, first + 2}, false},
                    {0, {first + 1, first + 3}, false},
                    {0, {first, first + 1, first + 3, first + 2}, true}};
  const auto warned = loadScene(project);
  std::string all;
  for (const std::string& w : warned->warnings) all += w + "\n";
  EXPECT_NE(all.find("points[" + std::to_string(first + 4) +
                     "].at[0]: (1.5, 1.5) lies on the background of photo 0 "
                     "'tiger_left.png'"),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("chains[0] and chains[1] cross in photo 0 'tiger_left.png'"), std::string::npos) << all;
  EXPECT_NE(all.find("chains[2] crosses itself in photo 0 'tiger_left.png'"), std::string::npos) << all;
  // The diagonals also cross the bow tie's crossing segments (chains[0]-[2] and [1]-[2] once each), but
  // not where the chains share a point (each diagonal meets the bow tie at two of its corners).
  EXPECT_EQ(warned->warnings.size(), before + 5) << all;
  // run reports the same warnings.
  Pipeline pipeline;
  const PipelineResult result = pipeline.run(project);
  int found = 0;
  for (const std::string& w : result.warnings) found += w.rfind("project: ", 0) == 0;
  EXPECT_EQ(found, static_cast<int>(warned->warnings.size()));
  // The options: a tolerance wider than the photo takes every point off the background; one warning
  // per kind lists the first of the three crossings and counts the other two in one line.
  std::vector<const Photo*> photos;
  for (const auto& photo : warned->photos) photos.push_back(photo.get());
  auto count = [](const std::vector<std::string>& ws, const std::string& text) {
    return std::count_if(ws.begin(), ws.end(), [&](const std::string& w) { return w.find(text) != std::string::npos; });
  };
  const std::vector<std::string> every = projectWarnings(project, photos);
  ProjectWarningOptions lenient;
  lenient.backgroundTolerancePx = 1e6;
  EXPECT_GT(count(every, "lies on the background"), 0);
  EXPECT_EQ(count(projectWarnings(project, photos, lenient), "lies on the background"), 0);
  ProjectWarningOptions one;
  one.maxPerKind = 1;
  const std::vector<std::string> fewer = projectWarnings(project, photos, one);
  EXPECT_EQ(count(every, "cross in photo"), 3);
  EXPECT_EQ(count(fewer, "cross in photo"), 1);
  EXPECT_EQ(count(fewer, "2 more crossings of feature lines"), 1);
  EXPECT_EQ(count(fewer, "crosses itself"), 1);  // its own kind
}

TEST(PipelineValidation, WorkingResolutionRunsWithSmallerPhotos) {
  Project project = loadProject(demoProject());
  const auto full = loadScene(project);
  project.options.maxPhotoSide = 256;
  Pipeline pipeline;
  const PipelineResult result = pipeline.run(project);
  size_t fullBytes = 0, smallBytes = 0;
  for (size_t i = 0; i < full->photos.size(); ++i) {
    const Photo& small = *result.scene->photos[i];
    EXPECT_EQ(small.width, full->photos[i]->width);  // coordinates unchanged
    EXPECT_EQ(std::max(small.rgb.cols, small.rgb.rows), 256);
    fullBytes += full->photos[i]->bytes();
    smallBytes += small.bytes();
  }
  EXPECT_LT(smallBytes * 2, fullBytes);  // the demo's photos are 453 px wide
  ASSERT_TRUE(result.model);
  EXPECT_TRUE(result.model->textured());
  EXPECT_GT(result.mapping->map.numMapped(), result.mapping->map.numFaces() / 4);
  // The option is validated with its field.
  std::vector<std::pair<int, int>> photoSizes;
  for (const auto& photo : full->photos) photoSizes.emplace_back(photo->width, photo->height);
  project.options.maxPhotoSide = 100;
  project.file = "p.json";
  EXPECT_NE(test::errorOf([&] {
              validateProject(project, 100000, 100000, photoSizes);
            }).find("options.maxPhotoSide: 100 is too small"),
            std::string::npos);
}

TEST(MontageCli, OutIsCheckedBeforeThePipelineAndLocked) {
  const std::string dir = test::tempDir("cli_out");
  std::string log;
  EXPECT_NE(test::runCommand(test::montageExe() + " run " + demoProject() + " --out '' 2>&1", &log), 0);
  EXPECT_NE(log.find("output folder: the path is empty"), std::string::npos) << log;
  EXPECT_EQ(log.find("[load]"), std::string::npos) << "the pipeline started: " << log;
  std::ofstream(dir + "/file") << "x";
  EXPECT_NE(test::runCommand(test::montageExe() + " run " + demoProject() + " --out " + dir + "/file 2>&1", &log), 0);
  EXPECT_NE(log.find(dir + "/file: output folder: is a file, not a folder"), std::string::npos) << log;
  // Two runs on one folder: the second is refused while the first holds the lock. The demo's own run
  // takes about a second now; the first run fills a fixed 4096^2 atlas, so that it holds the lock for
  // several seconds.
  Project slow = loadProject(demoProject());
  slow.options.atlasSize = 4096;
  saveProject(slow, dir + "/slow.json");
  const std::string out = dir + "/result";
  ASSERT_EQ(test::runCommand("(" + test::montageExe() + " run " + dir + "/slow.json --out " + out +
                                 " >/dev/null 2>&1 &) ; sleep 1; " + test::montageExe() + " run " + demoProject() +
                                 " --out " + out + " 2>&1; status=$?; sleep 12; exit $status",
                             &log) != 0,
            true);
  EXPECT_NE(log.find("another montage run or editor export is writing this output folder"), std::string::npos) << log;
}

TEST(MontageCli, RenderAndEvalRefuseWhatTheyCannotDo) {
  const std::string dir = test::tempDir("cli_refuse");
  const std::string mesh = test::testDataDir() + "/turtle.obj";
  std::string log;
  EXPECT_NE(test::runCommand(test::montageExe() + " render " + mesh + " --yaw nan --out " + dir + "/r.png 2>&1", &log),
            0);
  EXPECT_NE(log.find("--yaw and --pitch must be finite"), std::string::npos) << log;
  // A result with texture coordinates but no texture once gave "100% photo" and 11 dB.
  std::ofstream(dir + "/nomtl.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
  EXPECT_NE(test::runCommand(test::montageExe() + " eval --result " + dir + "/nomtl.obj --truth " + mesh +
                                 " --truth-texture " + test::assetsDir() + "/demo/tiger_left.png 2>&1",
                             &log),
            0);
  EXPECT_NE(log.find("nomtl.obj: the result has no texture"), std::string::npos) << log;
}
