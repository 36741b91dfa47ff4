// Inpainting against the truth (issue 34's measure; docs/images): a photo mapped onto a flat sheet with a hole
// cut out, filled by each inpainting mode, drawn side by side (truth, harmonic, rbf, structure, synthesis).
// Holes: a disc, an annulus (a ring of texture around a mapped island) and a whole side (a strip along the sheet's
// border). Prints per hole and mode, over the hole's pixels:
//  - the gradient energy of the fill divided by the truth's (1 is right; a smooth fill is near 0);
//  - the earth mover's distance between the fill's and the truth's L*u*v* colour histograms (8 bins a channel);
//  - a patch score: the mean distance (L*u*v*, per texel) of the fill's 7x7 patches to their nearest patch of
//    the truth's hole (a fill made of texture that belongs there scores low);
//  - mean ΔE to the truth (not a measure of a synthesis: a right-looking random texture scores worse than its
//    smooth mean), and the CPU time of the fill (user + sys, the whole inpainting) at final density and at the
//    preview's (detail 0.25).
// Texture mode is measured twice on the same fill: as the bake shows it (the exemplar looked up between the
// vertices, InpaintResult::colourAt) and as its vertices' colours interpolated ("texture, vertices"), side by side.
// With --exemplar, texture mode is also run from a region of the photo the user would pick (Project::holeModes'
// exemplar), a rectangle in sheet units, beside the fill from the photo around the hole ("texture, picked").
// Usage: tm_inpaint_picture PHOTO OUT.png [disc|annulus|side ...] [--modes=a,b] [--seed=N] [--detail=D]
//        [--exemplar=X0,Y0,X1,Y1]
//        (default: all three holes; one image per hole, OUT with the hole's name before .png; every mode but
//        strokes and off, or those named; N: the texture mode's seed; D: the refinement density the pictures
//        and measures are taken at, 1 = final, 0.25 = the preview's)
//        tm_inpaint_picture PHOTO OUT.png X Y R                  (a disc at (X, Y) of radius R, sheet units 0..1)

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>

#include "base/cpu_time.h"
#include "base/job.h"
#include "geometry/raster.h"
#include "geometry/shapes.h"
#include "image/codec.h"
#include "image/color.h"
#include "image/photo.h"
#include "surface/inpaint.h"

using namespace montage;

