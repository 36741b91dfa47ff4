#include "mapping/photometric.h"

#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <numeric>
#include <opencv2/imgproc.hpp>

#include "base/job.h"
#include "base/util.h"
#include "geometry/mesh.h"
#include "geometry/raster.h"
#include "image/photo.h"

namespace montage {

namespace {

constexpr int kParams = 7;  // rotation, translation (camera coordinates), focal length
using MatP = Eigen::Matrix<double, kParams, kParams>;
using VecP = Eigen::Matrix<double, kParams, 1>;
using RowP = Eigen::Matrix<double, 1, kParams>;
using JacP = Eigen::Matrix<double, 2, kParams>;

struct Sample {
  Vec3 p, n;
  int fold = 0;  // spatial half (the two-photo acceptance test)
};

// `count` points spread over the surface by area: each face takes its share (the remainders carried from face to
// face), placed on a Kronecker sequence folded into the triangle. Each point's fold is its cell's parity in a grid of
// a tenth of the bounding box.
std::vector<Sample> surfaceSamples(const Mesh& mesh, int count) {
  const int nf = mesh.numFaces();
  double total = 0;
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (int f = 0; f < nf; ++f) total += mesh.faceArea(f);
  for (int v = 0; v < mesh.numVertices(); ++v) lo = lo.cwiseMin(mesh.position(v)), hi = hi.cwiseMax(mesh.position(v));
  const double cell = std::max((hi - lo).maxCoeff() / 10, 1e-12);
  std::vector<Sample> out;
  if (total <= 0) return out;
  out.reserve(count + 16);
  double carry = 0;
  for (int f = 0; f < nf; ++f) {
    carry += mesh.faceArea(f) / total * count;
    const int n = static_cast<int>(carry);
    carry -= n;
    if (n == 0) continue;
    const auto c = mesh.facePositions(f);
    Vec3 normal = (c[1] - c[0]).cross(c[2] - c[0]);
    if (normal.norm() <= 0) continue;
    normal.normalize();
    for (int k = 0; k < n; ++k) {
      double u = std::fmod(0.5 + k * 0.7548776662466927, 1.0), v = std::fmod(0.5 + k * 0.5698402909980532, 1.0);
      if (u + v > 1) u = 1 - u, v = 1 - v;
      Sample s;
      s.p = c[0] + u * (c[1] - c[0]) + v * (c[2] - c[0]);
      s.n = normal;
      const Eigen::Vector3i g = ((s.p - lo) / cell).array().floor().cast<int>();
      s.fold = (g.x() + g.y() + g.z()) & 1;
      out.push_back(s);
    }
  }
  return out;
}

// A photo's pixels as floats in [0, 1] at its stored resolution, blurred by `sigma` file pixels.
cv::Mat blurredPhoto(const Photo& photo, double sigma) {
  const double unit = photo.rgb.depth() == CV_8U ? 1.0 / 255 : photo.rgb.depth() == CV_16U ? 1.0 / 65535 : 1.0;
  cv::Mat f;
  photo.rgb.convertTo(f, CV_32FC3, unit);
  const double s = sigma * photo.scale;
  if (s > 0.3) cv::GaussianBlur(f, f, cv::Size(0, 0), s, s, cv::BORDER_REPLICATE);
  return f;
}

bool clipped(const Vec3f& c) {
  return c.maxCoeff() > 0.98f || c.minCoeff() < 0.02f;
}

// Which samples a photo sees well through `camera`: in front, facing it within minCosine, not hidden (z-buffer),
// marginPx away from a depth edge, from the photo's border and from its silhouette. Also the pixels the mesh covers.
std::vector<char> visibility(const Mesh& mesh, const std::vector<Sample>& samples, const Photo& photo,
                             const PhotoCamera& camera, const PhotometricOptions& o, int& covered) {
  RasterOptions ro;
  ro.cullBackFaces = true;
  ro.barycentrics = false;
  const Camera& pin = camera.pinhole;
  const RasterBuffers rb = rasterize(mesh, pin, ro);
  covered = 0;
  for (int f : rb.face) covered += f >= 0;
  const Vec3 eye = pin.center();
  const double m = o.marginPx;
  std::vector<char> seen(samples.size(), 0);
  tbb::parallel_for(size_t(0), samples.size(), [&](size_t i) {
    const Sample& s = samples[i];
    const Vec3 c = pin.toCamera(s.p);
    if (c.z() <= 1e-12) return;
    if (s.n.dot((eye - s.p).normalized()) < o.minCosine) return;
    const Vec2 u(pin.fx * c.x() / c.z() + pin.cx, pin.fy * c.y() / c.z() + pin.cy);
    const double tol = 0.03 * c.z();
    for (const Vec2& d : {Vec2(0, 0), Vec2(m, 0), Vec2(-m, 0), Vec2(0, m), Vec2(0, -m)}) {
      const Vec2 q = u + d;
      if (q.x() < 0 || q.y() < 0 || q.x() >= rb.width || q.y() >= rb.height) return;
      const float z = rb.depth[rb.index(static_cast<int>(q.x()), static_cast<int>(q.y()))];
      if (!std::isfinite(z) || z < c.z() - tol || (d.norm() > 0 && z > c.z() + tol)) return;
    }
    Vec2 q;
    if (!camera.project(s.p, q) || q.x() < m || q.y() < m || q.x() > photo.width - m || q.y() > photo.height - m)
      return;
    if (photo.hasBackground)
      for (const Vec2& d : {Vec2(0, 0), Vec2(m, 0), Vec2(-m, 0), Vec2(0, m), Vec2(0, -m)})
        if (photo.alphaAt(q.x() + d.x(), q.y() + d.y()) < 0.99f) return;
    seen[i] = 1;
  });
  return seen;
}

// d(pixel)/d(camera coordinates) of the distorted projection at camera point c.
Eigen::Matrix<double, 2, 3> projectionJacobian(const PhotoCamera& camera, const Vec3& c) {
  const Camera& pin = camera.pinhole;
  const double iz = 1 / c.z(), x = c.x() * iz, y = c.y() * iz, r2 = x * x + y * y;
  const double d = 1 + camera.k1 * r2 + camera.k2 * r2 * r2, dd = 2 * camera.k1 + 4 * camera.k2 * r2;
  Eigen::Matrix2d dq;  // d(pixel)/d(x, y)
  dq << pin.fx * (d + x * dd * x), pin.fx * x * dd * y, pin.fy * y * dd * x, pin.fy * (d + y * dd * y);
  Eigen::Matrix<double, 2, 3> dn;  // d(x, y)/d(c)
  dn << iz, 0, -x * iz, 0, iz, -y * iz;
  return dq * dn;
}

Eigen::Matrix3d skew(const Vec3& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

// d(pixel)/d(step) at camera point c.
JacP stepJacobian(const PhotoCamera& camera, const Vec3& c) {
  const Eigen::Matrix<double, 2, 3> P = projectionJacobian(camera, c);
  JacP J;
  J.leftCols<3>() = -P * skew(c);
  J.middleCols<3>(3) = P;
  const double x = c.x() / c.z(), y = c.y() / c.z(), r2 = x * x + y * y;
  const double d = 1 + camera.k1 * r2 + camera.k2 * r2 * r2;
  J.col(6) = Vec2(x * d, y * d);
  return J;
}

// A step: a rotation w and a translation d in camera coordinates (c' = exp(w) c + d), and the focal length's change.
PhotoCamera moved(const PhotoCamera& camera, const VecP& step) {
  PhotoCamera out = camera;
  const Vec3 w = step.head<3>();
  const double angle = w.norm();
  const Eigen::Matrix3d E =
      angle > 0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
  out.pinhole.R = E * camera.pinhole.R;
  out.pinhole.t = E * camera.pinhole.t + step.segment<3>(3);
  out.pinhole.fx = out.pinhole.fy = camera.pinhole.fx + step[6];
  return out;
}

struct Clicks {
  std::vector<Vec3> points;
  std::vector<Vec2> pixels;
  double weight = 0;  // 1 / sigma^2
};

// The photos taking part, their cameras and colour models, and the samples: one refinement's state.
struct Problem {
  const Mesh* mesh = nullptr;
  const std::vector<Sample>* samples = nullptr;
  const PhotometricOptions* options = nullptr;
  std::vector<const Photo*> photos;
  std::vector<Clicks> clicks;
  std::vector<const SilhouetteDistance*> silhouettes;  // per photo: null without a background
  std::vector<std::vector<Vec3>> contours;             // per photo: the mesh's outer contour (per level)
  std::vector<PhotoCamera> cameras;
  std::vector<int> focalOf;  // per photo: its focal length's index, one for the photos that came with one camera's
                             // intrinsics (sharedIntrinsics), numbered from 0
  int focals = 0;
  std::vector<Vec3> gain, offset;
  // Per level, filled by prepare():
  std::vector<cv::Mat> images;  // the photos blurred by `blurred`, kept while the level stays
  double blurred = -1;
  std::vector<std::vector<char>> seen;
  std::vector<double> correlation;  // per photo: samples per independent blur cell (>= 1)

  // The active photos' images, visibility and correlation at `blur` through their cameras, and their contours when
  // the poses are to move (only the pose steps' cost reads them).
  void prepare(double blur, const std::vector<char>& active, bool poses) {
    const size_t n = photos.size();
    if (blur != blurred) images.assign(n, cv::Mat());
    blurred = blur;
    seen.assign(n, {});
    contours.assign(n, {});
    correlation.assign(n, 1.0);
    tbb::parallel_for(size_t(0), n, [&](size_t i) {
      if (!active[i]) return;
      if (images[i].empty()) images[i] = blurredPhoto(*photos[i], blur);
      int covered = 0;
      seen[i] = visibility(*mesh, *samples, *photos[i], cameras[i], *options, covered);
      if (poses && silhouettes[i]) contours[i] = outerContour(*mesh, cameras[i].pinhole, options->silhouetteSpacingPx);
      const double count = std::count(seen[i].begin(), seen[i].end(), 1);
      correlation[i] = std::max(1.0, count * 4 * blur * blur / std::max(covered, 1));
    });
  }

  bool observe(size_t i, const Vec3& p, Vec3f& colour) const {
    Vec2 q;
    if (!cameras[i].project(p, q)) return false;
    const double s = photos[i]->scale;
    colour = sampleBilinear3(images[i], q.x() * s, q.y() * s);
    return !clipped(colour);
  }

  // Sample k's colour as the active photos that see it show it (their gains and offsets applied): the mean, and how
  // many photos it is the mean of (0: none).
  int meanColour(size_t k, const std::vector<char>& active, Vec3& mean) const {
    Vec3 sum = Vec3::Zero();
    int count = 0;
    for (size_t i = 0; i < photos.size(); ++i) {
      Vec3f c;
      if (!active[i] || !seen[i][k] || !observe(i, (*samples)[k].p, c)) continue;
      sum += gain[i].cwiseProduct(c.cast<double>()) + offset[i];
      ++count;
    }
    if (count > 0) mean = sum / count;
    return count;
  }

  // The samples' colours: the mean of the active photos' corrected colours where two or more see them (NaN else).
  std::vector<Vec3> targets(const std::vector<char>& active, const std::vector<char>& use) const {
    const Vec3 none = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
    std::vector<Vec3> out(samples->size(), none);
    tbb::parallel_for(size_t(0), samples->size(), [&](size_t k) {
      Vec3 mean;
      if (use[k] && meanColour(k, active, mean) >= 2) out[k] = mean;
    });
    return out;
  }

  // Each active photo's gain and offset per channel against the targets (least squares), normalised to a mean gain
  // of one and a mean offset of zero over the active photos.
  void fitGains(const std::vector<char>& active, const std::vector<Vec3>& target) {
    for (size_t i = 0; i < photos.size(); ++i) {
      if (!active[i]) continue;
      Eigen::Matrix<double, 3, 5> acc = Eigen::Matrix<double, 3, 5>::Zero();  // n, sx, sy, sxx, sxy per channel
      for (size_t k = 0; k < samples->size(); ++k) {
        Vec3f c;
        if (!seen[i][k] || std::isnan(target[k].x()) || !observe(i, (*samples)[k].p, c)) continue;
        for (int ch = 0; ch < 3; ++ch) {
          const double x = c[ch], y = target[k][ch];
          acc.row(ch) += Eigen::Matrix<double, 1, 5>(1, x, y, x * x, x * y);
        }
      }
      for (int ch = 0; ch < 3; ++ch) {
        const double n = acc(ch, 0);
        if (n < 10) continue;
        const double mx = acc(ch, 1) / n, my = acc(ch, 2) / n, vx = acc(ch, 3) / n - mx * mx,
                     cxy = acc(ch, 4) / n - mx * my;
        if (vx < 1e-8) continue;
        gain[i][ch] = std::clamp(cxy / vx, 0.25, 4.0);
        offset[i][ch] = my - gain[i][ch] * mx;
      }
    }
    Vec3 meanGain = Vec3::Zero(), meanOffset = Vec3::Zero();
    int n = 0;
    for (size_t i = 0; i < photos.size(); ++i)
      if (active[i]) meanGain += gain[i], ++n;
    for (size_t i = 0; i < photos.size(); ++i)
      if (active[i]) gain[i] = gain[i].cwiseQuotient(meanGain / n), offset[i] = offset[i].cwiseQuotient(meanGain / n);
    for (size_t i = 0; i < photos.size(); ++i)
      if (active[i]) meanOffset += offset[i];
    for (size_t i = 0; i < photos.size(); ++i)
      if (active[i]) offset[i] -= meanOffset / n;
  }

  // The robust scale of the colour residuals (1.4826 x their median absolute value).
  double residualScale(const std::vector<char>& active, const std::vector<Vec3>& target) const {
    std::vector<double> r;
    for (size_t i = 0; i < photos.size(); ++i)
      for (size_t k = 0; active[i] && k < samples->size(); k += 3) {
        Vec3f c;
        if (!seen[i][k] || std::isnan(target[k].x()) || !observe(i, (*samples)[k].p, c)) continue;
        const Vec3 e = gain[i].cwiseProduct(c.cast<double>()) + offset[i] - target[k];
        for (int ch = 0; ch < 3; ++ch) r.push_back(std::abs(e[ch]));
      }
    if (r.size() < 30) return 0;
    std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
    return std::max(1.4826 * r[r.size() / 2], 1e-4);
  }

  // Photo i's cost (Huber on the colour residuals over `scale`, divided by the correlation; the clicks' squared
  // residuals over their noise) with `camera`, and optionally its Gauss-Newton system.
  double cost(size_t i, const PhotoCamera& camera, const std::vector<Vec3>& target, double scale, MatP* H,
              VecP* b) const {
    const double k = options->huber, wPhoto = 1 / correlation[i];
    const double s = photos[i]->scale;
    double total = 0;
    if (H) H->setZero(), b->setZero();
    for (size_t j = 0; j < samples->size(); ++j) {
      if (!seen[i][j] || std::isnan(target[j].x())) continue;
      const Vec3& p = (*samples)[j].p;
      Vec2 q;
      if (!camera.project(p, q)) continue;
      const Vec3f c = sampleBilinear3(images[i], q.x() * s, q.y() * s);
      if (clipped(c)) continue;
      const Vec3 e = (gain[i].cwiseProduct(c.cast<double>()) + offset[i] - target[j]) / scale;
      JacP dq;
      if (H) dq = stepJacobian(camera, camera.pinhole.toCamera(p));
      Vec3f gx, gy;
      if (H) sampleGradient3(images[i], q.x() * s, q.y() * s, gx, gy);
      for (int ch = 0; ch < 3; ++ch) {
        const double a = std::abs(e[ch]);
        total += wPhoto * (a <= k ? 0.5 * a * a : k * a - 0.5 * k * k);
        if (!H) continue;
        const double w = wPhoto * (a <= k ? 1 : k / a);
        const RowP J = gain[i][ch] / scale * s * (Eigen::RowVector2d(gx[ch], gy[ch]) * dq);
        *H += w * J.transpose() * J;
        *b += w * J.transpose() * e[ch];
      }
    }
    // The silhouette: the mesh's contour on the edge of the photo's foreground (Huber), as refineOnSilhouette has it.
    if (silhouettes[i]) {
      const double ws = 1 / (options->silhouetteSigmaPx * options->silhouetteSigmaPx), ks = options->silhouetteHuberPx;
      for (const Vec3& x : contours[i]) {
        Vec2 q;
        if (!camera.project(x, q)) continue;
        const double d = silhouettes[i]->at(q), a = std::abs(d);
        total += ws * (a <= ks ? 0.5 * a * a : ks * a - 0.5 * ks * ks);
        if (!H) continue;
        const double w = ws * (a <= ks ? 1 : ks / a);
        const RowP J = silhouettes[i]->gradient(q).transpose() * stepJacobian(camera, camera.pinhole.toCamera(x));
        *H += w * J.transpose() * J;
        *b += w * J.transpose() * d;
      }
    }
    const Clicks& cl = clicks[i];
    for (size_t j = 0; j < cl.points.size(); ++j) {
      Vec2 q;
      if (!camera.project(cl.points[j], q)) return std::numeric_limits<double>::infinity();
      const Vec2 e = q - cl.pixels[j];
      total += 0.5 * cl.weight * e.squaredNorm();
      if (!H) continue;
      const JacP J = stepJacobian(camera, camera.pinhole.toCamera(cl.points[j]));
      *H += cl.weight * J.transpose() * J;
      *b += cl.weight * J.transpose() * e;
    }
    return total;
  }

  // Levenberg-Marquardt on the active photos' poses and focal lengths together, the targets fixed: a pose per photo
  // and a focal length per focalOf, so that the photos of one camera keep sharing theirs.
  void stepJoint(const std::vector<char>& active, const std::vector<Vec3>& target, double scale) {
    const size_t n = photos.size();
    std::vector<std::array<int, kParams>> at(n);  // per active photo: each parameter's index in the joint vector
    std::vector<int> focalAt(focals, -1);
    int dim = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!active[i]) continue;
      for (int k = 0; k < 6; ++k) at[i][k] = dim++;
      int& f = focalAt[focalOf[i]];
      if (f < 0) f = dim++;
      at[i][6] = f;
    }
    // The cost of `cams` over the active photos, and optionally its joint Gauss-Newton system.
    const auto evaluate = [&](const std::vector<PhotoCamera>& cams, Eigen::MatrixXd* H, Eigen::VectorXd* b) {
      std::vector<double> part(n, 0);
      std::vector<MatP> Hs(n);
      std::vector<VecP> bs(n);
      tbb::parallel_for(size_t(0), n, [&](size_t i) {
        if (active[i]) part[i] = cost(i, cams[i], target, scale, H ? &Hs[i] : nullptr, H ? &bs[i] : nullptr);
      });
      if (H) {
        H->setZero(dim, dim);
        b->setZero(dim);
        for (size_t i = 0; i < n; ++i)
          for (int r = 0; active[i] && r < kParams; ++r) {
            (*b)[at[i][r]] += bs[i][r];
            for (int c = 0; c < kParams; ++c) (*H)(at[i][r], at[i][c]) += Hs[i](r, c);
          }
      }
      return std::accumulate(part.begin(), part.end(), 0.0);
    };
    const auto apply = [&](const Eigen::VectorXd& step) {
      std::vector<PhotoCamera> out = cameras;
      for (size_t i = 0; i < n; ++i) {
        if (!active[i]) continue;
        VecP s;
        for (int k = 0; k < kParams; ++k) s[k] = step[at[i][k]];
        out[i] = moved(cameras[i], s);
      }
      return out;
    };
    double lambda = 1e-4;
    Eigen::MatrixXd H;
    Eigen::VectorXd b;
    double current = evaluate(cameras, &H, &b);
    for (int it = 0; it < options->iterations; ++it) {
      bool improved = false;
      for (int tries = 0; tries < 6 && !improved; ++tries) {
        Eigen::MatrixXd A = H;
        A.diagonal() += lambda * H.diagonal().cwiseMax(1e-9);
        const Eigen::VectorXd step = A.ldlt().solve(-b);
        if (!step.allFinite()) return;
        const std::vector<PhotoCamera> next = apply(step);
        bool valid = true;
        for (size_t i = 0; i < n; ++i) valid = valid && (!active[i] || next[i].focal() > 0);
        const double c = valid ? evaluate(next, nullptr, nullptr) : std::numeric_limits<double>::infinity();
        if (c < current) {
          cameras = next;
          lambda = std::max(lambda / 4, 1e-7);
          improved = true;
          if (current - c < 1e-7 * current) return;  // converged
          current = evaluate(cameras, &H, &b);
        } else {
          lambda *= 8;
        }
      }
      if (!improved) return;
    }
  }

