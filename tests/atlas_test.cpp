// Tests of the texture atlas: layout (UVs inside the atlas and their chart's rectangle, disjoint
// footprints, the gutter), LSCM charts of closed and higher-genus regions, baking (photo resampling,
// seam levelling, inpainted colours, flat empty faces, gutter fill), the spot ground truth re-rendered
// through the atlas (PSNR in `montage eval`), the glTF validator and assimp, and bad input.
#include "atlas/atlas.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <random>
#include <regex>
#include <set>

#include "geometry/mesh.h"
#include "geometry/raster.h"
#include "geometry/shapes.h"
#include "image/photo.h"
#include "io/mesh_io.h"
#include "io/project.h"
#include "pipeline.h"
#include "surface/inpaint.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace montage {
namespace {

using test::errorOf;

// Every face of `mesh` mapped to photo 0 through the mesh's own texture coordinates (OBJ convention
// converted to pixels of a width x height photo).
AtlasInput ownUvInput(const Mesh& mesh, int width, int height) {
  AtlasInput in;
  in.faceSource.assign(mesh.numFaces(), 0);
  in.photoSizes = {cv::Size(width, height)};
  for (const auto& uv : mesh.cornerUV) {
    std::array<Vec2, 3> px;
    for (int k = 0; k < 3; ++k) px[k] = Vec2(uv[k].x() * width, (1 - uv[k].y()) * height);
    in.cornerUV.push_back(px);
  }
  return in;
}

// Texels of chart c found independently of the atlas code: texel centres inside a face (scanTriangle)
// and their 8 neighbours, which bilinear lookups inside the face read.
cv::Mat rasteriseCharts(const Atlas& atlas, int* overlaps) {
  cv::Mat label(atlas.size, atlas.size, CV_32FC1, cv::Scalar(-1));
  *overlaps = 0;
  for (size_t c = 0; c < atlas.charts.size(); ++c)
    for (int f : atlas.charts[c].faces)
      scanTriangle(atlas.cornerUV[f], atlas.size, atlas.size, [&](int x, int y, const Vec3&) {
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx < 0 || yy < 0 || xx >= atlas.size || yy >= atlas.size) continue;
            float& l = label.at<float>(yy, xx);
            if (l >= 0 && l != float(c)) ++*overlaps;
            l = float(c);
          }
      });
  return label;
}

// Texels of a chart that have a texel of another chart within Chebyshev distance `gutter`, or lie
// closer than `gutter` to the border. `label`: CV_32FC1 chart per texel, -1 for none.
int gutterViolations(const cv::Mat& label, int gutter) {
  if (gutter == 0) return 0;
  cv::Mat high, low, lowInput = label.clone();
  lowInput.setTo(1e9f, label < 0);
  const cv::Mat kernel = cv::Mat::ones(2 * gutter + 1, 2 * gutter + 1, CV_8U);
  cv::dilate(label, high, kernel, {-1, -1}, 1, cv::BORDER_CONSTANT, cv::Scalar(-1));
  cv::erode(lowInput, low, kernel, {-1, -1}, 1, cv::BORDER_CONSTANT, cv::Scalar(1e9f));
  int bad = 0;
  for (int y = 0; y < label.rows; ++y)
    for (int x = 0; x < label.cols; ++x) {
      const float l = label.at<float>(y, x);
      if (l < 0) continue;
      const bool border = x < gutter || y < gutter || x >= label.cols - gutter || y >= label.rows - gutter;
      if (border || high.at<float>(y, x) != l || low.at<float>(y, x) != l) ++bad;
    }
  return bad;
}

