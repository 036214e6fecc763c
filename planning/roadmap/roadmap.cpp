#include "planning/roadmap/roadmap.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <numeric>
#include <queue>
#include <sstream>

#include <ompl/base/PlannerData.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/geometric/planners/prm/PRM.h>

#include "planning/grid/any_angle.h"
#include "planning/ompl_space.h"

namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace vigil::planning {
namespace {

struct UnionFind {
  explicit UnionFind(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  }
  void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::vector<int> parent;
};

constexpr const char* kCacheMagic = "vigil-roadmap 1";

std::string params_line(const RoadmapParams& p, double radius) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "density %.17g min %d max %d k %d seed %llu radius %.17g", p.density, p.min_nodes,
                p.max_nodes, p.neighbours, static_cast<unsigned long long>(p.seed), radius);
  return buf;
}

}  // namespace

Status RoadmapParams::check(const std::string& file, int line) const {
  auto bad = [&](const char* key, const std::string& what) {
    return Status(bad_input(file, line, std::string("roadmap.") + key, what));
  };
  if (!(density >= 0.05 && density <= 50)) return bad("density", "must be in [0.05, 50] milestones per m^2");
  if (min_nodes < 2 || min_nodes > 1000000) return bad("min_nodes", "must be in [2, 1000000]");
  if (max_nodes < min_nodes || max_nodes > 1000000) return bad("max_nodes", "must be in [min_nodes, 1000000]");
  if (neighbours < 1 || neighbours > 100) return bad("neighbours", "must be in [1, 100]");
  if (connect_candidates < 1 || connect_candidates > 1000) return bad("connect_candidates", "must be in [1, 1000]");
  return Status::Ok();
}

Result<Roadmap> Roadmap::build(const InflatedGrid& grid, const RoadmapParams& params) {
  if (Status s = params.check(); !s) return s.error();
  if (grid.free_cells() == 0) return bad_input("", 0, "map", "no free space for the robot's radius");
  const auto t0 = std::chrono::steady_clock::now();
  Roadmap rm;
  rm.grid_ = &grid;
  rm.params_ = params;

  // OMPL's PRM over the inflated grid, grown to a milestone count (not a time) so the result
  // does not depend on the machine's speed.
  auto si = make_plane_space(
      grid.lower(), grid.upper(), [&grid](Vec2 p) { return grid.is_free(p); },
      [&grid](Vec2 a, Vec2 b) { return grid.segment_free(a, b); }, static_cast<uint32_t>(params.seed ^ (params.seed >> 32)));
  auto pdef = std::make_shared<ob::ProblemDefinition>(si);  // PRM needs one before it grows
  auto prm = std::make_shared<og::PRM>(si);
  prm->setMaxNearestNeighbors(static_cast<unsigned>(params.neighbours));
  prm->setProblemDefinition(pdef);
  prm->setup();
  double free_area = static_cast<double>(grid.free_cells()) * grid.grid().resolution() * grid.grid().resolution();
  const size_t target = static_cast<size_t>(
      std::clamp(params.density * free_area, static_cast<double>(params.min_nodes), static_cast<double>(params.max_nodes)));
  prm->growRoadmap(ob::PlannerTerminationCondition([&] { return prm->milestoneCount() >= target; }));
  ob::PlannerData data(si);
  prm->getPlannerData(data);
  rm.nodes_.reserve(data.numVertices());
  for (unsigned i = 0; i < data.numVertices(); ++i) rm.nodes_.push_back(state_point(data.getVertex(i).getState()));
  for (unsigned i = 0; i < data.numVertices(); ++i) {
    std::vector<unsigned> out;
    data.getEdges(i, out);
    for (unsigned j : out)
      if (i < j) rm.edges_.emplace_back(static_cast<int>(i), static_cast<int>(j));
  }
  std::sort(rm.edges_.begin(), rm.edges_.end());
  rm.edges_.erase(std::unique(rm.edges_.begin(), rm.edges_.end()), rm.edges_.end());
  rm.stats_.prm_nodes = rm.nodes_.size();

  // Bridges: within each connected free region, join the roadmap's components through the
  // shortest grid path between their nearest milestones.
  AnyAnglePlanner reference(grid);
  for (int guard = 0; guard < 10000; ++guard) {
    UnionFind uf(rm.nodes_.size());
    for (auto [a, b] : rm.edges_) uf.unite(a, b);
    // Per free region, the roadmap components in it (by smallest member).
    std::map<int, std::vector<int>> region_components;
    std::map<int, std::vector<int>> members;
    for (size_t i = 0; i < rm.nodes_.size(); ++i) members[uf.find(static_cast<int>(i))].push_back(static_cast<int>(i));
    for (const auto& [root, nodes] : members) region_components[grid.component(rm.nodes_[nodes.front()])].push_back(root);
    bool bridged = false;
    for (const auto& [region, roots] : region_components) {
      if (roots.size() < 2) continue;
      // The smallest component, joined to its nearest milestone in another component.
      int small = roots.front();
      for (int r : roots)
        if (members[r].size() < members[small].size()) small = r;
      double best = std::numeric_limits<double>::infinity();
      int from = -1, to = -1;
      for (int a : members[small]) {
        for (int r : roots) {
          if (r == small) continue;
          for (int b : members[r]) {
            const double d = (rm.nodes_[a] - rm.nodes_[b]).norm();
            if (d < best) best = d, from = a, to = b;
          }
        }
      }
      const ReferencePath bridge = reference.plan(rm.nodes_[from], rm.nodes_[to]);
      if (!bridge.found) continue;
      int prev = from;
      for (size_t k = 1; k < bridge.points.size(); ++k) {
        int id = to;
        if (k + 1 < bridge.points.size()) {
          id = static_cast<int>(rm.nodes_.size());
          rm.nodes_.push_back(bridge.points[k]);
        }
        rm.edges_.emplace_back(std::min(prev, id), std::max(prev, id));
        prev = id;
      }
      ++rm.stats_.bridges;
      bridged = true;
      break;  // recompute components
    }
    if (!bridged) break;
  }
  rm.finish();
  rm.stats_.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rm;
}