  // Coarse to fine: per level, the visibility, then rounds of targets, gains and (when `poses`) pose steps.
  void refine(const std::vector<char>& active, const std::vector<char>& use, bool poses, const JobControl* job,
              const std::vector<double>& blurs) {
    for (double blur : blurs) {
      prepare(blur, active, poses);
      for (int round = 0; round < options->rounds; ++round) {
        if (job) job->checkCancel();
        std::vector<Vec3> target = targets(active, use);
        fitGains(active, target);
        if (!poses) {
          if (round == 1) break;
          continue;
        }
        target = targets(active, use);
        const double scale = residualScale(active, target);
        if (scale <= 0) return;
        stepJoint(active, target, scale);
      }
    }
  }

  // How well the active photos predict photo h at the samples in `use` (h is not among them): mean absolute
  // difference per channel between h's colour, under its own gain and offset fitted to the prediction, and the
  // prediction. Negative when too few samples tell.
  double predictionError(size_t h, const std::vector<char>& active, const std::vector<char>& use) {
    std::vector<char> withH = active;
    withH[h] = 1;
    refine(withH, use, false, nullptr, {options->blurPx.back()});  // the colour models only, h's included
    const Vec3 g = gain[h], o = offset[h];
    double sum = 0;
    int n = 0;
    for (size_t k = 0; k < samples->size(); ++k) {
      if (!use[k] || !seen[h][k]) continue;
      Vec3 predicted;  // one predictor suffices for a held-out photo
      Vec3f c;
      if (meanColour(k, active, predicted) == 0 || !observe(h, (*samples)[k].p, c)) continue;
      sum += (g.cwiseProduct(c.cast<double>()) + o - predicted).cwiseAbs().sum() / 3;
      ++n;
    }
    return n >= options->minSharedSamples ? sum / n : -1;
  }
};

}  // namespace

