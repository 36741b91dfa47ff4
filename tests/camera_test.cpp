// Camera-aware mapping (issue 11): the camera fit per photo (mapping/camera.h), projection mapping and
// view selection (mapping/projection.h, mapping/view_select.h), proposals (mapping/proposals.h), the
// synthetic click noise and the projection oracle, on synthetic scenes whose cameras are known.
#include "mapping/camera.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>

#include "bench/eval.h"
#include "bench/landmarks.h"
#include "bench/sight.h"
#include "bench/synth.h"
#include "geometry/mesh.h"
#include "image/codec.h"
#include "image/photo.h"
#include "io/mesh_io.h"
#include "io/model.h"
#include "mapping/found_silhouette.h"
#include "mapping/photometric.h"
#include "mapping/projection.h"
#include "mapping/proposals.h"
#include "mapping/view_select.h"
#include "pipeline.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace montage;

namespace {

std::string demoMeshPath() {
  return test::testDataDir() + "/turtle.obj";
}

SurfaceColor patternOf(const Mesh& mesh) {
  return meshPattern(mesh);
}

// A synthetic scene of the demo mesh (always present), written to a fresh folder.
struct DemoScene {
  std::unique_ptr<Mesh> mesh;
  SynthScene scene;
  std::string dir;
};

DemoScene demoScene(const std::string& tag, int views, int features, double noise = 0, int size = 512, double k1 = 0) {
  DemoScene d;
  d.mesh = requireUsable(loadMesh(demoMeshPath()));
  SynthOptions o;
  o.views = views;
  o.features = features;
  o.size = size;
  o.clickNoisePx = noise;
  o.k1 = k1;
  d.scene = synthesize(*d.mesh, demoMeshPath(), patternOf(*d.mesh), o);
  d.dir = test::tempDir(tag);
  writeSynthScene(d.scene, d.dir);
  return d;
}

// A synthetic scene of `mesh` (read from `obj`) painted with `truth`'s texture, written into a new temporary folder
// named after `tag`; returns the folder.
std::string texturedScene(const Mesh& mesh, const std::string& obj, const TexturedModel& truth, const SynthOptions& o,
                          const std::string& tag, SynthScene* scene = nullptr) {
  SynthScene s = synthesize(
      mesh, obj, [&truth](int f, const Vec3& b) { return truth.colorAt(f, b); }, o);
  const std::string dir = test::tempDir(tag);
  writeSynthScene(s, dir);
  if (scene) *scene = std::move(s);
  return dir;
}

PhotoCamera trueCamera(const SynthScene& s, int k) {
  PhotoCamera c;
  c.pinhole = s.cameras[k];
  return c;
}

// Largest distance between two cameras' projections of the mesh's vertices that both see in front.
double projectionGap(const Mesh& mesh, const PhotoCamera& a, const PhotoCamera& b) {
  double worst = 0;
  for (int v = 0; v < mesh.numVertices(); ++v) {
    Vec2 pa, pb;
    if (!a.project(mesh.position(v), pa) || !b.project(mesh.position(v), pb)) continue;
    if (pa.x() < 0 || pa.y() < 0 || pa.x() > a.pinhole.width || pa.y() > a.pinhole.height) continue;
    worst = std::max(worst, (pa - pb).norm());
  }
  return worst;
}

}  // namespace

// ---- Camera fit ----

void expectRecoversCameras(const Mesh& mesh, const SynthScene& s) {
  for (int k = 0; k < static_cast<int>(s.cameras.size()); ++k) {
    const std::vector<CameraClick> clicks = photoClicks(s.project, k);
    ASSERT_GE(clicks.size(), 6u) << "photo " << k;
    const CameraFit fit = fitCamera(mesh, clicks, s.options.size, s.options.size);
    ASSERT_TRUE(fit.fits) << "photo " << k << ": " << fit.reason;
    EXPECT_NEAR(fit.camera.focal() / s.cameras[k].fx, 1.0, 0.01) << "photo " << k;
    EXPECT_EQ(fit.inliers, static_cast<int>(clicks.size()));
    EXPECT_LT(fit.maxResidual, 0.1) << "photo " << k;
    for (double r : fit.residual) EXPECT_LT(r, 0.1);
    EXPECT_LT((fit.camera.pinhole.center() - s.cameras[k].center()).norm(), 1e-3 * s.cameras[k].center().norm());
    EXPECT_LT(projectionGap(mesh, trueCamera(s, k), fit.camera), 0.1) << "photo " << k;
  }
}

TEST(CameraFit, RecoversSynthCamerasOfTheDemoMesh) {
  DemoScene d = demoScene("camera_fit_demo", 4, 120);
  expectRecoversCameras(*d.mesh, d.scene);
}

TEST(CameraFit, RecoversSynthCamerasOfSpot) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  auto mesh = requireUsable(loadMesh(obj));
  SynthOptions o;
  o.views = 6;
  o.features = 150;
  o.size = 800;
  const SynthScene s = synthesize(*mesh, obj, patternOf(*mesh), o);
  expectRecoversCameras(*mesh, s);
}

TEST(CameraFit, OneWrongClickAmongThirtyIsAnOutlierAndTheFitIsUnchanged) {
  DemoScene d = demoScene("camera_fit_outlier", 4, 200);
  std::vector<CameraClick> clicks = photoClicks(d.scene.project, 0);
  ASSERT_GE(clicks.size(), 30u);
  clicks.resize(30);
  const CameraFit clean = fitCamera(*d.mesh, std::vector<CameraClick>(clicks.begin() + 1, clicks.end()), 512, 512);
  ASSERT_TRUE(clean.fits);
  // The first click is put 40 px away from where its vertex is.
  clicks[0].pixel += Vec2(28, -28.5);
  const CameraFit fit = fitCamera(*d.mesh, clicks, 512, 512);
  ASSERT_TRUE(fit.fits) << fit.reason;
  EXPECT_FALSE(fit.inlier[0]);
  EXPECT_NEAR(fit.residual[0], 40, 0.5);
  EXPECT_EQ(fit.inliers, 29);
  for (int i = 1; i < 30; ++i) EXPECT_TRUE(fit.inlier[i]) << i;
  EXPECT_NEAR(fit.camera.focal() / clean.camera.focal(), 1.0, 1e-6);
  EXPECT_LT(projectionGap(*d.mesh, clean.camera, fit.camera), 1e-3);
  // Without the robust start and re-classification the wrong click would pull the camera: a plain
  // least-squares fit of all 30 (threshold so large that every click agrees) moves the projection.
  CameraFitOptions loose;
  loose.thresholdFraction = 1;
  const CameraFit pulled = fitCamera(*d.mesh, clicks, 512, 512, loose);
  EXPECT_GT(projectionGap(*d.mesh, clean.camera, pulled.camera), 0.5);
}

// RANSAC draws only as many samples as the least share of agreeing clicks that fits needs (86 at 60%):
// with 11 of 30 clicks wrong (63% agree), every seed still finds the camera and marks the 11.
TEST(CameraFit, ElevenWrongClicksAmongThirtyAreOutliersForEverySeed) {
  DemoScene d = demoScene("camera_fit_outliers", 4, 200);
  std::vector<CameraClick> clicks = photoClicks(d.scene.project, 0);
  ASSERT_GE(clicks.size(), 30u);
  clicks.resize(30);
  const CameraFit clean = fitCamera(*d.mesh, std::vector<CameraClick>(clicks.begin() + 11, clicks.end()), 512, 512);
  ASSERT_TRUE(clean.fits);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> angle(0, 2 * M_PI), distance(30, 120);
  for (int i = 0; i < 11; ++i) {
    const double a = angle(rng), r = distance(rng);
    clicks[i].pixel += Vec2(r * std::cos(a), r * std::sin(a));
  }
  for (unsigned seed = 1; seed <= 8; ++seed) {
    CameraFitOptions o;
    o.seed = seed;
    const CameraFit fit = fitCamera(*d.mesh, clicks, 512, 512, o);
    ASSERT_TRUE(fit.fits) << "seed " << seed << ": " << fit.reason;
    EXPECT_EQ(fit.inliers, 19) << "seed " << seed;
    for (int i = 0; i < 30; ++i) EXPECT_EQ(bool(fit.inlier[i]), i >= 11) << "seed " << seed << ", click " << i;
    EXPECT_LT(projectionGap(*d.mesh, clean.camera, fit.camera), 1e-3) << "seed " << seed;
  }
}

TEST(CameraFit, TooFewOrInconsistentClicksDoNotFit) {
  DemoScene d = demoScene("camera_fit_few", 4, 200);
  std::vector<CameraClick> clicks = photoClicks(d.scene.project, 0);
  ASSERT_GE(clicks.size(), 20u);
  const CameraFit five = fitCamera(*d.mesh, std::vector<CameraClick>(clicks.begin(), clicks.begin() + 5), 512, 512);
  EXPECT_FALSE(five.fits);
  EXPECT_NE(five.reason.find("at least 6"), std::string::npos) << five.reason;
  // The positions shuffled among the vertices: a photo of something else.
  std::vector<CameraClick> shuffled = clicks;
  std::mt19937 rng(3);
  for (size_t i = shuffled.size() - 1; i > 0; --i) std::swap(shuffled[i].pixel, shuffled[rng() % (i + 1)].pixel);
  const CameraFit other = fitCamera(*d.mesh, shuffled, 512, 512);
  EXPECT_FALSE(other.fits);
  EXPECT_NE(other.reason.find("another subject"), std::string::npos) << other.reason;
  EXPECT_NE(describeFit(other).find("does not fit"), std::string::npos);
  // Bad input is an error naming the click.
  std::vector<CameraClick> bad = clicks;
  bad[3].vertex = d.mesh->numVertices();
  EXPECT_NE(test::errorOf([&] { fitCamera(*d.mesh, bad, 512, 512); }).find("clicks[3].vertex"), std::string::npos);
}

TEST(CameraFit, RadialDistortionIsFittedWhenThePhotoHasIt) {
  DemoScene d = demoScene("camera_fit_radial", 4, 250);
  const int k = 1;
  PhotoCamera distorted = trueCamera(d.scene, k);
  distorted.k1 = -0.15;
  std::vector<CameraClick> clicks = photoClicks(d.scene.project, k);
  for (CameraClick& c : clicks) ASSERT_TRUE(distorted.project(d.mesh->position(c.vertex), c.pixel));
  const CameraFit fit = fitCamera(*d.mesh, clicks, 512, 512);
  ASSERT_TRUE(fit.fits) << fit.reason;
  EXPECT_NEAR(fit.camera.k1, -0.15, 0.01);
  EXPECT_LT(fit.maxResidual, 0.05);
  CameraFitOptions pinholeOnly;
  pinholeOnly.radialDistortion = false;
  const CameraFit plain = fitCamera(*d.mesh, clicks, 512, 512, pinholeOnly);
  EXPECT_EQ(plain.camera.k1, 0);
  EXPECT_GT(plain.rmsResidual, 5 * fit.rmsResidual);
  // Exact undistorted clicks do not get radial terms (the F-test keeps them out).
  const CameraFit exact = fitCamera(*d.mesh, photoClicks(d.scene.project, k), 512, 512);
  EXPECT_EQ(exact.camera.k1, 0);
  EXPECT_EQ(exact.camera.k2, 0);
}

TEST(CameraFit, PooledRadialFSumsTheTrialsOfOneCamera) {
  auto trial = [](int terms, double drop, double rss, int dof, bool agrees = true) {
    CameraFit f;
    f.radialTrial = {terms, drop, rss, dof, agrees, false};
    return f;
  };
  const CameraFit a = trial(1, 4, 100, 100), b = trial(2, 8, 200, 100), none = trial(0, 0, 0, 0),
                  disagrees = trial(2, 1000, 1, 100, false);
  EXPECT_NEAR(pooledRadialF({&a, &b}), (12.0 / 3) / (300.0 / 200), 1e-12);
  EXPECT_EQ(pooledRadialF({&a}), 0);                     // one photo: its own test decides
  EXPECT_EQ(pooledRadialF({&a, &none, &disagrees}), 0);  // untried and disagreeing trials do not count
  EXPECT_NEAR(pooledRadialF({&a, &b, &none}), pooledRadialF({&a, &b}), 1e-12);
}

namespace {

// The clicks of every photo of `d` moved to where `lens` (each photo's true pose and focal times `focalScale[k]`, with
// the given radial terms) puts their vertices, plus seeded Gaussian noise of `noise` px per axis.
std::vector<std::vector<CameraClick>> clicksThroughLens(const DemoScene& d, double k1, double noise,
                                                        const std::vector<double>& focalScale,
                                                        std::vector<PhotoCamera>& lens) {
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss(0, noise);
  std::vector<std::vector<CameraClick>> out;
  lens.clear();
  for (int k = 0; k < static_cast<int>(d.scene.cameras.size()); ++k) {
    PhotoCamera c = trueCamera(d.scene, k);
    c.pinhole.fx *= focalScale[k], c.pinhole.fy *= focalScale[k];
    c.k1 = k1;
    lens.push_back(c);
    std::vector<CameraClick> clicks = photoClicks(d.scene.project, k);
    for (CameraClick& click : clicks) {
      EXPECT_TRUE(c.project(d.mesh->position(click.vertex), click.pixel));
      if (noise > 0) click.pixel += Vec2(gauss(rng), gauss(rng));
    }
    out.push_back(std::move(clicks));
  }
  return out;
}

// Each photo's own fit (every one must fit), and the fits as fitSharedIntrinsics takes them.
std::vector<CameraFit> fitEach(const DemoScene& d, const std::vector<std::vector<CameraClick>>& clicks) {
  std::vector<CameraFit> fits;
  for (const auto& c : clicks) {
    fits.push_back(fitCamera(*d.mesh, c, 512, 512));
    EXPECT_TRUE(fits.back().fits) << fits.back().reason;
  }
  return fits;
}
std::vector<CameraFit*> pointersTo(std::vector<CameraFit>& fits) {
  std::vector<CameraFit*> out;
  for (CameraFit& f : fits) out.push_back(&f);
  return out;
}

}  // namespace