// The layout checks of the issue, on any atlas: UVs inside the atlas and their chart's rectangle,
// footprints of different charts disjoint and `gutter` texels apart (checked both on an independent
// rasterisation and on what the bake wrote), every face in exactly one chart.
void expectValidLayout(const Atlas& atlas, const Mesh& mesh, const AtlasImage* image) {
  ASSERT_EQ(static_cast<int>(atlas.faceChart.size()), mesh.numFaces());
  std::vector<int> seen(mesh.numFaces(), 0);
  for (size_t c = 0; c < atlas.charts.size(); ++c) {
    const AtlasChart& chart = atlas.charts[c];
    ASSERT_FALSE(chart.faces.empty());
    for (int f : chart.faces) {
      ++seen[f];
      ASSERT_EQ(atlas.faceChart[f], static_cast<int>(c));
      ASSERT_EQ(chart.source, atlas.faceSource[f]);
      for (const Vec2& p : atlas.cornerUV[f]) {
        ASSERT_TRUE(p.x() >= 0 && p.y() >= 0 && p.x() <= atlas.size && p.y() <= atlas.size)
            << "face " << f << " uv " << p.transpose();
        ASSERT_TRUE(p.x() >= chart.x && p.y() >= chart.y && p.x() <= chart.x + chart.width &&
                    p.y() <= chart.y + chart.height)
            << "face " << f << " uv " << p.transpose() << " outside its chart's rectangle";
      }
    }
  }
  for (int f = 0; f < mesh.numFaces(); ++f) ASSERT_EQ(seen[f], 1) << "face " << f;
  int overlaps = 0;
  const cv::Mat label = rasteriseCharts(atlas, &overlaps);
  EXPECT_EQ(overlaps, 0) << "texels rasterised by two charts";
  EXPECT_EQ(gutterViolations(label, atlas.gutter), 0);
  if (image) {
    // What the bake wrote covers the independent rasterisation and keeps the gutter too.
    cv::Mat baked;
    image->chart.convertTo(baked, CV_32F);
    int missing = 0;
    for (int y = 0; y < label.rows; ++y)
      for (int x = 0; x < label.cols; ++x)
        if (label.at<float>(y, x) >= 0 && baked.at<float>(y, x) != label.at<float>(y, x)) ++missing;
    EXPECT_EQ(missing, 0) << "texels a bilinear lookup reads that the bake did not write for their chart";
    EXPECT_EQ(gutterViolations(baked, atlas.gutter), 0);
  }
  EXPECT_GT(atlas.utilisation, 0);
  EXPECT_LE(atlas.utilisation, 1);
}

// ----------------------------------------------------------------------------------------------
// Spot: its own texture as photo 0

struct Spot {
  std::string obj, texture;
  std::unique_ptr<Mesh> mesh;
  std::shared_ptr<const Photo> photo;
};

Spot loadSpot(const std::string& obj) {
  Spot s;
  s.obj = obj;
  s.texture = (fs::path(obj).parent_path() / "spot_texture.png").string();
  s.mesh = requireUsable(loadMesh(obj));
  s.photo = std::make_shared<Photo>(loadPhoto(s.texture));
  return s;
}

TEST(Atlas, SpotLayoutIsValidAtEverySize) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  const Spot spot = loadSpot(obj);
  const AtlasInput in = ownUvInput(*spot.mesh, spot.photo->width, spot.photo->height);
  for (const auto& [size, gutter] : {std::pair{1024, 4}, {2048, 0}, {4096, 4}, {1024, 16}}) {
    AtlasOptions options;
    options.size = size;
    options.gutter = gutter;
    const Atlas atlas = buildAtlas(*spot.mesh, in, options);
    SCOPED_TRACE("size " + std::to_string(size) + ", gutter " + std::to_string(gutter));
    EXPECT_EQ(atlas.lscmCharts, 0);
    EXPECT_GT(atlas.photoCharts, 1);
    const AtlasImage image = bakeAtlas(atlas, *spot.mesh, {spot.photo}, nullptr, nullptr, options);
    expectValidLayout(atlas, *spot.mesh, &image);
    std::printf("spot %d, gutter %d: %zu charts, scale %.3f, utilisation %.3f, %d attempts\n", size, gutter,
                atlas.charts.size(), atlas.scale, atlas.utilisation, atlas.packAttempts);
  }
  // A fixed size with maxScale 1 keeps the photo's resolution when it fits.
  AtlasOptions capped;
  capped.size = 4096;
  capped.maxScale = 1;
  EXPECT_DOUBLE_EQ(buildAtlas(*spot.mesh, in, capped).scale, 1.0);
  // The automatic size: the photo's own resolution in the smallest multiple of 256 that holds it.
  const Atlas automatic = buildAtlas(*spot.mesh, in, AtlasOptions{});
  EXPECT_DOUBLE_EQ(automatic.scale, 1.0);
  EXPECT_EQ(automatic.size % 256, 0);
  EXPECT_LE(automatic.size, 2048);  // the texture is 1024 x 1024, its charts cover less than that
  EXPECT_GT(automatic.utilisation, 0.35);
  const AtlasImage image = bakeAtlas(automatic, *spot.mesh, {spot.photo}, nullptr, nullptr, AtlasOptions{});
  expectValidLayout(automatic, *spot.mesh, &image);
  std::printf("spot automatic: %d x %d, %zu charts, utilisation %.3f, %d attempts\n", automatic.size, automatic.size,
              automatic.charts.size(), automatic.utilisation, automatic.packAttempts);
  // Photos too large for 8192 at their own resolution: 8192, scaled down to fit.
  const AtlasInput huge = ownUvInput(*spot.mesh, 12 * spot.photo->width, 12 * spot.photo->height);
  const Atlas shrunk = buildAtlas(*spot.mesh, huge, AtlasOptions{});
  EXPECT_EQ(shrunk.size, 8192);
  EXPECT_LT(shrunk.scale, 1.0);
  EXPECT_GT(shrunk.scale, 0.3);
  expectValidLayout(shrunk, *spot.mesh, nullptr);
}

