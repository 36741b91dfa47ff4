#include "bench/render.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace montage {

Camera orbitCamera(const Mesh& mesh, const RenderOptions& options) {
  Vec3 lo, hi;
  mesh.bounds(lo, hi);
  const Vec3 center = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * (hi - lo).norm(), 1e-9);
  const int ss = std::max(1, options.supersample);
  const int width = options.size * ss, height = (options.height > 0 ? options.height : options.size) * ss;
  const double yaw = options.yawDeg * M_PI / 180, pitch = options.pitchDeg * M_PI / 180;
  const Vec3 dir(std::sin(yaw) * std::cos(pitch), std::sin(pitch), std::cos(yaw) * std::cos(pitch));
  // The bounding sphere fits the narrower of the two fields of view.
  const double halfY = 0.5 * options.fovYDeg * M_PI / 180;
  const double halfX = std::atan(std::tan(halfY) * width / height);
  const double distance = radius / std::sin(std::min(halfX, halfY)) * 1.05;
  return Camera::lookAt(center + distance * dir, center, Vec3::UnitY(), options.fovYDeg, width, height);
}

cv::Mat renderModel(const TexturedModel& model, const RenderOptions& options) {
  return renderSurface(
      model.mesh, [&](int f, const Vec3& b) { return model.colorAt(f, b); }, options);
}

cv::Mat renderSurface(const Mesh& mesh, const std::function<Vec3f(int face, const Vec3& bary)>& color,
                      const RenderOptions& options) {
  const Camera camera = orbitCamera(mesh, options);
  const RasterBuffers buffers = rasterize(mesh, camera);
  const Vec3 eye = camera.center();

  cv::Mat big(buffers.height, buffers.width, CV_8UC4,
              cv::Scalar(options.background[0], options.background[1], options.background[2], options.background[3]));
  for (int y = 0; y < buffers.height; ++y) {
    auto* row = big.ptr<cv::Vec4b>(y);
    for (int x = 0; x < buffers.width; ++x) {
      const int i = buffers.index(x, y);
      const int f = buffers.face[i];
      if (f < 0) continue;
      const Vec3 b = buffers.bary[i].cast<double>();
      Vec3f c = color(f, b);
      if (options.shading) {
        const auto q = mesh.facePositions(f);
        const Vec3 p = b[0] * q[0] + b[1] * q[1] + b[2] * q[2];
        const double lambert = std::abs(mesh.faceNormal(f).dot((eye - p).normalized()));
        c *= static_cast<float>(0.35 + 0.65 * lambert);
      }
      for (int k = 0; k < 3; ++k) row[x][k] = cv::saturate_cast<uchar>(255.f * c[k]);
      row[x][3] = 255;
    }
  }
  const cv::Size size(options.size, options.height > 0 ? options.height : options.size);
  if (big.size() == size) return big;
  cv::Mat out;
  cv::resize(big, out, size, 0, 0, cv::INTER_AREA);
  return out;
}

std::vector<cv::Mat> renderTurntable(const TexturedModel& model, int views, const RenderOptions& options) {
  TM_CHECK(views >= 1, "turntable: needs at least one view, got " + std::to_string(views));
  std::vector<cv::Mat> out;
  RenderOptions o = options;
  for (int k = 0; k < views; ++k) {
    o.yawDeg = options.yawDeg + 360.0 * k / views;
    out.push_back(renderModel(model, o));
  }
  return out;
}

cv::Mat contactSheet(const std::vector<cv::Mat>& images, int columns, int gap, const cv::Vec4b& background) {
  TM_CHECK(!images.empty(), "contact sheet: no images");
  const cv::Size cell = images[0].size();
  const int n = static_cast<int>(images.size());
  const int cols = columns > 0 ? std::min(columns, n) : static_cast<int>(std::ceil(std::sqrt(double(n))));
  const int rows = (n + cols - 1) / cols;
  cv::Mat sheet(rows * cell.height + (rows + 1) * gap, cols * cell.width + (cols + 1) * gap, CV_8UC4,
                cv::Scalar(background[0], background[1], background[2], background[3]));
  for (int i = 0; i < n; ++i) {
    TM_CHECK(images[i].size() == cell && images[i].type() == CV_8UC4,
             "contact sheet: image " + std::to_string(i) + " differs in size or type from the first");
    const int r = i / cols, c = i % cols;
    images[i].copyTo(
        sheet(cv::Rect(gap + c * (cell.width + gap), gap + r * (cell.height + gap), cell.width, cell.height)));
  }
  return sheet;
}