TEST(CameraFit, PhotosOfOneCameraShareItsIntrinsicsAndPayForItsLensTogether) {
  // Issue 37: four photos through one mild lens (k1 = +0.1 moves the turtle's clicks by up to about 1.5 px) with
  // 0.5 px of click noise. Alone, photos drop k1 or fit their own focal length; the bundle adjustment over all their
  // clicks finds one focal length and one k1, and lands the texture nearer the truth.
  const DemoScene d = demoScene("camera_fit_shared", 4, 250);
  std::vector<PhotoCamera> lens;
  const auto clicks = clicksThroughLens(d, 0.1, 0.5, {1, 1, 1, 1}, lens);
  std::vector<CameraFit> fits = fitEach(d, clicks);
  const std::vector<CameraFit> alone = fits;
  const std::vector<CameraFit*> members = pointersTo(fits);
  const SharedIntrinsics shared = fitSharedIntrinsics(*d.mesh, members);
  ASSERT_TRUE(shared.shared) << shared.why;
  EXPECT_EQ(shared.photos, 4);
  EXPECT_GE(shared.terms, 1) << shared.why;
  EXPECT_NEAR(shared.k1, 0.1, 0.04) << shared.why;
  EXPECT_NEAR(shared.focal / lens[0].focal(), 1.0, 0.01) << shared.why;
  double gapShared = 0, gapAlone = 0;
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(fits[k].sharedIntrinsics, 4);
    EXPECT_EQ(fits[k].camera.focal(), shared.focal);
    EXPECT_EQ(fits[k].camera.k1, shared.k1);
    EXPECT_EQ(fits[k].inliers, static_cast<int>(clicks[k].size())) << describeFit(fits[k]);
    gapShared += projectionGap(*d.mesh, lens[k], fits[k].camera);
    gapAlone += projectionGap(*d.mesh, lens[k], alone[k].camera);
  }
  std::printf("largest gap to the true projection, mean of 4 photos: %.2f px shared, %.2f px alone (%s)\n",
              gapShared / 4, gapAlone / 4, shared.why.c_str());
  EXPECT_LT(gapShared, 0.7 * gapAlone);
}

TEST(CameraFit, PhotosOfOneSizeWithDifferentFocalLengthsKeepTheirOwn) {
  // A zoom between shots (or two cameras of one image size): two photos at the scene's focal length, two at 1.4
  // times it. Shared intrinsics cannot explain them; Akaike's criterion keeps each photo's own, unchanged.
  const DemoScene d = demoScene("camera_fit_zoom", 4, 150);
  std::vector<PhotoCamera> lens;
  const auto clicks = clicksThroughLens(d, 0, 0.5, {1, 1, 1.4, 1.4}, lens);
  std::vector<CameraFit> fits = fitEach(d, clicks);
  const std::vector<CameraFit> alone = fits;
  const std::vector<CameraFit*> members = pointersTo(fits);
  const SharedIntrinsics shared = fitSharedIntrinsics(*d.mesh, members);
  EXPECT_FALSE(shared.shared) << shared.why;
  EXPECT_GT(shared.aicShared, shared.aicSeparate);
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(fits[k].sharedIntrinsics, 0);
    EXPECT_EQ(fits[k].camera.focal(), alone[k].camera.focal());
    EXPECT_NEAR(fits[k].camera.focal() / lens[k].focal(), 1.0, 0.02) << describeFit(fits[k]);
  }
  // The two photos at one focal length do share it.
  std::vector<CameraFit*> pair = {&fits[2], &fits[3]};
  const SharedIntrinsics zoomed = fitSharedIntrinsics(*d.mesh, pair);
  EXPECT_TRUE(zoomed.shared) << zoomed.why;
  EXPECT_NEAR(zoomed.focal / lens[2].focal(), 1.0, 0.02) << zoomed.why;
}

TEST(CameraFit, TheExifFocalLengthIsAPriorTheClicksMayRefuse) {
  // Issue 37: eight clicks of 1 px noise leave the focal length loose (it trades with the distance); the EXIF's,
  // within 2% (a 35 mm equivalent is rounded), pins it. A photo cropped after the shot keeps its EXIF, whose focal
  // length no longer fits its frame: the clicks refuse that prior and the fit is the one without it.
  const DemoScene d = demoScene("camera_fit_exif_prior", 2, 150);
  std::vector<PhotoCamera> lens;
  const auto clicks = clicksThroughLens(d, 0, 1.0, {1, 1}, lens);
  const double truth = lens[0].focal();
  const std::vector<CameraClick> few(clicks[0].begin(), clicks[0].begin() + 8);
  const CameraFit alone = fitCamera(*d.mesh, few, 512, 512);
  CameraFitOptions exif;
  exif.focalPriorPx = 1.02 * truth;
  const CameraFit withPrior = fitCamera(*d.mesh, few, 512, 512, exif);
  ASSERT_TRUE(alone.fits) << alone.reason;
  ASSERT_TRUE(withPrior.fits) << withPrior.reason;
  std::printf("8 clicks: focal %.1f px alone, %.1f px with the EXIF's %.1f, truth %.1f\n", alone.camera.focal(),
              withPrior.camera.focal(), exif.focalPriorPx, truth);
  EXPECT_EQ(alone.focalPrior, 0);
  EXPECT_EQ(withPrior.focalPrior, 1) << describeFit(withPrior);
  EXPECT_LT(std::abs(withPrior.camera.focal() / truth - 1), 0.04);
  EXPECT_LT(std::abs(withPrior.camera.focal() - truth), 0.5 * std::abs(alone.camera.focal() - truth));
  EXPECT_LT(projectionGap(*d.mesh, lens[0], withPrior.camera), projectionGap(*d.mesh, lens[0], alone.camera));

  CameraFitOptions cropped;
  cropped.focalPriorPx = 1.6 * truth;
  const CameraFit all = fitCamera(*d.mesh, clicks[0], 512, 512);
  const CameraFit refused = fitCamera(*d.mesh, clicks[0], 512, 512, cropped);
  ASSERT_GE(clicks[0].size(), 20u);
  EXPECT_EQ(refused.focalPrior, -1) << describeFit(refused);
  EXPECT_EQ(refused.camera.focal(), all.camera.focal());
  EXPECT_NE(describeFit(refused).find("EXIF's focal length refused"), std::string::npos);
}

TEST(CameraFit, ExactClicksThroughOnePinholeShareItExactly) {
  const DemoScene d = demoScene("camera_fit_shared_exact", 3, 120);
  std::vector<PhotoCamera> lens;
  const auto clicks = clicksThroughLens(d, 0, 0, {1, 1, 1}, lens);
  std::vector<CameraFit> fits = fitEach(d, clicks);
  const std::vector<CameraFit*> members = pointersTo(fits);
  const SharedIntrinsics shared = fitSharedIntrinsics(*d.mesh, members);
  ASSERT_TRUE(shared.shared) << shared.why;
  EXPECT_EQ(shared.terms, 0) << shared.why;
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(fits[k].maxResidual, 1e-4) << describeFit(fits[k]);
    EXPECT_LT(projectionGap(*d.mesh, lens[k], fits[k].camera), 1e-3);
  }
  // One photo alone, or a photo that does not fit, leaves the fits as they are.
  std::vector<CameraFit*> one = {&fits[0]};
  EXPECT_FALSE(fitSharedIntrinsics(*d.mesh, one).shared);
  CameraFit none;
  std::vector<CameraFit*> withNone = {&fits[0], &none};
  EXPECT_FALSE(fitSharedIntrinsics(*d.mesh, withNone).shared);
}

TEST(CameraPipeline, TheLensTermsOfOneCameraArePaidForByAllItsPhotosTogether) {
  // Issue 37: four photos through one lens (k1 = -0.5) with noisy clicks. Alone, some photos' F test drops k1 (their
  // clicks do not pay for it); the camera's photos pay for it together (their pooled trials, then one focal length
  // and one k1 in the bundle adjustment over all their clicks), and every photo keeps it.
  constexpr double k1 = -0.5;  // the turtle spans a normalised radius under 0.3: a strong lens moves its clicks 1-4 px
  const DemoScene d = demoScene("camera_pipeline_pooled_lens", 4, 150, 1.0, 512, k1);
  const Mesh& mesh = *d.mesh;
  const Project project = loadProject(d.dir + "/project.json");
  std::vector<CameraFit> alone;
  int dropsAlone = 0;
  for (int k = 0; k < 4; ++k) {
    alone.push_back(fitCamera(mesh, photoClicks(project, k), 512, 512));
    dropsAlone += alone.back().camera.k1 == 0;
  }
  ASSERT_GT(dropsAlone, 0) << "the scene no longer tests the pool: every photo keeps k1 alone";
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(project);
  ASSERT_EQ(r.cameras->fitted, 4);
  int pooled = 0;
  for (int k = 0; k < 4; ++k) {
    const CameraFit& fit = r.cameras->fits[k];
    PhotoCamera truth = trueCamera(d.scene, k);
    truth.k1 = k1;
    EXPECT_NE(fit.camera.k1, 0) << describeFit(fit);
    EXPECT_EQ(fit.sharedIntrinsics, 4) << describeFit(fit);  // one focal length and one k1 for the four
    if (alone[k].camera.k1 != 0) continue;
    ++pooled;
    // The texture lands nearer where the lens puts it (the largest gap over the visible vertices).
    std::printf("photo %d: largest gap to the true projection %.2f px pooled, %.2f px alone\n", k,
                projectionGap(mesh, truth, fit.camera), projectionGap(mesh, truth, alone[k].camera));
    EXPECT_LT(projectionGap(mesh, truth, fit.camera), 0.7 * projectionGap(mesh, truth, alone[k].camera))
        << "photo " << k << ": " << describeFit(fit) << " / alone: " << describeFit(alone[k]);
  }
  EXPECT_EQ(pooled, dropsAlone);
  for (const StageRecord& s : r.stages)
    if (s.stage == StageId::Camera) {
      std::printf("pooled F of the lens terms: %.2f\n", s.counts["pooled_radial_f"].get<double>());
      EXPECT_GT(s.counts["pooled_radial_f"].get<double>(), 2) << s.counts;
    }
}

TEST(CameraPipeline, TheSilhouetteFindsALensTheNoisyClicksDropped) {
  // Issue 37: spot, four photos with cut-outs, clicks with 2 px of noise. Through a weak lens (k1 = +0.05) the clicks
  // do not pay for k1, alone or pooled; the silhouettes' contours, across the frame, bring the camera half again as
  // near with it, and it is kept. Without a lens the trial brings nothing and every camera stays without.
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  TM_REQUIRE_SHARED(png, "meshes/spot/spot_texture.png");
  auto mesh = requireUsable(loadMesh(obj));
  const TexturedModel truth = modelFromMesh(*mesh, readImageRgba8(png));
  for (double k1 : {0.05, 0.0}) {
    SynthOptions o;
    o.views = 4;
    o.features = 150;
    o.size = 1024;
    o.clickNoisePx = 2;
    o.k1 = k1;
    const std::string dir = texturedScene(*mesh, obj, truth, o, "camera_silhouette_lens");
    const Project project = loadProject(dir + "/project.json");
    CameraFitOptions clicksOnly;
    clicksOnly.silhouette = false;
    const CameraFit alone = fitCamera(*mesh, photoClicks(project, 0), 1024, 1024, clicksOnly);
    ASSERT_EQ(alone.camera.k1, 0) << "the clicks keep the lens: the scene no longer tests the silhouette's trial";
    const PipelineResult r = Pipeline().run(project);
    for (int k = 0; k < 4; ++k) {
      const CameraFit& fit = r.cameras->fits[k];
      std::printf("k1 %.2f, photo %d: fitted k1 %.4f\n", k1, k, fit.camera.k1);
      if (k1 != 0)
        EXPECT_NEAR(fit.camera.k1, k1, 0.01) << describeFit(fit);
      else
        EXPECT_LT(std::abs(fit.camera.k1), 0.005) << describeFit(fit);
    }
  }
}

