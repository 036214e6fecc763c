// Tours over a patrol graph: the shortest closed walk through every vertex (a travelling
// salesman tour over the graph's shortest-path costs, expanded into a walk along its edges),
// the patrolling community's idleness reference (walk length over team size times speed).
#pragma once

#include <cstddef>
#include <vector>

#include "planning/patrol/patrol_graph.h"

namespace vigil::planning::patrol {

// Symmetric travel costs between the vertices of a graph (m): the graph's own shortest paths,
// or the planner's path lengths on the map.
class CostMatrix {
 public:
  CostMatrix() = default;
  explicit CostMatrix(size_t n, double fill = 0) : n_(n), c_(n * n, fill) {}
  static CostMatrix from(const GraphDistances& d);
  double operator()(int a, int b) const { return c_[static_cast<size_t>(a) * n_ + static_cast<size_t>(b)]; }
  void set(int a, int b, double v) {
    c_[static_cast<size_t>(a) * n_ + static_cast<size_t>(b)] = v;
    c_[static_cast<size_t>(b) * n_ + static_cast<size_t>(a)] = v;
  }
  size_t size() const { return n_; }

 private:
  size_t n_ = 0;
  std::vector<double> c_;
};

// An order of `subset` (a cyclic sequence, each once) of short total cost: nearest-neighbour
// starts from every vertex, each improved by 2-opt and Or-opt moves to a local optimum; the
// best is kept. Deterministic. A subset of one or two vertices is returned as is.
std::vector<int> solve_tour(const CostMatrix& cost, std::vector<int> subset);
double tour_cost(const CostMatrix& cost, const std::vector<int>& order);

struct ClosedWalk {
  std::vector<int> vertices;  // cyclic: the last is adjacent to the first (not repeated)
  std::vector<double> arc;    // arc length from vertices[0] to vertices[i] (m)
  double length = 0;          // the whole closed walk (m)
};

// The shortest closed walk (as solve_tour finds it) through every vertex of `subset` (all
// vertices when empty), along the graph's edges.
ClosedWalk closed_walk(const PatrolGraph& g, const GraphDistances& d, const std::vector<int>& subset = {});

}  // namespace vigil::planning::patrol