PhotometricRefinement refineCamerasPhotometric(const Mesh& mesh, const std::vector<const Photo*>& photos,
                                               const std::vector<CameraFit*>& fits, const PhotometricOptions& o,
                                               const JobControl* job,
                                               const std::vector<const SilhouetteDistance*>& silhouettes) {
  const auto start = Clock::now();
  std::deque<SilhouetteDistance> ownSilhouettes;  // for photos with a background whose caller keeps none
  PhotometricRefinement result;
  TM_CHECK(photos.size() == fits.size(), "refineCamerasPhotometric: one photo per fit");
  const std::vector<Sample> samples = surfaceSamples(mesh, o.samples);
  Problem problem;
  problem.mesh = &mesh;
  problem.samples = &samples;
  problem.options = &o;
  std::vector<int> index;
  for (size_t i = 0; i < fits.size(); ++i) {
    const CameraFit& fit = *fits[i];
    if (!fit.fits || fit.subject || !photos[i] || photos[i]->rgb.empty()) continue;
    if (fit.camera.pinhole.width != photos[i]->width || fit.camera.pinhole.height != photos[i]->height) continue;
    index.push_back(static_cast<int>(i));
    problem.photos.push_back(photos[i]);
    problem.cameras.push_back(fit.camera);
    // A photo's silhouette: its cut-out's, or the one the camera stage found around the mesh's outline (given).
    const SilhouetteDistance* given = i < silhouettes.size() ? silhouettes[i] : nullptr;
    if (!given && photos[i]->hasBackground) given = &ownSilhouettes.emplace_back(*photos[i]);
    problem.silhouettes.push_back(given);
    Clicks c;
    for (size_t k = 0; k < fit.clicks.size(); ++k)
      if (fit.inlier[k])
        c.points.push_back(mesh.position(fit.clicks[k].vertex)), c.pixels.push_back(fit.clicks[k].pixel);
    const double sigma = std::max(fit.noisePx > 0 ? fit.noisePx : fit.rmsResidual / std::sqrt(2.0), o.minClickSigmaPx);
    c.weight = 1 / (sigma * sigma);
    problem.clicks.push_back(std::move(c));
  }
  const size_t n = index.size();
  // The photos that come with one camera's intrinsics (fitSharedIntrinsics gave them one focal length and lens, and no
  // silhouette refinement made them their own) keep sharing their focal length; every other photo has its own.
  for (size_t i = 0; i < n; ++i) {
    const PhotoCamera& c = problem.cameras[i];
    int f = -1;
    for (size_t j = 0; j < i && f < 0 && fits[index[i]]->sharedIntrinsics > 0; ++j) {
      const PhotoCamera& d = problem.cameras[j];
      if (fits[index[j]]->sharedIntrinsics > 0 && c.pinhole.width == d.pinhole.width &&
          c.pinhole.height == d.pinhole.height && c.pinhole.fx == d.pinhole.fx && c.pinhole.fy == d.pinhole.fy &&
          c.pinhole.cx == d.pinhole.cx && c.pinhole.cy == d.pinhole.cy && c.k1 == d.k1 && c.k2 == d.k2)
        f = problem.focalOf[j];
    }
    problem.focalOf.push_back(f >= 0 ? f : problem.focals++);
  }
  problem.gain.assign(n, Vec3::Ones());
  problem.offset.assign(n, Vec3::Zero());
  if (n < 2) {
    result.why = "fewer than two photos of the object itself";
    result.seconds = secondsSince(start);
    return result;
  }
  // Who shares samples with whom, at the finest level through the clicks' cameras.
  const std::vector<char> all(n, 1), everySample(samples.size(), 1);
  problem.prepare(o.blurPx.back(), all, false);
  std::vector<int> seenBy(samples.size(), 0), shared(n, 0);
  for (size_t i = 0; i < n; ++i)
    for (size_t k = 0; k < samples.size(); ++k) seenBy[k] += problem.seen[i][k];
  for (size_t i = 0; i < n; ++i)
    for (size_t k = 0; k < samples.size(); ++k) shared[i] += problem.seen[i][k] && seenBy[k] >= 2;
  std::vector<char> active(n, 0);
  for (size_t i = 0; i < n; ++i) active[i] = shared[i] >= o.minSharedSamples;
  const int taking = std::count(active.begin(), active.end(), 1);
  for (size_t i = 0; i < n; ++i)
    if (active[i]) result.photos.push_back(index[i]);
  for (size_t k = 0; k < samples.size(); ++k) result.samples += seenBy[k] >= 2;
  if (taking < 2) {
    result.why = "no two photos of the object see " + std::to_string(o.minSharedSamples) + " surface samples in common";
    result.seconds = secondsSince(start);
    return result;
  }
  result.tried = true;
  const std::vector<PhotoCamera> clicked = problem.cameras;
  const auto reset = [&] {
    problem.cameras = clicked;
    problem.gain.assign(n, Vec3::Ones());
    problem.offset.assign(n, Vec3::Zero());
  };
  // The acceptance test: refined on one spatial half of the samples, judged on the other, where each photo is
  // predicted from the others.
  double before = 0, after = 0;
  std::vector<char> train(samples.size()), test(samples.size());
  for (size_t k = 0; k < samples.size(); ++k) train[k] = samples[k].fold == 0, test[k] = samples[k].fold == 1;
  for (int refined = 0; refined < 2; ++refined) {
    reset();
    if (refined) problem.refine(active, train, true, job, o.blurPx);
    for (size_t h = 0; h < n; ++h) {
      if (!active[h]) continue;
      std::vector<char> others = active;
      others[h] = 0;
      const double e = problem.predictionError(h, others, test);
      if (e >= 0) (refined ? after : before) += e;
    }
  }
  result.heldOutBefore = before;
  result.heldOutAfter = after;
  if (before <= 0 || after <= 0) {
    result.why = "too few samples held out to judge a refinement";
    result.seconds = secondsSince(start);
    return result;
  }
  if (after > before * (1 - o.minImprovement)) {
    result.why = "the photos predict each other no better on held-out samples (error " + std::to_string(before) +
                 " -> " + std::to_string(after) + ")";
    result.seconds = secondsSince(start);
    return result;
  }
  // Kept: every photo refined on every sample, at the finest level, from the cameras the test refined on half of
  // them (the coarse levels' basin is behind them: a third of the time, docs/pipeline.md).
  problem.refine(active, everySample, true, job, {o.blurPx.back()});
  result.kept = true;
  result.why = "the photos predict each other better on held-out samples";
  for (size_t i = 0; i < n; ++i) {
    if (!active[i]) continue;
    std::vector<double> moved;
    for (size_t k = 0; k < samples.size(); k += 7) {
      Vec2 a, b;
      if (problem.seen[i][k] && clicked[i].project(samples[k].p, a) && problem.cameras[i].project(samples[k].p, b))
        moved.push_back((a - b).norm());
    }
    std::nth_element(moved.begin(), moved.begin() + moved.size() / 2, moved.end());
    result.shiftPx.push_back(moved.empty() ? 0 : moved[moved.size() / 2]);
    result.gain.push_back(problem.gain[i]);
    result.offset.push_back(problem.offset[i]);
    CameraFit& fit = *fits[index[i]];
    fit.camera = problem.cameras[i];
    fit.photometricShiftPx = std::max(result.shiftPx.back(), 1e-6);
    measureClicks(mesh, fit);
    fit.reason = describeFit(fit);
  }
  result.seconds = secondsSince(start);
  return result;
}

}  // namespace montage
