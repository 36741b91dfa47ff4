// Alpha-expansion for Potts energies (see view_select.h).
//
// One expansion move: every node whose current label is not alpha and that may take alpha becomes a
// binary variable x (0 = keep, 1 = switch to alpha); the others are fixed. The energy of the move is
// graph-representable for Potts terms (Kolmogorov and Zabih 2004): with A = E(0,0), B = E(0,1),
// C = E(1,0), D = E(1,1) of a pair,  E = A + (C - A) x_i + (D - C) x_j + (B + C - A - D)(1 - x_i) x_j,
// where B + C - A - D >= 0. A node on the sink side of the minimum cut takes alpha. The cut is
// Boykov-Kolmogorov max-flow (OpenCV's GCGraph, the one GrabCut uses: one flat edge array per move).
#include "mapping/view_select.h"

#include <algorithm>
#include <cmath>

#include "geometry/graph_cut.h"

namespace montage {

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
  // Adjacency (edge indices per node, compressed rows: node n's edges are incident[first[n] .. first[n+1])).
  std::vector<int> first(p.numNodes + 1, 0), incident(2 * p.edges.size());
  const size_t incidentEdges = p.edges.size();
  for (size_t k = 0; k < p.edges.size(); ++k) {
    TM_CHECK(p.weights[k] >= 0 && std::isfinite(p.weights[k]), "solvePotts: weights must be finite and >= 0");
    ++first[p.edges[k][0] + 1], ++first[p.edges[k][1] + 1];
  }
  for (int n = 0; n < p.numNodes; ++n) first[n + 1] += first[n];
  {
    std::vector<int> fill(first.begin(), first.end() - 1);
    for (size_t k = 0; k < p.edges.size(); ++k) {
      incident[fill[p.edges[k][0]]++] = static_cast<int>(k);
      incident[fill[p.edges[k][1]]++] = static_cast<int>(k);
    }
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
      cv::detail::GCGraph<double> g(m, 2 * incidentEdges);
      for (int i = 0; i < m; ++i) g.addVtx();
      std::vector<double> unary(m, 0.0);  // coefficient of x (switching to alpha) per variable
      int pairs = 0;                      // pairwise edges added
      for (int i = 0; i < m; ++i) {
        const int n = nodes[i];
        unary[i] += cost(n, alpha) - cost(n, labels[n]);
        for (int e = first[n]; e < first[n + 1]; ++e) {
          const int k = incident[e];
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
            if (pair > 0) g.addEdges(i, j, pair, 0), ++pairs;
          } else {
            // A fixed neighbour: keep pays w when labels differ, alpha pays w when it differs from alpha.
            unary[i] += (alpha != labels[other] ? w : 0) - (labels[n] != labels[other] ? w : 0);
          }
        }
      }
      const std::vector<char> switches = expansionMove(g, unary, pairs);
      std::vector<int> next = labels;
      for (int i = 0; i < m; ++i)
        if (switches[i]) next[nodes[i]] = alpha;
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