TEST(CameraPipeline, AnAutoPhotoIsDecidedAgainWithTheLensItsCameraPaysFor) {
  // Issue 37: bob, four photos without a cut-out through one lens (k1 = -0.25), clicks with 2 px of noise. Alone,
  // photo 0's clicks drop the lens terms, and the lens's residuals make its clicks look like another subject's
  // (warped to every click: -5.1 dB). Its camera's other photos pay for the terms; with them it is the object.
  TM_REQUIRE_SHARED(obj, "meshes/bob/bob_tri.obj");
  TM_REQUIRE_SHARED(png, "meshes/bob/bob_diffuse.png");
  auto mesh = requireUsable(loadMesh(obj));
  const TexturedModel truth = modelFromMesh(*mesh, readImageRgba8(png));
  SynthOptions o;
  o.views = 4;
  o.features = 150;
  o.size = 1024;
  o.clickNoisePx = 2;
  o.k1 = -0.25;
  const std::string dir = texturedScene(*mesh, obj, truth, o, "camera_redecided");
  Project project = loadProject(dir + "/project.json");
  for (const PhotoRef& photo : project.photos) {  // laid over white, the alpha dropped: no silhouette to go by
    const cv::Mat rgba = readImageFile(photo.path);
    ASSERT_EQ(rgba.channels(), 4);
    cv::Mat flat(rgba.size(), CV_8UC3);
    rgba.forEach<cv::Vec4b>([&](const cv::Vec4b& c, const int* at) {
      cv::Vec3b& out = flat.at<cv::Vec3b>(at[0], at[1]);
      for (int k = 0; k < 3; ++k) out[k] = cv::saturate_cast<uchar>(c[k] * c[3] / 255.0 + 255 - c[3]);
    });
    ASSERT_TRUE(cv::imwrite(photo.path, flat));
  }
  const ModeDecision alone = decideAutoMode(*loadScene(project), 0);
  ASSERT_EQ(alone.mode, PhotoMode::Subject) << "the scene no longer tests the decision again: " << alone.why;
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(project);
  for (int k = 0; k < 4; ++k) {
    const CameraFit& fit = r.cameras->fits[k];
    EXPECT_FALSE(fit.subject) << k << ": " << fit.decision;
    EXPECT_LT(fit.camera.k1, -0.15) << k << ": " << describeFit(fit);
  }
  std::printf("photo 0 alone: %s\nwith its camera's lens: %s\n", alone.why.c_str(),
              r.cameras->fits[0].decision.c_str());
  // A run that finds the fits in its cache decides the same.
  const PipelineResult again = pipeline.run(project);
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(again.cameras->fits[k].subject, r.cameras->fits[k].subject);
    EXPECT_EQ(again.cameras->fits[k].camera.k1, r.cameras->fits[k].camera.k1);
  }
}

TEST(CameraPipeline, TheExifSaysWhichPhotosShareACameraAndGivesItsFocalLength) {
  // Issue 37: four JPEGs of one size whose EXIF names two cameras (two photos each) and their focal length (the
  // 35 mm equivalent, whole millimetres as cameras write it). The photos of each camera share their intrinsics, with
  // the EXIF's focal length a prior; the cameras are not mixed although all four photos have one size.
  const DemoScene d = demoScene("camera_pipeline_exif", 4, 150, 1.0);
  Project project = loadProject(d.dir + "/project.json");
  for (int k = 0; k < 4; ++k) {
    const cv::Mat stored = readImageFile(project.photos[k].path);  // B,G,R,A
    ASSERT_EQ(stored.channels(), 4);
    cv::Mat bgr, alpha;
    cv::cvtColor(stored, bgr, cv::COLOR_BGRA2BGR);
    cv::extractChannel(stored, alpha, 3);
    std::vector<unsigned char> jpeg;
    ASSERT_TRUE(cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, 95}));
    const int f35 = int(std::lround(d.scene.cameras[k].fx * std::hypot(36.0, 24.0) / std::hypot(512.0, 512.0)));
    const std::string model = k < 2 ? "Alpha" : "Beta";
    const std::vector<unsigned char> modelText(model.c_str(), model.c_str() + model.size() + 1);
    const std::vector<unsigned char> exif =
        test::exifPayload(false, {{271, 2, 5, {'T', 'e', 's', 't', 0}}, {272, 2, int(modelText.size()), modelText}},
                          {{41989, 3, 1, test::exif16(false, uint32_t(f35))}});
    const std::string path = d.dir + "/photo" + std::to_string(k) + ".jpg",
                      mask = d.dir + "/mask" + std::to_string(k) + ".png";
    const std::vector<unsigned char> bytes = test::withApp1(jpeg, exif);
    writeFileAtomic(path, std::string(bytes.begin(), bytes.end()));
    writePng(mask, alpha);
    project.photos[k].path = path, project.photos[k].mask = mask;
  }
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(project);
  ASSERT_EQ(r.cameras->fitted, 4);
  ASSERT_EQ(r.cameras->shared.size(), 2u);
  for (const SharedIntrinsics& s : r.cameras->shared) {
    EXPECT_TRUE(s.shared) << s.why;
    EXPECT_EQ(s.photos, 2);
    EXPECT_TRUE(s.focalPrior);
  }
  for (int k = 0; k < 4; ++k) {
    const CameraFit& fit = r.cameras->fits[k];
    EXPECT_EQ(fit.sharedIntrinsics, 2) << describeFit(fit);
    EXPECT_EQ(fit.focalPrior, 1) << describeFit(fit);
    EXPECT_NEAR(fit.camera.focal() / d.scene.cameras[k].fx, 1.0, 0.02) << describeFit(fit);
  }
}

TEST(CameraFit, SilhouetteRefinementRecoversTheCameraFromNoisyClicks) {
  DemoScene d = demoScene("camera_fit_silhouette", 4, 150, 1.0, 768);
  for (int k = 0; k < 4; ++k) {
    const Photo photo = loadPhoto(d.dir + "/photo_" + std::to_string(k) + ".png");
    ASSERT_TRUE(photo.hasBackground);
    CameraFit fit = fitCamera(*d.mesh, photoClicks(d.scene.project, k), 768, 768);
    ASSERT_TRUE(fit.fits) << fit.reason;
    const double before = projectionGap(*d.mesh, trueCamera(d.scene, k), fit.camera);
    refineOnSilhouette(*d.mesh, photo, fit);
    const double after = projectionGap(*d.mesh, trueCamera(d.scene, k), fit.camera);
    EXPECT_GT(fit.silhouettePoints, 100) << "photo " << k;
    EXPECT_LT(fit.silhouetteResidualPx, 0.5) << "photo " << k;
    EXPECT_LT(after, 0.5 * before) << "photo " << k << ": " << before << " -> " << after << " px";
    EXPECT_LT(after, 0.5) << "photo " << k;
    EXPECT_NE(fit.reason.find("on the silhouette"), std::string::npos);
  }
  // The preview's refinement on kept contours (ContourMemo, contourReusePx): refined again from where it
  // ended (the preview's warm start), a fit finds every contour it needs within half a pixel, extracts
  // none, and stays within a fraction of a pixel. (Without the lens trial, whose rounds extract contours of their
  // own, as the preview's refits are.)
  {
    CameraFitOptions noLens;
    noLens.silhouetteLens = false;
    const Photo photo = loadPhoto(d.dir + "/photo_0.png");
    const CameraFit start = fitCamera(*d.mesh, photoClicks(d.scene.project, 0), 768, 768);
    ContourMemo memo;
    CameraFit first = start;
    refineOnSilhouette(*d.mesh, photo, first, noLens, nullptr, &memo);
    ASSERT_GT(first.silhouettePoints, 0);
    ASSERT_FALSE(memo.contours.empty());
    const std::vector<std::pair<Camera, std::vector<Vec3>>> kept = memo.contours;
    CameraFitOptions preview = noLens;
    preview.contourReusePx = 0.5;
    CameraFit second = first;  // nudged: its points move by about 0.3 px at the image's edge
    second.silhouettePoints = 0;
    second.camera.pinhole.fx *= 1.0008, second.camera.pinhole.fy *= 1.0008;
    ASSERT_GT(projectionGap(*d.mesh, first.camera, second.camera), 0.05);
    refineOnSilhouette(*d.mesh, photo, second, preview, nullptr, &memo);
    ASSERT_EQ(memo.contours.size(), kept.size());  // nothing extracted
    for (size_t i = 0; i < kept.size(); ++i) EXPECT_EQ(memo.contours[i].second.size(), kept[i].second.size());
    EXPECT_GT(second.silhouettePoints, 0);  // refined (not left as it was)
    EXPECT_LT(projectionGap(*d.mesh, first.camera, second.camera), 0.25);
    // Without reuse every round extracts its contour again.
    CameraFit third = start;
    refineOnSilhouette(*d.mesh, photo, third, noLens, nullptr, &memo);
    EXPECT_EQ(memo.contours.size(), 4u);
    EXPECT_EQ(projectionGap(*d.mesh, first.camera, third.camera), 0);
    // The preview's coarser LM step (1e-6 instead of 1e-10) ends within a hundredth of a pixel.
    CameraFitOptions fine = noLens, coarse = noLens;
    fine.silhouetteRounds = coarse.silhouetteRounds = 1;
    coarse.silhouetteStep = 1e-6;
    CameraFit a = start, b = start;
    refineOnSilhouette(*d.mesh, photo, a, fine);
    refineOnSilhouette(*d.mesh, photo, b, coarse);
    ASSERT_GT(a.silhouettePoints, 0);
    ASSERT_GT(b.silhouettePoints, 0);
    EXPECT_GT(projectionGap(*d.mesh, start.camera, b.camera), 0.05);  // it did refine
    EXPECT_LT(projectionGap(*d.mesh, a.camera, b.camera), 0.01);
    // ... and a much coarser step stops farther from the fine one: the step decides where LM stops.
    CameraFitOptions coarsest = coarse;
    coarsest.silhouetteStep = 1e-2;
    CameraFit z = start;
    refineOnSilhouette(*d.mesh, photo, z, coarsest);
    ASSERT_GT(z.silhouettePoints, 0);
    std::printf("silhouette LM step 1e-6: %.5f px from 1e-10; step 1e-2: %.5f px\n",
                projectionGap(*d.mesh, a.camera, b.camera), projectionGap(*d.mesh, a.camera, z.camera));
    EXPECT_GT(projectionGap(*d.mesh, a.camera, z.camera), projectionGap(*d.mesh, a.camera, b.camera));
    // The preview's contours serve cameras up to kPreviewContourPx away: a contour generator's projection
    // moves with the camera only to second order. A fit nudged about 2 px refines on the kept contour,
    // extracting none, and ends as near the four-round fit as a refinement on contours made anew (both
    // within a twentieth of a pixel of it here, and within a tenth of each other).
    CameraFitOptions reuse = coarse, anew = coarse;
    reuse.contourReusePx = kPreviewContourPx;
    CameraFit nudged = first;
    nudged.silhouettePoints = 0;
    nudged.camera.pinhole.fx *= 1.01, nudged.camera.pinhole.fy *= 1.01;
    const double shift = cameraShiftPx(*d.mesh, first.camera.pinhole, nudged.camera.pinhole);
    ASSERT_GT(shift, 1.0);
    ASSERT_LT(shift, kPreviewContourPx);
    ContourMemo kept2;  // the contour through `first`'s camera, the last one the refinements above extracted
    kept2.contours = {memo.contours.back()};
    ASSERT_EQ(cameraShiftPx(*d.mesh, kept2.contours.front().first, first.camera.pinhole), 0);
    CameraFit viaKept = nudged, viaNew = nudged;
    refineOnSilhouette(*d.mesh, photo, viaKept, reuse, nullptr, &kept2);
    refineOnSilhouette(*d.mesh, photo, viaNew, anew);
    EXPECT_EQ(kept2.contours.size(), 1u);  // nothing extracted
    ASSERT_GT(viaKept.silhouettePoints, 0);
    ASSERT_GT(viaNew.silhouettePoints, 0);
    const double gap = projectionGap(*d.mesh, viaKept.camera, viaNew.camera);
    const double keptFromFinal = projectionGap(*d.mesh, viaKept.camera, first.camera);
    const double newFromFinal = projectionGap(*d.mesh, viaNew.camera, first.camera);
    std::printf(
        "nudged %.2f px: kept contours end %.4f px from new ones; from the four-round fit: kept %.4f, new %.4f px\n",
        shift, gap, keptFromFinal, newFromFinal);
    EXPECT_LT(gap, 0.1);
    EXPECT_LT(keptFromFinal, newFromFinal + 0.01);
  }
  // Exact clicks need no silhouette: the fit is left as it is.
  DemoScene exact = demoScene("camera_fit_silhouette_exact", 2, 100, 0, 512);
  const Photo photo = loadPhoto(exact.dir + "/photo_0.png");
  CameraFit fit = fitCamera(*exact.mesh, photoClicks(exact.scene.project, 0), 512, 512);
  const double focal = fit.camera.focal();
  refineOnSilhouette(*exact.mesh, photo, fit);
  EXPECT_EQ(fit.silhouettePoints, 0);
  EXPECT_EQ(fit.camera.focal(), focal);
}

// ---- Photometric refinement (issue 37) ----