void Roadmap::finish() {
  adjacency_.assign(nodes_.size(), {});
  for (auto [a, b] : edges_) {
    const double d = (nodes_[a] - nodes_[b]).norm();
    adjacency_[a].emplace_back(b, d);
    adjacency_[b].emplace_back(a, d);
  }
  UnionFind uf(nodes_.size());
  for (auto [a, b] : edges_) uf.unite(a, b);
  component_.resize(nodes_.size());
  size_t comps = 0;
  for (size_t i = 0; i < nodes_.size(); ++i) {
    component_[i] = uf.find(static_cast<int>(i));
    comps += component_[i] == static_cast<int>(i);
  }
  stats_.nodes = nodes_.size();
  stats_.edges = edges_.size();
  stats_.components = comps;
}

Status Roadmap::save(const std::filesystem::path& file) const {
  std::ofstream out(file, std::ios::trunc);
  if (!out) return bad_input(file.string(), 0, "", "cannot write the roadmap cache");
  char buf[96];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(grid_->fingerprint()));
  out << kCacheMagic << "\nfingerprint " << buf << "\nparams " << params_line(params_, grid_->radius()) << "\n";
  out << "prm_nodes " << stats_.prm_nodes << " bridges " << stats_.bridges << "\n";
  out << "nodes " << nodes_.size() << "\n";
  for (const Vec2& p : nodes_) {
    std::snprintf(buf, sizeof buf, "%a %a\n", p.x, p.y);  // hex floats: exact round trip
    out << buf;
  }
  out << "edges " << edges_.size() << "\n";
  for (auto [a, b] : edges_) out << a << " " << b << "\n";
  if (!out) return bad_input(file.string(), 0, "", "cannot write the roadmap cache");
  return Status::Ok();
}

