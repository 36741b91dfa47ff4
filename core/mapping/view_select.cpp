// Alpha-expansion for Potts energies (see view_select.h).
//
// One expansion move: every node whose current label is not alpha and that may take alpha becomes a
// binary variable x (0 = keep, 1 = switch to alpha); the others are fixed. The energy of the move is
// graph-representable for Potts terms (Kolmogorov and Zabih 2004): with A = E(0,0), B = E(0,1),
// C = E(1,0), D = E(1,1) of a pair,  E = A + (C - A) x_i + (D - C) x_j + (B + C - A - D)(1 - x_i) x_j,
// where B + C - A - D >= 0. A node on the sink side of the minimum cut takes alpha.
#include "mapping/view_select.h"

#include <algorithm>
#include <boost/graph/adjacency_list.hpp>
#include <boost/graph/boykov_kolmogorov_max_flow.hpp>
#include <cmath>

namespace montage {

namespace {

using Traits = boost::adjacency_list_traits<boost::vecS, boost::vecS, boost::directedS>;
struct EdgeProp {
  double capacity = 0, residual = 0;
  Traits::edge_descriptor reverse;
};
using Graph = boost::adjacency_list<boost::vecS, boost::vecS, boost::directedS, boost::no_property, EdgeProp>;

// Adds the directed pair u->v (capacity c_uv) and v->u (capacity c_vu), each the other's reverse.
void addPair(Graph& g, int u, int v, double cuv, double cvu) {
  const auto e = boost::add_edge(u, v, g).first;
  const auto r = boost::add_edge(v, u, g).first;
  g[e].capacity = cuv;
  g[r].capacity = cvu;
  g[e].reverse = r;
  g[r].reverse = e;
}

}  // namespace

double PottsProblem::energy(const std::vector<int>& labels) const {
  double e = 0;
  for (int n = 0; n < numNodes; ++n)
    if (labels[n] >= 0) e += cost[size_t(n) * numLabels + labels[n]];
  for (size_t k = 0; k < edges.size(); ++k)
    if (labels[edges[k][0]] != labels[edges[k][1]]) e += weights[k];
  return e;
}

std::vector<int> solvePotts(const PottsProblem& p, std::vector<int> labels, int maxSweeps, PottsStats* stats) {
  TM_CHECK(static_cast<int>(labels.size()) == p.numNodes, "solvePotts: labels: " + std::to_string(labels.size()) +
                                                              " entries for " + std::to_string(p.numNodes) + " nodes");
  TM_CHECK(p.cost.size() == size_t(p.numNodes) * p.numLabels, "solvePotts: cost: wrong size");
  TM_CHECK(p.weights.size() == p.edges.size(), "solvePotts: weights: one per edge needed");
  auto cost = [&](int n, int l) { return p.cost[size_t(n) * p.numLabels + l]; };
  auto allowed = [&](int n, int l) { return l >= 0 && std::isfinite(cost(n, l)); };
  for (int n = 0; n < p.numNodes; ++n) {
    if (allowed(n, labels[n])) continue;
    int best = -1;
    for (int l = 0; l < p.numLabels; ++l)
      if (allowed(n, l) && (best < 0 || cost(n, l) < cost(n, best))) best = l;
    labels[n] = best;
  }
  // Adjacency (edge indices per node).
  std::vector<std::vector<int>> incident(p.numNodes);
  for (size_t k = 0; k < p.edges.size(); ++k) {
    TM_CHECK(p.weights[k] >= 0 && std::isfinite(p.weights[k]), "solvePotts: weights must be finite and >= 0");
    incident[p.edges[k][0]].push_back(static_cast<int>(k));
    incident[p.edges[k][1]].push_back(static_cast<int>(k));
  }

  PottsStats st;
  double energy = p.energy(labels);
  st.initialEnergy = energy;
  std::vector<int> var(p.numNodes, -1);
  std::vector<int> nodes;
  for (int sweep = 0; sweep < maxSweeps; ++sweep) {
    ++st.sweeps;
    bool changed = false;
    for (int alpha = 0; alpha < p.numLabels; ++alpha) {
      nodes.clear();
      for (int n = 0; n < p.numNodes; ++n)
        if (labels[n] != alpha && allowed(n, alpha)) {
          var[n] = static_cast<int>(nodes.size());
          nodes.push_back(n);
        }
      if (nodes.empty()) continue;
      const int m = static_cast<int>(nodes.size());
      const int source = m, sink = m + 1;
      Graph g(m + 2);
      std::vector<double> unary(m, 0.0);  // coefficient of x (switching to alpha) per variable
      for (int i = 0; i < m; ++i) {
        const int n = nodes[i];
        unary[i] += cost(n, alpha) - cost(n, labels[n]);
        for (int k : incident[n]) {
          const int other = p.edges[k][0] == n ? p.edges[k][1] : p.edges[k][0];
          const double w = p.weights[k];
          if (var[other] >= 0) {
            if (other < n) continue;  // each variable pair once
            // A = w[l_n != l_o], B = E(0,1) = w[l_n != alpha] = w, C = E(1,0) = w, D = 0.
            const double A = labels[n] != labels[other] ? w : 0, B = w, C = w, D = 0;
            const int j = var[other];
            unary[i] += C - A;
            unary[j] += D - C;
            const double pair = B + C - A - D;
            if (pair > 0) addPair(g, i, j, pair, 0);
          } else {
            // A fixed neighbour: keep pays w when labels differ, alpha pays w when it differs from alpha.
            unary[i] += (alpha != labels[other] ? w : 0) - (labels[n] != labels[other] ? w : 0);
          }
        }
      }
      for (int i = 0; i < m; ++i) {
        if (unary[i] > 0) addPair(g, source, i, unary[i], 0);
        if (unary[i] < 0) addPair(g, i, sink, -unary[i], 0);
      }
      std::vector<boost::default_color_type> color(m + 2);
      boost::boykov_kolmogorov_max_flow(
          g, boost::get(&EdgeProp::capacity, g), boost::get(&EdgeProp::residual, g), boost::get(&EdgeProp::reverse, g),
          boost::make_iterator_property_map(color.begin(), boost::get(boost::vertex_index, g)),
          boost::get(boost::vertex_index, g), source, sink);
      std::vector<int> next = labels;
      for (int i = 0; i < m; ++i)
        if (color[i] != boost::black_color) next[nodes[i]] = alpha;
      for (int n : nodes) var[n] = -1;
      const double e = p.energy(next);
      if (e < energy - 1e-9 * std::max(1.0, std::abs(energy))) {
        labels.swap(next);
        energy = e;
        changed = true;
        ++st.moves;
      }
    }
    if (!changed) break;
  }
  st.finalEnergy = energy;
  if (stats) *stats = st;
  return labels;
}

}  // namespace montage
