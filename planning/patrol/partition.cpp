#include "planning/patrol/partition.h"

#include <algorithm>
#include <optional>
#include <cmath>
#include <limits>
#include <map>

#include "common/linear_assignment.h"

namespace vigil::planning::patrol {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = 1e-6;

// The regions' walk lengths, with a cache by vertex set (the local search asks for the same
// sets again and again).
class WalkCosts {
 public:
  explicit WalkCosts(const GraphDistances& d) : c_(CostMatrix::from(d)) {}
  double of(std::vector<int> vertices) {
    std::sort(vertices.begin(), vertices.end());
    if (vertices.size() <= 1) return 0;
    auto it = cache_.find(vertices);
    if (it != cache_.end()) return it->second;
    const double cost = tour_cost(c_, solve_tour(c_, vertices));
    cache_.emplace(std::move(vertices), cost);
    return cost;
  }

 private:
  CostMatrix c_;
  std::map<std::vector<int>, double> cache_;
};

// Whether the vertices of region `r` (with `without` left out) are connected along the graph.
bool connected(const PatrolGraph& g, const std::vector<int>& region, int r, int without) {
  int start = -1, size = 0;
  for (size_t v = 0; v < region.size(); ++v) {
    if (region[v] == r && static_cast<int>(v) != without) {
      ++size;
      if (start < 0) start = static_cast<int>(v);
    }
  }
  if (size <= 1) return true;
  std::vector<char> seen(region.size(), 0);
  std::vector<int> stack{start};
  seen[static_cast<size_t>(start)] = 1;
  int reached = 1;
  while (!stack.empty()) {
    const int v = stack.back();
    stack.pop_back();
    for (const GraphEdge& e : g.vertex(static_cast<size_t>(v)).edges) {
      if (e.to == without || region[static_cast<size_t>(e.to)] != r || seen[static_cast<size_t>(e.to)]) continue;
      seen[static_cast<size_t>(e.to)] = 1;
      ++reached;
      stack.push_back(e.to);
    }
  }
  return reached == size;
}

// What the search minimises, compared in order: regions under the least size, the longest
// walk, the sum of squared walks.
struct Score {
  int undersized = 0;
  double longest = 0, squares = 0;
  bool better_than(const Score& o) const {
    if (undersized != o.undersized) return undersized < o.undersized;
    if (longest < o.longest - kEps) return true;
    if (longest > o.longest + kEps) return false;
    return squares < o.squares - kEps;
  }
};

Score score(const std::vector<double>& walk, const std::vector<int>& sizes, int min_size, double min_walk) {
  Score s;
  for (size_t r = 0; r < walk.size(); ++r) {
    s.undersized += sizes[r] < min_size || walk[r] < min_walk - kEps;
    s.longest = std::max(s.longest, walk[r]);
    s.squares += walk[r] * walk[r];
  }
  return s;
}

std::vector<int> members_of(const std::vector<int>& region, int r) {
  std::vector<int> out;
  for (size_t v = 0; v < region.size(); ++v) {
    if (region[v] == r) out.push_back(static_cast<int>(v));
  }
  return out;
}

// Seeds by farthest-point sampling from `first`, then every vertex to its nearest seed (ties
// to the lower seed index). Each region is connected: a vertex's predecessor on a shortest
// path to its seed is at least as near that seed.
std::vector<int> voronoi(const GraphDistances& d, int n, int k, int first) {
  std::vector<int> seeds{first};
  while (static_cast<int>(seeds.size()) < k) {
    int far = -1;
    double fd = -1;
    for (int v = 0; v < n; ++v) {
      double near = kInf;
      for (int s : seeds) near = std::min(near, d.cost(v, s));
      if (near > fd + kEps) {
        fd = near;
        far = v;
      }
    }
    seeds.push_back(far);
  }
  std::vector<int> region(static_cast<size_t>(n), 0);
  for (int v = 0; v < n; ++v) {
    double best = kInf;
    for (int r = 0; r < k; ++r) {
      if (d.cost(v, seeds[static_cast<size_t>(r)]) < best - kEps) {
        best = d.cost(v, seeds[static_cast<size_t>(r)]);
        region[static_cast<size_t>(v)] = r;
      }
    }
  }
  return region;
}

// Voronoi ties can still cut a region where two shortest paths tie; any vertex cut off from
// its region's largest piece joins a neighbouring region instead.
void repair(const PatrolGraph& g, std::vector<int>& region, int k) {
  for (int guard = 0; guard < static_cast<int>(region.size()) * 2; ++guard) {
    bool changed = false;
    for (int r = 0; r < k && !changed; ++r) {
      if (connected(g, region, r, -1)) continue;
      // Keep the piece holding the region's lowest vertex; move one vertex of another piece.
      const std::vector<int> in = members_of(region, r);
      std::vector<char> seen(region.size(), 0);
      std::vector<int> stack{in.front()};
      seen[static_cast<size_t>(in.front())] = 1;
      while (!stack.empty()) {
        const int v = stack.back();
        stack.pop_back();
        for (const GraphEdge& e : g.vertex(static_cast<size_t>(v)).edges) {
          if (region[static_cast<size_t>(e.to)] == r && !seen[static_cast<size_t>(e.to)]) {
            seen[static_cast<size_t>(e.to)] = 1;
            stack.push_back(e.to);
          }
        }
      }
      for (int v : in) {
        if (seen[static_cast<size_t>(v)]) continue;
        for (const GraphEdge& e : g.vertex(static_cast<size_t>(v)).edges) {
          if (region[static_cast<size_t>(e.to)] != r) {
            region[static_cast<size_t>(v)] = region[static_cast<size_t>(e.to)];
            changed = true;
            break;
          }
        }
        if (changed) break;
      }
    }
    if (!changed) return;
  }
}

// Moves one boundary vertex at a time to a neighbouring region, the best move each round,
// while it improves the score.
void improve(const PatrolGraph& g, WalkCosts& costs, std::vector<int>& region, int k, int min_size, double min_walk,
             int max_moves) {
  const int n = static_cast<int>(region.size());
  std::vector<double> walk(static_cast<size_t>(k));
  std::vector<int> sizes(static_cast<size_t>(k), 0);
  for (int r = 0; r < k; ++r) walk[static_cast<size_t>(r)] = costs.of(members_of(region, r));
  for (int v = 0; v < n; ++v) ++sizes[static_cast<size_t>(region[static_cast<size_t>(v)])];
  Score now = score(walk, sizes, min_size, min_walk);
  for (int moves = 0; moves < max_moves; ++moves) {
    Score best = now;
    int bv = -1, bto = -1;
    double bwa = 0, bwb = 0;
    for (int v = 0; v < n; ++v) {
      const int from = region[static_cast<size_t>(v)];
      if (sizes[static_cast<size_t>(from)] <= 1) continue;
      int holds = -1;  // whether v holds its region together (then it may not move): -1 not known yet
      std::vector<int> tried;
      for (const GraphEdge& e : g.vertex(static_cast<size_t>(v)).edges) {
        const int to = region[static_cast<size_t>(e.to)];
        if (to == from || std::find(tried.begin(), tried.end(), to) != tried.end()) continue;
        tried.push_back(to);
        if (holds < 0) holds = connected(g, region, from, v) ? 0 : 1;
        if (holds) break;
        region[static_cast<size_t>(v)] = to;
        const double wa = costs.of(members_of(region, from));
        const double wb = costs.of(members_of(region, to));
        region[static_cast<size_t>(v)] = from;
        std::vector<double> w2 = walk;
        std::vector<int> s2 = sizes;
        w2[static_cast<size_t>(from)] = wa;
        w2[static_cast<size_t>(to)] = wb;
        --s2[static_cast<size_t>(from)];
        ++s2[static_cast<size_t>(to)];
        const Score sc = score(w2, s2, min_size, min_walk);
        if (sc.better_than(best)) {
          best = sc;
          bv = v;
          bto = to;
          bwa = wa;
          bwb = wb;
        }
      }
    }
    if (bv < 0) return;
    const int from = region[static_cast<size_t>(bv)];
    region[static_cast<size_t>(bv)] = bto;
    walk[static_cast<size_t>(from)] = bwa;
    walk[static_cast<size_t>(bto)] = bwb;
    --sizes[static_cast<size_t>(from)];
    ++sizes[static_cast<size_t>(bto)];
    now = best;
  }
}

// A spanning tree of the graph (Kruskal: the cheapest edges first; the DIAG graphs are nearly
// trees already): per vertex its neighbours in the tree with the edge costs.
std::vector<std::vector<GraphEdge>> spanning_tree(const PatrolGraph& g) {
  const int n = static_cast<int>(g.size());
  struct E {
    double cost;
    int a, b;
  };
  std::vector<E> edges;
  for (int a = 0; a < n; ++a) {
    for (const GraphEdge& e : g.vertex(static_cast<size_t>(a)).edges) {
      if (a < e.to) edges.push_back({e.cost, a, e.to});
    }
  }
  std::stable_sort(edges.begin(), edges.end(), [](const E& x, const E& y) { return x.cost < y.cost; });
  std::vector<int> up(static_cast<size_t>(n));
  for (int v = 0; v < n; ++v) up[static_cast<size_t>(v)] = v;
  auto root = [&](int v) {
    while (up[static_cast<size_t>(v)] != v) v = up[static_cast<size_t>(v)] = up[static_cast<size_t>(up[static_cast<size_t>(v)])];
    return v;
  };
  std::vector<std::vector<GraphEdge>> tree(static_cast<size_t>(n));
  for (const E& e : edges) {
    const int ra = root(e.a), rb = root(e.b);
    if (ra == rb) continue;
    up[static_cast<size_t>(ra)] = rb;
    tree[static_cast<size_t>(e.a)].push_back({e.b, e.cost});
    tree[static_cast<size_t>(e.b)].push_back({e.a, e.cost});
  }
  return tree;
}

// The fewest connected pieces of a tree whose edges inside each weigh at most `bound` (the
// greedy of Kundu and Misra, 1977, for edge weights): leaves up, a vertex keeps the lightest
// of its children's open pieces (each with the edge to it) while they fit and cuts the rest
// off as pieces of their own. A child's piece lighter than `least` may not be cut off (it
// always joins); a piece that then weighs more than the bound makes the answer "too many".
// Returns the pieces as a region per vertex, and their number.
int cut_tree(const std::vector<std::vector<GraphEdge>>& tree, int root, double bound, double least,
             std::vector<int>& region) {
  const int n = static_cast<int>(tree.size());
  std::vector<int> parent(static_cast<size_t>(n), -1), order;
  std::vector<char> seen(static_cast<size_t>(n), 0);
  std::vector<int> stack{root};
  seen[static_cast<size_t>(root)] = 1;
  while (!stack.empty()) {
    const int v = stack.back();
    stack.pop_back();
    order.push_back(v);
    for (const GraphEdge& e : tree[static_cast<size_t>(v)]) {
      if (seen[static_cast<size_t>(e.to)]) continue;
      seen[static_cast<size_t>(e.to)] = 1;
      parent[static_cast<size_t>(e.to)] = v;
      stack.push_back(e.to);
    }
  }
  std::vector<double> open(static_cast<size_t>(n), 0);  // weight of the piece a vertex passes up
  std::vector<char> cut(static_cast<size_t>(n), 0);       // the edge to the parent is cut
  int pieces = 0;
  bool over = false;
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    const int v = *it;
    std::vector<std::pair<double, int>> joins;
    for (const GraphEdge& e : tree[static_cast<size_t>(v)]) {
      if (e.to != parent[static_cast<size_t>(v)]) joins.push_back({open[static_cast<size_t>(e.to)] + e.cost, e.to});
    }
    std::sort(joins.begin(), joins.end());
    double acc = 0;
    for (const auto& [w, c] : joins) {
      if (open[static_cast<size_t>(c)] < least - kEps) acc += w;  // too light to stand alone
    }
    for (const auto& [w, c] : joins) {
      if (open[static_cast<size_t>(c)] < least - kEps) continue;
      if (acc + w <= bound + kEps) {
        acc += w;
      } else {
        cut[static_cast<size_t>(c)] = 1;
        ++pieces;
      }
    }
    if (acc > bound + kEps) over = true;
    open[static_cast<size_t>(v)] = acc;
  }
  ++pieces;  // the root's
  region.assign(static_cast<size_t>(n), -1);
  int next = 0;
  for (int v : order) {
    const int p = parent[static_cast<size_t>(v)];
    region[static_cast<size_t>(v)] = (p < 0 || cut[static_cast<size_t>(v)]) ? next++ : region[static_cast<size_t>(p)];
  }
  return over ? n + 1 : pieces;
}

