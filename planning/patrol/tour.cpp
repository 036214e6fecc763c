#include "planning/patrol/tour.h"

#include <algorithm>
#include <limits>
#include <numeric>

namespace vigil::planning::patrol {

CostMatrix CostMatrix::from(const GraphDistances& d) {
  CostMatrix m(d.size());
  for (size_t a = 0; a < d.size(); ++a) {
    for (size_t b = 0; b < d.size(); ++b) m.c_[a * m.n_ + b] = d.cost(static_cast<int>(a), static_cast<int>(b));
  }
  return m;
}

double tour_cost(const CostMatrix& c, const std::vector<int>& t) {
  double s = 0;
  for (size_t i = 0; i < t.size(); ++i) s += c(t[i], t[(i + 1) % t.size()]);
  return s;
}

namespace {

constexpr double kEps = 1e-9;

// 2-opt: reverse t[i+1..j] when that shortens the tour.
bool two_opt(const CostMatrix& c, std::vector<int>& t) {
  const size_t n = t.size();
  bool improved = false;
  for (size_t i = 0; i + 2 < n; ++i) {
    for (size_t j = i + 2; j < n; ++j) {
      if (i == 0 && j == n - 1) continue;
      const int a = t[i], b = t[i + 1], x = t[j], y = t[(j + 1) % n];
      const double delta = c(a, x) + c(b, y) - c(a, b) - c(x, y);
      if (delta < -kEps) {
        std::reverse(t.begin() + static_cast<long>(i) + 1, t.begin() + static_cast<long>(j) + 1);
        improved = true;
      }
    }
  }
  return improved;
}

// Or-opt: move a run of 1 to 3 vertices (either way round) to between two others.
bool or_opt(const CostMatrix& c, std::vector<int>& t) {
  const size_t n = t.size();
  for (size_t len = 1; len <= 3 && len + 2 <= n; ++len) {
    for (size_t i = 0; i < n; ++i) {
      // The run t[i..i+len-1] (cyclic), between p and q.
      const int p = t[(i + n - 1) % n], q = t[(i + len) % n];
      const int first = t[i], last = t[(i + len - 1) % n];
      const double removed = c(p, first) + c(last, q) - c(p, q);
      for (size_t k = 0; k < n; ++k) {
        // Insert between t[k] and t[k+1], both outside the run.
        bool inside = false;
        for (size_t r = 0; r <= len; ++r) {
          if ((i + n - 1 + r) % n == k) inside = true;
        }
        if (inside) continue;
        const int u = t[k], v = t[(k + 1) % n];
        const double fwd = c(u, first) + c(last, v) - c(u, v);
        const double rev = c(u, last) + c(first, v) - c(u, v);
        const double best = std::min(fwd, rev);
        if (best - removed < -kEps) {
          std::vector<int> run;
          for (size_t r = 0; r < len; ++r) run.push_back(t[(i + r) % n]);
          if (rev < fwd) std::reverse(run.begin(), run.end());
          std::vector<int> rest;
          for (size_t r = 0; r < n - len; ++r) rest.push_back(t[(i + len + r) % n]);
          // rest starts at q and ends at p; find u in it and insert after.
          std::vector<int> out;
          for (int x : rest) {
            out.push_back(x);
            if (x == u) out.insert(out.end(), run.begin(), run.end());
          }
          t = std::move(out);
          return true;
        }
      }
    }
  }
  return false;
}

}  // namespace

std::vector<int> solve_tour(const CostMatrix& c, std::vector<int> subset) {
  std::sort(subset.begin(), subset.end());
  subset.erase(std::unique(subset.begin(), subset.end()), subset.end());
  if (subset.size() <= 3) return subset;
  std::vector<int> best;
  double best_cost = std::numeric_limits<double>::infinity();
  for (size_t s = 0; s < subset.size(); ++s) {
    std::vector<int> t{subset[s]};
    std::vector<char> used(subset.size(), 0);
    used[s] = 1;
    for (size_t k = 1; k < subset.size(); ++k) {
      size_t pick = 0;
      double pd = std::numeric_limits<double>::infinity();
      for (size_t j = 0; j < subset.size(); ++j) {
        if (!used[j] && c(t.back(), subset[j]) < pd) {
          pd = c(t.back(), subset[j]);
          pick = j;
        }
      }
      used[pick] = 1;
      t.push_back(subset[pick]);
    }
    for (int guard = 0; guard < 1000; ++guard) {
      const bool a = two_opt(c, t);
      const bool b = or_opt(c, t);
      if (!a && !b) break;
    }
    const double tc = tour_cost(c, t);
    if (tc < best_cost - kEps) {
      best_cost = tc;
      best = t;
    }
  }
  // Start the cycle at its smallest vertex, so the answer does not depend on which start won.
  std::rotate(best.begin(), std::min_element(best.begin(), best.end()), best.end());
  return best;
}

ClosedWalk closed_walk(const PatrolGraph& g, const GraphDistances& d, const std::vector<int>& subset_in) {
  std::vector<int> subset = subset_in;
  if (subset.empty()) {
    subset.resize(g.size());
    std::iota(subset.begin(), subset.end(), 0);
  }
  const std::vector<int> order = solve_tour(CostMatrix::from(d), subset);
  ClosedWalk w;
  if (order.size() == 1) {
    w.vertices = order;
    w.arc = {0.0};
    return w;
  }
  for (size_t i = 0; i < order.size(); ++i) {
    const std::vector<int> leg = d.walk(order[i], order[(i + 1) % order.size()]);
    for (size_t k = 0; k + 1 < leg.size(); ++k) w.vertices.push_back(leg[k]);
  }
  double s = 0;
  for (size_t i = 0; i < w.vertices.size(); ++i) {
    w.arc.push_back(s);
    s += d.cost(w.vertices[i], w.vertices[(i + 1) % w.vertices.size()]);
  }
  w.length = s;
  return w;
}

}  // namespace vigil::planning::patrol
