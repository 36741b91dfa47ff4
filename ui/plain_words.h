// The pipeline's words for a user (issue 35, findings 5 and 6; GL-free): its warnings rewritten in plain
// words with what to do (the original kept for a tooltip), a stage's counts as rows of a table, and the
// concerns about a camera fit that passes but should not be trusted (its clicks nearly on one line, few
// of them, a click that disagrees).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "mapping/camera.h"

namespace montage {

struct PlainWarning {
  std::string text;      // what happened and what to do, in a user's words
  std::string original;  // the pipeline's own words (the tooltip)
};

// The warning in plain words. Warnings are "<stage>: <what>" (pipeline.cpp); known ones are rewritten,
// others keep their words without the stage prefix, which names where they came from instead
// ("(inpainting)"). Never empty for a non-empty warning.
PlainWarning plainWarning(const std::string& warning);

// A stage's counts (StageRecord::counts) as rows: one (name, value) per leaf, nested names joined with
// " / " ("photos / 0 / inliers"), underscores as spaces, numbers with at most 3 decimals, arrays of plain
// values on one row. An empty object gives no rows.
std::vector<std::pair<std::string, std::string>> countRows(const nlohmann::json& counts);

// Why a camera fit that passes is weak, each in plain words (empty when it is sound or does not fit, and
// for another subject, whose warp keeps every click): its agreeing clicks lie nearly on one line (their
// spread across their main direction under 20% of the spread along it), fewer than 8 clicks agree, or some
// clicks disagree with the camera ("1 of 10 clicks disagrees").
std::vector<std::string> weakFitConcerns(const CameraFit& fit);

}  // namespace montage
