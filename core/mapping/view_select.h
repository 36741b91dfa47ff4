// View selection: which photo textures each face, as photogrammetric texturers choose it (Lempitsky and
// Ivanov 2007, Waechter et al. 2014): a data cost per (face, photo) from the view's quality and a
// Potts smoothness cost per edge between faces of different photos, minimised by alpha-expansion
// graph cuts (Boykov, Veksler and Zabih 2001) on Boost's Boykov-Kolmogorov max-flow.
#pragma once

#include <array>
#include <limits>
#include <vector>

#include "base/common.h"

namespace montage {

// A labelling problem with Potts pairwise terms: `cost[node * numLabels + label]` (kForbidden where a
// label is not allowed), and edges (a, b) with weights w >= 0, paying w when their labels differ.
struct PottsProblem {
  static constexpr double kForbidden = std::numeric_limits<double>::infinity();
  int numNodes = 0, numLabels = 0;
  std::vector<double> cost;                             // numNodes x numLabels
  std::vector<std::array<int, 2>> edges;                // node pairs
  std::vector<double> weights;                          // per edge
  double energy(const std::vector<int>& labels) const;  // kForbidden when a forbidden label is used
};

struct PottsStats {
  int sweeps = 0;  // passes over all labels
  int moves = 0;   // expansion moves that lowered the energy
  double initialEnergy = 0, finalEnergy = 0;
};

// Minimises the energy by alpha-expansion from `labels` (numNodes entries; each node's label must be
// allowed, or -1 to start from its cheapest allowed label). A node with no allowed label keeps -1.
// Sweeps over all labels until a sweep changes nothing (at most maxSweeps).
std::vector<int> solvePotts(const PottsProblem& problem, std::vector<int> labels, int maxSweeps = 8,
                            PottsStats* stats = nullptr);

}  // namespace montage
