// Inpainting benchmark (paper section 5): a hole in a textured flat square, refined to about N
// vertices, filled with RBF guidance. Prints refinement, guidance, factorisation and per-channel solve
// times and the peak memory. Usage: tm_inpaint_bench [N ...]   (default 10000 100000 1000000)
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "surface/inpaint.h"
#include "image/photo.h"
#include "pipeline.h"
#include "geometry/shapes.h"

using namespace montage;

int main(int argc, char** argv) {
  std::vector<long> sizes;
  for (int i = 1; i < argc; ++i) sizes.push_back(std::atol(argv[i]));
  if (sizes.empty()) sizes = {10000, 100000, 1000000};

  const auto mesh = makeGrid(41, 41, 1.0 / 40);
  Photo photo;
  photo.width = photo.height = 1024;
  photo.rgb.create(1024, 1024, CV_32FC3);
  for (int r = 0; r < 1024; ++r)
    for (int c = 0; c < 1024; ++c)
      photo.rgb.at<cv::Vec3f>(r, c) =
          cv::Vec3f(float(0.5 + 0.3 * std::sin(c / 13.0)), float(0.5 + 0.3 * std::cos(r / 9.0)),
                    float(0.4 + 0.2 * std::sin((r + c) / 21.0)));
  TextureMap map;
  const double radius = 0.35;
  for (int f = 0; f < mesh->numFaces(); ++f) {
    const auto p = mesh->facePositions(f);
    const Vec3 centre = (p[0] + p[1] + p[2]) / 3;
    const bool hole = (centre - Vec3(0.5, 0.5, 0)).norm() < radius;
    map.facePhoto.push_back(hole ? TextureMap::kEmpty : 0);
    map.facePatch.push_back(0);
    map.cornerUV.push_back({Vec2(1000 * p[0].x() + 12, 1000 * p[0].y() + 12),
                            Vec2(1000 * p[1].x() + 12, 1000 * p[1].y() + 12),
                            Vec2(1000 * p[2].x() + 12, 1000 * p[2].y() + 12)});
  }
  double holeArea = 0;
  for (int f = 0; f < mesh->numFaces(); ++f)
    if (map.facePhoto[f] < 0) holeArea += mesh->faceArea(f);

  std::printf("%10s %10s %10s %9s %9s %9s %12s %9s %10s\n", "target", "refined", "unknowns", "refine s", "guide s",
              "factor s", "solve/ch s", "total s", "peak MiB");
  for (long n : sizes) {
    InpaintInput in;
    in.mesh = mesh.get();
    in.map = &map;
    in.photos = {&photo};
    in.options.mode = InpaintMode::Rbf;
    in.options.texelsPerUnit = std::sqrt(double(n) / holeArea);
    in.options.maxRefinedVertices = 20000000;
    const auto start = std::chrono::steady_clock::now();
    const InpaintResult res = inpaintSurface(in, {}, nullptr);
    const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const InpaintRegion& r = res.regions.at(0);
    struct rusage usage {};
    getrusage(RUSAGE_SELF, &usage);
    std::printf("%10ld %10d %10d %9.3f %9.3f %9.3f %12.4f %9.2f %10.1f\n", n, r.refinedVertices, r.unknowns,
                r.refineSeconds, r.guidanceSeconds, r.factorSeconds, r.solveSeconds / 3, total,
                usage.ru_maxrss / 1024.0);
    std::fflush(stdout);
    // The same system factorised by each backend (what PoissonSolver::kCholmodAbove is chosen from).
    const RefinedSurface& rs = res.refined;
    std::vector<char> fixed(rs.mesh.numVertices(), 0);
    for (int t = 0; t < rs.mesh.numTriangles(); ++t)
      if (rs.region[t] < 0)
        for (int v : rs.mesh.triangles[t]) fixed[v] = 1;
    const Eigen::MatrixXd values = res.colors.cast<double>();
    for (auto backend : {PoissonSolver::Backend::SimplicialLDLT, PoissonSolver::Backend::Cholmod}) {
      const PoissonSolver solver(rs.mesh, fixed, backend);
      const auto t0 = std::chrono::steady_clock::now();
      solver.solve(Eigen::MatrixXd::Zero(values.rows(), 3), values);
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::printf("%10s   %-15s factor %7.3f s, solve %7.4f s per channel\n", "",
                  backend == PoissonSolver::Backend::Cholmod ? "CHOLMOD" : "SimplicialLDLT", solver.factorSeconds(),
                  s / 3);
    }
  }
  return 0;
}
