// Tests of synthetic ground-truth scenes (core/synth.h): photos, feature visibility and positions,
// farthest-point sampling, determinism, the solid pattern and the files written.
#include "bench/synth.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <queue>
#include <random>
#include <set>

#include "geometry/mesh.h"
#include "image/photo.h"
#include "io/mesh_io.h"
#include "io/model.h"
#include "io/project.h"
#include "mapping/camera.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace montage {
namespace {

// RGB in [0, 1] as CV_32FC3, for sampleBilinear3.
cv::Mat toFloatRgb(const cv::Mat& rgba) {
  cv::Mat rgb, f;
  cv::cvtColor(rgba, rgb, cv::COLOR_RGBA2RGB);
  rgb.convertTo(f, CV_32FC3, 1.0 / 255);
  return f;
}

std::vector<Vec3> vertexNormals(const Mesh& mesh) {
  std::vector<Vec3> n(mesh.numVertices(), Vec3::Zero());
  for (int f = 0; f < mesh.numFaces(); ++f)
    for (int v : mesh.faceVertices(f)) n[v] += mesh.faceNormal(f) * mesh.faceArea(f);
  for (auto& x : n) x.normalize();
  return n;
}

// Geodesic (edge-path) distances from `source` to every vertex.
std::vector<double> dijkstra(const Mesh& mesh, int source) {
  std::vector<std::vector<std::pair<int, double>>> adj(mesh.numVertices());
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto c = mesh.faceVertices(f);
    for (int k = 0; k < 3; ++k) {
      const int a = c[k], b = c[(k + 1) % 3];
      const double len = (mesh.position(a) - mesh.position(b)).norm();
      adj[a].emplace_back(b, len);
      adj[b].emplace_back(a, len);
    }
  }
  std::vector<double> dist(mesh.numVertices(), std::numeric_limits<double>::infinity());
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
  dist[source] = 0;
  heap.emplace(0, source);
  while (!heap.empty()) {
    const auto [d, v] = heap.top();
    heap.pop();
    if (d > dist[v]) continue;
    for (const auto& [w, len] : adj[v])
      if (d + len < dist[w]) heap.emplace(dist[w] = d + len, w);
  }
  return dist;
}

double minPairwiseGeodesic(const Mesh& mesh, const std::vector<int>& vertices) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < vertices.size(); ++i) {
    const std::vector<double> d = dijkstra(mesh, vertices[i]);
    for (size_t j = i + 1; j < vertices.size(); ++j) best = std::min(best, d[vertices[j]]);
  }
  return best;
}

struct SpotScene {
  std::unique_ptr<Mesh> mesh;
  TexturedModel model;
  std::string path;
  SynthOptions options;
  SynthScene scene;
  std::vector<double> progress;
};

class SynthSpot : public ::testing::Test {
 protected:
  void SetUp() override {
    TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
    TM_REQUIRE_SHARED(png, "meshes/spot/spot_texture.png");
    if (!spot_) {
      spot_ = std::make_unique<SpotScene>();
      spot_->path = obj;
      spot_->mesh = requireUsable(loadMesh(obj));
      spot_->model = modelFromMesh(*spot_->mesh, readImageRgba8(png));
      spot_->options.views = 4;
      spot_->options.features = 150;
      spot_->options.size = 512;
      spot_->scene = synthesize(*spot_->mesh, obj, colorFunction(), spot_->options,
                                [this](double p) { spot_->progress.push_back(p); });
    }
  }
  SurfaceColor colorFunction() const {
    const TexturedModel* model = &spot_->model;
    return [model](int f, const Vec3& b) { return model->colorAt(f, b); };
  }
  const Mesh& mesh() const { return *spot_->mesh; }
  const TexturedModel& model() const { return spot_->model; }
  const SynthScene& scene() const { return spot_->scene; }
  static std::unique_ptr<SpotScene> spot_;
};
std::unique_ptr<SpotScene> SynthSpot::spot_;

