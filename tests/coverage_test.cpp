// Guidance to full coverage (mapping/coverage.h, issue 14): the unmapped regions of known synthetic scenes,
// their causes and clicks, the rejected pairs' grouping, report.json's "coverage", and the figure of the
// issue: the mapped share of a 40-feature scene before and after following "where to click next" five
// times, each click placed at the vertex's true projection.
#include "mapping/coverage.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "bench/synth.h"
#include "io/mesh_io.h"
#include "pipeline.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace montage;

namespace {

std::string turtlePath() {
  return test::testDataDir() + "/turtle.obj";
}

// A synthetic scene of the turtle written to a fresh folder, loaded back as a project.
struct Scene40 {
  std::unique_ptr<Mesh> mesh;
  SynthScene synth;
  Project project;
};

Scene40 synthScene(const std::string& tag, int views, int features, CameraMode cameras) {
  Scene40 s;
  s.mesh = requireUsable(loadMesh(turtlePath()));
  const Mesh& mesh = *s.mesh;
  SynthOptions o;
  o.views = views;
  o.features = features;
  o.size = 512;
  s.synth = synthesize(mesh, turtlePath(), meshPattern(mesh), o);
  const std::string dir = test::tempDir(tag);
  writeSynthScene(s.synth, dir);
  s.project = loadProject(dir + "/project.json");
  s.project.options.cameraMode = cameras;
  return s;
}

// The true cameras' views of a result's partition mesh: what a user can see in each photo.
PhotoViews trueViews(const PipelineResult& r, const SynthScene& synth) {
  PhotoViews views;
  for (size_t k = 0; k < synth.cameras.size(); ++k) {
    CameraFit fit;
    fit.fits = true;
    fit.camera.pinhole = synth.cameras[k];
    const ViewFrame frame = viewFrame(*r.scene->mesh, *r.scene->photos[k], fit.camera.pinhole);
    views.push_back(std::make_shared<const PhotoView>(
        viewPhoto(r.mapping->partition->mesh, r.mapping->partition->faceParent, frame, *r.scene->photos[k],
                  static_cast<int>(k), fit, CorrectionField{}, ProjectionOptions{})));
  }
  return views;
}

// Follows the best feasible suggestion of "where to click next": the click goes at the vertex's true
// projection, when the vertex is visible in the photo suggested. Returns false when none is feasible.
bool followNext(Project& project, const CoverageReport& report, const PipelineResult& r, const SynthScene& synth,
                int* infeasible) {
  const PhotoViews views = trueViews(r, synth);
  for (int index : report.next)
    for (const RegionCause& c : report.regions[index].causes) {
      if (!c.click.valid()) continue;
      const int v = r.scene->meshVertex(c.click.vertex);  // the click names the document's vertex
      if (!views[c.click.photo]->vertexVisible[v]) {
        ++*infeasible;
        continue;
      }
      PhotoCamera camera;
      camera.pinhole = synth.cameras[c.click.photo];
      Vec2 px;
      if (!camera.project(r.mapping->partition->mesh.position(v), px)) continue;
      const PhotoPoint at{c.click.photo, px.x(), px.y()};
      if (c.click.point >= 0) {
        for (const PhotoPoint& q : project.points[c.click.point].at)
          EXPECT_NE(q.photo, c.click.photo) << "suggested a click the feature already has";
        project.points[c.click.point].at.push_back(at);
      } else {
        project.points.push_back({c.click.vertex, {at}});
      }
      return true;
    }
  return false;
}

double regionArea(const CoverageReport& report) {
  double a = report.smallArea;
  for (const CoverageRegion& r : report.regions) a += r.area;
  return a;
}

}  // namespace

