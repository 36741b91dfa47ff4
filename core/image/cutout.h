// Cut-out of a photo's foreground: the paper's second preprocessing step (section 2: "we interactively
// segment the useless background regions ... The output for each pixel is an alpha value ranging from
// zero to one, where zero values are assigned only to background pixels"). GrabCut (Rother, Kolmogorov
// and Blake 2004, OpenCV imgproc) runs from a rectangle and from foreground/background strokes and is
// refined by further strokes; a mask brush edits the result directly; a feathered edge finishes it.
//
// Coordinates are photo pixels (photo.h: x right, y down, origin top-left). Masks are CV_8UC1 of the
// photo's size: 0 = background, > 0 = foreground, the value being alpha * 255.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "base/common.h"

namespace montage {

struct Photo;

struct CutoutOptions {
  int iterations = 5;        // GrabCut iterations from a rectangle (colour models re-learnt, then a graph cut)
  int strokeIterations = 2;  // after strokes, from models that have converged already
  int workingSide = 512;     // GrabCut runs on the photo scaled down to at most this many pixels a side
                             // (0 = full resolution), on the part of it around the object
  int bandPx = 1;            // then a graph cut at the photo's stored resolution decides the pixels within
                             // this many working pixels of GrabCut's edge (0 = none: the edge scaled up)
  double featherPx = 0;    // width of the feathered edge in photo pixels: alpha ramps from 0 at the
                           // background to 1 this far inside the foreground (0 = a hard edge)
};

// A stroke or brush path: a polyline in photo pixels and its radius (pixels).
struct CutoutStroke {
  std::vector<Vec2> points;
  double radius = 6;
  bool foreground = true;  // a foreground stroke (brush: add); false: background stroke (brush: erase)
};

// An interactive cut-out of one photo. It keeps GrabCut's state (per-pixel labels and the two colour
// models) so that later strokes refine the result instead of starting over. Expensive set-up (the
// working-resolution image) is done once in the constructor.
class Cutout {
 public:
  // `rgb`: the photo, sRGB, CV_8UC3, CV_16UC3 or CV_32FC3 in [0,1] (Photo::rgb). `photoSize`: the photo's
  // file size when `rgb` is stored at a working resolution (Photo::width, height; empty = rgb's size):
  // coordinates and masks are then the file's pixels. Throws montage::Error when empty.
  explicit Cutout(const cv::Mat& rgb, const CutoutOptions& options = {}, cv::Size photoSize = {});

  // Starts over from a rectangle (photo pixels, clipped to the photo): outside is background, inside is
  // unknown; runs GrabCut. Throws montage::Error when the rectangle is empty or covers the whole photo
  // (GrabCut then has no background to learn from).
  void setRect(const cv::Rect2d& rect);
  // Starts over from an existing foreground (a mask or alpha of the photo's size or of its stored size,
  // > 0 = foreground) as
  // GrabCut's probable labels, without running it: strokes then refine it, the brush edits it.
  void startFrom(const cv::Mat& alpha);
  // Starts over from a trimap (CV_8UC1 of the photo's size, GrabCut's labels: cv::GC_BGD, GC_FGD, GC_PR_BGD,
  // GC_PR_FGD) and runs GrabCut on the part of the photo around its uncertain pixels (the camera stage's cut-out
  // found around a mesh's projection). Throws montage::Error when the trimap is not of the photo's size or marks no
  // foreground or no background.
  void startFromTrimap(const cv::Mat& labels);
  // Marks a stroke as certain foreground or background and runs GrabCut again from the current state.
  // The region the stroke lies in that the cut gave to the other side, as far as its colour stays near
  // the stroke's, goes over to the stroke's side before the colour models are re-learnt, so that a stroke
  // moves the whole wrong region, not only the pixels under it.
  // Without a rectangle first, strokes alone initialise the models (both kinds are then needed).
  void addStroke(const CutoutStroke& stroke);
  // The same for several strokes at once (one GrabCut run).
  void addStrokes(const std::vector<CutoutStroke>& strokes);
  // Marks every non-zero pixel of `fg` / `bg` (CV_8U images of the photo's size, either may be empty)
  // as certain foreground / background and runs GrabCut (the command line's --fg / --bg files).
  void addStrokeMasks(const cv::Mat& fg, const cv::Mat& bg);
  // The mask brush: sets the pixels under the stroke to foreground (add) or background (erase) without
  // running GrabCut; they stay so in later runs.
  void brush(const CutoutStroke& stroke);

  // An independent copy of the cut-out's state (labels, colour models, options), to go back to it later
  // (the editor's undo): the copy and this object never share a buffer that either writes.
  Cutout copy() const;