TEST_F(SynthSpot, PhotosHaveTransparentBackground) {
  const SynthScene& s = scene();
  ASSERT_EQ(s.photos.size(), 4u);
  ASSERT_EQ(s.cameras.size(), 4u);
  Vec3 lo, hi;
  mesh().bounds(lo, hi);
  const Vec3 centre = 0.5 * (lo + hi);
  for (size_t k = 0; k < s.photos.size(); ++k) {
    const cv::Mat& p = s.photos[k];
    ASSERT_EQ(p.type(), CV_8UC4);
    ASSERT_EQ(p.cols, 512);
    ASSERT_EQ(p.rows, 512);
    for (const auto& corner : {cv::Point(0, 0), cv::Point(511, 0), cv::Point(0, 511), cv::Point(511, 511)}) {
      EXPECT_EQ(p.at<cv::Vec4b>(corner)[3], 0) << "photo " << k;
      EXPECT_EQ(p.at<cv::Vec4b>(corner), cv::Vec4b(0, 0, 0, 0)) << "photo " << k;
    }
    Vec2 c;
    ASSERT_TRUE(s.cameras[k].project(centre, c));
    EXPECT_GT(p.at<cv::Vec4b>(static_cast<int>(c.y()), static_cast<int>(c.x()))[3], 0) << "photo " << k;
    // The silhouette is antialiased: some pixels are partially covered.
    std::vector<cv::Mat> channels;
    cv::split(p, channels);
    const int partial = cv::countNonZero(channels[3] > 0 & channels[3] < 255);
    EXPECT_GT(partial, 100) << "photo " << k;
    // The mesh fills a good part of the photo but stays inside it.
    const double covered = cv::countNonZero(channels[3]) / (512.0 * 512.0);
    EXPECT_GT(covered, 0.1) << "photo " << k;
    EXPECT_EQ(cv::countNonZero(channels[3].row(0)) + cv::countNonZero(channels[3].row(511)) +
                  cv::countNonZero(channels[3].col(0)) + cv::countNonZero(channels[3].col(511)),
              0);
  }
  // One progress report per view, ending at 1.
  ASSERT_EQ(spot_->progress.size(), 4u);
  EXPECT_DOUBLE_EQ(spot_->progress.back(), 1.0);
  EXPECT_TRUE(std::is_sorted(spot_->progress.begin(), spot_->progress.end()));
}

TEST_F(SynthSpot, FeaturesLieOnForegroundWithTheTruthColour) {
  const SynthScene& s = scene();
  EXPECT_GE(s.project.points.size(), 100u);
  EXPECT_EQ(s.featureVertices.size(), 150u);
  std::vector<cv::Mat> rgb;
  for (const auto& p : s.photos) rgb.push_back(toFloatRgb(p));
  // Faces around each vertex, to read the texture colour at a vertex (on UV seams it differs by face).
  std::vector<std::vector<int>> vertexFaces(mesh().numVertices());
  for (int f = 0; f < mesh().numFaces(); ++f)
    for (int v : mesh().faceVertices(f)) vertexFaces[v].push_back(f);

  int written = 0, matching = 0;
  size_t order = 0;
  for (const FeaturePoint& fp : s.project.points) {
    // Points keep the sampling order.
    const auto it = std::find(s.featureVertices.begin() + order, s.featureVertices.end(), fp.vertex);
    ASSERT_NE(it, s.featureVertices.end()) << "vertex " << fp.vertex;
    order = it - s.featureVertices.begin() + 1;
    ASSERT_FALSE(fp.at.empty());
    std::set<int> photos;
    for (const PhotoPoint& pp : fp.at) {
      ASSERT_GE(pp.photo, 0);
      ASSERT_LT(pp.photo, 4);
      EXPECT_TRUE(photos.insert(pp.photo).second) << "two points in one photo";
      EXPECT_TRUE(pp.x >= 0 && pp.y >= 0 && pp.x <= 512 && pp.y <= 512) << pp.x << ", " << pp.y;
      const cv::Mat& photo = s.photos[pp.photo];
      EXPECT_GT(photo.at<cv::Vec4b>(static_cast<int>(pp.y), static_cast<int>(pp.x))[3], 0);
      // The point is the exact projection of the vertex.
      Vec2 proj;
      ASSERT_TRUE(s.cameras[pp.photo].project(mesh().position(fp.vertex), proj));
      EXPECT_NEAR(proj.x(), pp.x, 1e-9);
      EXPECT_NEAR(proj.y(), pp.y, 1e-9);

      const Vec3f seen = sampleBilinear3(rgb[pp.photo], pp.x, pp.y);
      double best = std::numeric_limits<double>::infinity();
      for (int f : vertexFaces[fp.vertex]) {
        Vec3 b = Vec3::Zero();
        const auto c = mesh().faceVertices(f);
        b[std::find(c.begin(), c.end(), fp.vertex) - c.begin()] = 1;
        best = std::min<double>(best, (model().colorAt(f, b) - seen).cwiseAbs().maxCoeff());
      }
      ++written;
      if (best < 0.06) ++matching;
    }
  }
  std::printf("%zu of %zu features written, %d positions, %d match the truth colour\n", s.project.points.size(),
              s.featureVertices.size(), written, matching);
  EXPECT_GE(matching, 0.95 * written);
}