TEST(Coverage, NoFeaturesLeaveOneRegionWithFewFeaturesAndAClick) {
  Scene40 s = synthScene("coverage_none", 2, 30, CameraMode::Off);
  s.project.points.clear();
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(s.project, {}, Tier::Preview);
  const CoverageReport report = coverageOf(r);
  ASSERT_EQ(report.regions.size(), 1u);
  EXPECT_DOUBLE_EQ(report.mappedShare, 0.0);
  const CoverageRegion& region = report.regions[0];
  EXPECT_NEAR(region.share, 1.0, 1e-9);
  EXPECT_EQ(static_cast<int>(region.faces.size()), r.mapping->partition->mesh.numFaces());
  ASSERT_EQ(region.causes.size(), 1u);
  EXPECT_EQ(region.causes[0].cause, CoverageCause::FewFeatures);
  EXPECT_NE(region.causes[0].why.find("no feature"), std::string::npos) << region.causes[0].why;
  EXPECT_TRUE(region.causes[0].click.valid());
  ASSERT_EQ(report.next.size(), 1u);
  EXPECT_EQ(report.next[0], 0);
}

// Every photo's camera fits: projection maps what some photo sees, so the empty regions are what no true
// camera sees, and each says so.
TEST(Coverage, WithEveryCameraFittedTheRegionsAreWhatNoPhotoSees) {
  Scene40 s = synthScene("coverage_fit", 4, 120, CameraMode::Auto);
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(s.project, {}, Tier::Preview);
  ASSERT_EQ(r.cameras->fitted, 4);
  const CoverageReport report = coverageOf(r);
  ASSERT_FALSE(report.regions.empty());
  const PhotoViews views = trueViews(r, s.synth);
  const Mesh& mesh = r.mapping->partition->mesh;
  double unseenInRegions = 0, regionArea = 0;
  for (const CoverageRegion& region : report.regions) {
    for (const RegionCause& c : region.causes)
      EXPECT_TRUE(c.cause == CoverageCause::NotSeen || c.cause == CoverageCause::Unprojected)
          << kCoverageCauseNames[static_cast<int>(c.cause)];
    EXPECT_EQ(region.causes[0].cause, CoverageCause::NotSeen);
    for (int f : region.faces) {
      bool seen = false;
      for (const auto& v : views) seen = seen || v->faceQuality[f] > 0;
      regionArea += mesh.faceArea(f);
      if (!seen) unseenInRegions += mesh.faceArea(f);
    }
  }
  EXPECT_GT(unseenInRegions / regionArea, 0.9);
  // No click maps what no photo sees.
  for (int i : report.next) EXPECT_NE(report.regions[i].causes[0].cause, CoverageCause::NotSeen);
  EXPECT_NEAR(report.mappedShare + regionArea / report.totalArea + report.smallArea / report.totalArea, 1.0, 1e-9);
}