// The truth re-rendered through our atlas: `montage eval` of the exported OBJ against spot itself.
// Also: the exported files load in the Khronos glTF validator and in assimp.
TEST(AtlasExport, SpotThroughTheAtlasMatchesTheTruth) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  const Spot spot = loadSpot(obj);
  AtlasOptions options;  // automatic size (the texture's own resolution), gutter 4
  const Atlas atlas = buildAtlas(*spot.mesh, ownUvInput(*spot.mesh, spot.photo->width, spot.photo->height), options);
  const AtlasImage image = bakeAtlas(atlas, *spot.mesh, {spot.photo}, nullptr, nullptr, options);
  TexturedModel model = atlasModel(*spot.mesh, atlas, image);
  const std::string dir = test::tempDir("atlas_spot");
  exportObj(model, dir, "model");
  exportGlb(model, dir + "/model.glb");
  writeAtlasLayers(atlas, image, dir);
  for (const char* f :
       {"model.obj", "model.mtl", "model_atlas.png", "model.glb", "model_atlas_source.png", "model_atlas_holes.png"})
    EXPECT_TRUE(fs::exists(fs::path(dir) / f)) << f;

  for (const std::string result : {dir + "/model.obj", dir + "/model.glb"}) {
    std::string log;
    ASSERT_EQ(test::runCommand(test::montageExe() + " eval --result " + result + " --truth " + spot.obj +
                                   " --truth-texture " + spot.texture + " --json " + dir + "/eval.json",
                               &log),
              0)
        << log;
    std::ifstream in(dir + "/eval.json");
    const nlohmann::json eval = nlohmann::json::parse(in);
    std::printf("%s: PSNR %.2f dB, delta E %.3f\n", result.c_str(), eval["psnr_all"].get<double>(),
                eval["delta_e_all"].get<double>());
    EXPECT_GE(eval["psnr_all"].get<double>(), 35.0) << eval.dump();
  }
}

#ifndef TM_GLTF_NODE_DIR
#define TM_GLTF_NODE_DIR ""
#define TM_GLTF_VALIDATE_JS ""
#endif

// An atlas model of spot with every kind of chart: photo faces, an inpainted region and empty faces.
TexturedModel mixedSpotModel(const std::string& obj) {
  const Spot spot = loadSpot(obj);
  AtlasInput in = ownUvInput(*spot.mesh, spot.photo->width, spot.photo->height);
  for (int f = 0; f < spot.mesh->numFaces(); ++f) {
    const auto q = spot.mesh->facePositions(f);
    const double x = (q[0] + q[1] + q[2]).x() / 3;
    if (x > 0.3) in.faceSource[f] = kSourceInpainted;
    if (x < -0.4) in.faceSource[f] = kSourceEmpty;
  }
  AtlasOptions options;
  options.size = 1024;
  const Atlas atlas = buildAtlas(*spot.mesh, in, options);
  return atlasModel(*spot.mesh, atlas, bakeAtlas(atlas, *spot.mesh, {spot.photo}, nullptr, nullptr, options));
}