namespace {

// The clicks' fits of a demo scene's photos (no silhouette refinement: the clicks alone), their photos, and the mean
// over the photos of the largest gap to the true camera.
struct ClickFits {
  std::vector<Photo> photos;
  std::vector<CameraFit> fits;
  std::vector<const Photo*> photoPtrs() const {
    std::vector<const Photo*> out;
    for (const Photo& p : photos) out.push_back(&p);
    return out;
  }
};

// `photo` (with its background) laid over `under` (CV_8UC3 RGB of the photo's size), its background dropped: a photo
// without a cut-out.
Photo laidOver(const Photo& photo, const cv::Mat& under) {
  Photo out = photo;
  cv::Mat a, rgb, back;
  photo.alpha.convertTo(a, CV_32F, 1.0 / 255);
  cv::cvtColor(a, a, cv::COLOR_GRAY2RGB);
  photo.rgb.convertTo(rgb, CV_32FC3);
  under.convertTo(back, CV_32FC3);
  cv::Mat rest;
  cv::subtract(cv::Scalar::all(1.0), a, rest);
  rgb = rgb.mul(a) + back.mul(rest);
  rgb.convertTo(out.rgb, CV_8UC3);
  out.alpha.release();
  out.distance.release();
  out.hasBackground = false;
  return out;
}

// Lays a photo over white and drops its background: a photo without a cut-out.
void flatten(Photo& photo) {
  photo = laidOver(photo, cv::Mat(photo.rgb.size(), CV_8UC3, cv::Scalar::all(255)));
}

// `silhouette`: each fit refined on its photo's silhouette, as the camera stage gives them; `flat`: the photos
// without their background (flatten).
ClickFits clickFits(const DemoScene& d, bool silhouette = false, bool flat = false) {
  ClickFits c;
  const int size = d.scene.options.size;
  for (size_t k = 0; k < d.scene.cameras.size(); ++k) {
    c.photos.push_back(loadPhoto(d.dir + "/photo_" + std::to_string(k) + ".png"));
    if (flat) flatten(c.photos.back());
    c.fits.push_back(fitCamera(*d.mesh, photoClicks(d.scene.project, static_cast<int>(k)), size, size));
    EXPECT_TRUE(c.fits.back().fits) << c.fits.back().reason;
    if (silhouette) refineOnSilhouette(*d.mesh, c.photos.back(), c.fits.back());
  }
  return c;
}

double meanGap(const DemoScene& d, const std::vector<CameraFit>& fits) {
  double sum = 0;
  for (size_t k = 0; k < fits.size(); ++k) sum += projectionGap(*d.mesh, trueCamera(d.scene, int(k)), fits[k].camera);
  return sum / fits.size();
}

// The scene's photo files laid over white, without alpha: photos without a cut-out.
void flattenFiles(const DemoScene& d) {
  for (size_t k = 0; k < d.scene.cameras.size(); ++k) {
    const std::string path = d.dir + "/photo_" + std::to_string(k) + ".png";
    const Photo photo = loadPhoto(path);
    ASSERT_TRUE(photo.hasBackground) << path;
    cv::Mat bgr;
    cv::cvtColor(laidOver(photo, cv::Mat(photo.rgb.size(), CV_8UC3, cv::Scalar::all(255))).rgb, bgr, cv::COLOR_RGB2BGR);
    cv::imwrite(path, bgr);
  }
}

}  // namespace

// Noisy clicks leave each camera pixels off; in photos without a cut-out (no silhouette to refine on) what the photos
// show where they overlap pulls the cameras together, and the held-out samples say so.
TEST(Photometric, OverlapsBringNoisyCamerasCloserToTheTruth) {
  DemoScene d = demoScene("photometric_noisy", 4, 60, 2.0, 640);
  ClickFits c = clickFits(d, false, true);
  const double before = meanGap(d, c.fits);
  const PhotometricRefinement r = refineCamerasPhotometric(*d.mesh, c.photoPtrs(), pointersTo(c.fits));
  const double after = meanGap(d, c.fits);
  std::printf("photometric: %s; held out: %.4f -> %.4f; largest gap to the truth %.3f -> %.3f px, %.2f s\n",
              r.why.c_str(), r.heldOutBefore, r.heldOutAfter, before, after, r.seconds);
  ASSERT_TRUE(r.tried) << r.why;
  EXPECT_EQ(r.photos.size(), 4u);
  EXPECT_GT(r.samples, 5000);
  ASSERT_TRUE(r.kept) << r.why;
  EXPECT_LT(r.heldOutAfter, r.heldOutBefore);
  EXPECT_GT(before, 1.0);  // the clicks' noise shows
  EXPECT_LT(after, 0.5 * before);
  for (size_t k = 0; k < c.fits.size(); ++k) {  // re-measured: the clicks agree as well as with the true camera
    CameraFit truth = fitFromCamera(*d.mesh, trueCamera(d.scene, int(k)), c.fits[k].clicks);
    truth.thresholdPx = c.fits[k].thresholdPx;
    measureClicks(*d.mesh, truth);
    EXPECT_GT(c.fits[k].photometricShiftPx, 0);
    EXPECT_GE(c.fits[k].inliers, truth.inliers) << "photo " << k;
  }
  // Photos with a background: their silhouettes already bring the cameras within a tenth of a pixel; the overlaps
  // are refused (the held-out samples are predicted no better) or change them by hundredths.
  ClickFits s = clickFits(d, true);
  const double silhouette = meanGap(d, s.fits);
  const PhotometricRefinement t = refineCamerasPhotometric(*d.mesh, s.photoPtrs(), pointersTo(s.fits));
  const double aligned = meanGap(d, s.fits);
  std::printf("from the silhouettes' cameras: %s; gap %.3f -> %.3f px\n", t.why.c_str(), silhouette, aligned);
  EXPECT_LT(silhouette, 0.2);
  EXPECT_LT(aligned, silhouette + 0.03);
}

// Photos at different exposures: the gains take the exposure, the poses still come together.
TEST(Photometric, ExposuresAreGainsNotMisregistration) {
  DemoScene d;
  d.mesh = requireUsable(loadMesh(demoMeshPath()));
  SynthOptions o;
  o.views = 4, o.features = 60, o.size = 640, o.clickNoisePx = 2.0;
  o.exposures = {1.0, 0.6, 1.3, 0.8};
  d.scene = synthesize(*d.mesh, demoMeshPath(), patternOf(*d.mesh), o);
  d.dir = test::tempDir("photometric_exposures");
  writeSynthScene(d.scene, d.dir);
  ClickFits c = clickFits(d, false, true);
  const double before = meanGap(d, c.fits);
  const PhotometricRefinement r = refineCamerasPhotometric(*d.mesh, c.photoPtrs(), pointersTo(c.fits));
  const double after = meanGap(d, c.fits);
  std::printf("photometric with exposures: %s; gap %.3f -> %.3f px; gains", r.why.c_str(), before, after);
  for (const Vec3& g : r.gain) std::printf(" %.2f", g.y());
  std::printf("\n");
  ASSERT_TRUE(r.kept) << r.why;
  EXPECT_LT(after, 0.6 * before);
  ASSERT_EQ(r.gain.size(), 4u);
  EXPECT_GT(r.gain[1].y(), r.gain[2].y() * 1.3);  // the darkest photo takes the largest gain (green, unclipped)
}

// Exact clicks stay where they are; photos that do not show one surface (each replaced by noise) are not aligned.
TEST(Photometric, ExactClicksStayAndUnrelatedPhotosAreNotAligned) {
  DemoScene d = demoScene("photometric_exact", 4, 60, 0.0, 512);
  ClickFits c = clickFits(d);
  const std::vector<CameraFit> exact = c.fits;
  const PhotometricRefinement r = refineCamerasPhotometric(*d.mesh, c.photoPtrs(), pointersTo(c.fits));
  ASSERT_TRUE(r.tried) << r.why;
  for (size_t k = 0; k < exact.size(); ++k)
    EXPECT_LT(projectionGap(*d.mesh, exact[k].camera, c.fits[k].camera), 0.05) << "photo " << k << ": " << r.why;

  DemoScene noisy = demoScene("photometric_unrelated", 4, 60, 2.0, 512);
  ClickFits u = clickFits(noisy, false, true);
  const std::vector<CameraFit> clicked = u.fits;
  cv::RNG rng(7);
  for (Photo& p : u.photos) {
    cv::Mat noise(p.rgb.size(), CV_8UC3);
    rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(noise, noise, cv::Size(0, 0), 2.0);
    p.rgb = noise;
  }
  const PhotometricRefinement v = refineCamerasPhotometric(*noisy.mesh, u.photoPtrs(), pointersTo(u.fits));
  std::printf("unrelated photos: %s\n", v.why.c_str());
  EXPECT_TRUE(v.tried);
  EXPECT_FALSE(v.kept);
  for (size_t k = 0; k < clicked.size(); ++k)
    EXPECT_EQ(projectionGap(*noisy.mesh, clicked[k].camera, u.fits[k].camera), 0);
}

// Two photos (two of three views 120 degrees apart) come together too.
TEST(Photometric, TwoPhotosComeTogether) {
  DemoScene d = demoScene("photometric_two", 3, 90, 2.0, 640);
  ClickFits c = clickFits(d, false, true);
  c.photos.pop_back();
  c.fits.pop_back();
  const double before = meanGap(d, c.fits);
  const PhotometricRefinement r = refineCamerasPhotometric(*d.mesh, c.photoPtrs(), pointersTo(c.fits));
  const double after = meanGap(d, c.fits);
  std::printf("two photos: %s; %d samples; held out %.4f -> %.4f; gap %.3f -> %.3f px\n", r.why.c_str(), r.samples,
              r.heldOutBefore, r.heldOutAfter, before, after);
  ASSERT_TRUE(r.tried) << r.why;
  ASSERT_TRUE(r.kept) << r.why;
  EXPECT_LT(after, 0.7 * before);
}

// Photos of one camera (fitSharedIntrinsics gave them one focal length) keep one focal length through the refinement,
// refined on all their overlaps together: noisy clicks leave it a percent off, which a focal per photo, free, trades
// against its pose and depth photo by photo (bob, 4 views, 2 px: focals 1605-1647 px for a true 1624, -1.41 dB).
TEST(Photometric, PhotosOfOneCameraKeepOneFocalLength) {
  DemoScene d = demoScene("photometric_shared", 4, 150, 2.0, 640);
  ClickFits c = clickFits(d, false, true);
  std::vector<CameraFit*> members = pointersTo(c.fits);
  const SharedIntrinsics joint = fitSharedIntrinsics(*d.mesh, members);
  ASSERT_TRUE(joint.shared) << joint.why;
  std::vector<CameraFit> own = c.fits;  // the same cameras, each with a focal of its own
  for (CameraFit& f : own) f.sharedIntrinsics = 0;
  const double before = meanGap(d, c.fits);
  const double truth = trueCamera(d.scene, 0).focal();
  const PhotometricRefinement r = refineCamerasPhotometric(*d.mesh, c.photoPtrs(), members);
  const PhotometricRefinement q = refineCamerasPhotometric(*d.mesh, c.photoPtrs(), pointersTo(own));
  ASSERT_TRUE(r.kept) << r.why;
  ASSERT_TRUE(q.kept) << q.why;
  double ownFocalError = 0;
  for (const CameraFit& f : own) ownFocalError = std::max(ownFocalError, std::abs(f.camera.focal() / truth - 1));
  const double sharedFocalError = std::abs(c.fits[0].camera.focal() / truth - 1);
  std::printf(
      "one camera: gap %.3f -> %.3f px (a focal per photo: %.3f px); focal %.1f px (truth %.1f, shared at "
      "first %.1f); largest focal error %.2f%% (a focal per photo: %.2f%%)\n",
      before, meanGap(d, c.fits), meanGap(d, own), c.fits[0].camera.focal(), truth, joint.focal, 100 * sharedFocalError,
      100 * ownFocalError);
  for (const CameraFit& f : c.fits) EXPECT_EQ(f.camera.focal(), c.fits[0].camera.focal());
  EXPECT_LT(sharedFocalError, ownFocalError);
  EXPECT_LT(meanGap(d, c.fits), meanGap(d, own));
}

// Through the pipeline: photos without a cut-out are aligned on their overlaps in the final result (and the preview
// that follows takes that verdict), and closer to the true cameras than with the option off.
TEST(CameraPipeline, PhotosWithoutACutOutAreAlignedOnTheirOverlaps) {
  DemoScene d = demoScene("camera_pipeline_photometric", 4, 60, 2.0, 640);
  flattenFiles(d);
  Project project = loadProject(d.dir + "/project.json");
  // 15 clicks a photo with 2 px noise: auto takes one photo for another subject (a camera fitted to all 18 clicks,
  // median residual 1.8 px, max 4.4 px); the user says what they show.
  for (PhotoRef& photo : project.photos) photo.mode = PhotoMode::Object;
  project.options.foundSilhouettes = false;  // the overlaps alone (the silhouettes found: the tests below)
  const auto gaps = [&](const PipelineResult& r) { return meanGap(d, r.cameras->fits); };
  Pipeline pipeline;
  const PipelineResult on = pipeline.run(project);
  ASSERT_TRUE(on.cameras);
  const PhotometricRefinement& ph = on.cameras->photometric;
  ASSERT_TRUE(ph.kept) << ph.why;
  EXPECT_EQ(ph.photos.size(), 4u);
  for (const CameraFit& f : on.cameras->fits) {
    EXPECT_GT(f.photometricShiftPx, 0);
    EXPECT_NE(f.reason.find("aligned with the other photos"), std::string::npos) << f.reason;
  }
  nlohmann::json camera;
  const nlohmann::json report = on.report();
  for (const auto& s : report["stages"])
    if (s["stage"] == "camera") camera = s["counts"]["photometric"];
  EXPECT_EQ(camera["kept"], true);
  EXPECT_LT(camera["held_out_error_after"].get<double>(), camera["held_out_error_before"].get<double>());
  const PipelineResult preview = pipeline.run(project, JobControl(), Tier::Preview);
  for (int k = 0; k < 4; ++k)
    EXPECT_EQ(projectionGap(*d.mesh, preview.cameras->fits[k].camera, on.cameras->fits[k].camera), 0);
  project.options.photometric = false;
  Pipeline without;
  const PipelineResult off = without.run(project);
  EXPECT_FALSE(off.cameras->photometric.tried);
  std::printf("pipeline, photos without a cut-out: gap to the truth %.3f px with the overlaps, %.3f without\n",
              gaps(on), gaps(off));
  EXPECT_LT(gaps(on), 0.5 * gaps(off));
}