TEST_F(SynthSpot, FarSideVertexIsNotWritten) {
  const SynthScene& s = scene();
  const std::vector<Vec3> normals = vertexNormals(mesh());
  const Vec3 eye = s.cameras[0].center();
  int far = -1;
  double farCos = 2;
  for (int v : s.featureVertices) {
    const double c = normals[v].dot((eye - mesh().position(v)).normalized());
    if (c < farCos) {
      farCos = c;
      far = v;
    }
  }
  ASSERT_GE(far, 0);
  EXPECT_LT(farCos, -0.5);  // really on the far side
  bool inPhoto0 = false, anywhere = false;
  for (const FeaturePoint& fp : s.project.points)
    if (fp.vertex == far) {
      anywhere = true;
      for (const PhotoPoint& pp : fp.at) inPhoto0 |= pp.photo == 0;
    }
  EXPECT_FALSE(inPhoto0) << "vertex " << far << " faces away from camera 0 but was written for photo 0";
  // Views are spread around the mesh, so some other view does see it.
  EXPECT_TRUE(anywhere);
}

TEST_F(SynthSpot, FarthestPointSamplesAreSpread) {
  const std::vector<int> fps = farthestPointSamples(mesh(), 150, 1);
  ASSERT_EQ(fps.size(), 150u);
  EXPECT_EQ(std::set<int>(fps.begin(), fps.end()).size(), 150u);
  for (int v : fps) {
    ASSERT_GE(v, 0);
    ASSERT_LT(v, mesh().numVertices());
  }
  EXPECT_EQ(fps, scene().featureVertices);  // the scene uses the same sampling

  std::mt19937 rng(5);
  std::vector<int> all(mesh().numVertices());
  std::iota(all.begin(), all.end(), 0);
  std::shuffle(all.begin(), all.end(), rng);
  const std::vector<int> random(all.begin(), all.begin() + 150);
  const double dFps = minPairwiseGeodesic(mesh(), fps), dRandom = minPairwiseGeodesic(mesh(), random);
  std::printf("min pairwise geodesic distance: FPS %.4f, random %.4f\n", dFps, dRandom);
  EXPECT_GE(dFps, 0.5 * dRandom);
  EXPECT_GT(dFps, dRandom);

  // Another seed starts elsewhere.
  EXPECT_NE(farthestPointSamples(mesh(), 10, 2), farthestPointSamples(mesh(), 10, 1));
}

TEST_F(SynthSpot, Deterministic) {
  const SynthScene again = synthesize(mesh(), spot_->path, colorFunction(), spot_->options);
  EXPECT_EQ(projectToJson(again.project, ""), projectToJson(scene().project, ""));
  ASSERT_EQ(again.photos.size(), scene().photos.size());
  for (size_t k = 0; k < again.photos.size(); ++k) {
    cv::Mat diff;
    cv::absdiff(again.photos[k], scene().photos[k], diff);
    EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0) << "photo " << k;
  }
  SynthOptions other = spot_->options;
  other.seed = 2;
  other.size = 128;
  SynthOptions same = spot_->options;
  same.size = 128;
  EXPECT_NE(projectToJson(synthesize(mesh(), spot_->path, colorFunction(), other).project, ""),
            projectToJson(synthesize(mesh(), spot_->path, colorFunction(), same).project, ""));
}

TEST_F(SynthSpot, ProjectNamesPhotosAndMesh) {
  const Project& p = scene().project;
  EXPECT_TRUE(fs::path(p.mesh).is_absolute());
  EXPECT_EQ(fs::weakly_canonical(p.mesh), fs::weakly_canonical(spot_->path));
  ASSERT_EQ(p.photos.size(), 4u);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(p.photos[k].path, "photo_" + std::to_string(k) + ".png");
  EXPECT_TRUE(p.options == PipelineOptions());
}

