#include "image/shiftmap.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "base/common.h"
#include "geometry/graph_cut.h"

namespace montage {

namespace {

constexpr double kUnreadable = 1e5;  // seam cost where a label reads outside the image or an unknown pixel
constexpr double kNoLabel = 1e12;    // an unknown pixel without a label: any valid one is better

struct Offset {
  int dx = 0, dy = 0;
};

class ShiftMap {
 public:
  ShiftMap(const cv::Mat& image, const cv::Mat& known, const ShiftMapOptions& o)
      : image_(image), o_(o), w_(image.cols), h_(image.rows), known_(size_t(w_) * h_) {
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x) known_[size_t(y) * w_ + x] = known.at<uchar>(y, x) != 0;
  }

  cv::Mat fill(ShiftMapStats& stats) {
    findOffsets();
    stats.labels = static_cast<int>(labels_.size()) - 1;
    buildDomain();
    stats.domain = static_cast<int>(domain_.size());
    stats.moves = expand();
    cv::Mat out = image_.clone();
    std::vector<char> filled(known_.begin(), known_.end());
    for (size_t i = 0; i < domain_.size(); ++i) {
      if (label_[i] < 0) continue;
      const int p = domain_[i];
      out.at<cv::Vec3b>(p / w_, p % w_) = pixel(source(p, label_[i]));
      filled[p] = 1;
    }
    stats.unreached = fillUnreached(out, filled);
    return out;
  }

 private:
  const cv::Vec3b& pixel(int p) const { return image_.at<cv::Vec3b>(p / w_, p % w_); }

  // Sum of squared differences of the patches whose top-left corners are a and b; stops above `bound`.
  long patchDistance(int a, int b, long bound) const {
    long sum = 0;
    for (int r = 0; r < o_.patch; ++r) {
      const cv::Vec3b* pa = image_.ptr<cv::Vec3b>(a / w_ + r) + a % w_;
      const cv::Vec3b* pb = image_.ptr<cv::Vec3b>(b / w_ + r) + b % w_;
      for (int c = 0; c < o_.patch; ++c)
        for (int k = 0; k < 3; ++k) {
          const int d = int(pa[c][k]) - int(pb[c][k]);
          sum += d * d;
        }
      if (sum >= bound) return sum;
    }
    return sum;
  }