TEST(AtlasExport, GltfValidatorReportsNoErrors) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  if (const std::string why = test::gltfValidatorMissing(); !why.empty()) GTEST_SKIP() << why;
  const std::string file = test::tempDir("atlas_gltf") + "/model.glb";
  exportGlb(mixedSpotModel(obj), file);
  int rc = 0;
  const std::string out = test::runGltfValidator(file, &rc);
  EXPECT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("errors: 0,"), std::string::npos) << out;
}

TEST(AtlasExport, AssimpLoadsObjAndGlb) {
  TM_REQUIRE_SHARED(obj, "meshes/spot/spot_triangulated.obj");
  if (test::runCommand("command -v assimp") != 0)
    GTEST_SKIP() << "assimp is not installed (Debian package assimp-utils)";
  const TexturedModel model = mixedSpotModel(obj);
  const std::string dir = test::tempDir("atlas_assimp");
  exportObj(model, dir, "model");
  exportGlb(model, dir + "/model.glb");
  for (const std::string file : {dir + "/model.obj", dir + "/model.glb"}) {
    std::string out;
    EXPECT_EQ(test::runCommand("assimp info '" + file + "'", &out), 0) << file << ":\n" << out;
    std::smatch m;
    ASSERT_TRUE(std::regex_search(out, m, std::regex("Faces:\\s+(\\d+)"))) << file << ":\n" << out;
    EXPECT_EQ(std::stoi(m[1]), model.mesh.numFaces()) << file;
  }
}

// ----------------------------------------------------------------------------------------------
// LSCM charts

// A torus (genus 1) of n x m quads, each split in two.
std::unique_ptr<Mesh> makeTorus(int n, int m) {
  std::vector<Vec3> v;
  std::vector<std::array<int, 3>> t;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      const double a = 2 * M_PI * i / n, b = 2 * M_PI * j / m;
      v.push_back(
          Vec3((2 + 0.7 * std::cos(b)) * std::cos(a), (2 + 0.7 * std::cos(b)) * std::sin(a), 0.7 * std::sin(b)));
    }
  const auto id = [&](int i, int j) { return ((i + n) % n) * m + (j + m) % m; };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      t.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      t.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return requireUsable(buildMesh(v, t));
}

TEST(Atlas, ClosedAndGenusOneRegionsAreCutIntoDiscsWithoutFlips) {
  std::vector<std::pair<std::string, std::unique_ptr<Mesh>>> meshes;
  meshes.emplace_back("icosphere", makeIcosphere(4));
  meshes.emplace_back("torus", makeTorus(48, 16));
  for (auto& [name, mesh] : meshes) {
    SCOPED_TRACE(name);
    AtlasInput in;
    in.faceSource.assign(mesh->numFaces(), kSourceInpainted);
    AtlasOptions options;
    options.size = 1024;
    const Atlas atlas = buildAtlas(*mesh, in, options);
    EXPECT_GE(atlas.discCuts, 1);
    EXPECT_EQ(atlas.photoCharts, 0);
    EXPECT_GE(atlas.lscmCharts, 2);
    for (const AtlasChart& chart : atlas.charts) {
      std::vector<int> local(mesh->numVertices(), -1);
      std::vector<std::array<int, 3>> tris;
      for (int f : chart.faces) {
        std::array<int, 3> tri;
        const auto fv = mesh->faceVertices(f);
        for (int k = 0; k < 3; ++k) tri[k] = fv[k];
        tris.push_back(tri);
      }
      EXPECT_TRUE(patchTopology(tris).isDisc()) << "chart of " << chart.faces.size() << " faces";
      EXPECT_LE(chart.quality.stretchL2, options.maxChartStretch);
      // Atlas y is down: a counter-clockwise (front) face has negative signed area in atlas texels,
      // as photo charts do (photo y down), so that v = 1 - y / size turns both counter-clockwise.
      for (int f : chart.faces) {
        const auto& p = atlas.cornerUV[f];
        const double area = (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[2] - p[0]).x() * (p[1] - p[0]).y();
        EXPECT_LT(area, 0) << "face " << f << " flipped";
      }
    }
    const AtlasImage image = bakeAtlas(atlas, *mesh, {}, nullptr, nullptr, options);
    expectValidLayout(atlas, *mesh, &image);
    std::printf("%s: %d faces, %zu charts (%d disc cuts, %d stretch splits), utilisation %.3f\n", name.c_str(),
                mesh->numFaces(), atlas.charts.size(), atlas.discCuts, atlas.stretchSplits, atlas.utilisation);
  }
}

