#include "stage_graph.h"

#include <numeric>

#include "base/common.h"

namespace montage {

namespace {

// Appends the value at `tokens` (from token k) under `node` to `out`; "*" walks every element of an array.
void appendField(const nlohmann::json& node, const std::vector<std::string>& tokens, size_t k, std::string& out) {
  if (k == tokens.size()) {
    out += node.dump();
    return;
  }
  const std::string& t = tokens[k];
  if (t == "*" && node.is_array()) {
    out += '[';
    for (const nlohmann::json& element : node) appendField(element, tokens, k + 1, out), out += ',';
    out += ']';
  } else if (node.is_object() && node.contains(t)) {
    appendField(node[t], tokens, k + 1, out);
  } else {
    out += "null";
  }
}

std::vector<std::string> pointerTokens(const std::string& pointer) {
  std::vector<std::string> tokens;
  for (size_t start = 1; start <= pointer.size();) {
    const size_t end = std::min(pointer.find('/', start), pointer.size());
    tokens.push_back(pointer.substr(start, end - start));
    start = end + 1;
  }
  return tokens;
}

}  // namespace

int StageGraph::add(StageDecl stage) {
  const int index = size();
  for (int r : stage.reads)
    TM_CHECK(r >= 0 && r < index,
             "stage '" + stage.name + "' reads stage " + std::to_string(r) + ", which is not declared before it");
  for (const std::string& f : stage.fields)
    TM_CHECK(!f.empty() && f[0] == '/', "stage '" + stage.name + "': field '" + f + "' is not a JSON pointer");
  TM_CHECK(stage.typicalShare >= 0 && stage.typicalShare <= 1,
           "stage '" + stage.name + "': typical share " + std::to_string(stage.typicalShare) + " is not in [0, 1]");
  stages_.push_back(std::move(stage));
  return index;
}

std::vector<double> StageGraph::typicalShares(bool preview) const {
  std::vector<double> w;
  for (const StageDecl& s : stages_) w.push_back(preview && s.finalOnly ? 0.0 : s.typicalShare);
  const double total = std::accumulate(w.begin(), w.end(), 0.0);
  for (double& x : w) x = total > 0 ? x / total : 1.0 / double(w.size());
  return w;
}

std::string StageGraph::fieldsKey(int i, const nlohmann::json& document) const {
  std::string key;
  for (const std::string& f : (*this)[i].fields) {
    key += f + '=';
    appendField(document, pointerTokens(f), 0, key);
    key += ';';
  }
  return key;
}

StageRun::StageRun(const StageGraph& graph, const nlohmann::json& document, const JobControl& job)
    : graph_(graph),
      document_(document),
      job_(job),
      keys_(size_t(graph.size())),
      warm_(size_t(graph.size())),
      kept_(size_t(graph.size()), 0),
      started_(size_t(graph.size())),
      records_(size_t(graph.size())) {}

const std::string& StageRun::begin(int i, const std::string& also, const std::string& warm) {
  job_.progress(static_cast<StageId>(i), 0.0);
  started_.at(size_t(i)) = std::chrono::steady_clock::now();
  std::string key;
  for (int r : graph_[i].reads) key += '{' + keys_.at(size_t(r)) + '}';
  key += graph_.fieldsKey(i, document_);
  key += also;
  keys_[size_t(i)] = std::move(key);
  warm_[size_t(i)] = warm;
  return keys_[size_t(i)];
}

void StageRun::record(int i, nlohmann::json counts, std::optional<bool> kept, std::optional<double> seconds) {
  StageRecord r;
  r.stage = static_cast<StageId>(i);
  r.name = graph_[i].name;
  r.cached = kept.value_or(kept_.at(size_t(i)) != 0);
  r.seconds =
      r.cached ? 0
               : seconds.value_or(
                     std::chrono::duration<double>(std::chrono::steady_clock::now() - started_.at(size_t(i))).count());
  r.counts = std::move(counts);
  records_.at(size_t(i)) = std::move(r);
}

std::vector<StageRecord> StageRun::records() const {
  std::vector<StageRecord> out;
  for (const auto& r : records_)
    if (r) out.push_back(*r);
  return out;
}

}  // namespace montage
