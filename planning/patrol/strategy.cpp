#include "planning/patrol/strategy.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <set>
#include <tuple>

#include "common/linear_assignment.h"

namespace vigil::planning::patrol {

std::shared_ptr<const PatrolSetup> PatrolSetup::make(PatrolGraph g, CostMatrix travel, double speed) {
  auto s = std::make_shared<PatrolSetup>(PatrolSetup{std::move(g), GraphDistances(PatrolGraph()), {}, {}, speed});
  s->distances = GraphDistances(s->graph);
  s->travel = travel.size() == s->graph.size() ? std::move(travel) : CostMatrix::from(s->distances);
  s->tour = closed_walk(s->graph, s->distances);
  s->partitions = std::make_shared<PartitionCache>();
  return s;
}

struct PatrolSetup::PartitionCache {
  std::mutex mu;
  std::map<std::tuple<int, long long, long long, bool>, std::shared_ptr<const GraphPartition>> by_count;
};

std::shared_ptr<const GraphPartition> PatrolSetup::partition(int count, double min_walk, double shared_cost,
                                                             bool pad_short) const {
  std::lock_guard<std::mutex> lock(partitions->mu);
  auto& p = partitions->by_count[{count, std::llround(min_walk * 1000.0), std::llround(shared_cost * 1000.0), pad_short}];
  if (!p) {
    PartitionOptions o;
    o.min_walk = min_walk;
    o.shared_cost = shared_cost;
    o.pad_short = pad_short;
    p = std::make_shared<const GraphPartition>(plan_regions(graph, distances, count, o));
  }
  return p;
}

namespace {

double circ(double a, double L) {
  a = std::fmod(a, L);
  return a < 0 ? a + L : a;
}

// Cyclic: the even formation along the walk that moves the team least. A member may stand where
// the walk passes more than once (a tree's walk passes every inner vertex on the way out and
// back): each place it could count as is an arc of the walk vertex nearest to it. For every
// candidate base (one of those arcs less a multiple of the spacing), members go to the slots
// base + k L / N by least total shift (min-cost assignment); the base whose largest shift is
// least wins (then the least total). Returns my slot's arc. Every member computes the same
// from the same list.
double formation(const ClosedWalk& w, const PatrolGraph& g, const std::vector<std::string>& members,
                 const std::vector<Vec2>& where, int me) {
  const int n = static_cast<int>(members.size());
  if (w.length <= 0 || n == 0) return 0;
  const double L = w.length, gap = L / static_cast<double>(n);
  std::vector<std::vector<double>> places(static_cast<size_t>(n));
  for (int m = 0; m < n; ++m) {
    const int v = g.nearest(where[static_cast<size_t>(m)]);
    for (size_t i = 0; i < w.vertices.size(); ++i) {
      if (w.vertices[i] == v) places[static_cast<size_t>(m)].push_back(w.arc[i]);
    }
    if (places[static_cast<size_t>(m)].empty()) places[static_cast<size_t>(m)].push_back(0);
  }
  auto dist = [&](double a, double b) {
    const double d = circ(a - b, L);
    return std::min(d, L - d);
  };
  double best_max = std::numeric_limits<double>::infinity(), best_sum = best_max, best_slot = 0;
  std::set<long long> tried;
  for (int m = 0; m < n; ++m) {
    for (double a : places[static_cast<size_t>(m)]) {
      for (int k = 0; k < n; ++k) {
        const double base = circ(a - k * gap, L);
        if (!tried.insert(std::llround(base * 1000.0)).second) continue;
        vigil::CostMatrix c(n, n);
        for (int r = 0; r < n; ++r) {
          for (int s = 0; s < n; ++s) {
            double d = std::numeric_limits<double>::infinity();
            for (double p : places[static_cast<size_t>(r)]) d = std::min(d, dist(p, base + s * gap));
            c.at(r, s) = d;
          }
        }
        const auto pairs = vigil::solve_linear_assignment(c);
        double mx = 0, sum = 0;
        int mine = 0;
        for (const auto& [r, s] : pairs) {
          mx = std::max(mx, c.at(r, s));
          sum += c.at(r, s);
          if (r == me) mine = s;
        }
        if (mx < best_max - 1e-6 || (mx < best_max + 1e-6 && sum < best_sum - 1e-6)) {
          best_max = mx;
          best_sum = sum;
          best_slot = circ(base + mine * gap, L);
        }
      }
    }
  }
  return best_slot;
}

// The first walk index at or after an arc length (cyclic).
size_t index_at(const ClosedWalk& w, double a) {
  a = circ(a, w.length);
  for (size_t i = 0; i < w.arc.size(); ++i) {
    if (w.arc[i] >= a - 1e-9) return i;
  }
  return 0;
}

class Cyclic : public PatrolStrategy {
 public:
  // Along the whole graph's walk, or along `walk` (a region's, for the partition strategy).
  Cyclic(std::shared_ptr<const PatrolSetup> s, const StrategyParams& p) : s_(std::move(s)), p_(p), w_(s_->tour) {}
  Cyclic(std::shared_ptr<const PatrolSetup> s, const StrategyParams& p, ClosedWalk walk)
      : s_(std::move(s)), p_(p), w_(std::move(walk)) {}
  const char* name() const override { return "cyclic"; }
  void set_team(const std::vector<std::string>& members, const std::vector<Vec2>& where, int me) override {
    cursor_ = index_at(w_, formation(w_, s_->graph, members, where, me));
  }
  int next(int at, Vec2, const PatrolKnowledge&) override {
    const auto& v = w_.vertices;
    if (at >= 0 && at == v[cursor_]) cursor_ = (cursor_ + 1) % v.size();
    return v[cursor_];
  }
  int64_t walk_index() const override { return static_cast<int64_t>(cursor_); }
  // The arc of the walk vertex I head for (the walk's end for index 0, so that the last edge
  // counts from the arc before it) less what is left to drive.
  double phase(double remaining) const override {
    const ClosedWalk& w = w_;
    if (w.length <= 0) return 0;
    const double to = cursor_ == 0 ? w.length : w.arc[cursor_];
    return circ(to - std::max(0.0, remaining), w.length);
  }
  double pace(double mine, const std::vector<std::pair<std::string, double>>& mates) const override {
    const double L = w_.length;
    if (L <= 0 || mine < 0) return 1;
    double ahead = L, behind = L;
    int n = 0;
    for (const auto& [who, m] : mates) {
      if (m < 0) continue;
      ++n;
      const double d = circ(m - mine, L);
      ahead = std::min(ahead, d);
      behind = std::min(behind, circ(L - d, L));
    }
    if (n == 0) return 1;
    return spacing_pace(ahead, behind, L / (n + 1), p_.pace_gain, p_.min_pace, p_.pace_band);
  }
  // At a vertex (the cursor has moved on to the next): my arc is that of the vertex before
  // the cursor; a mate's is its target's arc less what it still has to drive. Hold while the
  // gap to the robot ahead is shorter than the gap to the one behind by more than a tenth of
  // the even spacing: half the difference, at cruise speed.
  double hold(const PatrolKnowledge& k) const override {
    const ClosedWalk& w = w_;
    if (k.others.empty() || w.length <= 0) return 0;
    const size_t m = w.vertices.size();
    const double L = w.length;
    const double mine = w.arc[(cursor_ + m - 1) % m];
    double ahead = L, behind = L;
    for (const auto& [who, in] : k.others) {
      if (in.walk_index < 0 || static_cast<size_t>(in.walk_index) >= m) continue;
      const double remaining = std::max(0.0, in.eta - k.now) * s_->speed;
      const double theirs = w.arc[static_cast<size_t>(in.walk_index)] - remaining;
      const double d = circ(theirs - mine, L);
      if (d > 1e-6) ahead = std::min(ahead, d);
      if (L - d > 1e-6) behind = std::min(behind, L - d);
    }
    const double spacing = L / static_cast<double>(k.others.size() + 1);
    if (ahead >= behind - 0.1 * spacing) return 0;
    return std::min(0.5 * (behind - ahead), 0.5 * spacing) / s_->speed;
  }