// Cuts a tree into `k` pieces with the least heaviest piece (bisection on the bound), then
// splits the heaviest pieces while there are fewer than `k`.
std::vector<int> tree_partition(const PatrolGraph& g, int k, int root, double least) {
  const auto tree = spanning_tree(g);
  double lo = 0, hi = 0;
  for (const auto& adj : tree) {
    for (const GraphEdge& e : adj) hi += 0.5 * e.cost;
  }
  std::vector<int> region;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (cut_tree(tree, root, mid, least, region) <= k) hi = mid;
    else lo = mid;
  }
  int pieces = cut_tree(tree, root, hi, least, region);
  // Fewer pieces than robots: halve the heaviest piece that splits into two pieces of at
  // least `least` each (else the heaviest with two vertices, its last vertex given away).
  auto weigh = [&](int r) {
    double w = 0;
    for (size_t v = 0; v < tree.size(); ++v) {
      for (const GraphEdge& e : tree[v]) {
        if (region[v] == r && region[static_cast<size_t>(e.to)] == r) w += 0.5 * e.cost;
      }
    }
    return w;
  };
  // Cuts piece r in two; false when no cut leaves both halves at least `least`.
  auto halve = [&](int r, bool forced) {
    std::vector<int> local(tree.size(), -1), global;
    for (size_t v = 0; v < tree.size(); ++v) {
      if (region[v] == r) {
        local[v] = static_cast<int>(global.size());
        global.push_back(static_cast<int>(v));
      }
    }
    if (global.size() < 2) return false;
    std::vector<std::vector<GraphEdge>> sub(global.size());
    for (size_t i = 0; i < global.size(); ++i) {
      for (const GraphEdge& e : tree[static_cast<size_t>(global[i])]) {
        if (local[static_cast<size_t>(e.to)] >= 0) sub[i].push_back({local[static_cast<size_t>(e.to)], e.cost});
      }
    }
    double a = 0, b = weigh(r);
    std::vector<int> part;
    for (int it = 0; it < 60; ++it) {
      const double mid = 0.5 * (a + b);
      if (cut_tree(sub, 0, mid, least, part) <= 2) b = mid;
      else a = mid;
    }
    bool ok = cut_tree(sub, 0, b, least, part) == 2;
    if (ok) {
      // Both halves must weigh at least `least` (the root's half is not checked by the cut).
      double w[2] = {0, 0};
      for (size_t i = 0; i < sub.size(); ++i) {
        for (const GraphEdge& e : sub[i]) {
          if (part[i] == part[static_cast<size_t>(e.to)]) w[part[i]] += 0.5 * e.cost;
        }
      }
      ok = w[0] >= least - kEps && w[1] >= least - kEps;
    }
    if (!ok) {
      if (!forced) return false;
      part.assign(global.size(), 0);
      part.back() = 1;
    }
    for (size_t i = 0; i < global.size(); ++i) {
      if (part[i] > 0) region[static_cast<size_t>(global[i])] = pieces + part[i] - 1;
    }
    ++pieces;
    return true;
  };
  while (pieces < k) {
    std::vector<std::pair<double, int>> heavy;
    for (int r = 0; r < pieces; ++r) heavy.push_back({-weigh(r), r});
    std::sort(heavy.begin(), heavy.end());
    bool done = false;
    for (const auto& [w, r] : heavy) {
      if ((done = halve(r, false))) break;
    }
    for (const auto& [w, r] : heavy) {
      if (done) break;
      done = halve(r, true);
    }
    if (!done) break;
  }
  return region;
}

