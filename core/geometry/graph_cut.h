// One alpha-expansion move on OpenCV's GCGraph (Boykov-Kolmogorov max-flow), shared by the view
// selection's Potts labelling and the shift-map fill: each variable either keeps its label or switches
// to alpha; the caller has added the pairwise edges, this adds the unary terms and cuts.
#pragma once

#include <algorithm>
#include <opencv2/core.hpp>  // gcgraph.hpp needs it first
#include <opencv2/imgproc/detail/gcgraph.hpp>
#include <vector>

namespace montage {

// `unary[i]`: the cost of switching minus the cost of keeping, per variable; `pairs`: pairwise edges the
// caller added (without any, every variable decides alone: GCGraph's max-flow needs an edge). Returns
// whether each variable switches. Switching (x = 1) is the sink side: the source edge carries the cost of
// switching, the sink edge the cost of keeping.
inline std::vector<char> expansionMove(cv::detail::GCGraph<double>& graph, const std::vector<double>& unary,
                                       int pairs) {
  const int m = static_cast<int>(unary.size());
  for (int i = 0; i < m; ++i) graph.addTermWeights(i, std::max(unary[i], 0.0), std::max(-unary[i], 0.0));
  if (pairs > 0) graph.maxFlow();
  std::vector<char> switches(m);
  for (int i = 0; i < m; ++i) switches[i] = pairs > 0 ? !graph.inSourceSegment(i) : unary[i] < 0;
  return switches;
}

}  // namespace montage