TEST(Atlas, LargeRegionsAreSplitBeforeFlattening) {
  // Issue 15: one 1M-face empty chart took 220 s of LSCM. maxLscmFaces bounds every chart before it is
  // flattened; a lower bound gives more, smaller charts, each still a disc without flips.
  const auto mesh = makeIcosphere(5);  // 20480 faces, closed
  AtlasInput in;
  in.faceSource.assign(mesh->numFaces(), kSourceEmpty);
  size_t previousCharts = 0;
  for (const int maxFaces : {100000, 4000, 1000}) {
    SCOPED_TRACE(maxFaces);
    AtlasOptions options;
    options.size = 1024;
    options.maxLscmFaces = maxFaces;
    const Atlas atlas = buildAtlas(*mesh, in, options);
    if (maxFaces >= mesh->numFaces())
      EXPECT_EQ(atlas.sizeSplits, 0);
    else
      EXPECT_GE(atlas.sizeSplits, mesh->numFaces() / maxFaces - 1);
    size_t faces = 0;
    for (const AtlasChart& chart : atlas.charts) {
      EXPECT_LE(chart.faces.size(), size_t(maxFaces));
      EXPECT_EQ(chart.quality.flipped, 0);
      faces += chart.faces.size();
    }
    EXPECT_EQ(faces, size_t(mesh->numFaces()));
    EXPECT_GT(atlas.charts.size(), previousCharts);
    previousCharts = atlas.charts.size();
    expectValidLayout(atlas, *mesh, nullptr);
    std::printf("maxLscmFaces %d: %zu charts, %d size splits, %d disc cuts, lscm %.3f s\n", maxFaces,
                atlas.charts.size(), atlas.sizeSplits, atlas.discCuts, atlas.times.lscm);
  }
}

// ----------------------------------------------------------------------------------------------
// Baking: photo resampling with seam levelling, inpainted colours, empty faces, gutter fill

// A 12 x 12 grid (z = 0, 0.5 units apart): the left third from a photo (a smooth colour ramp), the
// middle third inpainted (refined 4x, vertex colours a known linear function), the right third empty.
struct BakeScene {
  std::unique_ptr<Mesh> mesh;
  std::shared_ptr<Photo> photo;
  AtlasInput input;
  InpaintResult inpaint;
  SeamLevelling levelling;
  static Vec3f inpaintColor(const Vec3& p) { return Vec3f(float(0.1 + p.x() / 10), float(0.2 + p.y() / 10), 0.6f); }
  static Vec3f photoColor(double x, double y) { return Vec3f(float(x / 300), float(y / 200), 0.3f); }
  static Vec3f levelOffset(const Vec3& p) { return Vec3f(float(0.2 * p.x() / 2), 0, float(-0.1 * p.y() / 6)); }
};