// Regions under the least size take a vertex from a neighbour, which takes one from its
// neighbour in turn, along the shortest chain of regions that ends at one with a vertex to
// spare (an ejection chain): single moves cannot do this when every neighbour is at the
// least size itself. Each step must leave the giving region connected; a chain that breaks is
// undone.
void fill_undersized(const PatrolGraph& g, std::vector<int>& region, int k, int min_size) {
  const int n = static_cast<int>(region.size());
  auto size_of = [&](int r) { return static_cast<int>(std::count(region.begin(), region.end(), r)); };
  for (int round = 0; round < k; ++round) {
    int needy = -1;
    for (int r = 0; r < k && needy < 0; ++r) {
      if (size_of(r) < min_size) needy = r;
    }
    if (needy < 0) return;
    // Breadth-first over regions from the needy one: from region a to region b when b has a
    // vertex next to a that b can give without falling apart.
    std::vector<int> came(static_cast<size_t>(k), -2), via(static_cast<size_t>(k), -1);
    came[static_cast<size_t>(needy)] = -1;
    std::vector<int> queue{needy};
    int donor = -1;
    for (size_t qi = 0; qi < queue.size() && donor < 0; ++qi) {
      const int a = queue[qi];
      for (int v = 0; v < n && donor < 0; ++v) {
        const int b = region[static_cast<size_t>(v)];
        if (b == a || came[static_cast<size_t>(b)] != -2 || size_of(b) <= 1) continue;
        bool next_to_a = false;
        for (const GraphEdge& e : g.vertex(static_cast<size_t>(v)).edges) next_to_a |= region[static_cast<size_t>(e.to)] == a;
        if (!next_to_a || !connected(g, region, b, v)) continue;
        came[static_cast<size_t>(b)] = a;
        via[static_cast<size_t>(b)] = v;
        queue.push_back(b);
        if (size_of(b) > min_size) donor = b;
      }
    }
    if (donor < 0) return;  // nothing to spare within reach: the graph does not allow it
    const std::vector<int> before = region;
    for (int b = donor; came[static_cast<size_t>(b)] >= 0; b = came[static_cast<size_t>(b)]) {
      const int v = via[static_cast<size_t>(b)];
      if (region[static_cast<size_t>(v)] != b || !connected(g, region, b, v)) {
        region = before;
        return;
      }
      region[static_cast<size_t>(v)] = came[static_cast<size_t>(b)];
    }
  }
}

}  // namespace

