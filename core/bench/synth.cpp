// Synthetic ground-truth scenes (see synth.h).
//
// Photos are rendered unlit: every covered pixel carries the surface's albedo, so a correct
// texturing reproduces the truth colours exactly. The silhouette is antialiased by 2x2
// supersampling: the mesh is rasterised at twice the resolution with a camera whose intrinsics are
// exactly twice the photo camera's (so sub-pixel centres sit at +0.25 and +0.75 of each photo
// pixel), and each photo pixel is the box-filtered average of its four samples: alpha = covered/4,
// colour = premultiplied average / alpha (the straight-alpha colour PNG stores). With lens distortion
// (options.k1, k2) the view is rendered so through a pinhole camera on a canvas large enough for every
// undistorted pixel, then resampled (bilinear on premultiplied colour) at each photo pixel's undistorted place.
#include "bench/synth.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <queue>
#include <random>
#include <utility>

#include "geometry/mesh.h"
#include "image/codec.h"
#include "image/color.h"
#include "io/mesh_io.h"
#include "mapping/camera.h"

namespace fs = std::filesystem;

namespace montage {

namespace {

// ---------------------------------------------------------------------------------------------
// Solid pattern: integer-hash value noise, fractal sums, a colour palette, spots and stripes.

uint32_t mix32(uint32_t h) {  // murmur3 finaliser
  h ^= h >> 16;
  h *= 0x85EBCA6Bu;
  h ^= h >> 13;
  h *= 0xC2B2AE35u;
  h ^= h >> 16;
  return h;
}

uint32_t hash3(int64_t x, int64_t y, int64_t z, uint32_t salt) {
  uint32_t h = mix32(salt * 0x9E3779B9u + 0x632BE5ABu);
  h = mix32(h ^ static_cast<uint32_t>(x));
  h = mix32(h ^ static_cast<uint32_t>(y) * 0x27D4EB2Fu);
  h = mix32(h ^ static_cast<uint32_t>(z) * 0x165667B1u);
  return h;
}

double hashUnit(int64_t x, int64_t y, int64_t z, uint32_t salt) {
  return (hash3(x, y, z, salt) >> 8) * (1.0 / 16777216.0);  // [0, 1)
}

double fade(double t) {
  return t * t * t * (t * (t * 6 - 15) + 10);
}  // quintic, C2

// Smooth value noise in [0, 1): hashed values at the integer lattice, quintic interpolation.
double valueNoise(const Vec3& p, uint32_t salt) {
  const double fx = std::floor(p.x()), fy = std::floor(p.y()), fz = std::floor(p.z());
  const auto ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy), iz = static_cast<int64_t>(fz);
  const double ux = fade(p.x() - fx), uy = fade(p.y() - fy), uz = fade(p.z() - fz);
  double c[2][2][2];
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      for (int d = 0; d < 2; ++d) c[a][b][d] = hashUnit(ix + a, iy + b, iz + d, salt);
  auto lerp = [](double a, double b, double t) { return a + (b - a) * t; };
  const double x00 = lerp(c[0][0][0], c[1][0][0], ux), x10 = lerp(c[0][1][0], c[1][1][0], ux);
  const double x01 = lerp(c[0][0][1], c[1][0][1], ux), x11 = lerp(c[0][1][1], c[1][1][1], ux);
  return lerp(lerp(x00, x10, uy), lerp(x01, x11, uy), uz);
}

// Fractal sum of `octaves` noise layers, each twice the frequency and half the amplitude of the
// previous one; normalised to [0, 1).
double fbm(const Vec3& p, int octaves, uint32_t salt) {
  double sum = 0, amplitude = 1, norm = 0, frequency = 1;
  for (int o = 0; o < octaves; ++o) {
    // Each octave is offset so the lattices do not line up.
    sum += amplitude * valueNoise(p * frequency + Vec3(17.3 * o, -9.1 * o, 5.7 * o), salt + 101u * o);
    norm += amplitude;
    amplitude *= 0.5;
    frequency *= 2;
  }
  return sum / norm;
}

// Cosine colour palette (smooth rainbow) at t.
Vec3 palette(double t) {
  const double kTwoPi = 2 * M_PI;
  return Vec3(0.5 + 0.5 * std::cos(kTwoPi * (t + 0.00)), 0.5 + 0.5 * std::cos(kTwoPi * (t + 0.33)),
              0.5 + 0.5 * std::cos(kTwoPi * (t + 0.67)));
}

// ---------------------------------------------------------------------------------------------
// Helpers for scenes.

// Uniform double in [0, 1) from a 32-bit engine, the same on every standard library.
double unit(std::mt19937& rng) {
  return rng() * (1.0 / 4294967296.0);
}

// Area-weighted vertex normals (unit; zero for vertices without faces).
std::vector<Vec3> vertexNormals(const Mesh& mesh) {
  std::vector<Vec3> normals(mesh.numVertices(), Vec3::Zero());
  for (int f = 0; f < mesh.numFaces(); ++f) {
    const auto q = mesh.facePositions(f);
    const Vec3 n = (q[1] - q[0]).cross(q[2] - q[0]);  // length = 2 * area
    for (int v : mesh.faceVertices(f)) normals[v] += n;
  }
  for (auto& n : normals) {
    const double len = n.norm();
    if (len > 0) n /= len;
  }
  return normals;
}

// View directions (unit, from the mesh centre towards the camera).
std::vector<Vec3> viewDirections(int views, unsigned seed) {
  std::mt19937 rng(seed ^ 0x5EEDCAFEu);
  std::vector<Vec3> dirs;
  if (views <= 4) {
    // Around the equator of the up axis (+Y), slightly above it, with a small seeded jitter.
    const double step = 2 * M_PI / views;
    for (int k = 0; k < views; ++k) {
      const double azimuth = k * step + (unit(rng) - 0.5) * 0.2 * std::min(step, M_PI / 2);
      const double elevation = 0.25 + (unit(rng) - 0.5) * 0.1;  // about 14 degrees
      dirs.emplace_back(std::cos(elevation) * std::sin(azimuth), std::sin(elevation),
                        std::cos(elevation) * std::cos(azimuth));
    }
    return dirs;
  }
  // Fibonacci sphere, randomly rotated about Y and jittered by a fraction of the point spacing.
  // |y| stays <= 0.95 so that +Y remains a usable image up direction.
  const double golden = M_PI * (3 - std::sqrt(5.0));
  const double offset = 2 * M_PI * unit(rng);
  const double spacing = std::sqrt(4 * M_PI / views);
  for (int i = 0; i < views; ++i) {
    const double y = 1 - 2 * (i + 0.5) / views;
    const double r = std::sqrt(std::max(0.0, 1 - y * y));
    const double phi = i * golden + offset;
    Vec3 d(r * std::cos(phi), y, r * std::sin(phi));
    d += 0.15 * spacing * Vec3(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5);
    d.normalize();
    if (std::abs(d.y()) > 0.95) {
      Vec2 xz(d.x(), d.z());
      if (xz.norm() < 1e-9) xz = Vec2(1, 0);
      xz = xz.normalized() * std::sqrt(1 - 0.95 * 0.95);
      d = Vec3(xz.x(), d.y() > 0 ? 0.95 : -0.95, xz.y());
    }
    dirs.push_back(d);
  }
  return dirs;
}

// The normalised point that PhotoCamera's radial distortion (1 + k1 r^2 + k2 r^4) takes to `distorted`
// (fixed-point iteration; the distortion is checked monotonic over the photo beforehand).
Vec2 undistortNormalised(const Vec2& distorted, double k1, double k2) {
  Vec2 x = distorted;
  for (int i = 0; i < 50; ++i) {
    const double r2 = x.squaredNorm();
    x = distorted / (1 + k1 * r2 + k2 * r2 * r2);
  }
  return x;
}

std::string photoName(int k) {
  return "photo_" + std::to_string(k) + ".png";
}

nlohmann::json vecJson(const Vec3& v) {
  return nlohmann::json::array({v.x(), v.y(), v.z()});
}

}  // namespace

