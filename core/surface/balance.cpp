#include "surface/balance.h"

#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <unordered_map>

#include "base/hash.h"
#include "base/job.h"
#include "base/util.h"
#include "geometry/mesh.h"
#include "image/color.h"
#include "image/photo.h"
#include "surface/trust.h"

namespace montage {

namespace {

// One seam sample: the same surface point seen in photos a and b (colours in the fit's space).
struct Sample {
  int a = 0, b = 0;
  Vec3f xa, xb;
  Vec3f srgbA, srgbB;          // as photographed, for the mismatch figures
  float weight = 1;            // min(alpha_a, alpha_b)
  float trust = 1;             // min of the two faces' trust (surface/trust.h); set per run, not kept in the memo
  Vec3f flat = Vec3f::Ones();  // per channel: 1 where both sides are flat around the point, towards 0 near edges
};

// How much a channel varies within `radius` file pixels of (x, y): the range (max - min) of 17 bilinear
// samples (the point and two rings of 8), per channel, in sRGB units.
Vec3f localRange(const Photo& photo, double x, double y, double radius) {
  Vec3f lo = photo.rgbAt(x, y), hi = lo;
  for (double r : {0.5 * radius, radius})
    for (int k = 0; k < 8; ++k) {
      const double angle = k * M_PI / 4 + (r < radius ? M_PI / 8 : 0);
      const Vec3f c = photo.rgbAt(x + r * std::cos(angle), y + r * std::sin(angle));
      lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
    }
  return hi - lo;
}

int cornerOf(const Mesh& mesh, int f, int v) {
  const auto fv = mesh.faceVertices(f);
  return fv[0] == v ? 0 : (fv[1] == v ? 1 : 2);
}

}  // namespace

struct BalanceMemo::Impl {
  std::unordered_map<uint64_t, std::vector<Sample>> current, previous;
};
BalanceMemo::BalanceMemo() : impl_(std::make_unique<Impl>()) {}
BalanceMemo::~BalanceMemo() = default;
void BalanceMemo::beginRun() {
  impl_->previous = std::move(impl_->current);
  impl_->current.clear();
}

namespace {

// The samples of every seam edge of `map`, in edge order. With `memo` and the photos' content keys, an edge
// whose photos, UVs and sampling options an earlier run saw takes its samples from there.
std::vector<Sample> seamSamples(const Mesh& mesh, const TextureMap& map, const std::vector<const Photo*>& photos,
                                const BalanceOptions& options, BalanceMemo::Impl* memo,
                                const std::vector<uint64_t>& photoKeys, const std::vector<float>& trust,
                                int& edgesKept) {
  const TriMesh& tri = mesh.tri;
  std::vector<OpenMesh::HalfedgeHandle> seams;  // edges between two photos, in edge order
  for (const auto eh : tri.edges()) {
    if (tri.is_boundary(eh)) continue;
    const auto h0 = tri.halfedge_handle(eh, 0);
    const int fa = tri.face_handle(h0).idx(), fb = tri.opposite_face_handle(h0).idx();
    if (fa < 0 || fb < 0) continue;
    const int pa = map.facePhoto[fa], pb = map.facePhoto[fb];
    if (pa >= 0 && pb >= 0 && pa != pb) seams.push_back(h0);
  }
  // Per edge in parallel, then in edge order: the samples do not depend on the number of threads.
  std::vector<std::vector<Sample>> perEdge(seams.size());
  std::vector<uint64_t> keys(seams.size(), 0);
  std::vector<char> kept(seams.size(), 0);
  const uint64_t optionsKey =
      hashMix(hashMix(hashMix(0xba1a5ce, options.flatRadiusPx), options.flatRange), uint64_t(options.linear));
  tbb::parallel_for(size_t(0), seams.size(), [&](size_t i) {
    std::vector<Sample>& out = perEdge[i];
    const auto h0 = seams[i];
    const int fa = tri.face_handle(h0).idx(), fb = tri.opposite_face_handle(h0).idx();
    const int pa = map.facePhoto[fa], pb = map.facePhoto[fb];
    const int u = tri.from_vertex_handle(h0).idx(), w = tri.to_vertex_handle(h0).idx();
    const Vec2 ua = map.cornerUV[fa][cornerOf(mesh, fa, u)], wa = map.cornerUV[fa][cornerOf(mesh, fa, w)];
    const Vec2 ub = map.cornerUV[fb][cornerOf(mesh, fb, u)], wb = map.cornerUV[fb][cornerOf(mesh, fb, w)];
    if (memo && photoKeys[pa] && photoKeys[pb]) {
      uint64_t h = hashMix(hashMix(hashMix(hashMix(optionsKey, pa), pb), photoKeys[pa]), photoKeys[pb]);
      keys[i] = hashMix(hashMix(hashMix(hashMix(h, ua), wa), ub), wb);
      const std::vector<Sample>* known = nullptr;  // the memo is read only while the edges run
      if (auto it = memo->current.find(keys[i]); it != memo->current.end()) known = &it->second;
      if (auto it = memo->previous.find(keys[i]); !known && it != memo->previous.end()) known = &it->second;
      if (known) {
        out = *known;
        kept[i] = 1;
        return;
      }
    }
    // About one sample per pixel of the finer side.
    const int n = std::clamp(int(std::ceil(std::max((ua - wa).norm(), (ub - wb).norm()))), 2, 64);
    const Photo& A = *photos[pa];
    const Photo& B = *photos[pb];
    for (int s = 0; s < n; ++s) {
      const double t = (s + 0.5) / n;
      const Vec2 qa = (1 - t) * ua + t * wa, qb = (1 - t) * ub + t * wb;
      const float alphaA = A.alphaAt(qa.x(), qa.y());
      const float alphaB = B.alphaAt(qb.x(), qb.y());
      if (!(alphaA > 0 && alphaB > 0)) continue;  // a side on the background says nothing about colour
      Sample sample;
      sample.a = pa, sample.b = pb;
      sample.srgbA = A.rgbAt(qa.x(), qa.y());
      sample.srgbB = B.rgbAt(qb.x(), qb.y());
      sample.weight = std::min({alphaA, alphaB, 1.0f});
      if (options.flatRadiusPx > 0) {
        // A misregistration of up to flatRadiusPx costs nothing where both sides are flat that far around.
        const Vec3f range = localRange(A, qa.x(), qa.y(), options.flatRadiusPx)
                                .cwiseMax(localRange(B, qb.x(), qb.y(), options.flatRadiusPx));
        for (int c = 0; c < 3; ++c) {
          const float u = range[c] / float(options.flatRange);
          sample.flat[c] = 1 / (1 + u * u);
        }
      }
      for (int c = 0; c < 3; ++c) {
        sample.xa[c] = options.linear ? srgbToLinearFast(sample.srgbA[c]) : sample.srgbA[c];
        sample.xb[c] = options.linear ? srgbToLinearFast(sample.srgbB[c]) : sample.srgbB[c];
      }
      out.push_back(sample);
    }
  });
  if (memo)
    for (size_t i = 0; i < seams.size(); ++i)
      if (keys[i]) memo->current[keys[i]] = perEdge[i];
  edgesKept = static_cast<int>(std::count(kept.begin(), kept.end(), 1));
  std::vector<Sample> out;
  for (size_t i = 0; i < seams.size(); ++i) {
    const float t = std::min(trust[tri.face_handle(seams[i]).idx()], trust[tri.opposite_face_handle(seams[i]).idx()]);
    for (Sample& sample : perEdge[i]) {
      sample.trust = t;
      out.push_back(sample);
    }
  }
  return out;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  return v[mid];
}

// Weight of a residual u (in units of the robust scale) under the loss, and its threshold.
double lossWeight(BalanceLoss loss, double u) {
  switch (loss) {
    case BalanceLoss::L2:
      return 1;
    case BalanceLoss::Huber: {
      constexpr double k = 1.345;
      return std::abs(u) <= k ? 1 : k / std::abs(u);
    }
    case BalanceLoss::Cauchy: {
      constexpr double c = 2.385;
      return 1 / (1 + (u / c) * (u / c));
    }
  }
  return 1;
}

double lossThreshold(BalanceLoss loss) {
  return loss == BalanceLoss::Cauchy ? 2.385 : 1.345;
}

// One channel of one sample, in the fit's space: photo a's value xa and photo b's value xb of one point.
struct Observation {
  int a, b;
  double xa, xb, weight;
};

struct Fit {
  std::vector<double> gain, offset;  // per photo
  int iterations = 0;
  long outliers = 0;
};

// IRLS: the gain (and offset) of every free photo, minimising the robust loss of
// (gain_a xa + offset_a) - (gain_b xb + offset_b) over the observations (references keep 1 and 0). From
// `start` when given (the loss weighs from the first iteration: a redescending loss such as Cauchy needs
// a start near the answer), otherwise from a least-squares first iteration. `gainPrior`: gains the fit is
// pulled towards (per photo; the photo's common gain, for one channel's fit), with options.channelSigma.
Fit fitObservations(const std::vector<Observation>& obs, const std::vector<int>& unknownOf, int free, bool withOffset,
                    BalanceLoss loss, const BalanceOptions& options, const Fit* start = nullptr,
                    const std::vector<double>* gainPrior = nullptr) {
  const int per = withOffset ? 2 : 1;
  const int n = free * per;
  const int photos = static_cast<int>(unknownOf.size());
  Fit fit;
  fit.gain.assign(photos, 1.0);
  fit.offset.assign(photos, 0.0);
  if (start) {
    fit.gain = start->gain;
    if (withOffset) fit.offset = start->offset;
  }
  if (n == 0 || obs.empty()) return fit;
  const int first = start ? 1 : 0;  // iteration index from which the loss weighs
  auto residual = [&](const Observation& o) {
    return (fit.gain[o.a] * o.xa + fit.offset[o.a]) - (fit.gain[o.b] * o.xb + fit.offset[o.b]);
  };
  double scale = 0;
  for (int it = first; it < options.maxIterations + first; ++it) {
    fit.iterations = it + 1 - first;
    if (it > 0) {
      std::vector<double> abs;
      abs.reserve(obs.size());
      for (const Observation& o : obs) abs.push_back(std::abs(residual(o)));
      scale = std::max(1.4826 * median(abs), 1e-4);
    }
    Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(n, n);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);
    for (const Observation& o : obs) {
      const double w = o.weight * (it > 0 ? lossWeight(loss, residual(o) / scale) : 1.0);
      // r = J theta + c: J the row of this observation, c what reference sides contribute.
      int index[4];
      double value[4];
      int k = 0;
      double c = 0;
      const int ua = unknownOf[o.a], ub = unknownOf[o.b];
      if (ua >= 0) {
        index[k] = ua * per, value[k++] = o.xa;
        if (withOffset) index[k] = ua * per + 1, value[k++] = 1;
      } else {
        c += o.xa;
      }
      if (ub >= 0) {
        index[k] = ub * per, value[k++] = -o.xb;
        if (withOffset) index[k] = ub * per + 1, value[k++] = -1;
      } else {
        c -= o.xb;
      }
      for (int i = 0; i < k; ++i) {
        rhs[index[i]] -= w * value[i] * c;
        for (int j = 0; j < k; ++j) normal(index[i], index[j]) += w * value[i] * value[j];
      }
    }
    // Priors. Offsets: MAP with residuals of kNoise (not the current robust scale, which collapses when a
    // gain of 0 and an offset explain a one-coloured seam exactly) and offsets of offsetSigma around 0. A
    // channel's gain: pulled towards the photo's common gain as much as `channelPrior` average observations
    // that agree with it would (little where the channel has many samples, much where it has few). Else a
    // tiny pull of the gains towards 1 keeps the system definite where nothing else does.
    constexpr double kNoise = 0.01;
    const double ridge = 1e-9 * std::max(1.0, normal.trace() / n);
    const double offsetPrior = (kNoise / options.offsetSigma) * (kNoise / options.offsetSigma);
    double meanCurvature = 0;  // of one observation, for one gain
    if (gainPrior) {
      for (const Observation& o : obs) meanCurvature += o.weight * 0.5 * (o.xa * o.xa + o.xb * o.xb);
      meanCurvature /= double(obs.size());
    }
    for (int p = 0; p < photos; ++p) {
      if (unknownOf[p] < 0) continue;
      const int g = unknownOf[p] * per;
      if (gainPrior) {
        const double weight = options.channelPrior * meanCurvature + ridge;
        normal(g, g) += weight;
        rhs[g] += weight * (*gainPrior)[p];
      } else {
        normal(g, g) += ridge;
        rhs[g] += ridge;
      }
      if (withOffset) normal(g + 1, g + 1) += offsetPrior;
    }
    const Eigen::VectorXd theta = normal.ldlt().solve(rhs);
    double change = 0;
    for (int p = 0; p < photos; ++p) {
      if (unknownOf[p] < 0) continue;
      const double g = theta[unknownOf[p] * per], off = withOffset ? theta[unknownOf[p] * per + 1] : 0.0;
      change = std::max({change, std::abs(g - fit.gain[p]), std::abs(off - fit.offset[p])});
      fit.gain[p] = g, fit.offset[p] = off;
    }
    if ((loss == BalanceLoss::L2 && it >= first) || (it > 0 && change < options.tolerance)) break;
  }
  if (loss != BalanceLoss::L2 && scale > 0)
    for (const Observation& o : obs) fit.outliers += std::abs(residual(o)) / scale > lossThreshold(loss);
  return fit;
}

// Clipping. A channel value at or beyond a photo's clipping level (in its own space) says nothing about
// the gain. Leaving out the samples clipped on either side is not enough: where the photos differ in
// exposure, the darker photo is unclipped where the brighter one is not, and the samples kept would be
// chosen by one side's (misregistration) noise, biasing the fit (on spot, red gains of 0.4 instead of 1.8).
// So a sample is kept when both sides, mapped to the reference by the current transforms, lie within
// the range neither photo clips: a condition symmetric in the two sides' noise.
struct ClipRange {
  double lo, hi;  // the fit space's values of the clipping levels
};

bool unclipped(const Sample& s, int c, const std::vector<double>& gain, const std::vector<double>& offset,
               const ClipRange& clip) {
  const double ta = gain[s.a] * s.xa[c] + offset[s.a], tb = gain[s.b] * s.xb[c] + offset[s.b];
  const double hi = std::min(gain[s.a] * clip.hi + offset[s.a], gain[s.b] * clip.hi + offset[s.b]);
  const double lo = std::max(gain[s.a] * clip.lo + offset[s.a], gain[s.b] * clip.lo + offset[s.b]);
  return std::max(ta, tb) < hi && std::min(ta, tb) > lo;
}

}  // namespace