// ---- Silhouettes found without a cut-out (issue 37) ----

namespace {

double maskIoU(const cv::Mat& a, const cv::Mat& b) {
  return double(cv::countNonZero((a > 127) & (b > 127))) / std::max(1, cv::countNonZero((a > 127) | (b > 127)));
}

// A real photo's pixels at `size` (RGB), or empty when the Debian package is not installed.
cv::Mat clutter(cv::Size size) {
  const std::string path = "/usr/lib/python3/dist-packages/skimage/data/coffee.png";
  cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR), rgb;
  if (bgr.empty()) return {};
  cv::resize(bgr, bgr, size, 0, 0, cv::INTER_AREA);
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

}  // namespace

// Photos without a cut-out, over white and over a real photo of a café table: GrabCut started from the noisy
// camera's outline finds the object's edge (closer to the truth than the outline), and the camera refined on it
// lands nearer the true one.
TEST(FoundSilhouette, FindsTheObjectsEdgeAroundANoisyOutline) {
  DemoScene d = demoScene("found_silhouette", 2, 90, 2.0, 640);
  const cv::Size size(640, 640);
  std::vector<std::pair<std::string, cv::Mat>> backgrounds = {{"white", cv::Mat(size, CV_8UC3, cv::Scalar::all(255))}};
  if (cv::Mat c = clutter(size); !c.empty())
    backgrounds.emplace_back("coffee", c);
  else
    std::printf("SKIPPED the cluttered background: python3-skimage's coffee.png is not installed\n");
  for (int k = 0; k < 2; ++k) {
    const Photo truth = loadPhoto(d.dir + "/photo_" + std::to_string(k) + ".png");
    ASSERT_TRUE(truth.hasBackground);
    const CameraFit clicks = fitCamera(*d.mesh, photoClicks(d.scene.project, k), 640, 640);
    ASSERT_TRUE(clicks.fits) << clicks.reason;
    const PhotoCamera real = trueCamera(d.scene, k);
    const double outlineIoU = maskIoU(projectedCoverage(*d.mesh, clicks.camera), truth.alpha);
    EXPECT_GT(maskIoU(projectedCoverage(*d.mesh, real), truth.alpha), 0.99);  // the coverage is the silhouette
    for (const auto& [name, under] : backgrounds) {
      const Photo flat = laidOver(truth, under);
      const FoundSilhouette found = findSilhouette(*d.mesh, flat, clicks.camera, clicks.thresholdPx);
      ASSERT_TRUE(found.found) << name << ": " << found.why;
      cv::theRNG().next();  // the thread's random state moved: the same cut (GrabCut's k-means is seeded)
      EXPECT_EQ(
          cv::norm(findSilhouette(*d.mesh, flat, clicks.camera, clicks.thresholdPx).mask, found.mask, cv::NORM_INF), 0)
          << name;
      const double foundIoU = maskIoU(found.mask, truth.alpha);
      CameraFit refined = clicks;
      const Photo withIt = withForeground(flat, found.mask);
      refineOnSilhouette(*d.mesh, withIt, refined);
      CameraFit onTruth = clicks;  // the same on the true cut-out
      refineOnSilhouette(*d.mesh, truth, onTruth);
      const double before = projectionGap(*d.mesh, real, clicks.camera);
      const double after = projectionGap(*d.mesh, real, refined.camera);
      std::printf(
          "photo %d over %s: IoU with the truth %.4f (the outline %.4f), %.2f s; gap to the true camera %.2f "
          "-> %.2f px (on the true cut-out %.2f px)\n",
          k, name.c_str(), foundIoU, outlineIoU, found.seconds, before, after,
          projectionGap(*d.mesh, real, onTruth.camera));
      EXPECT_GT(foundIoU, 0.98) << name;
      EXPECT_GT(foundIoU, outlineIoU) << name;
      EXPECT_GT(refined.silhouettePoints, 0) << name;
      EXPECT_LT(after, 0.6 * before) << name;
    }
  }
}

// Where the photo shows more of the object than the mesh has (a head scan's photo with shoulders below it), the edge
// found runs along the band's limit, and nothing is taken; a photo of noise is refused too.
TEST(FoundSilhouette, TakesNothingWhereThePhotoShowsMoreThanTheMesh) {
  DemoScene d = demoScene("found_silhouette_more", 1, 45, 2.0, 640);
  const Photo truth = loadPhoto(d.dir + "/photo_0.png");
  const CameraFit clicks = fitCamera(*d.mesh, photoClicks(d.scene.project, 0), 640, 640);
  ASSERT_TRUE(clicks.fits) << clicks.reason;
  // The mesh's upper part alone, the photo showing the whole object (a head scan without the shoulders its photo
  // shows): the cut-out runs on along the object, to the band's limit below the part's outline.
  const PhotoCamera real = trueCamera(d.scene, 0);
  std::vector<Vec3> positions;
  for (int v = 0; v < d.mesh->numVertices(); ++v) positions.push_back(d.mesh->position(v));
  std::vector<double> heights;
  for (int f = 0; f < d.mesh->numFaces(); ++f) {
    Vec2 q;
    const auto c = d.mesh->facePositions(f);
    real.project((c[0] + c[1] + c[2]) / 3, q);
    heights.push_back(q.y());
  }
  std::vector<double> sorted = heights;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() * 6 / 10, sorted.end());
  std::vector<std::array<int, 3>> upper;
  for (int f = 0; f < d.mesh->numFaces(); ++f)
    if (heights[f] < sorted[sorted.size() * 6 / 10]) upper.push_back(d.mesh->faceVertices(f));
  const std::unique_ptr<Mesh> part = requireUsable(buildMesh(positions, upper));
  const cv::Mat white(truth.rgb.size(), CV_8UC3, cv::Scalar::all(255));
  const FoundSilhouette more = findSilhouette(*part, laidOver(truth, white), clicks.camera, clicks.thresholdPx);
  std::printf("more of the object: %s\n", more.why.c_str());
  EXPECT_FALSE(more.found);
  EXPECT_GT(more.atLimit, 0.05);
  EXPECT_TRUE(more.mask.empty());
  // Nothing of the object at all: a photo of noise.
  Photo noise = laidOver(truth, white);
  cv::randu(noise.rgb, cv::Scalar::all(0), cv::Scalar::all(255));
  const FoundSilhouette none = findSilhouette(*d.mesh, noise, clicks.camera, clicks.thresholdPx);
  std::printf("a photo of noise: %s\n", none.why.c_str());
  EXPECT_FALSE(none.found);
}

// Through the pipeline: two photos 180 degrees apart without a cut-out share nothing to align; auto takes both for the
// object itself (one by the silhouette found), their cameras are refined on the silhouettes found around the mesh's
// outline, land nearer the truth than the clicks' cameras, and the preview that follows keeps them.
TEST(CameraPipeline, TwoPhotosWithoutACutOutAreRefinedOnTheSilhouettesFound) {
  DemoScene d = demoScene("camera_pipeline_found", 2, 90, 2.0, 640);
  flattenFiles(d);
  Project project = loadProject(d.dir + "/project.json");
  // Auto mode: from their clicks alone the photos are another subject (their first 8 clicks spread 0.5 of the
  // threshold, more than a photo without a silhouette may); with the silhouettes found they are the object.
  const auto gap = [&](const PipelineResult& r) { return meanGap(d, r.cameras->fits); };
  Pipeline pipeline;
  const PipelineResult on = pipeline.run(project);
  ASSERT_TRUE(on.cameras);
  const nlohmann::json report = on.report();
  int decidedBySilhouette = 0;
  for (int k = 0; k < 2; ++k) {
    const CameraFit& f = on.cameras->fits[k];
    ASSERT_TRUE(f.fits && !f.subject) << f.decision;
    decidedBySilhouette += f.decision.find("the silhouette found around the mesh's outline") != std::string::npos;
    EXPECT_TRUE(f.silhouetteFound) << f.silhouetteSearch;
    EXPECT_GT(f.silhouettePoints, 0);
    EXPECT_NE(f.reason.find("silhouette found around the mesh's outline"), std::string::npos) << f.reason;
    EXPECT_EQ(report["cameras"][k]["silhouette_found"], true);
  }
  const PipelineResult preview = pipeline.run(project, JobControl(), Tier::Preview);
  for (int k = 0; k < 2; ++k)
    EXPECT_EQ(projectionGap(*d.mesh, preview.cameras->fits[k].camera, on.cameras->fits[k].camera), 0);
  project.options.foundSilhouettes = false;
  Pipeline without;
  const PipelineResult auto_ = without.run(project);
  for (const CameraFit& f : auto_.cameras->fits) std::printf("without the silhouettes found: %s\n", f.decision.c_str());
  EXPECT_GE(decidedBySilhouette, 1);
  EXPECT_EQ(auto_.cameras->subjects, decidedBySilhouette);                // the clicks alone
  for (PhotoRef& photo : project.photos) photo.mode = PhotoMode::Object;  // the user says what they show
  const PipelineResult off = without.run(project);
  for (const CameraFit& f : off.cameras->fits) EXPECT_FALSE(f.silhouetteFound);
  std::printf(
      "pipeline, two photos without a cut-out: gap to the truth %.3f px on the silhouettes found, %.3f "
      "without\n",
      gap(on), gap(off));
  EXPECT_LT(gap(on), 0.6 * gap(off));
}

// Each view option moves the view the way its doc says (true cameras, photos with a background).
TEST(Projection, ViewOptionsChangeTheViewAsDocumented) {
  DemoScene d = demoScene("projection_view_options", 2, 60, 1.0);
  const Photo photo = loadPhoto(d.dir + "/photo_0.png");
  ASSERT_TRUE(photo.hasBackground);
  std::vector<int> parent(d.mesh->numFaces());
  std::iota(parent.begin(), parent.end(), 0);
  const CameraFit truth = fitFromCamera(*d.mesh, trueCamera(d.scene, 0), photoClicks(d.scene.project, 0));
  const ViewFrame frame = viewFrame(*d.mesh, photo, truth.camera.pinhole);
  auto view = [&](const ProjectionOptions& o) {
    return viewPhoto(*d.mesh, parent, frame, photo, 0, truth, CorrectionField{}, o);
  };
  auto seen = [](const PhotoView& v) {
    return std::count_if(v.faceQuality.begin(), v.faceQuality.end(), [](float q) { return q > 0; });
  };
  auto visible = [](const PhotoView& v) { return std::count(v.vertexVisible.begin(), v.vertexVisible.end(), 1); };
  const PhotoView base = view({});
  ASSERT_GT(seen(base), 100);
  ProjectionOptions o;
  o.minCos = 0.7;  // only faces seen nearly head-on
  EXPECT_LT(seen(view(o)), seen(base));
  o = {};
  o.depthTolerance = 1.0;  // the whole bounding box: occluded vertices count as seen
  EXPECT_GT(visible(view(o)), visible(base));
  o = {};
  o.maxBackgroundPx = -1;  // every face is "on the background"
  const PhotoView refused = view(o);
  EXPECT_EQ(seen(refused), 0);
  EXPECT_GT(refused.refusedBackground, base.refusedBackground);
  // The correction field: a wider smallest reach widens every click's bump.
  const CameraFit fit = fitCamera(*d.mesh, photoClicks(d.scene.project, 0), 512, 512);
  ASSERT_TRUE(fit.fits) << fit.reason;
  const CorrectionField narrow = correctionField(*d.mesh, fit, CorrectionMode::All, 8);
  const CorrectionField wide = correctionField(*d.mesh, fit, CorrectionMode::All, 40);
  ASSERT_EQ(narrow.localSupport.size(), wide.localSupport.size());
  ASSERT_FALSE(narrow.localSupport.empty());
  for (size_t i = 0; i < narrow.localSupport.size(); ++i) EXPECT_GE(wide.localSupport[i], narrow.localSupport[i]);
  EXPECT_GT(std::accumulate(wide.localSupport.begin(), wide.localSupport.end(), 0.0),
            std::accumulate(narrow.localSupport.begin(), narrow.localSupport.end(), 0.0));
  // A face may keep at most maxHidden hidden corners and samples: none hidden textures fewer faces, more more.
  o = {};
  o.maxHidden = 0;
  EXPECT_LT(seen(view(o)), seen(base));
  o.maxHidden = 3;
  EXPECT_GT(seen(view(o)), seen(base));
  // Mode `noise` (1 px clicks here): a larger noiseThreshold moves the texture at the clicks less (at 1 noise
  // deviation some residuals still move it), a huge one not at all, none as much as every residual.
  ASSERT_GT(fit.noisePx, 0);
  auto moved = [&](double threshold) {
    const CorrectionField f = correctionField(*d.mesh, fit, CorrectionMode::Noise, 8, threshold);
    double sum = 0;
    for (const Vec3& c : f.centres) sum += f.at(c).norm();
    return sum;
  };
  EXPECT_GT(moved(0), moved(1));
  EXPECT_GT(moved(1), 0);
  EXPECT_EQ(moved(1e9), 0);
  // Another subject's warp: its weights' falloff (warpAlpha) and its affine part (affineWarp) each move it away
  // from the handles.
  SubjectOptions subject;
  const CorrectionField warp = subjectField(d.scene.project, fit, 0, subject);
  ASSERT_FALSE(warp.warp.empty());
  const Vec2 away = warp.warp.from[0] + Vec2(37, -23);
  subject.warpAlpha = 2;
  EXPECT_GT((subjectField(d.scene.project, fit, 0, subject).warp.apply(away) - warp.warp.apply(away)).norm(), 1e-6);
  subject = {};
  subject.affineWarp = false;
  EXPECT_GT((subjectField(d.scene.project, fit, 0, subject).warp.apply(away) - warp.warp.apply(away)).norm(), 1e-6);
}

