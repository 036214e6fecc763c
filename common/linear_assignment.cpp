#include "common/linear_assignment.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace vigil {

namespace {

// Minimum-cost assignment of every row of a dense n x m matrix (n <= m, all entries finite) to
// distinct columns. Returns col_of_row. Successive shortest augmenting paths with potentials
// u (rows) and v (columns); index 0 is a virtual column that holds the row being inserted.
std::vector<int> assign_rows(const std::vector<double>& a, int n, int m) {
  const double kInf = std::numeric_limits<double>::infinity();
  std::vector<double> u(n + 1, 0.0), v(m + 1, 0.0);
  std::vector<int> row_of_col(m + 1, 0);  // 1-based row assigned to column j, 0 = free
  std::vector<int> prev_col(m + 1, 0);    // predecessor column on the shortest path
  std::vector<double> dist(m + 1);
  std::vector<char> done(m + 1);
  auto cost = [&](int i, int j) { return a[static_cast<size_t>(i - 1) * m + (j - 1)]; };

  for (int i = 1; i <= n; ++i) {
    row_of_col[0] = i;
    int j0 = 0;
    std::fill(dist.begin(), dist.end(), kInf);
    std::fill(done.begin(), done.end(), 0);
    // Grow a shortest-path tree (Dijkstra on reduced costs) until it reaches a free column.
    do {
      done[j0] = 1;
      const int i0 = row_of_col[j0];
      double delta = kInf;
      int j1 = 0;
      for (int j = 1; j <= m; ++j) {
        if (done[j]) continue;
        const double reduced = cost(i0, j) - u[i0] - v[j];
        if (reduced < dist[j]) {
          dist[j] = reduced;
          prev_col[j] = j0;
        }
        if (dist[j] < delta) {
          delta = dist[j];
          j1 = j;
        }
      }
      // Shift the potentials so the tree's edges stay tight and the new column joins it.
      for (int j = 0; j <= m; ++j) {
        if (done[j]) {
          u[row_of_col[j]] += delta;
          v[j] -= delta;
        } else {
          dist[j] -= delta;
        }
      }
      j0 = j1;
    } while (row_of_col[j0] != 0);
    // Augment: flip the assignments along the path back to the virtual column.
    do {
      const int j1 = prev_col[j0];
      row_of_col[j0] = row_of_col[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  std::vector<int> col_of_row(n, -1);
  for (int j = 1; j <= m; ++j)
    if (row_of_col[j] != 0) col_of_row[row_of_col[j] - 1] = j - 1;
  return col_of_row;
}

}  // namespace

std::vector<std::pair<int, int>> solve_linear_assignment(const CostMatrix& m) {
  std::vector<std::pair<int, int>> pairs;
  if (m.rows <= 0 || m.cols <= 0) return pairs;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (double c : m.costs) {
    if (!std::isfinite(c)) continue;
    lo = std::min(lo, c);
    hi = std::max(hi, c);
  }
  if (!(lo <= hi)) return pairs;  // nothing allowed

  // Work on the orientation with no more rows than columns, costs shifted to start at 0.
  // A forbidden entry costs more than any n allowed entries together (n * range + 1), so an
  // optimal full assignment uses as few forbidden entries as possible (as many allowed pairs as
  // any matching can have) and, among those, has the least allowed cost; the forbidden pairs
  // are dropped afterwards.
  const bool transpose = m.rows > m.cols;
  const int n = transpose ? m.cols : m.rows;
  const int k = transpose ? m.rows : m.cols;
  const double forbidden = n * (hi - lo) + 1.0;
  std::vector<double> a(static_cast<size_t>(n) * k);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < k; ++j) {
      const double c = transpose ? m.at(j, i) : m.at(i, j);
      a[static_cast<size_t>(i) * k + j] = std::isfinite(c) ? c - lo : forbidden;
    }
  }
  const std::vector<int> col_of_row = assign_rows(a, n, k);
  for (int i = 0; i < n; ++i) {
    const int j = col_of_row[i];
    if (j < 0) continue;
    const int r = transpose ? j : i, c = transpose ? i : j;
    if (std::isfinite(m.at(r, c))) pairs.emplace_back(r, c);
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

double assignment_cost(const CostMatrix& m, const std::vector<std::pair<int, int>>& pairs) {
  double total = 0;
  for (const auto& [r, c] : pairs) total += m.at(r, c);
  return total;
}

}  // namespace vigil
