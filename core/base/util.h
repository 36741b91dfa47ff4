// Small helpers shared by the core modules: wall-clock timing of stages and union-find.
#pragma once

#include <algorithm>
#include <chrono>
#include <numeric>
#include <vector>

namespace montage {

using Clock = std::chrono::steady_clock;

// Seconds of wall time since `start`.
inline double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Union-find over 0..n-1 with path halving; the smaller index becomes the root, so results do not
// depend on the order of unions.
struct UnionFind {
  std::vector<int> parent;
  explicit UnionFind(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(int a, int b) {
    a = find(a), b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

}  // namespace montage