SurfaceColor meshPattern(const Mesh& mesh) {
  Vec3 lo, hi;
  mesh.bounds(lo, hi);
  const double scale = 0.25 * (hi - lo).norm();
  return [&mesh, scale](int f, const Vec3& b) {
    const auto q = mesh.facePositions(f);
    return solidPattern(b[0] * q[0] + b[1] * q[1] + b[2] * q[2], scale);
  };
}

Vec3f solidPattern(const Vec3& p, double scale) {
  const Vec3 q = p / (scale > 0 ? scale : 1.0);

  // Base: a fractal noise (structures from `scale` down to scale/16) through a rainbow palette,
  // its lightness modulated by a second, independent noise.
  const double t = fbm(q, 5, 1u);
  Vec3 colour = palette(1.6 * t + 0.2 * fbm(q * 0.5, 2, 7u));
  colour *= 0.55 + 0.45 * fbm(q * 2.3 + Vec3(3.1, 1.7, -4.2), 4, 2u);

  // Sharp-edged spots: one sphere per lattice cell of size scale/6 in about half of the cells,
  // fully inside its cell (so neighbouring cells never need checking), with a hashed colour.
  const Vec3 s = q * 6.0;
  const Vec3 cellF(std::floor(s.x()), std::floor(s.y()), std::floor(s.z()));
  const auto cx = static_cast<int64_t>(cellF.x()), cy = static_cast<int64_t>(cellF.y()),
             cz = static_cast<int64_t>(cellF.z());
  if (hashUnit(cx, cy, cz, 11u) < 0.5) {
    const Vec3 centre(0.35 + 0.3 * hashUnit(cx, cy, cz, 12u), 0.35 + 0.3 * hashUnit(cx, cy, cz, 13u),
                      0.35 + 0.3 * hashUnit(cx, cy, cz, 14u));
    const double radius = 0.15 + 0.15 * hashUnit(cx, cy, cz, 15u);
    if ((s - cellF - centre).norm() < radius) {
      colour = palette(hashUnit(cx, cy, cz, 16u));
      colour = 0.15 * Vec3::Ones() + 0.85 * colour;
    }
  }

  // Thin dark stripes (period scale/10) whose course is bent by a noise.
  const double phase = q.dot(Vec3(0.48, 0.64, 0.6)) * 10.0 + 1.5 * fbm(q * 1.5, 3, 21u);
  if (phase - std::floor(phase) < 0.12) colour *= 0.2;

  colour = colour.cwiseMax(0.0).cwiseMin(1.0);
  return colour.cast<float>();
}

