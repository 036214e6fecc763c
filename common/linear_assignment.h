// Minimum-cost linear assignment (the Hungarian problem) on a rectangular cost matrix, with
// forbidden pairs. Used by the MOT metrics (vision/mot_metrics.h) for the per-frame matching of
// ground truth to hypotheses and the global identity matching of whole trajectories, and by the
// task allocator's optimal reference (planning/allocation).
//
// The solver is the shortest-augmenting-path method with dual potentials (Kuhn-Munkres in the
// form of Jonker and Volgenant, 1987): rows are added one at a time and each is routed to a
// free column along a shortest path in reduced costs, Dijkstra-style, O(rows^2 * cols).
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

namespace vigil {

// A rows x cols cost matrix, row-major. Entries that are not finite (NaN, +inf, -inf) mark
// pairs that may not be assigned.
struct CostMatrix {
  int rows = 0, cols = 0;
  std::vector<double> costs;  // rows * cols values

  CostMatrix() = default;
  CostMatrix(int r, int c, double fill = 0.0) : rows(r), cols(c), costs(static_cast<std::size_t>(r) * c, fill) {}
  double& at(int r, int c) { return costs[static_cast<std::size_t>(r) * cols + c]; }
  double at(int r, int c) const { return costs[static_cast<std::size_t>(r) * cols + c]; }
};

// The pairs (row, col) of an assignment with as many pairs on allowed entries as possible and,
// among those, the least total cost; sorted by row. Each row and each column appears at most
// once. An empty matrix or one without allowed entries gives no pairs.
std::vector<std::pair<int, int>> solve_linear_assignment(const CostMatrix& m);

// Total cost of `pairs` in `m`.
double assignment_cost(const CostMatrix& m, const std::vector<std::pair<int, int>>& pairs);

}  // namespace vigil

namespace vigil::vision {
// The vision code's historical names for the same solver.
using ::vigil::CostMatrix;
using ::vigil::solve_linear_assignment;
using ::vigil::assignment_cost;
}  // namespace vigil::vision