GraphPartition partition_graph(const PatrolGraph& g, const GraphDistances& d, int count, const PartitionOptions& o) {
  GraphPartition out;
  const int n = static_cast<int>(g.size());
  if (n == 0 || count <= 0) return out;
  const int k = std::min(count, n);
  const int min_size = o.min_size > 0 ? o.min_size : (n >= 2 * k ? 2 : 1);
  WalkCosts costs(d);
  std::vector<int> best_region;
  Score best;
  best.undersized = n + 1;
  const int restarts = std::max(1, std::min(o.restarts, n));
  for (int r = 0; r < 2 * restarts; ++r) {
    // Odd starts: the tree cut from a root; even: Voronoi regions of spread seeds.
    const int first = static_cast<int>(static_cast<long long>(r / 2) * n / restarts);
    // The tree cut keeps lone vertices from standing alone when regions need two (a piece
    // of two vertices weighs more than nothing).
    const double least = std::max(0.5 * o.min_walk, min_size >= 2 ? 1e-3 : 0.0);
    std::vector<int> region = r % 2 ? tree_partition(g, k, first, least) : voronoi(d, n, k, first);
    repair(g, region, k);
    fill_undersized(g, region, k, min_size);
    improve(g, costs, region, k, min_size, o.min_walk, o.max_moves);
    std::vector<double> walk(static_cast<size_t>(k));
    std::vector<int> sizes(static_cast<size_t>(k), 0);
    for (int q = 0; q < k; ++q) walk[static_cast<size_t>(q)] = costs.of(members_of(region, q));
    for (int v = 0; v < n; ++v) ++sizes[static_cast<size_t>(region[static_cast<size_t>(v)])];
    const Score sc = score(walk, sizes, min_size, o.min_walk);
    if (best_region.empty() || sc.better_than(best)) {
      best = sc;
      best_region = region;
    }
  }
  // Number the regions by their lowest vertex, so the answer does not depend on the seeds.
  std::vector<int> order(static_cast<size_t>(k), -1);
  int next = 0;
  for (int v = 0; v < n; ++v) {
    int& o2 = order[static_cast<size_t>(best_region[static_cast<size_t>(v)])];
    if (o2 < 0) o2 = next++;
  }
  out.region.resize(static_cast<size_t>(n));
  for (int v = 0; v < n; ++v) out.region[static_cast<size_t>(v)] = order[static_cast<size_t>(best_region[static_cast<size_t>(v)])];
  for (int q = 0; q < next; ++q) {
    out.walks.push_back(closed_walk(g, d, members_of(out.region, q)));
    out.longest = std::max(out.longest, out.walks.back().length);
  }
  return out;
}