std::vector<int> farthestPointSamples(const Mesh& mesh, int count, unsigned seed) {
  TM_CHECK(count >= 0, "farthestPointSamples: count: must be >= 0 (got " + std::to_string(count) + ")");
  const TriMesh& tri = mesh.tri;
  const int n = mesh.numVertices();

  // Compressed adjacency with edge lengths.
  std::vector<std::pair<int, int>> edges;
  edges.reserve(tri.n_edges());
  for (auto eh : tri.edges()) {
    const auto heh = tri.halfedge_handle(eh, 0);
    edges.emplace_back(tri.from_vertex_handle(heh).idx(), tri.to_vertex_handle(heh).idx());
  }
  std::vector<int> start(n + 1, 0);
  for (const auto& [a, b] : edges) {
    ++start[a + 1];
    ++start[b + 1];
  }
  for (int v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<int> neighbour(start[n]);
  std::vector<double> length(start[n]);
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (const auto& [a, b] : edges) {
      const double len = (mesh.position(a) - mesh.position(b)).norm();
      neighbour[fill[a]] = b;
      length[fill[a]++] = len;
      neighbour[fill[b]] = a;
      length[fill[b]++] = len;
    }
  }

  std::vector<int> connected;  // vertices with at least one edge; isolated ones are never sampled
  for (int v = 0; v < n; ++v)
    if (start[v + 1] > start[v]) connected.push_back(v);
  const int target = std::min<int>(count, static_cast<int>(connected.size()));
  std::vector<int> samples;
  if (target == 0) return samples;
  samples.reserve(target);

  std::mt19937 rng(seed);
  samples.push_back(connected[rng() % connected.size()]);

  // minDist[v]: geodesic (edge-path) distance from v to the nearest sample so far. Each new
  // Dijkstra only expands vertices it brings closer, so it stays within the new sample's cell.
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> minDist(n, inf);
  std::vector<char> chosen(n, 0);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
  while (true) {
    const int s = samples.back();
    chosen[s] = 1;
    minDist[s] = 0;
    heap.emplace(0.0, s);
    while (!heap.empty()) {
      const auto [d, v] = heap.top();
      heap.pop();
      if (d > minDist[v]) continue;  // stale entry
      for (int i = start[v]; i < start[v + 1]; ++i) {
        const int w = neighbour[i];
        const double nd = d + length[i];
        if (nd < minDist[w]) {
          minDist[w] = nd;
          heap.emplace(nd, w);
        }
      }
    }
    if (static_cast<int>(samples.size()) == target) break;
    int best = -1;
    double bestDist = -1;
    for (int v : connected)
      if (!chosen[v] && minDist[v] > bestDist) {
        bestDist = minDist[v];
        best = v;
      }
    TM_ASSERT(best >= 0);
    samples.push_back(best);
  }
  return samples;
}

