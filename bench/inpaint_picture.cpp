// Inpainting picture (docs/images): a photo mapped onto a flat sheet with a round hole cut out, filled
// by each inpainting mode, drawn side by side (truth, harmonic, rbf, synthesis). Prints per mode the
// mean Delta E to the truth and the fill's gradient energy against the truth's.
// Usage: tm_inpaint_picture PHOTO OUT.png [centre_x centre_y radius]   (sheet coordinates in [0,1])
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <opencv2/imgproc.hpp>

#include "base/job.h"
#include "geometry/raster.h"
#include "geometry/shapes.h"
#include "image/codec.h"
#include "image/color.h"
#include "image/photo.h"
#include "surface/inpaint.h"

using namespace montage;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: tm_inpaint_picture PHOTO OUT.png [centre_x centre_y radius]\n");
    return 2;
  }
  const Vec3 centre(argc > 4 ? std::atof(argv[3]) : 0.6, argc > 4 ? std::atof(argv[4]) : 0.6, 0);
  const double radius = argc > 5 ? std::atof(argv[5]) : 0.14;
  const Photo photo = loadPhoto(argv[1]);
  const auto mesh = makeGrid(41, 41, 1.0 / 40);
  const double scale = 0.6 * std::min(photo.width, photo.height), offset = 20;
  TextureMap truth;
  for (int f = 0; f < mesh->numFaces(); ++f) {
    const auto p = mesh->facePositions(f);
    truth.facePhoto.push_back(0);
    truth.facePatch.push_back(0);
    truth.cornerUV.push_back({Vec2(offset + scale * p[0].x(), offset + scale * p[0].y()),
                              Vec2(offset + scale * p[1].x(), offset + scale * p[1].y()),
                              Vec2(offset + scale * p[2].x(), offset + scale * p[2].y())});
  }
  TextureMap map = truth;
  for (int f = 0; f < mesh->numFaces(); ++f) {
    const auto p = mesh->facePositions(f);
    if (((p[0] + p[1] + p[2]) / 3 - centre).norm() < radius) map.facePhoto[f] = TextureMap::kEmpty;
  }
  // A square crop around the hole, 2.5 radii wide, one panel per mode.
  const int side = int(std::ceil(2.5 * 2 * radius * scale));
  const Vec2 origin = Vec2(centre.x(), centre.y()) * scale - Vec2(side / 2.0, side / 2.0);
  const std::vector<std::pair<const char*, InpaintMode>> modes = {{"truth", InpaintMode::Off},
                                                                  {"harmonic", InpaintMode::Harmonic},
                                                                  {"rbf", InpaintMode::Rbf},
                                                                  {"synthesis", InpaintMode::Synthesis}};
  cv::Mat out(side, side * int(modes.size()), CV_8UC3, cv::Scalar(0, 0, 0));
  for (size_t m = 0; m < modes.size(); ++m) {
    cv::Mat panel = out(cv::Rect(int(m) * side, 0, side, side));
    // Mapped faces: the photo; the truth panel shows it everywhere.
    for (int f = 0; f < mesh->numFaces(); ++f) {
      const auto p = mesh->facePositions(f);
      std::array<Vec2, 3> q;
      for (int k = 0; k < 3; ++k) q[k] = Vec2(p[k].x(), p[k].y()) * scale - origin;
      const bool use = m == 0 || map.facePhoto[f] >= 0;
      if (!use) continue;
      scanTriangle(q, side, side, [&](int x, int y, const Vec3& b) {
        const Vec3f c = mappedColor(truth, {&photo}, nullptr, f, b);
        panel.at<cv::Vec3b>(y, x) =
            cv::Vec3b(cv::saturate_cast<uchar>(255 * c[2]), cv::saturate_cast<uchar>(255 * c[1]),
                      cv::saturate_cast<uchar>(255 * c[0]));
      });
    }
    if (m == 0) continue;
    InpaintInput in;
    in.mesh = mesh.get();
    in.map = &map;
    in.photos = {&photo};
    in.options.mode = modes[m].second;
    const InpaintResult res = inpaintSurface(in, {}, nullptr);
    const RefinedSurface& rs = res.refined;
    double sumDe = 0, energy = 0, truthEnergy = 0;
    long n = 0;
    for (int t = 0; t < rs.mesh.numTriangles(); ++t) {
      if (rs.region[t] < 0) continue;
      std::array<Vec2, 3> q;
      for (int k = 0; k < 3; ++k)
        q[k] = Vec2(rs.mesh.positions[rs.mesh.triangles[t][k]].x(), rs.mesh.positions[rs.mesh.triangles[t][k]].y()) *
                   scale -
               origin;
      std::array<Vec3f, 3> c;
      for (int k = 0; k < 3; ++k) c[k] = res.colors.row(rs.mesh.triangles[t][k]).transpose();
      scanTriangle(q, side, side, [&](int x, int y, const Vec3& b) {
        const Vec3f v = float(b[0]) * c[0] + float(b[1]) * c[1] + float(b[2]) * c[2];
        panel.at<cv::Vec3b>(y, x) =
            cv::Vec3b(cv::saturate_cast<uchar>(255 * v[2]), cv::saturate_cast<uchar>(255 * v[1]),
                      cv::saturate_cast<uchar>(255 * v[0]));
        const Vec3 pb = b[0] * rs.parentBary[t][0] + b[1] * rs.parentBary[t][1] + b[2] * rs.parentBary[t][2];
        sumDe += deltaEuv(v, mappedColor(truth, {&photo}, nullptr, rs.parentFace[t], pb));
        ++n;
      });
    }
    // Gradient energy over the hole's pixels of the panel against the truth panel (Sobel on grey).
    cv::Mat grey, truthGrey, gx, gy, tx, ty;
    cv::cvtColor(panel, grey, cv::COLOR_BGR2GRAY);
    cv::cvtColor(out(cv::Rect(0, 0, side, side)), truthGrey, cv::COLOR_BGR2GRAY);
    cv::Sobel(grey, gx, CV_32F, 1, 0), cv::Sobel(grey, gy, CV_32F, 0, 1);
    cv::Sobel(truthGrey, tx, CV_32F, 1, 0), cv::Sobel(truthGrey, ty, CV_32F, 0, 1);
    long pixels = 0;
    for (int y = 0; y < side; ++y)
      for (int x = 0; x < side; ++x) {
        const Vec2 s = (Vec2(x + 0.5, y + 0.5) + origin) / scale;
        if ((Vec2(centre.x(), centre.y()) - s).norm() > 0.9 * radius) continue;
        energy += gx.at<float>(y, x) * gx.at<float>(y, x) + gy.at<float>(y, x) * gy.at<float>(y, x);
        truthEnergy += tx.at<float>(y, x) * tx.at<float>(y, x) + ty.at<float>(y, x) * ty.at<float>(y, x);
        ++pixels;
      }
    std::printf("%-10s mean Delta E %.2f   gradient energy %.0f (truth %.0f, ratio %.2f)   %s\n", modes[m].first,
                sumDe / std::max(n, 1L), energy / std::max(pixels, 1L), truthEnergy / std::max(pixels, 1L),
                energy / std::max(truthEnergy, 1e-9), res.regions.empty() ? "" : res.regions[0].note.c_str());
  }
  montage::writePng(argv[2], out);
  return 0;
}