  bool started() const { return started_; }
  const CutoutOptions& options() const { return options_; }
  void setFeather(double featherPx) { options_.featherPx = featherPx; }
  // The result at the photo's size: CV_8UC1, 0 = background, 255 = foreground, or 1..254 on the
  // feathered edge (options().featherPx). All zero before the first run.
  cv::Mat mask() const;
  // The binary result (0 / 255) at the photo's size.
  cv::Mat binaryMask() const;
  double lastSeconds() const { return lastSeconds_; }          // wall time of the last run (GrabCut and the band)
  double lastBandSeconds() const { return lastBandSeconds_; }  // of which the band's graph cut

 private:
  void paint(cv::Mat& labels, double scale, const CutoutStroke& stroke, int value) const;
  void spreadStroke(const CutoutStroke& stroke);
  void runGrabCut();
  void refine();
  void applyMarks(cv::Mat& full) const;

  CutoutOptions options_;
  cv::Size size_;     // the photo's size
  double scale_ = 1;  // working pixels per photo pixel
  cv::Mat stored_;    // CV_8UC3, the photo's pixels as given (the band's graph cut reads them)
  cv::Mat image_;     // CV_8UC3 at working resolution
  cv::Mat labels_;    // CV_8UC1 GrabCut labels (cv::GC_BGD, GC_FGD, GC_PR_BGD, GC_PR_FGD)
  cv::Mat bgdModel_, fgdModel_;
  cv::Rect rect_;  // working pixels
  cv::Rect roi_;   // working pixels: where GrabCut runs (the rectangle or strokes and a margin of background)
  // The result at stored_'s size, replaced (never written in place) by each run, so copies share it.
  cv::Mat result_;
  // Strokes, brush strokes and stroke images in the order given: painted again over each refined result
  // at the stored resolution, so what the user marked stays exactly so (the working labels are coarser).
  struct Mark {
    CutoutStroke stroke;
    cv::Mat image;  // a stroke image (CV_8UC1, non-zero = marked) instead of the stroke
  };
  std::vector<Mark> marks_;
  bool started_ = false, modelsReady_ = false;
  double lastSeconds_ = 0, lastBandSeconds_ = 0;
};

// One-shot cut-out: GrabCut from `rect` (photo pixels) and optional stroke masks (CV_8U, non-zero =
// stroke; may be empty), feathered by options.featherPx. Returns the mask (see Cutout::mask).
cv::Mat cutoutMask(const cv::Mat& rgb, const cv::Rect2d& rect, const cv::Mat& fgStrokes = {},
                   const cv::Mat& bgStrokes = {}, const CutoutOptions& options = {});

// A CV_8UC1 mask kept run-length encoded (row-major runs of one value): the cut-out's undo steps hold their
// masks so, a few hundred kilobytes for a 12-megapixel feathered mask instead of 12 MB.
class PackedMask {
 public:
  PackedMask() = default;
  explicit PackedMask(const cv::Mat& mask);  // CV_8UC1 (or empty)
  cv::Mat unpack() const;                    // the mask, bit for bit
  size_t bytes() const { return lengths_.size() * sizeof(uint32_t) + values_.size(); }
  bool empty() const { return size_.empty(); }

 private:
  cv::Size size_;
  std::vector<uint32_t> lengths_;
  std::vector<uint8_t> values_;
};

// A feathered mask from a binary one (CV_8UC1, non-zero = foreground): alpha = min(1, d / featherPx),
// d being the distance (pixels) from a foreground pixel's centre to the nearest background pixel's
// centre, so the foreground set is unchanged and only its edge is softened. featherPx <= 0 returns 0/255.
cv::Mat featherMask(const cv::Mat& binary, double featherPx);

// Share (0..1) of the image's border pixels (its outermost row and column of pixels on all four sides)
// that are foreground (alpha > 0). A cut-out object rarely touches more than one side.
double borderForegroundShare(const cv::Mat& alpha);

// Warnings about a photo's foreground, for the run report and `montage info`: no background at all (no
// alpha, no mask: the whole photo, background included, counts as the object), or a foreground that
// covers most of the image border (the cut-out probably kept background). Empty when neither applies.
std::vector<std::string> foregroundWarnings(const Photo& photo);
// The same from what photoStats measures: whether the photo has a background, and borderForegroundShare.
std::vector<std::string> foregroundWarnings(bool hasBackground, double borderShare);

// Writes a mask as an 8-bit grey PNG (atomically). Throws montage::Error naming the file on failure.
void writeMaskPng(const cv::Mat& mask, const std::string& path);

}  // namespace montage
