// The editor's background worker: a quick preview (where it differs) and a preview first, then the final bake of
// the same snapshot; newest
// snapshot wins, errors come back as messages, the worker survives them.
#include "worker.h"

#include <chrono>
#include <thread>

#include "test_support.h"

using namespace montage;

namespace {
std::shared_ptr<const Project> demo() {
  return std::make_shared<const Project>(loadProject(test::assetsDir() + "/demo/project.json"));
}
}  // namespace

TEST(Worker, RunsASnapshotAndHandsBackItsResult) {
  PipelineWorker worker;
  const long g = worker.submit(demo());
  ASSERT_TRUE(worker.waitIdle(120));
  auto outcome = worker.take();
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->generation, g);
  ASSERT_TRUE(outcome->result) << outcome->error;
  EXPECT_EQ(outcome->tier, Tier::Final);  // the final bake followed the preview and replaced it
  EXPECT_GT(outcome->result->model->mesh.numFaces(), 0);
  EXPECT_FALSE(worker.take().has_value());  // taken once
}

TEST(Worker, ThePreviewComesFirstWithAModelThatSamplesThePhotos) {
  PipelineWorker worker;
  const auto project = demo();
  const long g = worker.submit(project);
  // Take the preview as the editor does, polling, before the final bake replaces it.
  std::optional<WorkerOutcome> preview;
  for (int i = 0; i < 120000 && !preview; ++i) {
    if (auto o = worker.take()) {
      if (o->tier == Tier::Preview)
        preview = std::move(o);
      else if (o->tier == Tier::Final)
        break;  // the final came first: the preview was replaced before this loop saw it
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_TRUE(preview.has_value()) << "no preview outcome was seen before the final";
  EXPECT_EQ(preview->generation, g);
  ASSERT_TRUE(preview->result) << preview->error;
  EXPECT_FALSE(preview->result->model);  // no bake in the preview tier
  ASSERT_TRUE(preview->preview);
  const TexturedModel& model = *preview->preview;
  const Mapping& mapping = *preview->result->mapping;
  ASSERT_EQ(model.mesh.numFaces(), mapping.map.numFaces());
  ASSERT_EQ(model.materials.size(), project->photos.size() + 2);  // photos, inpainted, empty
  int photoFaces = 0;
  for (int f = 0; f < model.mesh.numFaces(); ++f) {
    const int p = mapping.map.facePhoto[f];
    const bool inpainted =
        !preview->result->colors->inpaint.faceRegion.empty() && preview->result->colors->inpaint.faceRegion[f] >= 0;
    if (p < 0 || inpainted) {
      EXPECT_EQ(model.faceMaterial[f], static_cast<int>(project->photos.size()) + (inpainted ? 0 : 1)) << "face " << f;
      continue;
    }
    ++photoFaces;
    ASSERT_EQ(model.faceMaterial[f], p) << "face " << f;
    // The UVs are the photo pixels, normalised, v up.
    const Photo& photo = *preview->result->scene->photos[p];
    EXPECT_NEAR(model.uv[f][0].x(), mapping.map.cornerUV[f][0].x() / photo.width, 1e-6);
    EXPECT_NEAR(model.uv[f][0].y(), 1 - mapping.map.cornerUV[f][0].y() / photo.height, 1e-6);
  }
  EXPECT_GT(photoFaces, model.mesh.numFaces() / 4);
  for (size_t p = 0; p < project->photos.size(); ++p) {
    EXPECT_EQ(model.materials[p].texture.type(), CV_8UC4);
    EXPECT_EQ(model.materials[p].texture.cols, preview->result->scene->photos[p]->rgb.cols);
  }
  ASSERT_TRUE(worker.waitIdle(120));
  auto final = worker.take();
  ASSERT_TRUE(final.has_value());
  EXPECT_EQ(final->tier, Tier::Final);
  EXPECT_EQ(final->generation, g);
  ASSERT_TRUE(final->result && final->result->model) << final->error;
}

// Issue 36: where the quick preview differs (the demo's holes are textured), it comes first, then the preview
// that refines it, then the final; the status says which tier is the snapshot's first.
TEST(Worker, TheQuickPreviewComesFirstThenThePreviewThenTheFinal) {
  PipelineWorker worker;
  const long g = worker.submit(demo());
  std::vector<Tier> tiers;
  bool firstSeen = false, laterSeen = false;
  for (int i = 0; i < 120000 && (tiers.empty() || tiers.back() != Tier::Final); ++i) {
    const WorkerStatus s = worker.status();
    if (s.busy && s.generation == g) {
      (s.first ? firstSeen : laterSeen) = true;
      EXPECT_EQ(s.first, s.tier == Tier::Quick);
    }
    if (auto o = worker.take()) {
      ASSERT_TRUE(o->result) << o->error;
      EXPECT_EQ(o->generation, g);
      tiers.push_back(o->tier);
      if (o->tier == Tier::Quick) {
        ASSERT_TRUE(o->preview);  // shown like a preview
        for (const InpaintRegion& r : o->result->colors->inpaint.regions)
          if (r.kind == InpaintRegion::Kind::Hole) EXPECT_EQ(r.mode, InpaintMode::Harmonic);
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_EQ(tiers, (std::vector<Tier>{Tier::Quick, Tier::Preview, Tier::Final}));
  EXPECT_TRUE(firstSeen);
  EXPECT_TRUE(laterSeen);
}

TEST(Worker, NewestSnapshotWins) {
  PipelineWorker worker;
  auto first = demo();
  auto second = std::make_shared<Project>(*first);
  second->points.resize(second->points.size() / 2);
  worker.submit(first);
  const long g2 = worker.submit(second);
  ASSERT_TRUE(worker.waitIdle(120));
  auto outcome = worker.take();
  ASSERT_TRUE(outcome.has_value());
  EXPECT_EQ(outcome->generation, g2);
  ASSERT_TRUE(outcome->result) << outcome->error;
  EXPECT_EQ(outcome->result->scene->project.points.size(), second->points.size());
}

TEST(Worker, AnErrorIsReportedAndTheWorkerGoesOn) {
  PipelineWorker worker;
  auto broken = std::make_shared<Project>(*demo());
  broken->mesh = "/nonexistent/mesh.obj";
  worker.submit(broken);
  ASSERT_TRUE(worker.waitIdle(120));
  auto failed = worker.take();
  ASSERT_TRUE(failed.has_value());
  EXPECT_FALSE(failed->result);
  EXPECT_NE(failed->error.find("/nonexistent/mesh.obj"), std::string::npos) << failed->error;

  worker.submit(demo());
  ASSERT_TRUE(worker.waitIdle(120));
  auto ok = worker.take();
  ASSERT_TRUE(ok.has_value());
  EXPECT_TRUE(ok->result) << ok->error;
}