TEST_F(SynthSpot, WritesReadableFiles) {
  const std::string dir = (fs::path(test::tempDir("synth")) / "scene").string();  // created by the writer
  writeSynthScene(scene(), dir);
  const Project loaded = loadProject((fs::path(dir) / "project.json").string());
  ASSERT_EQ(loaded.photos.size(), 4u);
  EXPECT_EQ(loaded.points, scene().project.points);
  EXPECT_EQ(fs::weakly_canonical(loaded.mesh), fs::weakly_canonical(spot_->path));
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(fs::weakly_canonical(loaded.photos[k].path),
              fs::weakly_canonical(fs::path(dir) / ("photo_" + std::to_string(k) + ".png")));
    const cv::Mat png = cv::imread(loaded.photos[k].path, cv::IMREAD_UNCHANGED);
    ASSERT_EQ(png.type(), CV_8UC4);
    cv::Mat rgba, diff;
    cv::cvtColor(png, rgba, cv::COLOR_BGRA2RGBA);
    cv::absdiff(rgba, scene().photos[k], diff);
    EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0) << "photo " << k;
  }
  std::ifstream in(fs::path(dir) / "cameras.json");
  const nlohmann::json cams = nlohmann::json::parse(in);
  ASSERT_EQ(cams["views"].size(), 4u);
  const Camera& c0 = scene().cameras[0];
  EXPECT_DOUBLE_EQ(cams["views"][0]["fx"].get<double>(), c0.fx);
  EXPECT_EQ(cams["views"][0]["width"].get<int>(), 512);
  EXPECT_EQ(cams["views"][0]["R"].size(), 9u);
  EXPECT_DOUBLE_EQ(cams["views"][0]["R"][1].get<double>(), c0.R(0, 1));
  EXPECT_DOUBLE_EQ(cams["views"][0]["eye"][2].get<double>(), c0.center().z());
  EXPECT_EQ(cams["features"].get<std::vector<int>>(), scene().featureVertices);
  EXPECT_EQ(cams["options"]["size"].get<int>(), 512);
}

TEST_F(SynthSpot, ManyViewsSurroundTheMesh) {
  SynthOptions o;
  o.views = 9;
  o.features = 60;
  o.size = 128;
  const SynthScene s = synthesize(mesh(), spot_->path, colorFunction(), o);
  ASSERT_EQ(s.photos.size(), 9u);
  Vec3 lo, hi;
  mesh().bounds(lo, hi);
  const Vec3 centre = 0.5 * (lo + hi);
  double minY = 1, maxY = -1;
  for (int k = 0; k < 9; ++k) {
    std::vector<cv::Mat> ch;
    cv::split(s.photos[k], ch);
    EXPECT_GT(cv::countNonZero(ch[3]), 128 * 128 / 20) << "photo " << k;
    const Vec3 dir = (s.cameras[k].center() - centre).normalized();
    minY = std::min(minY, dir.y());
    maxY = std::max(maxY, dir.y());
  }
  EXPECT_LT(minY, -0.5);  // views from below and from above
  EXPECT_GT(maxY, 0.5);
  std::set<int> seenBy;
  for (const auto& fp : s.project.points)
    for (const auto& pp : fp.at) seenBy.insert(pp.photo);
  EXPECT_EQ(seenBy.size(), 9u);
}

TEST(Synth, RejectsBadOptions) {
  const auto mesh = requireUsable(buildMesh({Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)}, {{0, 1, 2}}));
  const SurfaceColor grey = [](int, const Vec3&) { return Vec3f(0.5f, 0.5f, 0.5f); };
  SynthOptions o;
  o.views = 0;
  EXPECT_THROW(synthesize(*mesh, "x.obj", grey, o), Error);
  o = SynthOptions();
  o.size = 4;
  EXPECT_THROW(synthesize(*mesh, "x.obj", grey, o), Error);
  o = SynthOptions();
  EXPECT_THROW(synthesize(*mesh, "x.obj", SurfaceColor(), o), Error);
  try {
    o.views = -1;
    synthesize(*mesh, "x.obj", grey, o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("views"), std::string::npos) << e.what();
  }
}