SynthScene synthesize(const Mesh& restMesh, const std::string& meshPath, const SurfaceColor& color,
                      const SynthOptions& options, const std::function<void(double)>& progress) {
  const std::string where = "synthesize";
  auto fail = [&](const std::string& field, const std::string& reason) {
    return Error(where + ": " + field + ": " + reason);
  };
  if (options.views < 1) throw fail("views", "must be >= 1 (got " + std::to_string(options.views) + ")");
  if (options.features < 0) throw fail("features", "must be >= 0 (got " + std::to_string(options.features) + ")");
  if (options.size < 16 || options.size > 8192)
    throw fail("size", "must be in [16, 8192] pixels (got " + std::to_string(options.size) + ")");
  if (!(options.fovYDeg > 1 && options.fovYDeg < 170))
    throw fail("fovYDeg", "must be in (1, 170) degrees (got " + std::to_string(options.fovYDeg) + ")");
  if (!(options.borderPx >= 0 && options.borderPx <= options.size / 4.0))
    throw fail("borderPx", "must be in [0, size/4] (got " + std::to_string(options.borderPx) + ")");
  if (!std::isfinite(options.minFacing)) throw fail("minFacing", "must be finite");
  if (!(options.clickNoisePx >= 0 && options.clickNoisePx <= options.size / 4.0))
    throw fail("clickNoisePx", "must be in [0, size/4] pixels (got " + std::to_string(options.clickNoisePx) + ")");
  if (!(std::isfinite(options.k1) && std::isfinite(options.k2) && std::abs(options.k1) <= 1 && std::abs(options.k2) <= 1))
    throw fail("k1, k2", "must be in [-1, 1] (got " + std::to_string(options.k1) + ", " + std::to_string(options.k2) + ")");
  if (!color) throw fail("color", "no surface colour function given");
  if (restMesh.numFaces() == 0) throw fail(meshPath.empty() ? "mesh" : meshPath, "the mesh has no faces");

  SynthScene scene;
  scene.options = options;
  // What the photos show: the mesh, or its deformed copy (same faces, so `color` reads the undeformed place).
  if (options.deform.kind != DeformKind::None)
    scene.photographed = withPositions(restMesh, deformPositions(restMesh, options.deform));
  const Mesh& mesh = scene.photographed ? *scene.photographed : restMesh;

  // Bounding sphere: box centre, radius to the farthest vertex used by a face.
  std::vector<char> used(mesh.numVertices(), 0);
  for (int f = 0; f < mesh.numFaces(); ++f)
    for (int v : mesh.faceVertices(f)) used[v] = 1;
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (int v = 0; v < mesh.numVertices(); ++v)
    if (used[v]) {
      lo = lo.cwiseMin(mesh.position(v));
      hi = hi.cwiseMax(mesh.position(v));
    }
  const Vec3 centre = 0.5 * (lo + hi);
  double radius = 0;
  for (int v = 0; v < mesh.numVertices(); ++v)
    if (used[v]) radius = std::max(radius, (mesh.position(v) - centre).norm());
  if (!(radius > 0) || !std::isfinite(radius))
    throw fail(meshPath.empty() ? "mesh" : meshPath, "the mesh has no extent (all vertices coincide)");

  // The sphere fits the field of view with a 10% margin.
  const double kMargin = 1.1;
  const double distance = radius * kMargin / std::sin(options.fovYDeg * M_PI / 360.0);
  const Vec3 up(0, 1, 0);
  const int size = options.size;
  const double depthTolerance = 5e-3 * radius;
  const int border = static_cast<int>(std::ceil(options.borderPx));
  const double borderSq = options.borderPx * options.borderPx;

  const std::vector<Vec3> normals = vertexNormals(mesh);
  // Sampled on the surface made whole: a mesh split at UV seams (a glTF) has a vertex on each side of a seam at one
  // place, and sampling it split could click one place twice. Each is named by the file's first vertex there.
  const WeldedMesh whole = weldIdenticalPositions(restMesh);
  scene.featureVertices = farthestPointSamples(whole.mesh ? *whole.mesh : restMesh, options.features, options.seed);
  if (whole.mesh)
    for (int& v : scene.featureVertices) v = whole.mesh->vertexOrigin[v];
  std::vector<std::vector<PhotoPoint>> seen(scene.featureVertices.size());

  const std::vector<Vec3> dirs = viewDirections(options.views, options.seed);
  // The supersampled image is rendered in bands of whole photo rows, each with a camera shifted by
  // the band's first row, so memory stays bounded for large photos (about 16M samples per band).
  const int fineSize = 2 * size;
  const int bandRows = std::max(2, std::min(fineSize, (1 << 24) / fineSize) / 2 * 2);
  const bool distorted = options.k1 != 0 || options.k2 != 0;
  for (int k = 0; k < options.views; ++k) {
    const Vec3 eye = centre + distance * dirs[k];
    const Camera camera = Camera::lookAt(eye, centre, up, options.fovYDeg, size, size);
    const PhotoCamera lens{camera, options.k1, options.k2};
    // The pinhole camera the view is rendered through: the photo camera itself, or with distortion the same view
    // on a canvas that holds every photo pixel's undistorted place (its border's, the distortion being radial
    // and monotonic), with a margin of 2 pixels for the bilinear resampling.
    Camera render = camera;
    if (distorted) {
      // Monotonic out to the photo's corners: d/dr [r (1 + k1 r^2 + k2 r^4)] > 0 wherever an undistorted corner
      // can lie.
      const double cornerR = std::hypot(std::max(camera.cx, size - camera.cx) / camera.fx,
                                        std::max(camera.cy, size - camera.cy) / camera.fy);
      double r = 0;
      for (; r * (1 + options.k1 * r * r + options.k2 * r * r * r * r) < cornerR; r += 1e-3)
        if (1 + 3 * options.k1 * r * r + 5 * options.k2 * r * r * r * r <= 0 || r > 4)
          throw fail("k1, k2", "the distortion (" + std::to_string(options.k1) + ", " + std::to_string(options.k2) +
                                   ") folds the photo before its corners: choose smaller terms");
      Vec2 lo = Vec2::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
      for (int i = 0; i <= size; ++i)
        for (const Vec2& edge : {Vec2(i, 0), Vec2(i, size), Vec2(0, i), Vec2(size, i)}) {
          const Vec2 n((edge.x() - camera.cx) / camera.fx, (edge.y() - camera.cy) / camera.fy);
          const Vec2 u = undistortNormalised(n, options.k1, options.k2);
          const Vec2 pixel(camera.fx * u.x() + camera.cx, camera.fy * u.y() + camera.cy);
          lo = lo.cwiseMin(pixel), hi = hi.cwiseMax(pixel);
        }
      const int x0 = static_cast<int>(std::floor(lo.x())) - 2, y0 = static_cast<int>(std::floor(lo.y())) - 2;
      render.width = static_cast<int>(std::ceil(hi.x())) + 2 - x0;
      render.height = static_cast<int>(std::ceil(hi.y())) + 2 - y0;
      render.cx -= x0, render.cy -= y0;
    }

    // Candidate features: in front, facing the camera, far enough from the image border.
    struct Candidate {
      size_t feature;
      Vec2 pixel;
      double depth;
      int fineX, fineY;  // the supersample holding the point
      int face = -1;     // what the z-buffer shows there
      float zbuffer = 0;
    };
    std::vector<Candidate> candidates;
    for (size_t i = 0; i < scene.featureVertices.size(); ++i) {
      const int v = scene.featureVertices[i];
      const Vec3 p = mesh.position(v);
      Vec2 pixel, rendered;
      double depth = 0;
      if (!lens.project(p, pixel, &depth) || !render.project(p, rendered)) continue;  // behind the camera
      if (normals[v].dot((eye - p).normalized()) < options.minFacing) continue;
      const double x = pixel.x(), y = pixel.y();
      if (!(x >= options.borderPx && y >= options.borderPx && x <= size - options.borderPx &&
            y <= size - options.borderPx && x < size && y < size))
        continue;
      candidates.push_back(
          Candidate{i, pixel, depth,
                    std::clamp(static_cast<int>(std::floor(2 * rendered.x())), 0, 2 * render.width - 1),
                    std::clamp(static_cast<int>(std::floor(2 * rendered.y())), 0, 2 * render.height - 1)});
    }

    const double exposure = options.exposures.empty() ? 1.0 : options.exposures[k % options.exposures.size()];
    TM_CHECK(exposure > 0 && std::isfinite(exposure), "synth: exposure " + std::to_string(exposure) + " must be > 0");
    cv::Mat photo(render.height, render.width, CV_8UC4, cv::Scalar(0, 0, 0, 0));
    const int fineRows = 2 * render.height;
    for (int band = 0; band < fineRows; band += bandRows) {
      const int rows = std::min(bandRows, fineRows - band);
      Camera fine = render;  // 2x2 supersampling camera: same view, twice the intrinsics
      fine.width = 2 * render.width;
      fine.height = rows;
      fine.fx *= 2;
      fine.fy *= 2;
      fine.cx *= 2;
      fine.cy = 2 * render.cy - band;
      const RasterBuffers raster = rasterize(mesh, fine);
      for (int y = band / 2; y < (band + rows) / 2; ++y) {
        auto* row = photo.ptr<cv::Vec4b>(y);
        for (int x = 0; x < render.width; ++x) {
          Vec3 sum = Vec3::Zero();
          int covered = 0;
          for (int sy = 0; sy < 2; ++sy)
            for (int sx = 0; sx < 2; ++sx) {
              const int i = raster.index(2 * x + sx, 2 * y + sy - band);
              const int f = raster.face[i];
              if (f < 0) continue;
              const Vec3f c = color(f, raster.bary[i].cast<double>());
              sum += c.cast<double>().cwiseMax(0.0).cwiseMin(1.0);
              ++covered;
            }
          if (covered == 0) continue;
          Vec3 rgb = sum / covered;
          if (exposure != 1.0)
            for (int ch = 0; ch < 3; ++ch) rgb[ch] = linearToSrgb(std::min(1.0, exposure * srgbToLinear(rgb[ch])));
          row[x] =
              cv::Vec4b(cv::saturate_cast<uchar>(rgb.x() * 255.0), cv::saturate_cast<uchar>(rgb.y() * 255.0),
                        cv::saturate_cast<uchar>(rgb.z() * 255.0), cv::saturate_cast<uchar>(covered * 255.0 / 4.0));
        }
      }
      for (Candidate& c : candidates)
        if (c.fineY >= band && c.fineY < band + rows) {
          const int i = raster.index(c.fineX, c.fineY - band);
          c.face = raster.face[i];
          c.zbuffer = raster.depth[i];
        }
    }

    if (distorted) {  // each photo pixel from its undistorted place on the pinhole canvas
      cv::Mat mapX(size, size, CV_32F), mapY(size, size, CV_32F);
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
          const Vec2 n((x + 0.5 - camera.cx) / camera.fx, (y + 0.5 - camera.cy) / camera.fy);
          const Vec2 u = undistortNormalised(n, options.k1, options.k2);
          mapX.at<float>(y, x) = static_cast<float>(render.fx * u.x() + render.cx - 0.5);
          mapY.at<float>(y, x) = static_cast<float>(render.fy * u.y() + render.cy - 0.5);
        }
      cv::Mat premultiplied;
      photo.convertTo(premultiplied, CV_32FC4, 1.0 / 255);
      premultiplied.forEach<cv::Vec4f>([](cv::Vec4f& p, const int*) { p[0] *= p[3], p[1] *= p[3], p[2] *= p[3]; });
      cv::Mat sampled;
      cv::remap(premultiplied, sampled, mapX, mapY, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0, 0, 0, 0));
      sampled.forEach<cv::Vec4f>([](cv::Vec4f& p, const int*) {
        if (p[3] > 1e-6f) p[0] /= p[3], p[1] /= p[3], p[2] /= p[3];
      });
      sampled.convertTo(photo, CV_8UC4, 255.0);
    }

    for (const Candidate& c : candidates) {
      const int v = scene.featureVertices[c.feature];
      const double x = c.pixel.x(), y = c.pixel.y();
      // Every pixel whose centre lies within borderPx (and the pixel holding the point) is foreground.
      const int px = static_cast<int>(std::floor(x)), py = static_cast<int>(std::floor(y));
      bool inside = true;
      for (int r = py - border - 1; r <= py + border + 1 && inside; ++r)
        for (int col = px - border - 1; col <= px + border + 1 && inside; ++col) {
          const double dx = col + 0.5 - x, dy = r + 0.5 - y;
          if (!(r == py && col == px) && dx * dx + dy * dy > borderSq) continue;
          if (r < 0 || col < 0 || r >= size || col >= size || photo.at<cv::Vec4b>(r, col)[3] == 0) inside = false;
        }
      if (!inside || c.face < 0) continue;
      // Not occluded: the surface seen at the point (supersampled z-buffer) is one of the vertex's
      // faces or lies at the vertex's depth.
      const auto corners = mesh.faceVertices(c.face);
      const bool ownFace = corners[0] == v || corners[1] == v || corners[2] == v;
      if (!ownFace && c.depth > c.zbuffer + depthTolerance) continue;
      seen[c.feature].push_back(PhotoPoint{k, x, y});
    }

    scene.photos.push_back(photo);
    scene.cameras.push_back(camera);
    if (progress) progress(static_cast<double>(k + 1) / options.views);
  }

  // Click noise: a seeded Gaussian (Box-Muller on the library-independent generator), in feature order.
  if (options.clickNoisePx > 0) {
    std::mt19937 noise(options.seed ^ 0xC11C4A11u);
    auto gaussian = [&] {
      const double u1 = (noise() + 0.5) * (1.0 / 4294967296.0), u2 = unit(noise);
      return std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2);
    };
    for (auto& positions : seen)
      for (PhotoPoint& at : positions) {
        at.x = std::clamp(at.x + options.clickNoisePx * gaussian(), 0.0, double(size));
        at.y = std::clamp(at.y + options.clickNoisePx * gaussian(), 0.0, double(size));
      }
  }

  Project& project = scene.project;
  std::error_code ec;
  const fs::path absolute = meshPath.empty() ? fs::path() : fs::absolute(meshPath, ec);
  project.mesh = ec ? meshPath : absolute.lexically_normal().string();
  for (int k = 0; k < options.views; ++k) project.photos.push_back(PhotoRef{photoName(k), ""});
  for (size_t i = 0; i < scene.featureVertices.size(); ++i)
    if (!seen[i].empty()) project.points.push_back(FeaturePoint{scene.featureVertices[i], seen[i]});
  return scene;
}