int GraphPartition::slots() const {
  int n = 0;
  for (size_t r = 0; r < walks.size(); ++r) n += r < robots.size() ? robots[r] : 1;
  return n;
}

double GraphPartition::longest_share() const {
  double m = 0;
  for (size_t r = 0; r < walks.size(); ++r) m = std::max(m, walks[r].length / (r < robots.size() ? robots[r] : 1));
  return m;
}

GraphPartition plan_regions(const PatrolGraph& g, const GraphDistances& d, int team, const PartitionOptions& o) {
  const double shared_cost = o.shared_cost;
  GraphPartition best;
  const int n = static_cast<int>(g.size());
  if (n == 0 || team <= 0) return best;
  Score best_score;
  PartitionOptions split = o;
  if (o.pad_short) split.min_walk = 0;  // short regions are padded, not avoided
  for (int q = std::min(team, n); q >= 1; --q) {
    GraphPartition p = partition_graph(g, d, q, split);
    // One robot each, then every further robot to the region with the longest share.
    p.robots.assign(static_cast<size_t>(p.count()), 1);
    auto length = [&](size_t r) { return o.pad_short ? std::max(p.walks[r].length, o.min_walk) : p.walks[r].length; };
    auto share = [&](size_t r) {
      return length(r) / p.robots[r] * (1.0 + shared_cost * (p.robots[r] - 1));
    };
    // A padded region is one robot's detour loop: never shared. Robots left with no region to
    // share make the plan undersized.
    auto shareable = [&](size_t r) { return !o.pad_short || p.walks[r].length >= o.min_walk - kEps; };
    int stranded = 0;
    for (int extra = team - p.count(); extra > 0; --extra) {
      std::optional<size_t> worst;
      for (size_t r = 0; r < p.walks.size(); ++r) {
        if (shareable(r) && (!worst || share(r) > share(*worst) + kEps)) worst = r;
      }
      if (!worst) {
        worst = 0;
        for (size_t r = 1; r < p.walks.size(); ++r) {
          if (share(r) > share(*worst) + kEps) worst = r;
        }
        ++stranded;
      }
      ++p.robots[*worst];
    }
    Score sc;
    sc.undersized = stranded;
    const int min_size = o.min_size > 0 ? o.min_size : (n >= 2 * q ? 2 : 1);
    for (int r = 0; r < p.count(); ++r) {
      const auto members = static_cast<int>(std::count(p.region.begin(), p.region.end(), r));
      sc.undersized += members < min_size || (!o.pad_short && p.walks[static_cast<size_t>(r)].length < o.min_walk - kEps);
      sc.longest = std::max(sc.longest, share(static_cast<size_t>(r)));
    }
    // More regions win ties (fewer robots share a walk).
    if (best.walks.empty() || sc.better_than(best_score)) {
      best_score = sc;
      best = std::move(p);
    }
  }
  return best;
}