TEST(Synth, FarthestPointSamplesSkipIsolatedVertices) {
  // A tetrahedron and one vertex no face uses.
  const std::vector<Vec3> v = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1), Vec3(5, 5, 5)};
  const auto mesh = buildMesh(v, {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}).mesh;
  ASSERT_TRUE(mesh);
  ASSERT_EQ(mesh->numVertices(), 5);
  const std::vector<int> all = farthestPointSamples(*mesh, 10, 1);
  EXPECT_EQ(all.size(), 4u);
  EXPECT_EQ(std::set<int>(all.begin(), all.end()), (std::set<int>{0, 1, 2, 3}));
  EXPECT_TRUE(farthestPointSamples(*mesh, 0, 1).empty());
  EXPECT_THROW(farthestPointSamples(*mesh, -1, 1), Error);
}

TEST(Synth, SolidPatternIsDeterministicAndVaried) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-3, 3);
  double sum = 0, sumSq = 0;
  std::set<int> hues;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const Vec3f c = solidPattern(p, 2.0);
    ASSERT_TRUE((c.array() >= 0).all() && (c.array() <= 1).all());
    EXPECT_EQ(c, solidPattern(p, 2.0));
    sum += c.mean();
    sumSq += c.mean() * c.mean();
    hues.insert(static_cast<int>(c.x() * 3) * 9 + static_cast<int>(c.y() * 3) * 3 + static_cast<int>(c.z() * 3));
  }
  const double variance = sumSq / n - (sum / n) * (sum / n);
  EXPECT_GT(variance, 0.005);
  EXPECT_GE(hues.size(), 10u);  // colourful, not one hue
  // Structure at small scales: nearby points differ, but not everywhere (the pattern is smooth).
  int small = 0, large = 0;
  for (int i = 0; i < 1000; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng));
    const double d = (solidPattern(p, 2.0) - solidPattern(p + Vec3(0.02, 0, 0), 2.0)).norm();
    small += d > 1e-4;
    large += d > 0.3;
  }
  EXPECT_GT(small, 900);
  EXPECT_LT(large, 200);
}

TEST(Synth, SolidPatternOnAMeshWithoutUvs) {
  TM_REQUIRE_SHARED(obj, "meshes/bunny/bunny.obj");
  const auto mesh = requireUsable(loadMesh(obj));
  ASSERT_FALSE(mesh->hasUV());
  const SurfaceColor color = meshPattern(*mesh);
  SynthOptions o;
  o.views = 2;
  o.features = 50;
  o.size = 256;
  const SynthScene s = synthesize(*mesh, obj, color, o);
  ASSERT_EQ(s.photos.size(), 2u);
  EXPECT_GT(s.project.points.size(), 20u);
  for (const cv::Mat& p : s.photos) {
    std::vector<cv::Mat> ch;
    cv::split(p, ch);
    const cv::Mat fg = ch[3] == 255;
    ASSERT_GT(cv::countNonZero(fg), 1000);
    cv::Scalar mean, stddev;
    cv::meanStdDev(p, mean, stddev, fg);
    std::printf("bunny photo: colour stddev %.1f %.1f %.1f (of 255)\n", stddev[0], stddev[1], stddev[2]);
    for (int c = 0; c < 3; ++c) EXPECT_GT(stddev[c], 20.0) << "channel " << c;
  }
}

// ---- Deformed scenes: photos of another subject with a known truth (issue 33) ----

TEST(SynthDeform, KindsMoveTheMeshAndScaleOneIsTheIdentity) {
  const auto mesh = requireUsable(loadMesh(test::testDataDir() + "/turtle.obj"));
  Vec3 lo, hi;
  mesh->bounds(lo, hi);
  const double diagonal = (hi - lo).norm();
  for (const char* kind : {"bend", "twist", "scale", "limbs", "turn"}) {
    SCOPED_TRACE(kind);
    const std::vector<Vec3> moved = deformPositions(*mesh, parseDeformation(kind));
    ASSERT_EQ(int(moved.size()), mesh->numVertices());
    double most = 0;
    for (int v = 0; v < mesh->numVertices(); ++v) most = std::max(most, (moved[v] - mesh->position(v)).norm());
    EXPECT_GT(most, 0.05 * diagonal);
    EXPECT_LT(most, diagonal);
  }
  for (const char* none : {"scale:1", "bend:0", "turn:0"}) {
    const std::vector<Vec3> same = deformPositions(*mesh, parseDeformation(none));
    for (int v = 0; v < mesh->numVertices(); v += 13) EXPECT_LT((same[v] - mesh->position(v)).norm(), 1e-12) << none;
  }
  EXPECT_EQ(parseDeformation("limbs:0.5").text(), "limbs:0.5");
  EXPECT_NE(test::errorOf([] { parseDeformation("curl"); }).find("unknown kind"), std::string::npos);
  EXPECT_NE(test::errorOf([] { parseDeformation("bend:x"); }).find("not a number"), std::string::npos);
  EXPECT_NE(test::errorOf([] { parseDeformation("scale:0"); }).find("> 0"), std::string::npos);
}