void writeSynthScene(const SynthScene& scene, const std::string& dir) {
  TM_CHECK(scene.photos.size() == scene.cameras.size() && scene.photos.size() == scene.project.photos.size(),
           located(dir, "synthetic scene is inconsistent: " + std::to_string(scene.photos.size()) + " photos, " +
                            std::to_string(scene.cameras.size()) + " cameras, " +
                            std::to_string(scene.project.photos.size()) + " project photos"));
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error(located(dir, "cannot create the folder: " + ec.message()));
  const fs::path folder = fs::absolute(dir, ec).lexically_normal();
  if (ec) throw Error(located(dir, "cannot resolve the folder: " + ec.message()));

  Project project = scene.project;
  nlohmann::json views = nlohmann::json::array();
  for (size_t k = 0; k < scene.photos.size(); ++k) {
    const cv::Mat& photo = scene.photos[k];
    const std::string name = photoName(static_cast<int>(k));
    const std::string path = (folder / name).string();
    TM_CHECK(photo.type() == CV_8UC4 && !photo.empty(),
             located(path, "photo " + std::to_string(k) + " is not an 8-bit RGBA image"));
    writePng(path, photo, kPngFast, false);
    project.photos[k] = PhotoRef{path, ""};

    const Camera& c = scene.cameras[k];
    nlohmann::json R = nlohmann::json::array();
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 3; ++col) R.push_back(c.R(r, col));
    views.push_back({{"photo", name},
                     {"width", c.width},
                     {"height", c.height},
                     {"fx", c.fx},
                     {"fy", c.fy},
                     {"cx", c.cx},
                     {"cy", c.cy},
                     {"k1", scene.options.k1},
                     {"k2", scene.options.k2},
                     {"R", R},
                     {"t", vecJson(c.t)},
                     {"eye", vecJson(c.center())}});
  }
  saveProject(project, (folder / "project.json").string());

  const SynthOptions& o = scene.options;
  nlohmann::json cameras = {{"format", "texturemontage-synth-cameras"},
                            {"version", 1},
                            {"convention",
                             "OpenCV: p_cam = R p_world + t; (x, y) = (x/z, y/z) scaled by 1 + k1 r^2 + k2 r^4 "
                             "(r^2 = x^2 + y^2); pixel = (fx x + cx, fy y + cy), origin at the top-left image corner, "
                             "pixel centres at +0.5"},
                            {"mesh", project.mesh},
                            {"views", views},
                            {"features", scene.featureVertices},
                            {"options",
                             {{"views", o.views},
                              {"features", o.features},
                              {"seed", o.seed},
                              {"size", o.size},
                              {"fov_y_deg", o.fovYDeg},
                              {"min_facing", o.minFacing},
                              {"border_px", o.borderPx},
                              {"click_noise_px", o.clickNoisePx},
                              {"k1", o.k1},
                              {"k2", o.k2},
                              {"supersampling", 2}}}};
  if (scene.photographed) {
    saveMeshObj(*scene.photographed, (folder / "deformed.obj").string());
    cameras["deformation"] = {
        {"kind", kDeformKindNames[size_t(o.deform.kind)]}, {"amount", o.deform.amount}, {"mesh", "deformed.obj"}};
  }
  writeFileAtomic((folder / "cameras.json").string(), cameras.dump(2) + "\n");
}

}  // namespace montage