 private:
  std::shared_ptr<const PatrolSetup> s_;
  StrategyParams p_;
  ClosedWalk w_;
  size_t cursor_ = 0;
};

class Partition : public PatrolStrategy {
 public:
  Partition(std::shared_ptr<const PatrolSetup> s, const StrategyParams& p) : s_(std::move(s)), p_(p) {}
  const char* name() const override { return "partition"; }
  // My region: the team's plan for its size (plan_regions), members given to regions by
  // least total distance from where they are (every member computes the same); the members of
  // my region spread along its walk as the cyclic strategy spreads a team.
  void set_team(const std::vector<std::string>& members, const std::vector<Vec2>& where, int me) override {
    const auto plan = s_->partition(static_cast<int>(members.size()), p_.min_region_walk, p_.region_share_cost,
                                    p_.region_detours);
    const std::vector<int> regions = assign_regions(s_->graph, s_->distances, *plan, where);
    const int r = me >= 0 && static_cast<size_t>(me) < regions.size() ? regions[static_cast<size_t>(me)] : -1;
    std::vector<std::string> mine;
    std::vector<Vec2> at;
    int my_index = 0;
    region_mates_.clear();
    for (size_t i = 0; i < members.size(); ++i) {
      if (regions[i] != r) continue;
      if (static_cast<int>(i) == me) my_index = static_cast<int>(mine.size());
      else region_mates_.insert(members[i]);
      mine.push_back(members[i]);
      at.push_back(where[i]);
    }
    // No region (more members than places): the whole graph's walk.
    walk_ = std::make_unique<Cyclic>(s_, p_, r >= 0 ? plan->walks[static_cast<size_t>(r)] : s_->tour);
    walk_->set_team(mine, at, my_index);
    short_ = p_.region_detours && r >= 0 && plan->walks[static_cast<size_t>(r)].length < p_.min_region_walk;
  }
  bool short_walk() const override { return short_; }
  int next(int at, Vec2 p, const PatrolKnowledge& k) override { return walk_ ? walk_->next(at, p, k) : -1; }
  int64_t walk_index() const override { return walk_ ? walk_->walk_index() : -1; }
  double phase(double remaining) const override { return walk_ ? walk_->phase(remaining) : -1; }
  // Spacing with the mates of my region only (the others are on other walks).
  double pace(double mine, const std::vector<std::pair<std::string, double>>& mates) const override {
    if (!walk_) return 1;
    std::vector<std::pair<std::string, double>> same;
    for (const auto& m : mates) {
      if (region_mates_.count(m.first)) same.push_back(m);
    }
    return walk_->pace(mine, same);
  }