// ---- Synthetic click noise ----

TEST(CameraSynth, ClickNoiseIsSeededGaussian) {
  auto mesh = requireUsable(loadMesh(demoMeshPath()));
  SynthOptions o;
  o.views = 3;
  o.features = 120;
  o.size = 512;
  const SynthScene exact = synthesize(*mesh, demoMeshPath(), patternOf(*mesh), o);
  o.clickNoisePx = 1.5;
  const SynthScene noisy = synthesize(*mesh, demoMeshPath(), patternOf(*mesh), o);
  const SynthScene again = synthesize(*mesh, demoMeshPath(), patternOf(*mesh), o);
  ASSERT_EQ(exact.project.points.size(), noisy.project.points.size());
  EXPECT_TRUE(noisy.project.points == again.project.points);  // repeatable
  double sum2 = 0;
  int n = 0;
  for (size_t i = 0; i < exact.project.points.size(); ++i)
    for (size_t j = 0; j < exact.project.points[i].at.size(); ++j) {
      const PhotoPoint& a = exact.project.points[i].at[j];
      const PhotoPoint& b = noisy.project.points[i].at[j];
      sum2 += (a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y);
      n += 2;
    }
  ASSERT_GT(n, 100);
  EXPECT_NEAR(std::sqrt(sum2 / n), 1.5, 0.25);
  o.clickNoisePx = -1;
  EXPECT_NE(test::errorOf([&] { synthesize(*mesh, demoMeshPath(), patternOf(*mesh), o); }).find("clickNoisePx"),
            std::string::npos);
}

// ---- Potts labelling ----

TEST(ViewSelect, AlphaExpansionMatchesBruteForceOnSmallProblems) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 40; ++trial) {
    PottsProblem p;
    p.numNodes = 7;
    p.numLabels = 3;
    for (int i = 0; i < p.numNodes * p.numLabels; ++i)
      p.cost.push_back(rng() % 5 == 0 && i % p.numLabels != (i / p.numLabels) % p.numLabels  // one label always allowed
                           ? PottsProblem::kForbidden
                           : (rng() % 100) / 10.0);
    for (int l = 0; l < p.numLabels; ++l) p.cost[l] = l == 1 ? 0.5 : PottsProblem::kForbidden;  // node 0: only 1
    for (int a = 0; a < p.numNodes; ++a)
      for (int b = a + 1; b < p.numNodes; ++b)
        if (rng() % 3 == 0) p.edges.push_back({a, b}), p.weights.push_back((rng() % 60) / 10.0);
    double best = PottsProblem::kForbidden;
    std::vector<int> labels(p.numNodes, 0);
    for (int code = 0; code < 2187; ++code) {  // 3^7
      int c = code;
      for (int n = 0; n < p.numNodes; ++n) labels[n] = c % 3, c /= 3;
      best = std::min(best, p.energy(labels));
    }
    PottsStats stats;
    const std::vector<int> solved = solvePotts(p, std::vector<int>(p.numNodes, -1), 8, &stats);
    const double e = p.energy(solved);
    ASSERT_TRUE(std::isfinite(best));
    ASSERT_TRUE(std::isfinite(e));
    EXPECT_EQ(solved[0], 1);
    // Alpha-expansion is within a factor 2 of the optimum for Potts (Boykov et al. 2001).
    EXPECT_LE(e, 2 * best + 1e-9) << "trial " << trial;
    EXPECT_LE(stats.finalEnergy, stats.initialEnergy);
  }
}

TEST(ViewSelect, SmoothnessRemovesIsolatedLabels) {
  // A chain of 20 nodes preferring label 0, except node 10 that slightly prefers 1.
  PottsProblem p;
  p.numNodes = 20;
  p.numLabels = 2;
  for (int n = 0; n < p.numNodes; ++n) {
    p.cost.push_back(n == 10 ? 0.6 : 0.0);
    p.cost.push_back(n == 10 ? 0.0 : 0.6);
  }
  for (int n = 0; n + 1 < p.numNodes; ++n) p.edges.push_back({n, n + 1}), p.weights.push_back(1.0);
  const std::vector<int> smooth = solvePotts(p, std::vector<int>(20, -1));
  EXPECT_EQ(smooth[10], 0);
  for (double& w : p.weights) w = 0.1;
  EXPECT_EQ(solvePotts(p, std::vector<int>(20, -1))[10], 1);
}

// ---- Pipeline: projection path, paper path, mixed projects, proposals ----

// Calls fn(corner UV, click, its point) for every corner of a mapped face at a vertex clicked in the face's photo.
// `project`'s ids are the document's: the stages' mesh names them through the scene (Scene::meshVertex).
template <class Fn>
void forEachMappedClick(const PipelineResult& r, const Project& project, Fn fn) {
  const Mapping& m = *r.mapping;
  const Mesh& mesh = m.partition->mesh;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const int p = m.map.facePhoto[f];
    if (p < 0) continue;
    const auto c = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k)
      for (const FeaturePoint& point : project.points)
        if (r.scene->meshVertex(point.vertex) == c[k])
          for (const PhotoPoint& at : point.at)
            if (at.photo == p) fn(m.map.cornerUV[f][k], at, point);
  }
}

TEST(CameraPipeline, PhotosOfTheObjectAreMappedByProjectionWithClicksExact) {
  DemoScene d = demoScene("camera_pipeline_projection", 4, 150, 1.0);
  Project project = loadProject(d.dir + "/project.json");
  project.options.correction = CorrectionMode::All;  // the paper's hard constraints (the default shrinks noise away)
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(project);
  ASSERT_TRUE(r.cameras);
  EXPECT_EQ(r.cameras->fitted, 4);
  const nlohmann::json report = r.report();
  ASSERT_EQ(report["cameras"].size(), 4u);
  for (const auto& c : report["cameras"]) {
    EXPECT_EQ(c["path"], "projection");
    EXPECT_NEAR(c["focal_px"].get<double>() / d.scene.cameras[0].fx, 1.0, 0.15);  // 1 px noise at 512 px
    EXPECT_GT(c["residual_median_px"].get<double>(), 0.3);                        // the click noise
    EXPECT_LT(c["residual_max_px"].get<double>(), 5.0);
  }
  // Every click of a photo lands exactly where it was clicked, in every face mapped to that photo.
  const Mapping& m = *r.mapping;
  const Mesh& mesh = m.partition->mesh;
  int checked = 0;
  forEachMappedClick(r, project, [&](const Vec2& uv, const PhotoPoint& at, const FeaturePoint&) {
    EXPECT_LT((uv - Vec2(at.x, at.y)).norm(), 1e-6);
    ++checked;
  });
  EXPECT_GT(checked, 100);
  // The stages and their order.
  std::vector<StageId> order;
  for (const StageRecord& s : r.stages) order.push_back(s.stage);
  const std::vector<StageId> expected = {StageId::Load,       StageId::Camera,  StageId::Partition, StageId::Map,
                                         StageId::Projection, StageId::Balance, StageId::Seams,     StageId::Level,
                                         StageId::Inpaint,    StageId::Bake};
  EXPECT_EQ(order, expected);
  // Seam optimisation never squeezes a projected face's texture triangle towards a line (it did: stretch
  // 4e10 on the armadillo).
  for (const StageRecord& s : r.stages)
    if (s.stage == StageId::Seams)
      EXPECT_LE(s.counts["max_stretch_after"].get<double>(), 2 * s.counts["max_stretch_before"].get<double>());
  // Most of what the photos see is mapped; no flip.
  EXPECT_GT(r.projection->result.seenFaces, mesh.numFaces() / 2);
  EXPECT_EQ(r.projection->result.emptyFaces, mesh.numFaces() - m.map.numMapped());
}

// Mean distance, photo pixels, from each mapped face corner's UV to its true projection (no correction).
double meanDistanceToTruth(const PipelineResult& r, const SynthScene& scene) {
  const Mesh& mesh = r.mapping->partition->mesh;
  double sum = 0;
  int n = 0;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const int p = r.mapping->map.facePhoto[f];
    if (p < 0) continue;
    const auto c = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k) {
      Vec2 truth;
      if (!trueCamera(scene, p).project(mesh.position(c[k]), truth)) continue;
      sum += (r.mapping->map.cornerUV[f][k] - truth).norm();
      ++n;
    }
  }
  EXPECT_GT(n, 1000);
  return sum / std::max(n, 1);
}

TEST(CameraPipeline, NoisyClicksMoveTheTextureOnlyBeyondTheirNoiseAndExactClicksStayExact) {
  // Issue 37: with many clicks of 1 px noise, the paper's hard constraints pull the texture onto each noisy
  // click; the default `noise` mode moves it only by what the noise does not explain, and lands it near the camera's
  // projection, as `off` does. The fit tells the noise (per axis) within 25%.
  DemoScene noisy = demoScene("camera_pipeline_noise", 4, 200, 1.0);
  Project project = loadProject(noisy.dir + "/project.json");
  ASSERT_EQ(project.options.correction, CorrectionMode::Noise);  // the default
  std::map<CorrectionMode, double> error;
  for (CorrectionMode mode : {CorrectionMode::Noise, CorrectionMode::All, CorrectionMode::Off}) {
    project.options.correction = mode;
    Pipeline pipeline;
    const PipelineResult r = pipeline.run(project);
    ASSERT_EQ(r.cameras->fitted, 4);
    error[mode] = meanDistanceToTruth(r, noisy.scene);
    if (mode == CorrectionMode::Noise)
      for (const auto& c : r.report()["cameras"]) EXPECT_NEAR(c["click_noise_px"].get<double>(), 1.0, 0.25) << c;
  }
  std::printf("mean distance of the mapped corners to their true projection: noise %.3f px, all %.3f px, off %.3f px\n",
              error[CorrectionMode::Noise], error[CorrectionMode::All], error[CorrectionMode::Off]);
  EXPECT_LT(error[CorrectionMode::Noise], 0.8 * error[CorrectionMode::All])
      << "noise " << error[CorrectionMode::Noise] << " px, all " << error[CorrectionMode::All] << " px";
  EXPECT_LT(error[CorrectionMode::Noise], error[CorrectionMode::Off] + 0.1)
      << "noise " << error[CorrectionMode::Noise] << " px, off " << error[CorrectionMode::Off] << " px";

  // Exact clicks, one of them moved 3 px: the fit sees no noise, so every click is kept exactly, the moved one too.
  DemoScene exact = demoScene("camera_pipeline_exact", 4, 200, 0);
  project = loadProject(exact.dir + "/project.json");
  FeaturePoint* moved = nullptr;
  for (FeaturePoint& point : project.points)
    if (!moved && point.at.size() == 1 && point.at[0].photo == 0) moved = &point;
  ASSERT_TRUE(moved);
  moved->at[0].x += 3;
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(project);
  for (const auto& c : r.report()["cameras"]) EXPECT_LT(c["click_noise_px"].get<double>(), 0.05) << c;
  int checked = 0, movedChecked = 0;
  forEachMappedClick(r, project, [&](const Vec2& uv, const PhotoPoint& at, const FeaturePoint& point) {
    EXPECT_LT((uv - Vec2(at.x, at.y)).norm(), 0.05);
    ++checked;
    movedChecked += &point == moved;
  });
  EXPECT_GT(checked, 100);
  EXPECT_GT(movedChecked, 0);
}