std::vector<int> assign_regions(const PatrolGraph& g, const GraphDistances& d, const GraphPartition& p,
                                const std::vector<Vec2>& where) {
  const int m = static_cast<int>(where.size()), k = p.count();
  std::vector<int> out(static_cast<size_t>(m), -1);
  if (m == 0 || k == 0) return out;
  std::vector<int> slot_region;  // a column per place
  for (int r = 0; r < k; ++r) {
    const int places = static_cast<size_t>(r) < p.robots.size() ? p.robots[static_cast<size_t>(r)] : 1;
    for (int j = 0; j < places; ++j) slot_region.push_back(r);
  }
  vigil::CostMatrix c(m, static_cast<int>(slot_region.size()));
  for (int i = 0; i < m; ++i) {
    const int at = g.nearest(where[static_cast<size_t>(i)]);
    for (int r = 0; r < k; ++r) {
      double best = kInf;
      for (size_t v = 0; v < p.region.size(); ++v) {
        if (p.region[v] == r) best = std::min(best, d.cost(at, static_cast<int>(v)));
      }
      for (size_t j = 0; j < slot_region.size(); ++j) {
        if (slot_region[j] == r) c.at(i, static_cast<int>(j)) = best;
      }
    }
  }
  for (const auto& [i, j] : vigil::solve_linear_assignment(c)) out[static_cast<size_t>(i)] = slot_region[static_cast<size_t>(j)];
  return out;
}

}  // namespace vigil::planning::patrol