cv::Vec4b sourceLayerColor(int code) {
  if (code == 254) return {214, 39, 40, 255};  // inpainted: red
  if (code == 253) return {60, 60, 60, 255};   // empty: dark grey
  if (code <= 0 || code > 250) return {210, 210, 210, 255};
  // Photos: a qualitative palette without red or grey, darker on each further round.
  static constexpr unsigned char kPalette[8][3] = {{31, 119, 180}, {255, 127, 14}, {44, 160, 44},   {148, 103, 189},
                                                   {23, 190, 207}, {188, 189, 34}, {227, 119, 194}, {140, 86, 75}};
  const int i = (code - 1) % 8, round = (code - 1) / 8;
  const double f = std::pow(0.75, round);
  return {static_cast<unsigned char>(kPalette[i][0] * f), static_cast<unsigned char>(kPalette[i][1] * f),
          static_cast<unsigned char>(kPalette[i][2] * f), 255};
}

cv::Mat colorizeSourceLayer(const cv::Mat& source) {
  TM_CHECK(source.type() == CV_8UC1, "source layer: expected an 8-bit single-channel image");
  cv::Vec4b lut[256];
  for (int i = 0; i < 256; ++i) lut[i] = sourceLayerColor(i);
  cv::Mat out(source.size(), CV_8UC4);
  for (int y = 0; y < source.rows; ++y) {
    const auto* s = source.ptr<unsigned char>(y);
    auto* o = out.ptr<cv::Vec4b>(y);
    for (int x = 0; x < source.cols; ++x) o[x] = lut[s[x]];
  }
  return out;
}

std::vector<int> sourceLayerCodes(const cv::Mat& source) {
  TM_CHECK(source.type() == CV_8UC1, "source layer: expected an 8-bit single-channel image");
  std::vector<char> seen(256, 0);
  for (int y = 0; y < source.rows; ++y) {
    const auto* s = source.ptr<unsigned char>(y);
    for (int x = 0; x < source.cols; ++x) seen[s[x]] = 1;
  }
  std::vector<int> codes;
  for (int i = 1; i < 256; ++i)
    if (seen[i]) codes.push_back(i);
  return codes;
}

void drawLegend(cv::Mat& rgba, const std::vector<std::pair<cv::Vec4b, std::string>>& entries) {
  const double scale = std::max(0.5, rgba.rows / 900.0);
  const int line = static_cast<int>(std::lround(28 * scale)), pad = line / 3;
  int width = 0;
  for (const auto& [colour, label] : entries) {
    int base = 0;
    width = std::max(width, cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, 0.6 * scale, 1, &base).width);
  }
  const cv::Rect box(pad, pad, std::min(rgba.cols - 2 * pad, 3 * pad + line + width),
                     std::min(rgba.rows - 2 * pad, pad + line * static_cast<int>(entries.size())));
  cv::Mat roi = rgba(box);
  roi = 0.25 * roi + cv::Scalar(191, 191, 191, 191);  // a light, mostly opaque panel
  for (size_t i = 0; i < entries.size(); ++i) {
    const int y = box.y + pad / 2 + static_cast<int>(i) * line;
    const cv::Vec4b& c = entries[i].first;
    cv::rectangle(rgba, cv::Rect(box.x + pad, y + line / 6, line * 2 / 3, line * 2 / 3),
                  cv::Scalar(c[0], c[1], c[2], 255), cv::FILLED);
    cv::putText(rgba, entries[i].second, cv::Point(box.x + 2 * pad + line * 2 / 3, y + line * 3 / 4),
                cv::FONT_HERSHEY_SIMPLEX, 0.6 * scale, cv::Scalar(20, 20, 20, 255), std::max(1, int(scale + 0.5)),
                cv::LINE_AA);
  }
}

}  // namespace montage