TEST(CameraPipeline, ARunThatKeepsNothingForTheNextGivesTheSameResult) {
  // `montage run`'s pipeline (Keep::ThisRunOnly) lets go of the projection's frames and the seams' tiles
  // after their stages: the same model, and after an edit that reruns the projection it renders every
  // frame again where a keeping pipeline reuses them, to the same result.
  DemoScene d = demoScene("camera_pipeline_keep", 4, 150, 1.0);
  Project project = loadProject(d.dir + "/project.json");
  Pipeline keeping, oneRun(Pipeline::Keep::ThisRunOnly);
  const PipelineResult a = keeping.run(project);
  const PipelineResult b = oneRun.run(project);
  ASSERT_EQ(a.cameras->fitted, 4);
  ASSERT_TRUE(a.exported && b.exported);
  EXPECT_EQ(b.mapping->map.facePhoto, a.mapping->map.facePhoto);
  EXPECT_EQ(b.mapping->map.cornerUV, a.mapping->map.cornerUV);
  EXPECT_TRUE(b.exported->uv == a.exported->uv);
  ASSERT_EQ(b.exported->materials.size(), a.exported->materials.size());
  for (size_t m = 0; m < a.exported->materials.size(); ++m)
    EXPECT_EQ(cv::norm(b.exported->materials[m].texture, a.exported->materials[m].texture, cv::NORM_INF), 0);
  project.options.viewSmoothness = 2.0;  // the projection runs again, on the same cameras
  const PipelineResult c = oneRun.run(project);
  const PipelineResult e = keeping.run(project);
  const auto framesReused = [](const PipelineResult& r) {
    const StageRecord& s = r.stages[static_cast<int>(StageId::Projection)];
    EXPECT_EQ(s.stage, StageId::Projection);
    EXPECT_FALSE(s.cached);
    return s.counts["frames_reused"].get<int>();
  };
  EXPECT_EQ(framesReused(e), 4);
  EXPECT_EQ(framesReused(c), 0);
  EXPECT_EQ(c.mapping->map.facePhoto, e.mapping->map.facePhoto);
  EXPECT_EQ(c.mapping->map.cornerUV, e.mapping->map.cornerUV);
}

TEST(CameraPipeline, PhotosOfAnotherSubjectKeepEveryClick) {
  // The demo: real photos of a tiger clicked onto a cat. No camera explains them: both are taken for another
  // subject, and no click is ever an outlier.
  {
    const PipelineResult demo = Pipeline().run(loadProject(test::assetsDir() + "/demo/project.json"));
    ASSERT_TRUE(demo.cameras);
    EXPECT_EQ(demo.cameras->fitted, 0);
    EXPECT_EQ(demo.cameras->subjects, 2);
    for (const auto& c : demo.report()["cameras"]) {
      EXPECT_EQ(c["shows"], "another subject");
      EXPECT_TRUE(c["outliers"].empty() || !c["fits"].get<bool>());
    }
    EXPECT_EQ(demo.projection->result.subjects.size(), 2u);
  }
  // A synthetic scene fits; with its points shuffled between vertices it is a photo of another subject.
  DemoScene d = demoScene("camera_pipeline_shuffled", 3, 150);
  Project project = loadProject(d.dir + "/project.json");
  EXPECT_EQ(Pipeline().run(project).cameras->fitted, 3);
  std::vector<int> vertices;
  for (const FeaturePoint& p : project.points) vertices.push_back(p.vertex);
  std::mt19937 rng(11);
  std::shuffle(vertices.begin(), vertices.end(), rng);
  for (size_t i = 0; i < vertices.size(); ++i) project.points[i].vertex = vertices[i];
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(project);
  ASSERT_TRUE(r.cameras);
  EXPECT_EQ(r.cameras->fitted, 0);
  for (const CameraFit& fit : r.cameras->fits) {
    EXPECT_TRUE(fit.subject);
    EXPECT_FALSE(fit.decision.empty());
    for (char in : fit.inlier) EXPECT_TRUE(in);  // every click kept
  }
  // Shuffled clicks fold any warp: each photo takes the paper's path, whose mapping is the final one.
  ASSERT_EQ(r.projection->result.subjects.size(), 3u);
  for (const SubjectChoice& c : r.projection->result.subjects) {
    EXPECT_FALSE(c.warp) << c.why;
    EXPECT_NE(c.why.find("folds"), std::string::npos) << c.why;
  }
  EXPECT_EQ(r.projection->result.fittedPhotos, 0);
  EXPECT_EQ(r.mapping.get(), r.projection->mapping.get());
  EXPECT_GT(r.mapping->partition->paths.size(), 0u);
  EXPECT_TRUE(r.proposals.empty());
}

TEST(CameraPipeline, MixedProjectsKeepEachPhotosPath) {
  DemoScene d = demoScene("camera_pipeline_mixed", 3, 150);
  Project project = loadProject(d.dir + "/project.json");
  // Photo 2's positions shuffled among its points: it no longer fits.
  std::vector<PhotoPoint*> inTwo;
  for (FeaturePoint& p : project.points)
    for (PhotoPoint& at : p.at)
      if (at.photo == 2) inTwo.push_back(&at);
  ASSERT_GE(inTwo.size(), 10u);
  std::mt19937 rng(2);
  for (size_t i = inTwo.size() - 1; i > 0; --i) {
    PhotoPoint* other = inTwo[rng() % (i + 1)];
    std::swap(inTwo[i]->x, other->x);
    std::swap(inTwo[i]->y, other->y);
  }
  Pipeline pipeline;
  const PipelineResult r = pipeline.run(project);
  ASSERT_EQ(r.cameras->fits.size(), 3u);
  EXPECT_TRUE(r.cameras->fits[0].fits && !r.cameras->fits[0].subject);
  EXPECT_TRUE(r.cameras->fits[1].fits && !r.cameras->fits[1].subject);
  EXPECT_TRUE(r.cameras->fits[2].subject);
  const nlohmann::json report = r.report();
  EXPECT_EQ(report["cameras"][0]["path"], "projection");
  EXPECT_EQ(report["cameras"][2]["shows"], "another subject");
  EXPECT_FALSE(r.projection->result.projected[2]);
  // Faces the paper's path gave to photo 2 keep photo 2 and their UVs; the others are projected.
  const ProjectionResult& pr = r.projection->result;
  EXPECT_EQ(pr.photoProjectedFaces[2], 0);
  EXPECT_GT(pr.photoProjectedFaces[0], 0);
  EXPECT_GT(pr.photoProjectedFaces[1], 0);
  bool warned = false;
  for (const std::string& w : r.warnings)
    warned |= w.find("photo 2 (another subject) takes the paper's path") != std::string::npos;
  EXPECT_TRUE(warned);
  // The camera option off sends every photo down the paper's path.
  project.options.cameraMode = CameraMode::Off;
  const PipelineResult off = pipeline.run(project);
  EXPECT_EQ(off.cameras->fitted, 0);
  EXPECT_EQ(off.projection->result.fittedPhotos, 0);
  EXPECT_EQ(off.projection->result.map.numFaces(), 0);  // nothing projected: the paper's map goes on to the seams
}

TEST(CameraPipeline, ProposalsLieWithinOnePixelOfTheTrueProjection) {
  DemoScene d = demoScene("camera_pipeline_proposals", 4, 150, 0, 768);
  Project project = loadProject(d.dir + "/project.json");
  // Remove photo 1's click of every other point that is also clicked elsewhere.
  std::vector<int> removed;
  for (size_t i = 0; i < project.points.size(); i += 2) {
    auto& at = project.points[i].at;
    const auto it = std::find_if(at.begin(), at.end(), [](const PhotoPoint& a) { return a.photo == 1; });
    if (it != at.end() && at.size() >= 2) {
      at.erase(it);
      removed.push_back(static_cast<int>(i));
    }
  }
  ASSERT_GE(removed.size(), 5u);
  project.declinedProposals.push_back({project.points[removed[0]].vertex, 1});
  const PipelineResult r = Pipeline().run(project);
  int found = 0;
  for (const Proposal& p : r.proposals) {
    Vec2 truth;
    ASSERT_TRUE(d.scene.cameras[p.photo].project(d.mesh->position(p.vertex), truth));
    EXPECT_LT((p.pixel - truth).norm(), 1.0) << "point " << p.point << " photo " << p.photo;
    EXPECT_FALSE(p.point == removed[0] && p.photo == 1);                                   // declined
    for (const PhotoPoint& at : project.points[p.point].at) EXPECT_NE(at.photo, p.photo);  // never where clicked
    found += p.photo == 1 && std::find(removed.begin(), removed.end(), p.point) != removed.end();
  }
  // Most of the removed clicks come back as proposals (all but the declined one, where photo 1 sees them).
  EXPECT_GE(found, static_cast<int>(removed.size()) - 2);
  EXPECT_EQ(r.report()["proposals"].size(), r.proposals.size());
}

TEST(CameraPipeline, ExactClicksComeWithinOneAndAHalfDecibelsOfTheOracle) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  TM_REQUIRE_SHARED(png, "meshes/spot/spot_texture.png");
  auto mesh = requireUsable(loadMesh(obj));
  const TexturedModel truth = modelFromMesh(*mesh, readImageRgba8(png));
  SynthOptions o;
  o.views = 4;
  o.features = 150;
  o.size = 768;
  SynthScene s;
  const std::string dir = texturedScene(*mesh, obj, truth, o, "camera_oracle", &s);
  const Project project = loadProject(dir + "/project.json");
  const PipelineResult result = Pipeline().run(project);
  std::vector<PhotoCamera> cameras = readSynthCameras(dir + "/cameras.json");
  ASSERT_EQ(cameras.size(), 4u);
  EXPECT_EQ(cameras[2].pinhole.R, s.cameras[2].R);
  const PipelineResult oracle = projectionOracle(project, cameras);
  EvalOptions eo;
  eo.samples = 60000;
  const EvalResult a = evaluate(*result.model, truth, eo), b = evaluate(*oracle.model, truth, eo);
  EXPECT_GE(a.psnrCovered, b.psnrCovered - 1.5);
  EXPECT_GT(b.psnrCovered, 30);
  EXPECT_EQ(a.flippedTriangles, 0);
  EXPECT_LE(a.coverageInpainted + a.coverageEmpty, b.coverageInpainted + b.coverageEmpty + 0.05);
  // The paper's path alone (camera fit off) is far below: the reason for this path.
  Project paper = project;
  paper.options.cameraMode = CameraMode::Off;
  const EvalResult c = evaluate(*Pipeline().run(paper).model, truth, eo);
  EXPECT_LT(c.psnrCovered, a.psnrCovered - 5);
}

// Issue 34, item 3: a face some photo sees is mapped from it, not inpainted. The inpainted share stays within
// one point of what no photo sees well enough (bench/sight.h: in front, facing by at least the projection's
// minimum cosine, unoccluded, on the photo's alpha through a true camera).
TEST(CameraPipeline, FacesAPhotoSeesAreMappedNotInpainted) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  TM_REQUIRE_SHARED(png, "meshes/spot/spot_texture.png");
  auto mesh = requireUsable(loadMesh(obj));
  const TexturedModel truth = modelFromMesh(*mesh, readImageRgba8(png));
  for (int views : {2, 4}) {
    SynthOptions o;
    o.views = views;
    o.features = 150;
    o.size = 768;
    const std::string dir = texturedScene(*mesh, obj, truth, o, "camera_seen_" + std::to_string(views));
    const PipelineResult r = Pipeline(Pipeline::Keep::ThisRunOnly).run(loadProject(dir + "/project.json"));
    const Mesh& refined = r.mapping->partition->mesh;
    ASSERT_EQ(r.baked->atlas.faceSource.size(), size_t(refined.numFaces()));
    std::vector<const Photo*> photos;
    for (const auto& p : r.scene->photos) photos.push_back(p.get());
    // Seen well enough: facing a camera by the projection's own minimum cosine. Faces seen more obliquely lie
    // within a pixel or two of the silhouette, where the photo's colours mix with the background: mapped, they
    // measured worse than inpainted (docs/pipeline.md).
    SightOptions so;
    so.minCos = ProjectionOptions{}.minCos;
    const Sight sight = cameraSight(refined, readSynthCameras(dir + "/cameras.json"), photos, so);
    double total = 0, inpainted = 0;
    for (int f = 0; f < refined.numFaces(); ++f) {
      total += refined.faceArea(f);
      if (r.baked->atlas.faceSource[f] < 0) inpainted += refined.faceArea(f);
    }
    inpainted /= total;
    EXPECT_GT(sight.unseenShare, 0.05) << views << " views";  // the scene leaves some of the cow unseen
    // The target is 1 point. Two views still miss it (1.5 points; 2.1 before faces with one hidden sample
    // were mapped): the rest are faces partly hidden within a few pixels of the silhouette, better inpainted.
    const double allowed = views == 2 ? 0.0175 : 0.01;
    EXPECT_LE(inpainted, sight.unseenShare + allowed) << views << " views: inpainted " << 100 * inpainted
                                                      << "%, no photo sees well enough " << 100 * sight.unseenShare
                                                      << "%";
  }
}