namespace {

// A hole on the unit sheet: whether a point is in it, and the square of the sheet the pictures show.
struct Hole {
  std::string name;
  Vec2 centre;
  double r0 = 0, r1 = 0;  // disc: r1; annulus: r0..r1; side: x > 1 - r1
  bool contains(const Vec2& p) const {
    if (name == "side") return p.x() > 1 - r1;
    const double d = (p - centre).norm();
    return d < r1 && d >= r0;
  }
};

// 3D histogram of L*u*v* colours (8 bins a channel over L 0..100, u -100..180, v -140..110) as an EMD signature.
cv::Mat signature(const std::vector<Vec3f>& luv) {
  std::vector<float> count(512, 0);
  auto bin = [](float x, float lo, float hi) { return std::clamp(int((x - lo) / (hi - lo) * 8), 0, 7); };
  for (const Vec3f& c : luv) count[bin(c[0], 0, 100) * 64 + bin(c[1], -100, 180) * 8 + bin(c[2], -140, 110)] += 1;
  const int bins = static_cast<int>(std::count_if(count.begin(), count.end(), [](float c) { return c > 0; }));
  cv::Mat sig(std::max(bins, 1), 4, CV_32F, cv::Scalar(0));
  for (int i = 0, row = 0; i < 512; ++i) {
    if (count[i] == 0) continue;
    float* r = sig.ptr<float>(row++);
    r[0] = count[i] / float(luv.size());
    r[1] = float(i / 64) * 100 / 8.f, r[2] = float(i / 8 % 8) * 280 / 8.f, r[3] = float(i % 8) * 250 / 8.f;
  }
  return sig;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: tm_inpaint_picture PHOTO OUT.png [disc|annulus|side ...]\n");
    return 2;
  }
  // Options after the holes: --modes=a,b,... (default: harmonic, rbf, synthesis, structure, texture), --seed=N,
  // --detail=D.
  std::string onlyModes;
  uint64_t seed = 1;
  double pictureDetail = 1;
  std::array<double, 4> picked = {0, 0, 0, 0};  // --exemplar: a rectangle in sheet units
  bool hasPicked = false;
  for (; argc > 3 && std::string(argv[argc - 1]).rfind("--", 0) == 0; --argc) {
    const std::string a = argv[argc - 1];
    if (a.rfind("--modes=", 0) == 0)
      onlyModes = "," + a.substr(8) + ",";
    else if (a.rfind("--seed=", 0) == 0)
      seed = std::strtoull(a.c_str() + 7, nullptr, 10);
    else if (a.rfind("--detail=", 0) == 0 && std::atof(a.c_str() + 9) > 0)
      pictureDetail = std::atof(a.c_str() + 9);
    else if (a.rfind("--exemplar=", 0) == 0 &&
             std::sscanf(a.c_str() + 11, "%lf,%lf,%lf,%lf", &picked[0], &picked[1], &picked[2], &picked[3]) == 4 &&
             picked[2] > picked[0] && picked[3] > picked[1])
      hasPicked = true;
    else {
      std::fprintf(stderr,
                   "unknown option %s (--modes=a,b, --seed=N, --detail=D with D > 0, --exemplar=X0,Y0,X1,Y1 with "
                   "X1 > X0 and Y1 > Y0)\n",
                   a.c_str());
      return 2;
    }
  }
  std::vector<Hole> holes;
  if (argc == 6 && std::isdigit(static_cast<unsigned char>(argv[3][0]))) {  // a disc at x y with radius r
    holes.push_back(Hole{"disc", Vec2(std::atof(argv[3]), std::atof(argv[4])), 0, std::atof(argv[5])});
    argc = 3;
  }
  for (int i = 3; i < argc; ++i) holes.push_back(Hole{argv[i]});
  if (holes.empty()) holes = {Hole{"disc"}, Hole{"annulus"}, Hole{"side"}};
  for (Hole& h : holes) {
    if (h.r1 > 0) continue;  // given
    if (h.name == "disc")
      h.centre = Vec2(0.6, 0.6), h.r1 = 0.14;
    else if (h.name == "annulus")
      h.centre = Vec2(0.5, 0.5), h.r0 = 0.08, h.r1 = 0.2;
    else if (h.name == "side")
      h.centre = Vec2(0.85, 0.5), h.r1 = 0.3;
    else {
      std::fprintf(stderr, "unknown hole %s (disc, annulus, side)\n", h.name.c_str());
      return 2;
    }
  }
  const Photo photo = loadPhoto(argv[1]);
  const auto mesh = makeGrid(61, 61, 1.0 / 60);
  const double scale = 0.9 * std::min(photo.width, photo.height), offset = 0.05 * std::min(photo.width, photo.height);
  TextureMap truth;
  for (int f = 0; f < mesh->numFaces(); ++f) {
    const auto p = mesh->facePositions(f);
    truth.facePhoto.push_back(0);
    truth.facePatch.push_back(0);
    truth.cornerUV.push_back({Vec2(offset + scale * p[0].x(), offset + scale * p[0].y()),
                              Vec2(offset + scale * p[1].x(), offset + scale * p[1].y()),
                              Vec2(offset + scale * p[2].x(), offset + scale * p[2].y())});
  }
  double load[3] = {0, 0, 0};
  if (getloadavg(load, 3) < 0) load[0] = -1;
  std::printf("%s: %dx%d, sheet %d faces, %.0f texels across; load %.2f\n", argv[1], photo.width, photo.height,
              mesh->numFaces(), scale, load[0]);
  std::printf(
      "| hole | mode | gradient energy / truth | histogram EMD | patch score | mean ΔE | CPU s final | CPU s "
      "preview | note |\n|---|---|---|---|---|---|---|---|---|\n");
  for (const Hole& hole : holes) {
    TextureMap map = truth;
    int holeFaces = 0;
    for (int f = 0; f < mesh->numFaces(); ++f) {
      const auto p = mesh->facePositions(f);
      const Vec3 c = (p[0] + p[1] + p[2]) / 3;
      if (hole.contains(Vec2(c.x(), c.y()))) map.facePhoto[f] = TextureMap::kEmpty, ++holeFaces;
    }
    // The picture: the hole's bounding square, a margin around it.
    const double half = hole.name == "side" ? 0.5 : 1.25 * hole.r1;
    const int side = int(std::ceil(2 * half * scale));
    const Vec2 origin = hole.centre * scale - Vec2(side / 2.0, side / 2.0);
    auto sheetOf = [&](int x, int y) -> Vec2 { return (Vec2(x + 0.5, y + 0.5) + origin) / scale; };
    // Pixels well inside the hole (a texel off its border), where the measures are taken.
    auto measured = [&](int x, int y) {
      const Vec2 s = sheetOf(x, y);
      const double e = 1.5 / scale;
      return hole.contains(s) && hole.contains(s + Vec2(e, 0)) && hole.contains(s - Vec2(e, 0)) &&
             hole.contains(s + Vec2(0, e)) && hole.contains(s - Vec2(0, e)) && s.x() < 1 && s.y() < 1 && s.y() > 0;
    };
    struct Column {
      const char* name;
      InpaintMode mode;
      bool verticesOnly;  // the texture mode's fill drawn from its vertices' colours alone
      bool picked = false;  // texture from the --exemplar region
    };
    std::vector<Column> modes = {{"truth", InpaintMode::Off, false}};
    for (size_t i = 0; i < kInpaintModeNames.size(); ++i)
      if (i != size_t(InpaintMode::Off) && i != size_t(InpaintMode::Strokes) &&
          (onlyModes.empty() || onlyModes.find("," + std::string(kInpaintModeNames[i]) + ",") != std::string::npos)) {
        modes.push_back({kInpaintModeNames[i], InpaintMode(i), false});
        if (InpaintMode(i) == InpaintMode::Texture) {
          modes.push_back({"texture, vertices", InpaintMode::Texture, true});
          if (hasPicked) modes.push_back({"texture, picked", InpaintMode::Texture, false, true});
        }
      }
    cv::Mat out(side, side * int(modes.size()), CV_32FC3, cv::Scalar(0, 0, 0));
    cv::Mat truthLuv;
    InpaintResult res;  // the last column's fill (the vertices-only column draws it again)
    for (size_t m = 0; m < modes.size(); ++m) {
      cv::Mat panel = out(cv::Rect(int(m) * side, 0, side, side));
      for (int f = 0; f < mesh->numFaces(); ++f) {
        if (m != 0 && map.facePhoto[f] < 0) continue;
        const auto p = mesh->facePositions(f);
        std::array<Vec2, 3> q;
        for (int k = 0; k < 3; ++k) q[k] = Vec2(p[k].x(), p[k].y()) * scale - origin;
        scanTriangle(q, side, side, [&](int x, int y, const Vec3& b) {
          const Vec3f c = mappedColor(truth, {&photo}, nullptr, f, b);
          panel.at<cv::Vec3f>(y, x) = cv::Vec3f(c[0], c[1], c[2]);
        });
      }
      std::string note;
      double cpuFinal = 0, cpuPreview = 0;
      if (m > 0 && modes[m].verticesOnly) {
        // The previous column's fill, without the texture between its vertices (no new run, no new times).
        res.detailPoint.clear();
        note = "the texture column's fill, its vertices' colours interpolated";
      } else if (m > 0) {
        InpaintInput in;
        in.mesh = mesh.get();
        in.map = &map;
        in.photos = {&photo};
        in.options.mode = modes[m].mode;
        in.options.textureSeed = seed;
        if (modes[m].picked) {
          HoleExemplar region{0, {}};
          for (const Vec2& q : {Vec2(picked[0], picked[1]), Vec2(picked[2], picked[1]), Vec2(picked[2], picked[3]),
                                Vec2(picked[0], picked[3])})
            region.polygon.push_back(Vec2::Constant(offset) + scale * q);
          for (int f = 0; f < mesh->numFaces() && in.holeModes.empty(); ++f)
            if (map.facePhoto[f] < 0) in.holeModes.push_back({f, InpaintMode::Texture, region});
        }
        in.options.detail = 0.25;
        double c0 = cpuSeconds();
        res = inpaintSurface(in, {}, nullptr);
        cpuPreview = cpuSeconds() - c0;
        in.options.detail = 1;
        c0 = cpuSeconds();
        InpaintResult finalFill = inpaintSurface(in, {}, nullptr);
        cpuFinal = cpuSeconds() - c0;
        if (pictureDetail != 0.25) {
          if (pictureDetail != 1) in.options.detail = pictureDetail, finalFill = inpaintSurface(in, {}, nullptr);
          res = std::move(finalFill);
        }
        if (!res.regions.empty()) note = res.regions[0].note;
      }
      if (m > 0) {
        const RefinedSurface& rs = res.refined;
        for (int t = 0; t < rs.mesh.numTriangles(); ++t) {
          if (rs.region[t] < 0) continue;
          std::array<Vec2, 3> q;
          for (int k = 0; k < 3; ++k) {
            const Vec3& p = rs.mesh.positions[rs.mesh.triangles[t][k]];
            q[k] = Vec2(p.x(), p.y()) * scale - origin;
          }
          scanTriangle(q, side, side, [&](int x, int y, const Vec3& b) {
            const Vec3f v = res.colourAt(t, b).cwiseMax(0.f).cwiseMin(1.f);  // as the bake shows it
            panel.at<cv::Vec3f>(y, x) = cv::Vec3f(v[0], v[1], v[2]);
          });
        }
      }
      const cv::Mat luv = srgbToLuv(panel);
      if (m == 0) {
        truthLuv = luv;
        continue;
      }
      // Gradient energy (Sobel on L*), histograms, ΔE.
      cv::Mat gx, gy, tx, ty, l, tl;
      cv::extractChannel(luv, l, 0), cv::extractChannel(truthLuv, tl, 0);
      cv::Sobel(l, gx, CV_32F, 1, 0), cv::Sobel(l, gy, CV_32F, 0, 1);
      cv::Sobel(tl, tx, CV_32F, 1, 0), cv::Sobel(tl, ty, CV_32F, 0, 1);
      double energy = 0, truthEnergy = 0, sumDe = 0;
      std::vector<Vec3f> fill, real;
      std::vector<cv::Point> centres;
      for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x) {
          if (!measured(x, y)) continue;
          energy += gx.at<float>(y, x) * gx.at<float>(y, x) + gy.at<float>(y, x) * gy.at<float>(y, x);
          truthEnergy += tx.at<float>(y, x) * tx.at<float>(y, x) + ty.at<float>(y, x) * ty.at<float>(y, x);
          const cv::Vec3f a = luv.at<cv::Vec3f>(y, x), b = truthLuv.at<cv::Vec3f>(y, x);
          fill.emplace_back(a[0], a[1], a[2]);
          real.emplace_back(b[0], b[1], b[2]);
          sumDe += cv::norm(a - b);
          if (x >= 3 && y >= 3 && x + 3 < side && y + 3 < side) centres.emplace_back(x, y);
        }
      if (fill.empty()) {
        std::printf("| %s | %s | no pixel inside the hole (%d x %d picture) |\n", hole.name.c_str(), modes[m].name,
                    side, side);
        continue;
      }
      const double emd = cv::EMD(signature(fill), signature(real), cv::DIST_L2);
      // Patch score: 400 of the fill's patches (seeded), each against every second patch of the truth's hole.
      std::mt19937 rng(7);
      std::vector<cv::Point> probes = centres;
      std::shuffle(probes.begin(), probes.end(), rng);
      probes.resize(std::min<size_t>(probes.size(), 400));
      std::vector<cv::Point> library;
      for (const cv::Point& c : centres)
        if (c.x % 2 == 0 && c.y % 2 == 0) library.push_back(c);
      double patchSum = 0;
      for (const cv::Point& p : probes) {
        double best = 1e300;
        for (const cv::Point& c : library) {
          double d = 0;
          for (int dy = -3; dy <= 3 && d < best; ++dy) {
            const cv::Vec3f* a = luv.ptr<cv::Vec3f>(p.y + dy) + p.x - 3;
            const cv::Vec3f* b = truthLuv.ptr<cv::Vec3f>(c.y + dy) + c.x - 3;
            for (int dx = 0; dx < 7; ++dx) {
              const cv::Vec3f e = a[dx] - b[dx];
              d += e.dot(e);
            }
          }
          best = std::min(best, d);
        }
        patchSum += std::sqrt(best / 49);
      }
      std::printf("| %s | %s | %.2f | %.2f | %.2f | %.2f | %.3f | %.3f | %s |\n", hole.name.c_str(), modes[m].name,
                  energy / std::max(truthEnergy, 1e-9), emd, patchSum / std::max<size_t>(probes.size(), 1),
                  sumDe / std::max<size_t>(fill.size(), 1), cpuFinal, cpuPreview, note.c_str());
      std::fflush(stdout);
    }
    std::string path = argv[2];
    const size_t dot = path.rfind(".png");
    path = (dot == std::string::npos ? path : path.substr(0, dot)) + "_" + hole.name + ".png";
    cv::Mat rgb8;
    out.convertTo(rgb8, CV_8UC3, 255);
    montage::writePng(path, rgb8, kPngFast, false);
    std::string names = "truth";
    for (size_t m = 1; m < modes.size(); ++m) names += std::string(", ") + modes[m].name;
    std::printf("(%d hole faces; picture %s: %s)\n", holeFaces, path.c_str(), names.c_str());
  }
  return 0;
}