BakeScene bakeScene() {
  BakeScene s;
  s.mesh = makeGrid(12, 12, 0.5);
  auto photo = std::make_shared<Photo>();
  photo->width = 300;
  photo->height = 200;
  photo->rgb = cv::Mat(200, 300, CV_32FC3);
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 300; ++x) {
      const Vec3f c = BakeScene::photoColor(x + 0.5, y + 0.5);
      photo->rgb.at<cv::Vec3f>(y, x) = cv::Vec3f(c[0], c[1], c[2]);
    }
  s.photo = photo;
  const int F = s.mesh->numFaces();
  s.input.photoSizes = {cv::Size(300, 200)};
  s.input.faceSource.assign(F, kSourceEmpty);
  s.input.cornerUV.assign(F, {Vec2::Zero(), Vec2::Zero(), Vec2::Zero()});
  s.inpaint.faceRegion.assign(F, -1);
  s.inpaint.regions.resize(1);
  s.levelling.cornerOffset.assign(F, {Vec3f::Zero(), Vec3f::Zero(), Vec3f::Zero()});
  RefinedSurface& r = s.inpaint.refined;
  std::vector<Vec3f> colors;
  for (int f = 0; f < F; ++f) {
    const auto q = s.mesh->facePositions(f);
    const double cx = (q[0] + q[1] + q[2]).x() / 3;
    if (cx < 2) {
      s.input.faceSource[f] = 0;
      // Photo pixels = 30 per unit, y flipped, shifted: a similarity of the surface, inside the photo.
      for (int k = 0; k < 3; ++k) s.input.cornerUV[f][k] = Vec2(20 + 30 * q[k].x(), 195 - 30 * q[k].y());
      // Levelling: a per-vertex offset (continuous across edges, as seam levelling makes it).
      for (int k = 0; k < 3; ++k) s.levelling.cornerOffset[f][k] = BakeScene::levelOffset(q[k]);
    } else if (cx < 4) {
      s.input.faceSource[f] = kSourceInpainted;
      s.inpaint.faceRegion[f] = 0;
      // Refine 1-to-4 at the edge midpoints; corners in the parent's barycentrics.
      const std::array<Vec3, 6> b = {Vec3(1, 0, 0),     Vec3(0, 1, 0),     Vec3(0, 0, 1),
                                     Vec3(0.5, 0.5, 0), Vec3(0, 0.5, 0.5), Vec3(0.5, 0, 0.5)};
      const int base = r.mesh.numVertices();
      for (const Vec3& bb : b) {
        const Vec3 p = bb[0] * q[0] + bb[1] * q[1] + bb[2] * q[2];
        r.mesh.positions.push_back(p);
        colors.push_back(BakeScene::inpaintColor(p));
      }
      for (const std::array<int, 3>& t : {std::array{0, 3, 5}, {3, 1, 4}, {5, 4, 2}, {3, 4, 5}}) {
        r.mesh.triangles.push_back({base + t[0], base + t[1], base + t[2]});
        r.parentFace.push_back(f);
        r.parentBary.push_back({b[t[0]], b[t[1]], b[t[2]]});
        r.region.push_back(0);
      }
    }
  }
  s.inpaint.colors.resize(static_cast<int>(colors.size()), 3);
  for (size_t i = 0; i < colors.size(); ++i) s.inpaint.colors.row(static_cast<int>(i)) = colors[i].transpose();
  return s;
}

TEST(AtlasBake, PhotoInpaintedAndEmptyFacesGetTheirColours) {
  BakeScene s = bakeScene();
  for (const bool rotate : {false, true}) {
    AtlasOptions options;
    options.size = 1024;
    options.rotateCharts = rotate;
    options.emptyColor = Vec3f(0.9f, 0.1f, 0.5f);
    const Atlas atlas = buildAtlas(*s.mesh, s.input, options);
    const AtlasImage image = bakeAtlas(atlas, *s.mesh, {s.photo}, &s.levelling, &s.inpaint, options);
    expectValidLayout(atlas, *s.mesh, &image);
    const TexturedModel model = atlasModel(*s.mesh, atlas, image);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0, 1);
    double worst[3] = {0, 0, 0};
    for (int f = 0; f < s.mesh->numFaces(); ++f)
      for (int i = 0; i < 10; ++i) {
        double b0 = u(rng), b1 = u(rng);
        if (b0 + b1 > 1) b0 = 1 - b0, b1 = 1 - b1;
        const Vec3 b(b0, b1, 1 - b0 - b1);
        const auto q = s.mesh->facePositions(f);
        const Vec3 p = b[0] * q[0] + b[1] * q[1] + b[2] * q[2];
        Vec3f want;
        int kind = 0;
        if (s.input.faceSource[f] == 0) {
          const Vec2 px = b[0] * s.input.cornerUV[f][0] + b[1] * s.input.cornerUV[f][1] + b[2] * s.input.cornerUV[f][2];
          want = BakeScene::photoColor(px.x(), px.y()) + BakeScene::levelOffset(p);
        } else if (s.input.faceSource[f] == kSourceInpainted) {
          want = BakeScene::inpaintColor(p), kind = 1;
        } else {
          want = options.emptyColor, kind = 2;
        }
        worst[kind] = std::max(worst[kind], double((model.colorAt(f, b) - want).cwiseAbs().maxCoeff()));
      }
    // 8-bit quantisation and bilinear lookups of linear ramps: within 2/255.
    EXPECT_LT(worst[0], 2.0 / 255) << "photo faces, rotate " << rotate;
    EXPECT_LT(worst[1], 2.0 / 255) << "inpainted faces, rotate " << rotate;
    EXPECT_LT(worst[2], 1.0 / 255) << "empty faces, rotate " << rotate;

    // Layers: source ids and hole mask agree with the charts.
    const cv::Mat source = atlasSourceLayer(atlas, image), holes = atlasHoleMask(atlas, image);
    std::set<int> values;
    for (int y = 0; y < source.rows; ++y)
      for (int x = 0; x < source.cols; ++x) {
        values.insert(source.at<unsigned char>(y, x));
        EXPECT_EQ(holes.at<unsigned char>(y, x) == 255, source.at<unsigned char>(y, x) >= 253);
      }
    EXPECT_EQ(values, (std::set<int>{0, 1, 253, 254}));
  }
}