// The editor's preview refits a dragged photo from its last camera and starts view selection from the
// last choices; the final tier of the same document still equals a fresh run exactly.
TEST(CameraPipeline, ThePreviewStartsFromTheLastRunAndTheFinalMatchesAFreshRun) {
  DemoScene d = demoScene("camera_pipeline_warm", 4, 150, 1.0);
  Project doc = loadProject(d.dir + "/project.json");
  ASSERT_TRUE(doc.chains.empty());
  Pipeline pipeline;
  PipelineResult last = pipeline.run(doc);
  ASSERT_EQ(last.cameras->fitted, 4);
  std::mt19937 rng(7);
  for (int step = 0; step < 2; ++step) {
    SCOPED_TRACE("step " + std::to_string(step));
    std::set<int> changed;  // photos whose clicks change
    if (step == 1) {        // a delete: the photos of its clicks are refitted
      for (const PhotoPoint& at : doc.points[5].at) changed.insert(at.photo);
      doc.points.erase(doc.points.begin() + 5);
    } else {  // a drag of a photo-0 click by a few pixels
      changed.insert(0);
      for (FeaturePoint& p : doc.points)
        if (!p.at.empty() && p.at[0].photo == 0) {
          p.at[0].x += std::uniform_real_distribution<double>(2, 4)(rng);
          p.at[0].y -= std::uniform_real_distribution<double>(2, 4)(rng);
          break;
        }
    }
    const PipelineResult preview = pipeline.run(doc, {}, Tier::Preview);
    // A fresh pipeline has no last run: its preview mapping is the final's.
    const PipelineResult fresh = Pipeline().run(doc, {}, Tier::Preview);
    ASSERT_EQ(preview.cameras->fitted, 4);
    const ProjectionResult& pr = preview.projection->result;
    EXPECT_EQ(pr.selectionSweeps, 1);  // one sweep from the last labels
    if (pr.meshHash == last.projection->result.meshHash) {
      // The same refined mesh: the views of photos whose camera did not move are the last run's, and the
      // faces far from any change keep their photo without selection.
      EXPECT_EQ(pr.viewsReused, 4 - static_cast<int>(changed.size()));
      EXPECT_GT(pr.selectionKept, 0);
      EXPECT_LT(pr.selectionKept, preview.mapping->map.numFaces());
    }
    // The warm camera lands within a fraction of a pixel of the fit from scratch. The photos share their camera's
    // intrinsics, so a changed click moves every photo's fit a little: in the preview a photo whose clicks did not
    // change keeps its last camera.
    for (int k = 0; k < 4; ++k) {
      const CameraFit& warm = preview.cameras->fits[k];
      EXPECT_EQ(warm.sharedIntrinsics, 4) << describeFit(warm);
      const double gap = projectionGap(*d.mesh, warm.camera, fresh.cameras->fits[k].camera);
      EXPECT_LT(gap, 0.5) << "photo " << k;
      if (changed.count(k)) std::printf("photo %d: the warm camera is %.3f px from the fit from scratch\n", k, gap);
      if (changed.count(k)) {
        EXPECT_GT(gap, 0) << "photo " << k << " was refitted from scratch";
      } else {
        EXPECT_EQ(projectionGap(*d.mesh, warm.camera, last.cameras->fits[k].camera), 0)
            << "photo " << k << ", whose clicks did not change, was refitted";
      }
    }
    // It shows nearly the same photo choices and UVs as the final.
    const TextureMap& a = preview.mapping->map;
    const TextureMap& b = fresh.mapping->map;
    ASSERT_EQ(a.numFaces(), b.numFaces());
    int same = 0, mapped = 0;
    for (int f = 0; f < a.numFaces(); ++f) {
      mapped += b.facePhoto[f] >= 0;
      same += b.facePhoto[f] >= 0 && a.facePhoto[f] == b.facePhoto[f];
    }
    EXPECT_GT(same, 0.97 * mapped);
    // The seams start from the last run's sides and match as well as a fresh optimisation's.
    auto seamFigure = [](const PipelineResult& r, const char* name) {
      for (const StageRecord& s : r.stages)
        if (s.stage == StageId::Seams) return s.counts[name].get<double>();
      return -1.0;
    };
    EXPECT_GT(seamFigure(preview, "warm_sides"), 0);
    EXPECT_EQ(seamFigure(fresh, "warm_sides"), 0);
    EXPECT_LT(seamFigure(preview, "delta_e_after"), 1.1 * seamFigure(fresh, "delta_e_after") + 0.1);
    // The final of the same document: exactly the fresh run's.
    const PipelineResult final = pipeline.run(doc, {}, Tier::Final);
    EXPECT_GT(final.projection->result.selectionSweeps, 1);
    EXPECT_EQ(final.projection->result.framesNear, 0);
    EXPECT_EQ(final.projection->result.selectionKept, 0);
    test::expectSameMapping(*final.mapping, *fresh.mapping, "final after the preview");
    last = final;
  }
}

// A delete changes the refined mesh: the views of the photos whose camera stays are made again on the new
// mesh, carrying over what the two meshes share (ViewFrameCache::view, carryOver). They equal the views a
// fresh pipeline computes in full, entry for entry, and so does the mapping.
TEST(CameraPipeline, AViewCarriedOverToANewRefinementEqualsAFreshOne) {
  DemoScene d = demoScene("camera_pipeline_carry", 4, 150, 1.0);
  Project doc = loadProject(d.dir + "/project.json");
  // Each photo keeps its own camera: photos that share their intrinsics all move when any click does, and no view
  // would be carried (the final tier takes every camera as a fresh run does).
  doc.options.sharedIntrinsics = false;
  Pipeline pipeline;
  const PipelineResult first = pipeline.run(doc);
  ASSERT_EQ(first.cameras->fitted, 4);
  int carriedViews = 0;
  std::mt19937 rng(11);
  for (int step = 0; step < 3; ++step) {
    SCOPED_TRACE("step " + std::to_string(step));
    // Delete a point clicked in one photo only: the other photos keep their cameras.
    std::vector<size_t> single;
    for (size_t i = 0; i < doc.points.size(); ++i)
      if (doc.points[i].at.size() == 1) single.push_back(i);
    ASSERT_FALSE(single.empty());
    doc.points.erase(doc.points.begin() + single[rng() % single.size()]);
    const PipelineResult kept = pipeline.run(doc);
    const PipelineResult fresh = Pipeline().run(doc);
    const ProjectionResult &a = kept.projection->result, &b = fresh.projection->result;
    ASSERT_NE(a.meshHash, first.projection->result.meshHash);
    EXPECT_EQ(b.viewsCarried, 0);
    carriedViews += a.viewsCarried;
    if (a.viewsCarried > 0) EXPECT_GT(a.carriedShare, 0.5);
    ASSERT_EQ(a.views.size(), b.views.size());
    for (size_t p = 0; p < a.views.size(); ++p) {
      SCOPED_TRACE("photo " + std::to_string(p));
      ASSERT_EQ(!a.views[p], !b.views[p]);
      if (!a.views[p]) continue;
      const PhotoView &x = *a.views[p], &y = *b.views[p];
      ASSERT_EQ(x.vertexUV.size(), y.vertexUV.size());
      for (size_t v = 0; v < x.vertexUV.size(); ++v)  // NaN (behind the camera) in both, or the same pixel
        ASSERT_TRUE(x.vertexUV[v] == y.vertexUV[v] || (x.vertexUV[v].hasNaN() && y.vertexUV[v].hasNaN())) << v;
      EXPECT_EQ(x.vertexVisible, y.vertexVisible);
      EXPECT_EQ(x.vertexSilhouettePx, y.vertexSilhouettePx);
      EXPECT_EQ(x.faceQuality, y.faceQuality);
      EXPECT_EQ(x.faceRefused, y.faceRefused);
      EXPECT_EQ(x.refusedFlipped, y.refusedFlipped);
      EXPECT_EQ(x.refusedBackground, y.refusedBackground);
      EXPECT_TRUE(x.edgeLuv == y.edgeLuv);
    }
    test::expectSameMapping(*kept.mapping, *fresh.mapping, "after the delete");
  }
  EXPECT_GE(carriedViews, 3);  // each delete leaves at least one photo's camera as it was
}

// ---- Photos of another subject (issue 33): the warp and the mode decision ----

TEST(SubjectWarp, IsExactAtEveryHandleAndAffineWhereTheHandlesAre) {
  // Handles moved by an affine map plus a bump on one of them: the warp takes each exactly where it goes, and
  // far from the bump follows the affine map; left out, a handle on the affine map is predicted to within a pixel.
  ImageWarp warp;
  const Eigen::Matrix2d a{{1.2, 0.1}, {-0.05, 0.9}};
  const Vec2 b(7, -3);
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) {
      const Vec2 from(40 + 50 * i, 30 + 45 * j);
      warp.from.push_back(from);
      warp.to.push_back(a * from + b + (i == 2 && j == 2 ? Vec2(6, 4) : Vec2::Zero()));
    }
  for (size_t i = 0; i < warp.from.size(); ++i) EXPECT_LT((warp.apply(warp.from[i]) - warp.to[i]).norm(), 1e-9);
  const Vec2 corner(45, 32);
  EXPECT_LT((warp.apply(corner) - (a * corner + b)).norm(), 0.5);
  EXPECT_LT(warp.heldOut(0).norm(), 1.0);
  EXPECT_GT(warp.heldOut(12).norm(), 3.0);  // the bump cannot be predicted from the others
  warp.affine = false;                      // a similarity cannot follow the shear, but stays exact at handles
  for (size_t i = 0; i < warp.from.size(); ++i) EXPECT_LT((warp.apply(warp.from[i]) - warp.to[i]).norm(), 1e-9);
}

TEST(PhotoMode, TheAutoDecisionHasAMarginAndHysteresis) {
  const SubjectOptions o;
  auto evidence = [](int clicks, double share, double spread, double silhouette = -1) {
    CameraEvidence e;
    e.clicks = clicks, e.agreeShare = share, e.spread = spread, e.silhouette = silhouette;
    return e;
  };
  // Too few clicks: another subject, every click kept, until decisionClicks.
  EXPECT_EQ(decidePhotoMode({}, evidence(o.decisionClicks - 1, 1, 0.1), o).mode, PhotoMode::Subject);
  // The object itself: its first clicks fit; all of them a little worse, within the flip thresholds, stay so.
  const CameraEvidence objectFirst = evidence(8, 1, 0.3, 0.97);
  EXPECT_EQ(decidePhotoMode(objectFirst, evidence(20, 0.9, 0.8, 0.9), o).mode, PhotoMode::Object);
  EXPECT_EQ(decidePhotoMode(objectFirst, evidence(20, 0.7, 0.8, 0.9), o).mode, PhotoMode::Subject);
  // A similar face fits a camera about as well as a noisy photo of the head, but not its silhouette.
  EXPECT_EQ(decidePhotoMode(evidence(8, 1, 0.6, 0.43), evidence(16, 1, 0.6, 0.43), o).mode, PhotoMode::Subject);
  // Without a silhouette, a spread a similar face reaches by luck is not enough...
  const CameraEvidence subjectFirst = evidence(8, 0.9, 0.6);
  EXPECT_EQ(decidePhotoMode(subjectFirst, evidence(16, 0.95, 0.5), o).mode, PhotoMode::Subject);
  // ...and another subject becomes the object itself only when all its clicks clearly fit.
  EXPECT_EQ(decidePhotoMode(subjectFirst, evidence(16, 1, 0.2), o).mode, PhotoMode::Object);
  // First clicks of 3 px noise that missed the spread by a hair: a handful more keeps the decision, dozens that
  // agree with the camera and show its silhouette make it the object itself; a similar face's dozens do not.
  const CameraEvidence noisyFirst = evidence(8, 1, 0.76, 0.99);
  EXPECT_EQ(decidePhotoMode(noisyFirst, evidence(16, 1, 0.62, 0.99), o).mode, PhotoMode::Subject);
  EXPECT_EQ(decidePhotoMode(noisyFirst, evidence(o.joinClicks, 1, 0.62, 0.99), o).mode, PhotoMode::Object);
  EXPECT_EQ(decidePhotoMode(noisyFirst, evidence(o.joinClicks, 0.95, 0.62, 0.99), o).mode, PhotoMode::Subject);
  EXPECT_EQ(decidePhotoMode(evidence(8, 1, 0.6, 0.43), evidence(60, 1, 0.6, 0.43), o).mode, PhotoMode::Subject);
  EXPECT_EQ(decidePhotoMode(subjectFirst, evidence(60, 1, 0.6), o).mode, PhotoMode::Subject);  // no silhouette
}

TEST(PhotoMode, OneClickMoreMovedOrFewerLeavesTheModeOfTheFaceAndTigerCasesUnchanged) {
  // Photos of another subject with landmarks (bench/data): a portrait of another person clicked onto the Lee
  // Perry-Smith head scan, and Tux Paint's tiger onto Sumner's cat. The decision is another subject, and no one
  // click more (a held-out landmark), moved by 2 px, or fewer changes it.
  const std::string data = test::sharedDataDir();
  if (data.empty()) GTEST_SKIP() << "../shared/data is absent: the cases need meshes/leeperrysmith and meshes/sumner";
  int cases = 0;
  for (const std::string name : {"face_leeperrysmith.json", "tiger_cat.json"}) {
    SCOPED_TRACE(name);
    LandmarkCase c;
    try {
      c = loadLandmarkCase(test::assetsDir() + "/../bench/data/" + name, data);
    } catch (const Error& e) {  // a photo from a Debian package that is not installed
      std::printf("SKIPPED %s: %s (packages python3-skimage, tuxpaint-stamps-default)\n", name.c_str(), e.what());
      continue;
    }
    ++cases;
    const auto mode = [](const Project& p) { return decideAutoMode(*loadScene(p), 0); };
    const ModeDecision base = mode(c.project);
    EXPECT_EQ(base.mode, PhotoMode::Subject) << base.why;
    for (const auto& [what, project] : oneClickChanges(c)) {
      const ModeDecision d = mode(project);
      EXPECT_EQ(d.mode, base.mode) << what << ": " << d.why;
    }
  }
  if (cases == 0)
    GTEST_SKIP() << "neither case's photo is installed (packages python3-skimage, tuxpaint-stamps-default)";
}
