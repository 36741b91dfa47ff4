#include "geometry/shapes.h"

#include <cmath>
#include <map>

namespace montage {

namespace {

// One level of midpoint subdivision in place: each triangle into four, midpoints appended (projected
// onto the unit sphere when `onSphere`).
void subdivideOnce(std::vector<Vec3>& v, std::vector<std::array<int, 3>>& f, bool onSphere) {
  std::map<std::pair<int, int>, int> mid;
  const auto midpoint = [&](int a, int b) {
    const auto key = std::minmax(a, b);
    const auto it = mid.find(key);
    if (it != mid.end()) return it->second;
    const Vec3 m = 0.5 * (v[a] + v[b]);
    v.push_back(onSphere ? Vec3(m.normalized()) : m);
    return mid[key] = static_cast<int>(v.size()) - 1;
  };
  std::vector<std::array<int, 3>> next;
  next.reserve(4 * f.size());
  for (const auto& tri : f) {
    const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
    next.push_back({tri[0], a, c});
    next.push_back({tri[1], b, a});
    next.push_back({tri[2], c, b});
    next.push_back({a, b, c});
  }
  f = std::move(next);
}

}  // namespace

std::unique_ptr<Mesh> makeIcosphere(int levels) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (Vec3& p : v) p.normalize();
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int l = 0; l < levels; ++l) subdivideOnce(v, f, true);
  return requireUsable(buildMesh(v, f, {}, {}, "icosphere"));
}

std::unique_ptr<Mesh> makeGrid(int nx, int ny, double step) {
  TM_CHECK(nx >= 2 && ny >= 2, "makeGrid: needs at least 2 x 2 vertices");
  std::vector<Vec3> v;
  v.reserve(size_t(nx) * ny);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) v.emplace_back(i * step, j * step, 0.0);
  std::vector<std::array<int, 3>> f;
  f.reserve(2 * size_t(nx - 1) * (ny - 1));
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      const int a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
      f.push_back({a, b, d});
      f.push_back({a, d, c});
    }
  return requireUsable(buildMesh(v, f, {}, {}, "grid"));
}

std::unique_ptr<Mesh> subdivideMidpoint(const Mesh& mesh, int levels) {
  TM_CHECK(levels >= 0 && levels <= 6, "subdivideMidpoint: levels must be in 0..6");
  std::vector<Vec3> v(mesh.numVertices());
  for (int i = 0; i < mesh.numVertices(); ++i) v[i] = mesh.position(i);
  std::vector<std::array<int, 3>> f(mesh.numFaces());
  for (int i = 0; i < mesh.numFaces(); ++i) f[i] = mesh.faceVertices(i);
  for (int l = 0; l < levels; ++l) subdivideOnce(v, f, false);
  return requireUsable(buildMesh(v, f, {}, {}, "subdivided"));
}

}  // namespace montage