  // PatchMatch (Barnes et al. 2009) among the fully known patches, with offsets of at least minOffset;
  // then the histogram of the offsets, smoothed, and its strongest local maxima (He and Sun 2012).
  void findOffsets() {
    labels_ = {Offset{}};  // label 0: the pixel itself
    const int P = o_.patch;
    if (w_ < P || h_ < P) return;
    cv::Mat unknown(h_, w_, CV_8U);
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x) unknown.at<uchar>(y, x) = known_[size_t(y) * w_ + x] ? 0 : 1;
    cv::Mat sums;
    cv::integral(unknown, sums, CV_32S);
    std::vector<char> patchOk(size_t(w_) * h_, 0);
    std::vector<int> patches;
    for (int y = 0; y + P <= h_; ++y)
      for (int x = 0; x + P <= w_; ++x) {
        const int s = sums.at<int>(y + P, x + P) - sums.at<int>(y, x + P) - sums.at<int>(y + P, x) + sums.at<int>(y, x);
        if (s == 0) patchOk[size_t(y) * w_ + x] = 1, patches.push_back(y * w_ + x);
      }
    if (patches.size() < 2) return;
    auto allowed = [&](int q, int c) {
      if (!patchOk[c]) return false;
      return std::abs(c % w_ - q % w_) >= o_.minOffset || std::abs(c / w_ - q / w_) >= o_.minOffset;
    };
    std::vector<int> match(size_t(w_) * h_, -1);
    std::vector<long> best(size_t(w_) * h_, std::numeric_limits<long>::max());
    auto tryMatch = [&](int q, int cx, int cy) {
      if (cx < 0 || cy < 0 || cx + P > w_ || cy + P > h_) return;
      const int c = cy * w_ + cx;
      if (c == match[q] || !allowed(q, c)) return;
      const long d = patchDistance(q, c, best[q]);
      if (d < best[q]) best[q] = d, match[q] = c;
    };
    std::mt19937_64 rng(o_.seed);
    for (int q : patches)
      for (int t = 0; t < 16 && match[q] < 0; ++t) {
        const int c = patches[rng() % patches.size()];
        tryMatch(q, c % w_, c / w_);
      }
    const int radius0 = std::max(w_, h_);
    for (int it = 0; it < o_.searchIterations; ++it) {
      const bool forward = it % 2 == 0;
      const int step = forward ? 1 : -1;
      for (size_t k = 0; k < patches.size(); ++k) {
        const int q = patches[forward ? k : patches.size() - 1 - k];
        const int x = q % w_, y = q / w_;
        // Propagation: the neighbour's offset (the one already visited in this pass).
        for (const auto& [nx, ny] : {std::pair{x - step, y}, std::pair{x, y - step}}) {
          if (nx < 0 || ny < 0 || nx >= w_ || ny >= h_) continue;
          const int n = ny * w_ + nx;
          if (match[n] >= 0) tryMatch(q, match[n] % w_ + (x - nx), match[n] / w_ + (y - ny));
        }
        // Random search around the current match, in halving windows.
        if (match[q] < 0) continue;
        for (int r = radius0; r >= 1; r /= 2) {
          const int mx = match[q] % w_, my = match[q] / w_;
          std::uniform_int_distribution<int> d(-r, r);
          tryMatch(q, mx + d(rng), my + d(rng));
        }
      }
    }
    cv::Mat hist(2 * h_ - 1, 2 * w_ - 1, CV_64F, cv::Scalar(0));
    for (int q : patches)
      if (match[q] >= 0) hist.at<double>(match[q] / w_ - q / w_ + h_ - 1, match[q] % w_ - q % w_ + w_ - 1) += 1;
    const cv::Mat counts = hist.clone();
    cv::GaussianBlur(hist, hist, cv::Size(), std::sqrt(2.0), 0, cv::BORDER_CONSTANT);
    cv::Mat peaks;
    cv::dilate(hist, peaks, cv::Mat::ones(9, 9, CV_8U));
    std::vector<std::pair<double, int>> maxima;  // (smoothed count, histogram index)
    for (int r = 0; r < hist.rows; ++r)
      for (int c = 0; c < hist.cols; ++c) {
        const double v = hist.at<double>(r, c);
        const int dx = c - (w_ - 1), dy = r - (h_ - 1);
        if (v > 0 && v == peaks.at<double>(r, c) && (std::abs(dx) >= o_.minOffset || std::abs(dy) >= o_.minOffset))
          maxima.emplace_back(v, r * hist.cols + c);
      }
    std::sort(maxima.begin(), maxima.end(), [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
    // A small canvas has few maxima: the other offsets found follow, the most frequent first.
    if (static_cast<int>(maxima.size()) < o_.offsets) {
      std::vector<std::pair<double, int>> others;
      std::vector<char> taken(hist.total(), 0);
      for (const auto& m : maxima) taken[m.second] = 1;
      for (int i = 0; i < static_cast<int>(hist.total()); ++i) {
        const int dx = i % hist.cols - (w_ - 1), dy = i / hist.cols - (h_ - 1);
        const double v = counts.at<double>(i / hist.cols, i % hist.cols);
        if (v > 0 && !taken[i] && (std::abs(dx) >= o_.minOffset || std::abs(dy) >= o_.minOffset))
          others.emplace_back(v, i);
      }
      std::sort(others.begin(), others.end(), [](const auto& a, const auto& b) {
        return a.first != b.first ? a.first > b.first : a.second < b.second;
      });
      maxima.insert(maxima.end(), others.begin(), others.end());
    }
    for (size_t i = 0; i < maxima.size() && static_cast<int>(i) < o_.offsets; ++i)
      labels_.push_back({maxima[i].second % hist.cols - (w_ - 1), maxima[i].second / hist.cols - (h_ - 1)});
  }

  // The pixels to label: the unknown ones and the known ones within `band` of them.
  void buildDomain() {
    cv::Mat unknown(h_, w_, CV_8U);
    for (int y = 0; y < h_; ++y)
      for (int x = 0; x < w_; ++x) unknown.at<uchar>(y, x) = known_[size_t(y) * w_ + x] ? 0 : 255;
    cv::Mat near;
    cv::dilate(unknown, near, cv::Mat::ones(2 * o_.band + 1, 2 * o_.band + 1, CV_8U));
    index_.assign(size_t(w_) * h_, -1);
    for (int p = 0; p < w_ * h_; ++p)
      if (near.at<uchar>(p / w_, p % w_)) index_[p] = static_cast<int>(domain_.size()), domain_.push_back(p);
    label_.assign(domain_.size(), -1);
    for (size_t i = 0; i < domain_.size(); ++i) {
      const int p = domain_[i];
      if (known_[p]) {
        label_[i] = 0;
        continue;
      }
      for (int l = 1; l < static_cast<int>(labels_.size()) && label_[i] < 0; ++l)
        if (source(p, l) >= 0) label_[i] = l;
    }
    // Each 4-neighbour pair with a pixel in the domain, once (the other one may be outside: label 0).
    for (int p : domain_) {
      const int x = p % w_, y = p / w_;
      if (x + 1 < w_) edges_.push_back({p, p + 1});
      if (y + 1 < h_) edges_.push_back({p, p + w_});
      if (x > 0 && index_[p - 1] < 0) edges_.push_back({p - 1, p});
      if (y > 0 && index_[p - w_] < 0) edges_.push_back({p - w_, p});
    }
  }

  // The pixel label l copies into p, or -1 when it lies outside the image or is unknown.
  int source(int p, int l) const {
    const int x = p % w_ + labels_[l].dx, y = p / w_ + labels_[l].dy;
    if (x < 0 || y < 0 || x >= w_ || y >= h_) return -1;
    const int s = y * w_ + x;
    return known_[s] ? s : -1;
  }

  int labelAt(int p, const std::vector<int>& labels) const { return index_[p] < 0 ? 0 : labels[index_[p]]; }

  // The photomontage seam cost where p and its neighbour q take labels a and b.
  double seam(int p, int q, int a, int b) const {
    if (a == b || a < 0 || b < 0) return 0;
    double cost = 0;
    for (int x : {p, q}) {
      const int sa = source(x, a), sb = source(x, b);
      if (sa < 0 || sb < 0) {
        cost += kUnreadable;
        continue;
      }
      const cv::Vec3b& ca = pixel(sa);
      const cv::Vec3b& cb = pixel(sb);
      for (int k = 0; k < 3; ++k) cost += double(int(ca[k]) - int(cb[k])) * (int(ca[k]) - int(cb[k]));
    }
    return cost;
  }

  double energy(const std::vector<int>& labels) const {
    double e = 0;
    for (int l : labels) e += l < 0 ? kNoLabel : 0;
    for (const auto& [p, q] : edges_) e += seam(p, q, labelAt(p, labels), labelAt(q, labels));
    return e;
  }

  // Alpha-expansion (Boykov, Veksler and Zabih 2001): each label in turn may take over any pixel it can
  // fill; a move is kept when it lowers the energy (pairs that break the triangle inequality are cut
  // to submodular ones, so a move is checked, not assumed).
  int expand() {
    const int numLabels = static_cast<int>(labels_.size());
    const int n = static_cast<int>(domain_.size());
    double current = energy(label_);
    std::vector<int> var(n, -1), nodes;
    int moves = 0;
    for (int round = 0; round < o_.rounds; ++round) {
      bool changed = false;
      for (int alpha = 1; alpha <= numLabels; ++alpha) {
        const int a = alpha % numLabels;  // the identity last
        nodes.clear();
        for (int i = 0; i < n; ++i)
          if (label_[i] != a && source(domain_[i], a) >= 0) var[i] = static_cast<int>(nodes.size()), nodes.push_back(i);
        if (nodes.empty()) continue;
        const int m = static_cast<int>(nodes.size());
        std::vector<double> unary(m, 0.0);  // cost of switching to a minus the cost of keeping
        for (int k = 0; k < m; ++k)
          if (label_[nodes[k]] < 0) unary[k] -= kNoLabel;
        cv::detail::GCGraph<double> graph(m, 4 * m);
        for (int k = 0; k < m; ++k) graph.addVtx();
        int pairs = 0;
        for (const auto& [p, q] : edges_) {
          const int ip = index_[p], iq = index_[q];
          const int vp = ip >= 0 ? var[ip] : -1, vq = iq >= 0 ? var[iq] : -1;
          if (vp < 0 && vq < 0) continue;
          const int lp = labelAt(p, label_), lq = labelAt(q, label_);
          if (vp >= 0 && vq >= 0) {
            const double A = seam(p, q, lp, lq), B = seam(p, q, lp, a), C = seam(p, q, a, lq);
            unary[vp] += C - A;
            unary[vq] -= C;
            const double pair = B + C - A;
            if (pair > 0) graph.addEdges(vp, vq, pair, 0), ++pairs;
          } else if (vp >= 0) {
            unary[vp] += seam(p, q, a, lq) - seam(p, q, lp, lq);
          } else {
            unary[vq] += seam(p, q, lp, a) - seam(p, q, lp, lq);
          }
        }
        const std::vector<char> switches = expansionMove(graph, unary, pairs);
        std::vector<int> next = label_;
        for (int k = 0; k < m; ++k)
          if (switches[k]) next[nodes[k]] = a;
        for (int i : nodes) var[i] = -1;
        const double e = energy(next);
        if (e < current - 1e-9 * std::max(1.0, current)) {
          label_.swap(next);
          current = e;
          changed = true;
          ++moves;
        }
      }
      if (!changed) break;
    }
    return moves;
  }

  // Unknown pixels no label reaches take the colour of a filled 4-neighbour, ring by ring; returns how many.
  int fillUnreached(cv::Mat& out, std::vector<char>& filled) const {
    std::vector<int> ring;
    for (;;) {
      ring.clear();
      for (int p = 0; p < w_ * h_; ++p) {
        if (filled[p]) continue;
        const int x = p % w_, y = p / w_;
        for (const int nb :
             {x > 0 ? p - 1 : -1, x + 1 < w_ ? p + 1 : -1, y > 0 ? p - w_ : -1, y + 1 < h_ ? p + w_ : -1})
          if (nb >= 0 && filled[nb]) {
            out.at<cv::Vec3b>(y, x) = out.at<cv::Vec3b>(nb / w_, nb % w_);
            ring.push_back(p);
            break;
          }
      }
      if (ring.empty()) break;  // done, or no known pixel at all
      for (int p : ring) filled[p] = 1;
    }
    return static_cast<int>(std::count(label_.begin(), label_.end(), -1));
  }

  const cv::Mat& image_;
  const ShiftMapOptions& o_;
  const int w_, h_;
  std::vector<char> known_;
  std::vector<Offset> labels_;
  std::vector<int> domain_, index_, label_;
  std::vector<std::pair<int, int>> edges_;
};

}  // namespace

cv::Mat shiftMapFill(const cv::Mat& image, const cv::Mat& known, const ShiftMapOptions& options, ShiftMapStats* stats) {
  TM_CHECK(image.type() == CV_8UC3, "shift-map: the image must be 8-bit with 3 channels");
  TM_CHECK(known.type() == CV_8UC1 && known.size() == image.size(),
           "shift-map: the known mask must be 8-bit, one channel, the image's size");
  TM_CHECK(options.patch >= 2 && options.offsets >= 0 && options.minOffset >= 1 && options.band >= 0,
           "shift-map: bad options");
  ShiftMapStats s;
  cv::Mat out = ShiftMap(image, known, options).fill(s);
  if (stats) *stats = s;
  return out;
}

}  // namespace montage
