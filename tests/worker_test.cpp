// The editor's background worker: newest snapshot wins, errors come back as messages, the worker
// survives them.
#include "worker.h"

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
  EXPECT_GT(outcome->result->model->mesh.numFaces(), 0);
  EXPECT_FALSE(worker.take().has_value());  // taken once
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