namespace montage {

std::vector<PhotoCamera> readSynthCameras(const std::string& path) {
  std::ifstream in(path);
  TM_CHECK(in, located(path, "cannot open the cameras file"));
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw Error(located(path, std::string("invalid JSON: ") + e.what()));
  }
  TM_CHECK(j.is_object() && j.value("format", "") == "texturemontage-synth-cameras",
           located(path, "format: not a TextureMontage synthetic cameras file"));
  TM_CHECK(j.contains("views") && j["views"].is_array(), located(path, "views: missing or not an array"));
  std::vector<PhotoCamera> cameras;
  for (size_t k = 0; k < j["views"].size(); ++k) {
    const nlohmann::json& v = j["views"][k];
    const std::string where = "views[" + std::to_string(k) + "]";
    auto number = [&](const char* field) {
      TM_CHECK(v.contains(field) && v[field].is_number(),
               located(path, where + "." + field + ": missing or not a number"));
      return v[field].get<double>();
    };
    auto numbers = [&](const char* field, size_t n) {
      TM_CHECK(v.contains(field) && v[field].is_array() && v[field].size() == n,
               located(path, where + "." + field + ": must be an array of " + std::to_string(n) + " numbers"));
      std::vector<double> out;
      for (const auto& x : v[field]) {
        TM_CHECK(x.is_number(), located(path, where + "." + field + ": must hold numbers"));
        out.push_back(x.get<double>());
      }
      return out;
    };
    PhotoCamera c;
    c.pinhole.width = static_cast<int>(number("width"));
    c.pinhole.height = static_cast<int>(number("height"));
    TM_CHECK(c.pinhole.width > 0 && c.pinhole.height > 0, located(path, where + ": width and height must be positive"));
    c.pinhole.fx = number("fx");
    c.pinhole.fy = number("fy");
    c.pinhole.cx = number("cx");
    c.pinhole.cy = number("cy");
    const std::vector<double> R = numbers("R", 9), t = numbers("t", 3);
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 3; ++col) c.pinhole.R(r, col) = R[3 * r + col];
    c.pinhole.t = Vec3(t[0], t[1], t[2]);
    for (const char* field : {"k1", "k2"})  // optional: scenes written before distortion have none
      if (v.contains(field)) (field[1] == '1' ? c.k1 : c.k2) = number(field);
    cameras.push_back(c);
  }
  return cameras;
}

std::string readSynthDeformedMesh(const std::string& path) {
  std::ifstream in(path);
  TM_CHECK(in, located(path, "cannot open the cameras file"));
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw Error(located(path, std::string("invalid JSON: ") + e.what()));
  }
  if (!j.is_object() || !j.contains("deformation")) return {};
  const nlohmann::json& d = j["deformation"];
  TM_CHECK(d.is_object() && d.contains("mesh") && d["mesh"].is_string() && !d["mesh"].get<std::string>().empty(),
           located(path, "deformation.mesh: missing or not a file name"));
  return (fs::path(path).parent_path() / d["mesh"].get<std::string>()).lexically_normal().string();
}

}  // namespace montage