// Outside the footprints every texel repeats a footprint colour: no background (black) reaches
// bilinear lookups or mip levels.
TEST(AtlasBake, GuttersAndFreeSpaceRepeatChartColours) {
  BakeScene s = bakeScene();
  // Two flat colours only: the photo is one colour and the inpainted faces are not refined.
  s.photo->rgb.setTo(cv::Scalar(0.2, 0.8, 0.4));
  AtlasInput in = s.input;
  AtlasOptions options;
  options.size = 1024;
  options.emptyColor = Vec3f(1, 1, 0);
  const Atlas atlas = buildAtlas(*s.mesh, in, options);
  const AtlasImage image = bakeAtlas(atlas, *s.mesh, {s.photo}, nullptr, nullptr, options);
  std::set<uint32_t> inside, all;
  for (int y = 0; y < image.rgba.rows; ++y)
    for (int x = 0; x < image.rgba.cols; ++x) {
      const cv::Vec4b c = image.rgba.at<cv::Vec4b>(y, x);
      const uint32_t key = c[0] | c[1] << 8 | c[2] << 16 | uint32_t(c[3]) << 24;
      all.insert(key);
      if (image.chart.at<int>(y, x) >= 0) inside.insert(key);
    }
  EXPECT_EQ(all, inside) << "a colour outside the footprints that no chart has";
  EXPECT_LE(inside.size(), 3u);  // photo, flat inpainted (no inpainting result), empty
  // A 16x mip level (area average) has no black texel either.
  cv::Mat mip;
  cv::resize(image.rgba, mip, cv::Size(64, 64), 0, 0, cv::INTER_AREA);
  for (int y = 0; y < mip.rows; ++y)
    for (int x = 0; x < mip.cols; ++x) {
      const cv::Vec4b c = mip.at<cv::Vec4b>(y, x);
      ASSERT_GT(c[0] + c[1] + c[2], 250) << "dark mip texel at " << x << ", " << y;
    }
}

// ----------------------------------------------------------------------------------------------
// A real texture map with holes: the demo (a cat from tiger photos) through the mapping stages.