Result<Roadmap> Roadmap::build_cached(const InflatedGrid& grid, const RoadmapParams& params,
                                      const std::filesystem::path& file) {
  if (Status s = params.check(); !s) return s.error();
  std::ifstream in(file);
  if (in) {
    auto t0 = std::chrono::steady_clock::now();
    std::string line, fp_line, params_text;
    std::getline(in, line);
    char buf[32];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(grid.fingerprint()));
    bool ok = line == kCacheMagic && std::getline(in, fp_line) && fp_line == std::string("fingerprint ") + buf &&
              std::getline(in, params_text) && params_text == "params " + params_line(params, grid.radius());
    Roadmap rm;
    rm.grid_ = &grid;
    rm.params_ = params;
    std::string word;
    size_t n = 0, m = 0;
    if (ok) ok = static_cast<bool>(in >> word >> rm.stats_.prm_nodes >> word >> rm.stats_.bridges >> word >> n);
    if (ok && n <= 10'000'000) {
      rm.nodes_.resize(n);
      for (size_t i = 0; i < n && ok; ++i) {
        std::string xs, ys;
        ok = static_cast<bool>(in >> xs >> ys);
        if (ok) rm.nodes_[i] = {std::strtod(xs.c_str(), nullptr), std::strtod(ys.c_str(), nullptr)};
      }
      if (ok) ok = static_cast<bool>(in >> word >> m) && word == "edges";
      for (size_t i = 0; i < m && ok; ++i) {
        int a, b;
        ok = static_cast<bool>(in >> a >> b) && a >= 0 && b >= 0 && static_cast<size_t>(a) < n &&
             static_cast<size_t>(b) < n;
        if (ok) rm.edges_.emplace_back(a, b);
      }
    } else {
      ok = false;
    }
    if (ok) {
      rm.finish();
      rm.stats_.from_cache = true;
      rm.stats_.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      return rm;
    }
  }
  auto built = build(grid, params);
  if (!built) return built;
  (void)built->save(file);  // best effort: a read-only folder only costs the next run a rebuild
  return built;
}

std::vector<int> Roadmap::visible_nodes(Vec2 p) const {
  std::vector<std::pair<double, int>> by_distance;
  by_distance.reserve(nodes_.size());
  for (size_t i = 0; i < nodes_.size(); ++i) by_distance.emplace_back((nodes_[i] - p).norm(), static_cast<int>(i));
  const size_t k = std::min(by_distance.size(), static_cast<size_t>(params_.connect_candidates));
  std::partial_sort(by_distance.begin(), by_distance.begin() + k, by_distance.end());
  std::vector<int> out;
  for (size_t i = 0; i < k; ++i)
    if (grid_->segment_free(p, nodes_[by_distance[i].second])) out.push_back(by_distance[i].second);
  return out;
}

std::optional<std::vector<Vec2>> Roadmap::route(Vec2 start, Vec2 goal) const {
  if (grid_->segment_free(start, goal)) return std::vector<Vec2>{start, goal};
  const std::vector<int> from = visible_nodes(start), to = visible_nodes(goal);
  if (from.empty() || to.empty()) return std::nullopt;
  // A* over milestones; virtual node n is the goal.
  const int n = static_cast<int>(nodes_.size());
  std::vector<double> goal_cost(n, std::numeric_limits<double>::infinity());
  for (int t : to) goal_cost[t] = (nodes_[t] - goal).norm();
  std::vector<double> g(n + 1, std::numeric_limits<double>::infinity());
  std::vector<int> parent(n + 1, -1);
  std::vector<uint8_t> closed(n + 1, 0);
  struct Entry {
    double f, g;
    int node;
  };
  auto worse = [](const Entry& a, const Entry& b) {
    if (a.f != b.f) return a.f > b.f;
    return a.node > b.node;
  };
  std::priority_queue<Entry, std::vector<Entry>, decltype(worse)> open(worse);
  for (int f : from) {
    const double d = (nodes_[f] - start).norm();
    if (d < g[f]) {
      g[f] = d;
      parent[f] = -2;  // from the start
      open.push({d + (nodes_[f] - goal).norm(), d, f});
    }
  }
  while (!open.empty()) {
    const Entry e = open.top();
    open.pop();
    if (closed[e.node] || e.g != g[e.node]) continue;
    closed[e.node] = 1;
    if (e.node == n) break;
    if (std::isfinite(goal_cost[e.node])) {
      const double ng = e.g + goal_cost[e.node];
      if (ng < g[n]) {
        g[n] = ng;
        parent[n] = e.node;
        open.push({ng, ng, n});
      }
    }
    for (auto [m, d] : adjacency_[e.node]) {
      const double ng = e.g + d;
      if (ng < g[m]) {
        g[m] = ng;
        parent[m] = e.node;
        open.push({ng + (nodes_[m] - goal).norm(), ng, m});
      }
    }
  }
  if (!closed[n]) return std::nullopt;
  std::vector<Vec2> pts{goal};
  for (int c = parent[n]; c >= 0; c = parent[c]) pts.push_back(nodes_[c]);
  pts.push_back(start);
  std::reverse(pts.begin(), pts.end());
  return pts;
}

}  // namespace vigil::planning