TEST(SynthDeform, ClicksNameTheUndeformedVerticesAndLandAtTheDeformedProjections) {
  const std::string obj = test::testDataDir() + "/turtle.obj";
  const auto mesh = requireUsable(loadMesh(obj));
  SynthOptions o;
  o.views = 3;
  o.features = 60;
  o.size = 384;
  o.deform = parseDeformation("limbs");
  const SynthScene scene = synthesize(*mesh, obj, meshPattern(*mesh), o);
  ASSERT_TRUE(scene.photographed);
  ASSERT_EQ(scene.photographed->numVertices(), mesh->numVertices());
  ASSERT_EQ(scene.photographed->numFaces(), mesh->numFaces());
  EXPECT_EQ(scene.featureVertices, farthestPointSamples(*mesh, 60, o.seed));  // sampled on the undeformed mesh
  ASSERT_GE(scene.project.points.size(), 25u);                                // of 60 sampled: the turtle in 3 views
  int far = 0, clicks = 0;
  for (const FeaturePoint& p : scene.project.points) {
    ASSERT_GE(p.vertex, 0);
    ASSERT_LT(p.vertex, mesh->numVertices());
    for (const PhotoPoint& at : p.at) {
      Vec2 shown, rest;
      ASSERT_TRUE(scene.cameras[at.photo].project(scene.photographed->position(p.vertex), shown));
      EXPECT_LT((shown - Vec2(at.x, at.y)).norm(), 1e-9);
      scene.cameras[at.photo].project(mesh->position(p.vertex), rest);
      far += (rest - shown).norm() > 2;
      ++clicks;
    }
  }
  EXPECT_GT(far, clicks / 5);  // the deformation moves many clicks away from the undeformed mesh's projections

  const std::string dir = test::tempDir("synth_deform");
  writeSynthScene(scene, dir);
  const Project project = loadProject(dir + "/project.json");
  EXPECT_TRUE(fs::equivalent(project.mesh, obj)) << project.mesh;  // the clicks are for the mesh itself
  const std::string deformed = readSynthDeformedMesh(dir + "/cameras.json");
  EXPECT_TRUE(fs::equivalent(deformed, fs::path(dir) / "deformed.obj")) << deformed;
  const auto reloaded = requireUsable(loadMesh(deformed));
  ASSERT_EQ(reloaded->numVertices(), mesh->numVertices());
  for (int v = 0; v < mesh->numVertices(); v += 17)
    EXPECT_LT((reloaded->position(v) - scene.photographed->position(v)).norm(), 1e-9);
  // A scene of the mesh itself records no deformation.
  const std::string plain = test::tempDir("synth_plain");
  o.deform = {};
  o.features = 5;
  writeSynthScene(synthesize(*mesh, obj, meshPattern(*mesh), o), plain);
  EXPECT_EQ(readSynthDeformedMesh(plain + "/cameras.json"), "");
  EXPECT_FALSE(fs::exists(plain + "/deformed.obj"));
}