TEST(Atlas, DemoTextureMapWithHoles) {
  Project project = loadProject(test::assetsDir() + "/demo/project.json");
  const auto scene = loadScene(project);
  const Mapping mapping = mapTexture(*scene);
  const Mesh& mesh = mapping.partition->mesh;
  const AtlasInput in = atlasInput(mesh, mapping.map, scene->photos, nullptr);
  int empty = 0;
  for (int s : in.faceSource) empty += s == kSourceEmpty;
  ASSERT_GT(empty, 0) << "the demo is expected to leave holes";
  AtlasOptions options;
  options.size = 2048;
  const Atlas atlas = buildAtlas(mesh, in, options);
  const AtlasImage image = bakeAtlas(atlas, mesh, scene->photos, nullptr, nullptr, options);
  expectValidLayout(atlas, mesh, &image);
  EXPECT_GT(atlas.photoCharts, 0);
  EXPECT_GT(atlas.lscmCharts, 0);
  // Photo faces show their photo: the model's colour at random points equals the photo's there.
  const TexturedModel model = atlasModel(mesh, atlas, image);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0, 1);
  double sum = 0;
  int n = 0;
  for (int f = 0; f < mesh.numFaces(); ++f) {
    if (in.faceSource[f] < 0) continue;
    double b0 = u(rng), b1 = u(rng);
    if (b0 + b1 > 1) b0 = 1 - b0, b1 = 1 - b1;
    const Vec3 b(b0, b1, 1 - b0 - b1);
    const auto& uv = in.cornerUV[f];
    const Vec2 px = b[0] * uv[0] + b[1] * uv[1] + b[2] * uv[2];
    const Vec3f want = sampleBilinear3(scene->photos[in.faceSource[f]]->rgb, px.x(), px.y());
    sum += (model.colorAt(f, b) - want).squaredNorm() / 3;
    ++n;
  }
  const double rmse = std::sqrt(sum / n);
  std::printf("demo: %zu charts (%d photo, %d LSCM), scale %.3f, utilisation %.3f, colour RMSE %.4f\n",
              atlas.charts.size(), atlas.photoCharts, atlas.lscmCharts, atlas.scale, atlas.utilisation, rmse);
  EXPECT_LT(rmse, 0.02);
}

// ----------------------------------------------------------------------------------------------
// Bad input

TEST(Atlas, BadInputGivesClearErrors) {
  BakeScene s = bakeScene();
  AtlasOptions options;
  options.size = 100;
  EXPECT_NE(errorOf([&] {
              buildAtlas(*s.mesh, s.input, options);
            }).find("size 100 is neither 0 (automatic) nor in [256, 8192]"),
            std::string::npos);
  options.size = 9000;
  EXPECT_NE(errorOf([&] { buildAtlas(*s.mesh, s.input, options); }).find("nor in [256, 8192]"), std::string::npos);
  options = {};
  options.size = 1024;
  options.gutter = -1;
  EXPECT_NE(errorOf([&] { buildAtlas(*s.mesh, s.input, options); }).find("gutter -1"), std::string::npos);
  options.gutter = 4;
  AtlasInput bad = s.input;
  bad.faceSource.pop_back();
  EXPECT_NE(errorOf([&] { buildAtlas(*s.mesh, bad, options); }).find("faceSource has"), std::string::npos);
  bad = s.input;
  bad.faceSource[0] = 3;
  EXPECT_NE(errorOf([&] { buildAtlas(*s.mesh, bad, options); }).find("photo 3 has no size"), std::string::npos);
  bad = s.input;
  bad.cornerUV[0][1] = Vec2(std::nan(""), 0);
  EXPECT_NE(errorOf([&] { buildAtlas(*s.mesh, bad, options); }).find("face 0: photo coordinates are not finite"),
            std::string::npos);
  // Baking without the photo.
  const Atlas atlas = buildAtlas(*s.mesh, s.input, options);
  EXPECT_NE(errorOf([&] { bakeAtlas(atlas, *s.mesh, {}, nullptr, nullptr, options); }).find("photo 0 is missing"),
            std::string::npos);

  // 400 separate triangles, each its own chart, with a 64-texel gutter: they cannot all fit into
  // 1024 x 1024 at any scale. A clear error, quickly, no hang.
  std::vector<Vec3> v;
  std::vector<std::array<int, 3>> t;
  for (int i = 0; i < 400; ++i) {
    const int b = static_cast<int>(v.size());
    v.insert(v.end(), {Vec3(3 * i, 0, 0), Vec3(3 * i + 1, 0, 0), Vec3(3 * i, 1, 0)});
    t.push_back({b, b + 1, b + 2});
  }
  const auto many = requireUsable(buildMesh(v, t));
  AtlasInput manyIn;
  manyIn.faceSource.assign(many->numFaces(), kSourceInpainted);
  options.gutter = 64;
  const std::string msg = errorOf([&] { buildAtlas(*many, manyIn, options); });
  EXPECT_NE(msg.find("400 charts do not fit into a 1024x1024 atlas with a 64-texel gutter"), std::string::npos) << msg;
}

}  // namespace
}  // namespace montage
