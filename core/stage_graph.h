// A pipeline declared once (issue 36). Each stage names what it reads: the earlier stages whose outputs it
// takes, the fields of the project document, and in words what else its code adds to its key (a tier, a warm
// start, file contents); its share of a typical run; whether the preview runs it. One runner (StageRun)
// derives from that declaration each stage's key, whether its kept output (StageMemo) serves, the
// cancellation point and progress report at its start, and its record in the report. The pipeline's own
// stages are declared in pipelineStages() (pipeline.cpp); Pipeline::addStage appends more.
#pragma once

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "base/job.h"

namespace montage {

struct StageDecl {
  std::string name;
  std::vector<int> reads;           // earlier stages (graph indices) whose outputs it reads; their keys are in its key
  std::vector<std::string> fields;  // the project document's fields it reads, as JSON pointers ("/options/seed");
                                    // "*" stands for every element of an array ("/photos/*/colorLocked")
  std::string also;                 // in words: what else its code adds to its key (empty: nothing)
  double typicalShare = 0;          // its share of a final run's time before a run was measured (progress bar)
  bool finalOnly = false;           // the final tier only: the preview stops before it
};

class StageGraph {
 public:
  // Appends a stage; its reads must be earlier stages and its share in [0, 1]. Returns its index.
  int add(StageDecl stage);
  int size() const { return static_cast<int>(stages_.size()); }
  const StageDecl& operator[](int i) const { return stages_.at(static_cast<size_t>(i)); }
  // Each stage's share of a run of the tier before one was measured, summing to 1 (finalOnly stages 0 in the
  // preview).
  std::vector<double> typicalShares(bool preview) const;
  // The values of stage i's fields in `document`, as one string (a missing field reads as null).
  std::string fieldsKey(int i, const nlohmann::json& document) const;

 private:
  std::vector<StageDecl> stages_;
};

// One stage of a run as report.json shows it.
struct StageRecord {
  StageId stage = StageId::Load;  // the graph index (the pipeline's own stages: StageId)
  std::string name;               // the declaration's
  bool cached = false;            // output reused from an earlier run
  double seconds = 0;             // wall time of this run (0 when cached)
  nlohmann::json counts;          // stage-specific figures (faces, photos, mapped faces...)
};

// What a stage keeps between runs: its output and the key of the inputs it was made from.
template <class T>
struct StageMemo {
  std::string key;
  std::shared_ptr<const T> value;
};

// One run through a graph: keys, reuse, cancellation points, progress and records, all from the declaration.
class StageRun {
 public:
  StageRun(const StageGraph& graph, const nlohmann::json& document, const JobControl& job);
  // Stage i starts: a cancellation point (throws Cancelled) and its progress report (fraction 0). Its key is the
  // keys of the stages it reads, its fields' values and `also`. `warm` (the preview's warm starts): what an
  // output made now would add to the key, since it starts from the last run's; a kept output with or without
  // it serves (a preview takes either), and the stage's key becomes the one of the output it gets.
  const std::string& begin(int i, const std::string& also = "", const std::string& warm = "");
  // Replaces stage i's key, for a stage whose key is known once it has run (the camera: its photos' fits).
  void setKey(int i, std::string key) { keys_.at(size_t(i)) = std::move(key); }
  const std::string& key(int i) const { return keys_.at(size_t(i)); }
  // Stage i's output: the memo's when it was made from this key, else make()'s, kept in the memo (only once
  // make() returns: a cancelled stage leaves the memo as it was).
  template <class T, class Make>
  std::shared_ptr<const T> get(int i, StageMemo<T>& memo, Make&& make) {
    std::string& key = keys_.at(size_t(i));
    const std::string& warm = warm_.at(size_t(i));
    if (memo.value && (memo.key == key || (!warm.empty() && memo.key == key + warm))) {
      key = memo.key;
      kept_.at(size_t(i)) = true;
      return memo.value;
    }
    std::shared_ptr<const T> made = make();
    memo = {key + warm, made};
    key = memo.key;
    return made;
  }
  // Whether get() reused stage i's kept output in this run.
  bool kept(int i) const { return kept_.at(size_t(i)) != 0; }
  // Records stage i with its figures: kept (0 s) when get() reused its output or `kept` says so, else the wall
  // time since begin() unless `seconds` is given.
  void record(int i, nlohmann::json counts, std::optional<bool> kept = {}, std::optional<double> seconds = {});
  // The recorded stages in declared order.
  std::vector<StageRecord> records() const;

 private:
  const StageGraph& graph_;
  const nlohmann::json& document_;
  const JobControl& job_;
  std::vector<std::string> keys_, warm_;
  std::vector<char> kept_;
  std::vector<std::chrono::steady_clock::time_point> started_;
  std::vector<std::optional<StageRecord>> records_;
};

}  // namespace montage