// Lens distortion (synth --k1 --k2): the photos are rendered through PhotoCamera's radial model, each click sits at its
// vertex's distorted projection and shows the vertex's colour there (not at the pinhole projection), cameras.json
// carries the terms, and a camera fit on one photo's exact clicks finds k1 again.
TEST(SynthLens, DistortedPhotosShowEachClickAtItsDistortedProjectionAndTheFitFindsK1) {
  const std::string obj = test::testDataDir() + "/turtle.obj";
  const auto mesh = requireUsable(loadMesh(obj));
  SynthOptions o;
  o.views = 3;
  o.features = 90;
  o.size = 1024;
  o.fovYDeg = 50;  // a wide lens, so that the turtle reaches where the distortion moves points by pixels
  o.k1 = -0.2;
  const SurfaceColor color = meshPattern(*mesh);
  const SynthScene scene = synthesize(*mesh, obj, color, o);
  std::vector<std::vector<int>> vertexFaces(mesh->numVertices());
  for (int f = 0; f < mesh->numFaces(); ++f)
    for (int v : mesh->faceVertices(f)) vertexFaces[v].push_back(f);
  auto colourDistance = [&](int vertex, const cv::Mat& rgb, const Vec2& at) {
    const Vec3f seen = sampleBilinear3(rgb, at.x(), at.y());
    double best = std::numeric_limits<double>::infinity();
    for (int f : vertexFaces[vertex]) {
      Vec3 b = Vec3::Zero();
      const auto c = mesh->faceVertices(f);
      b[std::find(c.begin(), c.end(), vertex) - c.begin()] = 1;
      best = std::min<double>(best, (color(f, b) - seen).cwiseAbs().maxCoeff());
    }
    return best;
  };
  std::vector<cv::Mat> rgb;
  for (const auto& p : scene.photos) rgb.push_back(toFloatRgb(p));
  int clicks = 0, moved = 0;
  double worstMove = 0, errorAtLens = 0, errorAtPinhole = 0;
  for (const FeaturePoint& p : scene.project.points)
    for (const PhotoPoint& at : p.at) {
      const PhotoCamera lens{scene.cameras[at.photo], o.k1, o.k2};
      Vec2 distorted, pinhole;
      ASSERT_TRUE(lens.project(mesh->position(p.vertex), distorted));
      ASSERT_TRUE(scene.cameras[at.photo].project(mesh->position(p.vertex), pinhole));
      EXPECT_LT((distorted - Vec2(at.x, at.y)).norm(), 1e-9);
      ++clicks;
      worstMove = std::max(worstMove, (distorted - pinhole).norm());
      if ((distorted - pinhole).norm() < 1.5) continue;
      ++moved;
      errorAtLens += colourDistance(p.vertex, rgb[at.photo], distorted);
      errorAtPinhole += colourDistance(p.vertex, rgb[at.photo], pinhole);
    }
  std::printf("%d clicks, %d moved 1.5 px or more by the lens (at most %.1f px); the vertex's colour there: mean "
              "error %.4f at the distorted projection, %.4f at the pinhole projection\n",
              clicks, moved, worstMove, errorAtLens / std::max(moved, 1), errorAtPinhole / std::max(moved, 1));
  ASSERT_GE(moved, 10);
  EXPECT_LT(errorAtLens / moved, 0.1);  // bilinear reads of a pattern with texel-sized detail
  EXPECT_LT(2 * errorAtLens, errorAtPinhole);

  const std::string dir = test::tempDir("synth_lens");
  writeSynthScene(scene, dir);
  const std::vector<PhotoCamera> cameras = readSynthCameras(dir + "/cameras.json");
  ASSERT_EQ(cameras.size(), 3u);
  EXPECT_EQ(cameras[1].k1, o.k1);
  EXPECT_EQ(cameras[1].k2, 0.0);

  const Project project = loadProject(dir + "/project.json");
  const std::vector<CameraClick> photo0 = photoClicks(project, 0);
  ASSERT_GE(photo0.size(), 20u);
  const CameraFit fit = fitCamera(*mesh, photo0, o.size, o.size);
  ASSERT_TRUE(fit.fits) << fit.reason;
  std::printf("photo 0: %zu exact clicks, fitted k1 %.4f k2 %.4f, RMS %.4f px\n", photo0.size(), fit.camera.k1,
              fit.camera.k2, fit.rmsResidual);
  EXPECT_NEAR(fit.camera.k1, o.k1, 0.02);
  EXPECT_LT(fit.rmsResidual, 0.05);

  // A distortion that folds the photo before its corners is refused, naming the terms.
  o.k1 = -1;
  EXPECT_NE(test::errorOf([&] { synthesize(*mesh, obj, color, o); }).find("folds the photo"), std::string::npos);
}

}  // namespace
}  // namespace montage
