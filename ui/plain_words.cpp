#include "plain_words.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <regex>

namespace montage {

namespace {

// "inpaint" -> "inpainting": where a warning comes from, as the Stages table names it.
std::string stageWords(const std::string& prefix) {
  static const std::vector<std::pair<std::string, std::string>> names = {
      {"mesh", "mesh"},           {"project", "project"}, {"camera", "camera fit"}, {"map", "mapping"},
      {"projection", "projection"}, {"balance", "colour balance"}, {"inpaint", "inpainting"}};
  for (const auto& [key, words] : names)
    if (key == prefix) return words;
  return prefix;
}

// Why a region is left empty (kCellStatusNames), in words with what to do.
std::string emptyReason(const std::string& status) {
  if (status == "touches the mesh border")
    return "they reach the mesh's open border with too few clicked lines around them; click points along the border "
           "in a photo that shows it";
  if (status == "not a disc")
    return "they wrap around a handle or a pinch of the mesh; click a point on each side of it in one photo";
  if (status == "not a triangle")
    return "no clicked points surround them in one photo; click three or more points around them in a photo that "
           "shows them";
  if (status == "no common photo")
    return "the points around them were clicked in different photos; click them in one photo";
  if (status == "mirrored")
    return "the points around them lie mirrored in the photo (clicked in the wrong order or on the wrong side); "
           "check those points";
  if (status == "failed") return "their map could not be built; move or add a point nearby";
  return status;
}

std::string trimNumber(double v) {
  char text[48];
  std::snprintf(text, sizeof(text), "%.3f", v);
  std::string s = text;
  while (!s.empty() && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s == "-0" ? "0" : s;
}

std::string valueWords(const nlohmann::json& v) {
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  if (v.is_number_float()) return trimNumber(v.get<double>());
  if (v.is_string()) return v.get<std::string>();
  if (v.is_null()) return "-";
  return v.dump();
}

void addRows(const nlohmann::json& v, const std::string& name, std::vector<std::pair<std::string, std::string>>& out) {
  if (v.is_object()) {
    for (const auto& [key, child] : v.items()) {
      std::string k = key;
      std::replace(k.begin(), k.end(), '_', ' ');
      addRows(child, name.empty() ? k : name + " / " + k, out);
    }
    return;
  }
  if (v.is_array()) {
    const bool plain = std::all_of(v.begin(), v.end(), [](const auto& e) { return !e.is_structured(); });
    if (plain) {
      std::string joined;
      for (const auto& e : v) joined += (joined.empty() ? "" : ", ") + valueWords(e);
      out.emplace_back(name, joined.empty() ? "none" : joined);
      return;
    }
    for (size_t i = 0; i < v.size(); ++i) addRows(v[i], name + " / " + std::to_string(i), out);
    return;
  }
  out.emplace_back(name, valueWords(v));
}

}  // namespace

PlainWarning plainWarning(const std::string& warning) {
  PlainWarning out{warning, warning};
  std::smatch m;
  const auto is = [&](const char* pattern) { return std::regex_match(warning, m, std::regex(pattern)); };
  if (is(R"re(inpaint: hole (\d+): synthesis: the hole and its band do not flatten without folds: filled with "(\w+)" instead)re")) {
    out.text = "Hole " + m[1].str() +
               " (a part no photo covers) could not take texture copied from around it: the surface around it does "
               "not lay flat. It is filled with smooth colours from its border instead. To give it texture, click "
               "it in a photo that shows it.";
  } else if (is(R"re(inpaint: hole (\d+): texture: the photo region picked for the hole (.*): filled with "(\w+)" instead)re")) {
    out.text = "Hole " + m[1].str() + " (a part no photo covers) cannot take its texture from the region drawn for it "
               "in a photo: it holds too little of the subject. It is filled with smooth colours from its border "
               "instead. Draw a larger region on the subject (Coverage tab: the photo button beside its fill).";
  } else if (is(R"re(inpaint: hole (\d+): texture: (.*): filled with "(\w+)" instead)re")) {
    out.text = "Hole " + m[1].str() + " (a part no photo covers) is filled with smooth colours from its border "
               "instead of texture continued from around it (" + m[2].str() +
               "). To give it texture, click it in a photo that shows it, or draw a photo region for its texture "
               "(Coverage tab).";
  } else if (is(R"re(inpaint: hole (\d+): synthesis: (.*): filled with "(\w+)" instead)re")) {
    out.text = "Hole " + m[1].str() + " (a part no photo covers) is filled with smooth colours from its border "
               "instead of texture copied from around it (" + m[2].str() +
               "). To give it texture, click it in a photo that shows it.";
  } else if (is(R"re(project: points\[(\d+)\]\.at\[\d+\]: \(([^)]*)\) lies on the background of photo (\d+) '(.*)' \(([0-9.]+) px from the foreground\))re")) {
    out.text = "Point " + m[1].str() + " lies on the background of photo " + m[3].str() + " (" + m[4].str() + "), " +
               m[5].str() + " px outside the object's outline at (" + m[2].str() +
               "): drag it onto the object, or refine the photo's cut-out if the object is there.";
  } else if (is(R"re(project: chains\[(\d+)\] and chains\[(\d+)\] cross in photo (\d+) '(.*)' at \(([^)]*)\).*)re")) {
    out.text = "Lines " + m[1].str() + " and " + m[2].str() + " cross in photo " + m[3].str() + " (" + m[4].str() +
               ") at (" + m[5].str() + "): the surface between them cannot be laid out there; move a point of one "
               "so that they no longer cross.";
  } else if (is(R"re(project: chains\[(\d+)\] crosses itself in photo (\d+) '(.*)' at \(([^)]*)\).*)re")) {
    out.text = "Line " + m[1].str() + " crosses itself in photo " + m[2].str() + " (" + m[3].str() + ") at (" +
               m[4].str() + "): move one of its points so that it no longer crosses.";
  } else if (is(R"re(project: (\d+) more (points lie on a photo's background|crossings of feature lines|self-intersections of feature lines or polygons))re")) {
    out.text = m[1].str() + " more " + m[2].str() + " (not listed one by one).";
  } else if (is(R"re(map: (\d+) regions? (?:is|are) left empty: (.*))re")) {
    const bool one = m[1].str() == "1";
    out.text = (one ? "1 part of the surface gets" : m[1].str() + " parts of the surface get") +
               " no photo and " + (one ? "is" : "are") + " filled in with colour: " + emptyReason(m[2].str()) + ".";
  } else if (is(R"re(map: (\d+) mapped faces are flipped in their photo)re")) {
    out.text = m[1].str() + " small triangles of the surface lie mirrored in their photo, so their texture is "
               "reversed there: look for clicked points whose lines cross in that photo and move one of them.";
  } else if (is(R"re(map: (\d+) texture coordinates could not leave the photo background)re")) {
    out.text = m[1].str() + " places on the surface take their colour from the photo's background: move the "
               "points near them inside the object's outline, or refine the photo's cut-out.";
  } else if (is(R"re(map: photo (\d+) maps by projection: fits: (.*))re")) {
    out.text = "Photo " + m[1].str() +
               ": its clicks fit one camera, so the photo is projected onto the surface it sees (" + m[2].str() + ").";
  } else if (is(R"re((?:map|camera): photo (\d+)(?: \(another subject\))? takes the paper's path: (?:does not fit: )?(.*))re")) {
    out.text = "Photo " + m[1].str() + ": its clicks do not fit one camera (" + m[2].str() +
               "), so the photo maps only between the points clicked in it: click more points, spread over the "
               "object, to map more of it.";
  } else if (is(R"re((?:map): photo (\d+) takes the paper's path \(another subject\))re")) {
    out.text = "Photo " + m[1].str() + " shows another subject: it maps only between the points clicked in it.";
  } else if (is(R"re(projection: photo (\d+) \(another subject\) takes the paper's path: (.*))re")) {
    // The reason up to its figures in parentheses: "the warp folds 60.3% of its faces".
    const std::string why = m[2].str().substr(0, m[2].str().find(" ("));
    out.text = "Photo " + m[1].str() + " shows another subject; bending it onto the surface by a camera and a "
               "warp was not better here (" + why + "), so it maps only between the points clicked in it.";
  } else if (is(R"re(balance: photo (\d+): the colour balance found no sensible transform \((.*)\); it keeps its colours)re")) {
    out.text = "Photo " + m[1].str() + "'s colours could not be matched to the other photos (" + m[2].str() +
               "): it is used as it is, and seams between it and the others may show. Tick \"lock colours\" of the "
               "photo the others should follow (Photos tab).";
  } else {
    // Unknown: the pipeline's words without the stage prefix, which says where it came from.
    static const std::regex prefix(R"re(^(mesh|project|camera|map|projection|balance|inpaint): (.*)$)re");
    if (std::regex_match(warning, m, prefix)) {
      std::string text = m[2].str();
      if (!text.empty()) text[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(text[0])));
      out.text = text + " (" + stageWords(m[1].str()) + ")";
    }
  }
  return out;
}

std::vector<std::pair<std::string, std::string>> countRows(const nlohmann::json& counts) {
  std::vector<std::pair<std::string, std::string>> out;
  if (counts.is_null() || (counts.is_object() && counts.empty())) return out;
  addRows(counts, "", out);
  return out;
}

std::vector<std::string> weakFitConcerns(const CameraFit& fit) {
  std::vector<std::string> out;
  if (!fit.fits || fit.subject) return out;
  std::vector<Vec2> agree;
  for (size_t i = 0; i < fit.clicks.size(); ++i)
    if (i < fit.inlier.size() && fit.inlier[i]) agree.push_back(fit.clicks[i].pixel);
  if (agree.size() >= 3) {
    Vec2 mean = Vec2::Zero();
    for (const Vec2& p : agree) mean += p;
    mean /= double(agree.size());
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const Vec2& p : agree) cov += (p - mean) * (p - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov / double(agree.size()));
    const double across = std::sqrt(std::max(0.0, eig.eigenvalues()[0]));
    const double along = std::sqrt(std::max(0.0, eig.eigenvalues()[1]));
    if (along > 0 && across < 0.2 * along)
      out.push_back("its clicks lie nearly on one line, which leaves the camera free to turn about it: click "
                    "points away from that line");
  }
  if (fit.inliers < 8)
    out.push_back("only " + std::to_string(fit.inliers) + " clicks agree with its camera: click a few more points");
  const int disagree = static_cast<int>(fit.clicks.size()) - fit.inliers;
  if (disagree > 0)
    out.push_back(std::to_string(disagree) + " of " + std::to_string(fit.clicks.size()) +
                  (disagree == 1 ? " clicks disagrees" : " clicks disagree") +
                  " with its camera (marked with a red cross): check where it was clicked");
  return out;
}

}  // namespace montage