// A triangle whose corner loses its click in the triangle's photo: the region there names that corner,
// and the click it suggests (at the true projection) maps the region's place again.
TEST(Coverage, ARemovedClickIsDiagnosedAndItsSuggestedClickMapsTheRegion) {
  Scene40 s = synthScene("coverage_removed", 4, 40, CameraMode::Off);
  Pipeline pipeline;
  const PipelineResult before = pipeline.run(s.project, {}, Tier::Preview);
  // A mapped cell with a corner clicked in two or more photos; drop that corner's click in the cell's photo.
  const Mapping& m = *before.mapping;
  int face = -1, corner = -1, photo = -1;
  double best = 0;
  for (const CellPlan& plan : m.cells) {
    if (plan.status != CellStatus::Mapped) continue;
    double area = 0;
    for (int f : plan.faces) area += m.partition->mesh.faceArea(f);
    for (int v : plan.corners)
      for (size_t p = 0; p < s.project.points.size(); ++p)
        if (m.partition->featureVertex[p] == v && s.project.points[p].at.size() >= 2 && area > best)
          best = area, face = plan.faces[plan.faces.size() / 2], corner = static_cast<int>(p), photo = plan.photo;
  }
  ASSERT_GE(corner, 0) << "no mapped cell with a corner in two photos";
  Project edited = s.project;
  auto& at = edited.points[corner].at;
  at.erase(std::remove_if(at.begin(), at.end(), [&](const PhotoPoint& q) { return q.photo == photo; }), at.end());
  const PipelineResult after = pipeline.run(edited, {}, Tier::Preview);
  const CoverageReport report = coverageOf(after);
  ASSERT_LT(report.mappedShare, coverageOf(before).mappedShare);
  ASSERT_EQ(after.mapping->map.facePhoto[face], TextureMap::kEmpty) << "the cell's face stays mapped";
  const CoverageRegion* region = nullptr;
  for (const CoverageRegion& r : report.regions)
    if (std::binary_search(r.faces.begin(), r.faces.end(), face)) region = &r;
  ASSERT_NE(region, nullptr) << "no region holds the emptied face";
  EXPECT_NE(std::find(region->points.begin(), region->points.end(), corner), region->points.end());
  ASSERT_FALSE(region->causes.empty());
  EXPECT_FALSE(region->causes[0].why.empty());
  EXPECT_FALSE(region->causes[0].fix.empty());
  // Following the guidance maps more of the surface again.
  int infeasible = 0;
  Project fixed = edited;
  ASSERT_TRUE(followNext(fixed, report, after, s.synth, &infeasible));
  const CoverageReport again = coverageOf(pipeline.run(fixed, {}, Tier::Preview));
  EXPECT_GT(again.mappedShare, report.mappedShare);
}

TEST(Coverage, RejectedPairsAreGroupedAndFarOnesMarkedExpected) {
  Scene40 s = synthScene("coverage_rejected", 4, 40, CameraMode::Off);
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(s.project, {}, Tier::Preview);
  const CoverageReport report = coverageOf(r);
  const auto& rejected = r.mapping->partition->rejected;
  ASSERT_FALSE(rejected.empty());
  ASSERT_EQ(report.rejectedExpected.size(), rejected.size());
  size_t total = 0;
  int expected = 0;
  for (const RejectedGroup& g : report.rejected) {
    total += g.pairs.size();
    expected += g.expected;
    EXPECT_FALSE(g.words.empty());
    for (size_t i = 0; i < g.pairs.size(); ++i) {
      EXPECT_EQ(rejected[g.pairs[i]].reason, g.reason);
      // The pairs that bear on an empty region come first.
      EXPECT_EQ(report.rejectedExpected[g.pairs[i]] != 0, static_cast<int>(i) >= int(g.pairs.size()) - g.expected);
    }
  }
  EXPECT_EQ(total, rejected.size());
  EXPECT_GT(expected, 0);
  // A pair not expected has both ends around one listed region.
  for (size_t i = 0; i < rejected.size(); ++i) {
    if (report.rejectedExpected[i]) continue;
    bool around = false;
    for (const CoverageRegion& region : report.regions) {
      const std::set<int> pts(region.points.begin(), region.points.end());
      around = around || (pts.count(rejected[i].fromPoint) && pts.count(rejected[i].toPoint));
    }
    EXPECT_TRUE(around) << i;
  }
  EXPECT_NE(rejectedWords(rejected[0]).size(), 0u);
}

TEST(Coverage, ReportJsonCarriesTheRegions) {
  Scene40 s = synthScene("coverage_report", 4, 40, CameraMode::Off);
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(s.project, {}, Tier::Preview);
  const CoverageReport report = coverageOf(r);
  const nlohmann::json j = r.report();
  ASSERT_TRUE(j.contains("coverage"));
  const auto& c = j["coverage"];
  EXPECT_DOUBLE_EQ(c["mapped_share"].get<double>(), report.mappedShare);
  ASSERT_EQ(c["regions"].size(), report.regions.size());
  for (size_t i = 0; i < report.regions.size(); ++i) {
    EXPECT_EQ(c["regions"][i]["faces"].get<size_t>(), report.regions[i].faces.size());
    EXPECT_EQ(c["regions"][i]["why"].get<std::string>(), report.regions[i].causes[0].why);
    EXPECT_EQ(c["regions"][i]["fix"].get<std::string>(), report.regions[i].causes[0].fix);
  }
  if (!report.next.empty()) EXPECT_EQ(c["next"]["region"].get<int>(), report.next[0]);
  // The listed and small regions and the mapped area make up the surface.
  EXPECT_NEAR((report.mappedArea + regionArea(report)) / report.totalArea, 1.0, 1e-9);
}