 private:
  std::shared_ptr<const PatrolSetup> s_;
  StrategyParams p_;
  std::unique_ptr<Cyclic> walk_;
  std::set<std::string> region_mates_;
  bool short_ = false;
};

class Greedy : public PatrolStrategy {
 public:
  Greedy(std::shared_ptr<const PatrolSetup> s, double theta) : s_(std::move(s)), theta_(theta) {}
  const char* name() const override { return "greedy"; }
  void set_team(const std::vector<std::string>&, const std::vector<Vec2>&, int) override {}
  int next(int at, Vec2 p, const PatrolKnowledge& k) override {
    const size_t n = s_->graph.size();
    int from = at;
    double extra = 0;
    if (from < 0) {
      from = s_->graph.nearest(p);
      extra = (s_->graph.vertex(from).position - p).norm();
    }
    std::set<int> taken;
    for (const auto& [who, in] : k.others) taken.insert(in.vertex);
    // A vertex I am still inside (a visit would not count) is no target: going back and forth
    // between two vertices closer than the re-arm distance would count nothing and keep both
    // looking idle. Then vertices others head for only if nothing else is left.
    for (int pass = 0; pass < 3; ++pass) {
      int best = -1;
      double bu = -std::numeric_limits<double>::infinity();
      for (size_t u = 0; u < n; ++u) {
        const int ui = static_cast<int>(u);
        if (ui == at && n > 1) continue;
        if (pass < 2 && u < k.inside.size() && k.inside[u]) continue;
        if (pass == 0 && taken.count(ui)) continue;
        const double travel = (s_->travel(from, ui) + extra) / s_->speed;
        const double idle = k.now - (u < k.last_visit.size() ? k.last_visit[u] : 0.0);
        const double util = idle - theta_ * travel;
        if (util > bu + 1e-9) {
          bu = util;
          best = ui;
        }
      }
      if (best >= 0) return best;
    }
    return from;
  }

 private:
  std::shared_ptr<const PatrolSetup> s_;
  double theta_;
};

}  // namespace

double spacing_pace(double ahead, double behind, double spacing, double gain, double min_pace, double band) {
  const double excess = behind - ahead - std::max(0.0, band) * spacing;
  if (!(spacing > 0) || !(excess > 0)) return 1;
  const double lo = std::clamp(min_pace, 0.0, 1.0);
  return std::clamp(1.0 - gain * excess / (2.0 * spacing), lo, 1.0);
}

const std::vector<std::string>& strategy_names() {
  static const std::vector<std::string> names{"cyclic", "partition", "greedy"};
  return names;
}

Result<std::unique_ptr<PatrolStrategy>> make_strategy(const std::string& name, std::shared_ptr<const PatrolSetup> setup,
                                                       const StrategyParams& params) {
  if (!setup || setup->graph.size() == 0) return bad_input("", 0, "graph", "the patrol graph is empty");
  if (name == "cyclic") {
    if (!(params.pace_gain >= 0) || !std::isfinite(params.pace_gain)) return bad_input("", 0, "pace_gain", "must be a finite number >= 0");
    if (!(params.min_pace >= 0 && params.min_pace <= 1)) return bad_input("", 0, "min_pace", "must be in [0, 1]");
    return std::unique_ptr<PatrolStrategy>(std::make_unique<Cyclic>(setup, params));
  }
  if (name == "partition") {
    if (!(params.min_region_walk >= 0) || !std::isfinite(params.min_region_walk)) {
      return bad_input("", 0, "min_region_walk", "must be a finite number >= 0");
    }
    if (!(params.region_share_cost >= 0) || !std::isfinite(params.region_share_cost)) {
      return bad_input("", 0, "region_share_cost", "must be a finite number >= 0");
    }
    return std::unique_ptr<PatrolStrategy>(std::make_unique<Partition>(setup, params));
  }
  if (name == "greedy") {
    if (!(params.theta >= 0) || !std::isfinite(params.theta)) return bad_input("", 0, "theta", "must be a finite number >= 0");
    return std::unique_ptr<PatrolStrategy>(std::make_unique<Greedy>(setup, params.theta));
  }
  return bad_input("", 0, "strategy", "unknown patrol strategy '" + name + "' (cyclic, partition, greedy)");
}

}  // namespace vigil::planning::patrol