ColorBalance balanceColors(const Mesh& mesh, const TextureMap& map, const std::vector<const Photo*>& photos,
                           const std::vector<bool>& locked, const BalanceOptions& options, const JobControl& job,
                           BalanceMemo* memo, const std::vector<uint64_t>& photoKeys, const ColorBalance* warm) {
  const auto start = Clock::now();
  const int np = static_cast<int>(photos.size());
  TM_CHECK(locked.empty() || static_cast<int>(locked.size()) == np,
           "colour balance: " + std::to_string(locked.size()) + " lock flags for " + std::to_string(np) + " photos");
  TM_CHECK(options.maxIterations >= 1, "colour balance: maxIterations must be >= 1");
  TM_CHECK(options.tolerance > 0, "colour balance: tolerance must be > 0");
  TM_CHECK(options.offsetSigma > 0, "colour balance: offsetSigma must be > 0");
  TM_CHECK(options.saturated > 0.5 && options.saturated <= 1, "colour balance: saturated must be in (0.5, 1]");
  TM_CHECK(options.darkest >= 0 && options.darkest < 0.5, "colour balance: darkest must be in [0, 0.5)");
  ColorBalance out;
  out.transforms.assign(np, ColorTransform{});
  for (auto& t : out.transforms) t.linear = options.linear;
  out.reference.assign(np, 1);
  TM_CHECK(!memo || photoKeys.size() == photos.size(),
           "colour balance: " + std::to_string(photoKeys.size()) + " photo keys for " + std::to_string(np) + " photos");
  const FaceTrust trust = faceTrust(mesh, map, options.trust);
  const std::vector<Sample> samples = seamSamples(mesh, map, photos, options, memo ? &memo->impl() : nullptr,
                                                  photoKeys, trust.trust, out.edgesKept);
  job.checkCancel();

  const ClipRange clip{options.linear ? srgbToLinear(options.darkest) : options.darkest,
                       options.linear ? srgbToLinear(options.saturated) : options.saturated};
  const std::vector<double> ones(np, 1.0), zeros(np, 0.0);
  auto anyChannel = [&](const Sample& s) {
    return unclipped(s, 0, ones, zeros, clip) || unclipped(s, 1, ones, zeros, clip) ||
           unclipped(s, 2, ones, zeros, clip);
  };

  // Photo pairs with enough samples join photos into groups; each group needs a reference.
  // Samples are counted by their trust: a pair seen only at grazing angles joins nothing.
  std::vector<double> pairCount(size_t(np) * np, 0);
  auto pairOf = [&](const Sample& s) { return size_t(std::min(s.a, s.b)) * np + std::max(s.a, s.b); };
  for (const Sample& s : samples)
    if (anyChannel(s)) pairCount[pairOf(s)] += s.trust;
  UnionFind groups(np);
  for (int a = 0; a < np; ++a)
    for (int b = a + 1; b < np; ++b)
      if (pairCount[size_t(a) * np + b] >= options.minSamples) {
        groups.unite(a, b);
        ++out.pairs;
      }
  std::vector<int> groupSize(np, 0), groupReference(np, -1);
  for (int p = 0; p < np; ++p) ++groupSize[groups.find(p)];
  for (int p = 0; p < np; ++p)
    if (!locked.empty() && locked[p] && groupReference[groups.find(p)] < 0) groupReference[groups.find(p)] = p;
  for (int p = 0; p < np; ++p)
    if (groupReference[groups.find(p)] < 0) groupReference[groups.find(p)] = p;  // the group's first photo
  std::vector<int> unknownOf(np, -1);
  int free = 0;
  if (options.mode != BalanceMode::Off)
    for (int p = 0; p < np; ++p) {
      const bool isLocked = !locked.empty() && locked[p];
      if (groupSize[groups.find(p)] < 2 || isLocked || groupReference[groups.find(p)] == p) continue;
      out.reference[p] = 0;
      unknownOf[p] = free++;
    }
  // Only samples between two photos of one group, with a free side, count.
  std::vector<Sample> used;
  for (const Sample& s : samples)
    if (s.trust > 0 && pairCount[pairOf(s)] >= options.minSamples && (unknownOf[s.a] >= 0 || unknownOf[s.b] >= 0))
      used.push_back(s);

  if (free > 0) {
    // A first estimate: one gain per photo shared by the channels (exposure), from the samples clipped
    // nowhere; it decides which samples each channel's fit may use.
    std::vector<Observation> obs;
    for (const Sample& s : used)
      for (int c = 0; c < 3; ++c)
        if (unclipped(s, c, ones, zeros, clip))
          obs.push_back({s.a, s.b, s.xa[c], s.xb[c], s.weight * s.trust * s.flat[c]});
    // Huber is convex: its answer does not depend on the start, and it is a good start for Cauchy.
    const BalanceLoss firstLoss = options.loss == BalanceLoss::L2 ? BalanceLoss::L2 : BalanceLoss::Huber;
    // A warm start serves when it balanced the same photos with the same references.
    const bool warmed = warm && warm->reference == out.reference && static_cast<int>(warm->commonGain.size()) == np &&
                        static_cast<int>(warm->transforms.size()) == np;
    Fit warmShared;
    std::array<Fit, 3> fits;
    if (warmed) {
      warmShared.gain = warm->commonGain;
      warmShared.offset.assign(np, 0.0);
      for (int c = 0; c < 3; ++c) {
        fits[c].gain.resize(np), fits[c].offset.resize(np);
        for (int p = 0; p < np; ++p)
          fits[c].gain[p] = warm->transforms[p].gain[c], fits[c].offset[p] = warm->transforms[p].offset[c];
      }
    }
    const Fit shared = fitObservations(obs, unknownOf, free, false, firstLoss, options, warmed ? &warmShared : nullptr);
    out.commonGain = shared.gain;
    if (!warmed)
      for (auto& f : fits) f = shared;
    // Then per channel, the samples chosen by the current transforms; twice, as the choice depends on them
    // (once from a warm start, whose transforms already chose them).
    long outliers = 0, counted = 0;
    // The channels' fits read nothing of each other: they run side by side.
    for (int round = 0; round < (warmed ? 1 : 2); ++round) {
      job.checkCancel();
      std::array<long, 3> used3{};
      tbb::parallel_for(0, 3, [&](int c) {
        std::vector<Observation> channel;
        for (const Sample& s : used)
          if (unclipped(s, c, fits[c].gain, fits[c].offset, clip))
            channel.push_back({s.a, s.b, s.xa[c], s.xb[c], s.weight * s.trust * s.flat[c]});
        const Fit previous = fits[c];
        fits[c] = fitObservations(channel, unknownOf, free, options.mode == BalanceMode::GainOffset, options.loss,
                                  options, options.loss == BalanceLoss::L2 ? nullptr : &previous,
                                  options.channelPrior > 0 ? &shared.gain : nullptr);
        used3[c] = static_cast<long>(channel.size());
      });
      outliers = counted = 0;
      for (int c = 0; c < 3; ++c) {
        out.iterations = std::max(out.iterations, fits[c].iterations);
        outliers += fits[c].outliers, counted += used3[c];
      }
    }
    out.samples = static_cast<int>(counted / 3);
    out.outlierShare = counted ? double(outliers) / counted : 0.0;
    for (int p = 0; p < np; ++p)
      for (int c = 0; c < 3; ++c) {
        out.transforms[p].gain[c] = float(fits[c].gain[p]);
        out.transforms[p].offset[c] = float(fits[c].offset[p]);
      }
  }
  for (int p = 0; p < np; ++p) {
    ColorTransform& t = out.transforms[p];
    if (out.reference[p]) continue;
    const bool sane = t.gain.allFinite() && t.offset.allFinite() && t.gain.minCoeff() > 0.05f && t.gain.maxCoeff() < 20;
    if (!sane) {
      out.warnings.push_back("photo " + std::to_string(p) + ": the colour balance found no sensible transform (gain " +
                             std::to_string(t.gain.minCoeff()) + ".." + std::to_string(t.gain.maxCoeff()) +
                             "); it keeps its colours");
      t = ColorTransform{};
      t.linear = options.linear;
      out.reference[p] = 1;
    }
  }

  double before = 0, after = 0;
  for (const Sample& s : samples) {
    before += deltaEuv(s.srgbA, s.srgbB);
    after += deltaEuv(out.transforms[s.a].apply(s.srgbA), out.transforms[s.b].apply(s.srgbB));
  }
  out.mismatchBefore = samples.empty() ? 0 : before / samples.size();
  out.mismatchAfter = samples.empty() ? 0 : after / samples.size();
  out.seconds = secondsSince(start);
  return out;
}