TEST(Coverage, MinShareLeavesSmallRegionsUnlisted) {
  Scene40 s = synthScene("coverage_minshare", 4, 40, CameraMode::Off);
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(s.project, {}, Tier::Preview);
  CoverageOptions all;
  all.minShare = 0;
  const CoverageReport full = coverageOf(r, all);
  ASSERT_GE(full.regions.size(), 2u);
  CoverageOptions big;
  big.minShare = full.regions[0].share * 0.999;
  const CoverageReport one = coverageOf(r, big);
  EXPECT_EQ(one.regions.size(), 1u);
  EXPECT_EQ(one.smallRegions, static_cast<int>(full.regions.size()) - 1);
  EXPECT_NEAR(regionArea(one), regionArea(full), 1e-9);
}

TEST(Coverage, MismatchedInputIsAnError) {
  Scene40 s = synthScene("coverage_bad", 2, 20, CameraMode::Off);
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(s.project, {}, Tier::Preview);
  TextureMap shorter = r.mapping->map;
  shorter.facePhoto.pop_back();
  const std::vector<CameraFit> fits;
  const PhotoViews views;
  const std::string message = test::errorOf([&] {
    analyseCoverage({s.project, *r.mapping->partition, shorter, r.mapping->cells, fits, views, 2});
  });
  EXPECT_NE(message.find("texture map"), std::string::npos) << message;
}

// The figure: a scene made with 40 features (the paper's path: no camera), the mapped share before
// and after following "where to click next" up to five times.
TEST(Coverage, FollowingWhereToClickNextFiveTimesMapsMore) {
  Scene40 s = synthScene("coverage_next", 4, 40, CameraMode::Off);
  Pipeline pipeline;
  Project project = s.project;
  PipelineResult r = pipeline.run(project, {}, Tier::Preview);
  CoverageReport report = coverageOf(r);
  // The ceiling: the share of the surface some photo sees.
  const PhotoViews views = trueViews(r, s.synth);
  const Mesh& mesh = r.mapping->partition->mesh;
  double seen = 0;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    bool any = false;
    for (const auto& v : views) any = any || v->faceQuality[f] > 0;
    if (any) seen += mesh.faceArea(f);
  }
  const double first = report.mappedShare;
  std::printf("[coverage] %zu features, 4 photos: mapped %.1f%% of the surface (seen by some photo: %.1f%%)\n",
              project.points.size(), 100 * first, 100 * seen / report.totalArea);
  int infeasible = 0, followed = 0;
  for (int step = 0; step < 5; ++step) {
    const std::string words = report.next.empty() ? "" : report.regions[report.next[0]].causes[0].why;
    if (!followNext(project, report, r, s.synth, &infeasible)) break;
    ++followed;
    r = pipeline.run(project, {}, Tier::Preview);
    report = coverageOf(r);
    std::printf("[coverage] click %d (%s): mapped %.1f%%\n", step + 1, words.c_str(), 100 * report.mappedShare);
  }
  std::printf("[coverage] after %d clicks: %.1f%% -> %.1f%% (%d suggested clicks not visible in their photo)\n",
              followed, 100 * first, 100 * report.mappedShare, infeasible);
  // Without cameras the core cannot tell whether a suggested vertex shows in the photo it names; a user
  // skips such a suggestion (as here) and the list runs dry once only hidden places are left.
  EXPECT_GE(followed, 1);
  EXPECT_GT(report.mappedShare, first + 0.02);
}