namespace {

// Integer depths: the balanced value of every stored value, per channel (what balancedPhoto writes).
std::array<std::vector<uint16_t>, 3> levelTables(const ColorTransform& t, int levels) {
  std::array<std::vector<uint16_t>, 3> table;
  for (int c = 0; c < 3; ++c) {
    table[c].resize(levels);
    for (int v = 0; v < levels; ++v)
      table[c][v] = uint16_t(std::lround(t.apply(float(v) / (levels - 1), c) * (levels - 1)));
  }
  return table;
}

}  // namespace

double balancedPhotoDistance(const ColorTransform& a, const ColorTransform& b, int depth) {
  if (a.gain == b.gain && a.offset == b.offset && a.linear == b.linear) return 0;
  if (depth == CV_8U || depth == CV_16U) {
    const int levels = depth == CV_8U ? 256 : 65536;
    const auto ta = levelTables(a, levels), tb = levelTables(b, levels);
    int most = 0;
    for (int c = 0; c < 3; ++c)
      for (int v = 0; v < levels; ++v) most = std::max(most, std::abs(int(ta[c][v]) - int(tb[c][v])));
    return most * 255.0 / (levels - 1);
  }
  // Float photos store any value: the transforms differ, and the distance is sampled (never 0).
  double most = 1e-9;
  for (int c = 0; c < 3; ++c)
    for (int v = 0; v <= 4096; ++v)
      most = std::max(most, 255.0 * std::abs(double(a.apply(v / 4096.0f, c)) - b.apply(v / 4096.0f, c)));
  return most;
}

std::shared_ptr<const Photo> balancedPhoto(const std::shared_ptr<const Photo>& photo, const ColorTransform& transform) {
  if (!photo || transform.identity()) return photo;
  auto out = std::make_shared<Photo>(*photo);  // shares alpha and distance (cv::Mat is reference counted)
  const cv::Mat& in = photo->rgb;
  TM_CHECK(in.channels() == 3, located(photo->path, "colour balance: expected 3 colour channels"));
  cv::Mat rgb(in.size(), in.type());
  if (in.depth() == CV_8U || in.depth() == CV_16U) {
    // Integer depths keep their depth (the photo stays compact): one table per channel of every value.
    const auto table = levelTables(transform, in.depth() == CV_8U ? 256 : 65536);
    cv::parallel_for_(cv::Range(0, rgb.rows), [&](const cv::Range& rows) {
      for (int y = rows.start; y < rows.end; ++y)
        if (in.depth() == CV_8U) {
          const uint8_t* p = in.ptr<uint8_t>(y);
          uint8_t* o = rgb.ptr<uint8_t>(y);
          for (int i = 0; i < 3 * rgb.cols; ++i) o[i] = uint8_t(table[i % 3][p[i]]);
        } else {
          const uint16_t* p = in.ptr<uint16_t>(y);
          uint16_t* o = rgb.ptr<uint16_t>(y);
          for (int i = 0; i < 3 * rgb.cols; ++i) o[i] = table[i % 3][p[i]];
        }
    });
  } else {
    TM_CHECK(in.depth() == CV_32F, located(photo->path, "colour balance: unsupported pixel depth"));
    cv::parallel_for_(cv::Range(0, rgb.rows), [&](const cv::Range& rows) {
      for (int y = rows.start; y < rows.end; ++y) {
        const float* p = in.ptr<float>(y);
        float* o = rgb.ptr<float>(y);
        for (int i = 0; i < 3 * rgb.cols; ++i) o[i] = transform.apply(p[i], i % 3);
      }
    });
  }
  out->rgb = rgb;
  return out;
}

}  // namespace montage
