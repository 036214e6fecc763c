#include "planning/patrol/strategy.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

namespace vigil::planning::patrol {

std::shared_ptr<const PatrolSetup> PatrolSetup::make(PatrolGraph g, CostMatrix travel, double speed) {
  auto s = std::make_shared<PatrolSetup>(PatrolSetup{std::move(g), GraphDistances(PatrolGraph()), {}, {}, speed});
  s->distances = GraphDistances(s->graph);
  s->travel = travel.size() == s->graph.size() ? std::move(travel) : CostMatrix::from(s->distances);
  s->tour = closed_walk(s->graph, s->distances);
  return s;
}

namespace {

// Where each member sits along a closed walk (the arc of its nearest walk vertex, first
// occurrence), and the even spacing that moves the team least: the offsets base + k L / N in
// the members' order along the walk.
struct Spread {
  double base = 0;
  int rank = 0;  // my position in the order along the walk
  int count = 1;
};

double circ(double a, double L) {
  a = std::fmod(a, L);
  return a < 0 ? a + L : a;
}

Spread spread(const ClosedWalk& w, const PatrolGraph& g, const std::vector<std::string>& members,
              const std::vector<Vec2>& where, int me) {
  Spread s;
  s.count = static_cast<int>(members.size());
  if (w.length <= 0 || members.empty()) return s;
  std::vector<std::pair<double, int>> arc;  // (arc, member)
  for (size_t m = 0; m < members.size(); ++m) {
    size_t best = 0;
    double bd = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < w.vertices.size(); ++i) {
      const double d = (g.vertex(w.vertices[i]).position - where[m]).norm();
      if (d < bd - 1e-9) {
        bd = d;
        best = i;
      }
    }
    arc.push_back({w.arc[best], static_cast<int>(m)});
  }
  std::sort(arc.begin(), arc.end());
  const double L = w.length, gap = L / static_cast<double>(members.size());
  double best_cost = std::numeric_limits<double>::infinity();
  for (size_t c = 0; c < arc.size(); ++c) {
    const double base = circ(arc[c].first - static_cast<double>(c) * gap, L);
    double cost = 0;
    for (size_t k = 0; k < arc.size(); ++k) {
      const double target = circ(base + static_cast<double>(k) * gap, L);
      const double d = std::abs(target - arc[k].first);
      cost += std::min(d, L - d);
    }
    if (cost < best_cost - 1e-9) {
      best_cost = cost;
      s.base = base;
    }
  }
  for (size_t k = 0; k < arc.size(); ++k) {
    if (arc[k].second == me) s.rank = static_cast<int>(k);
  }
  return s;
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
  explicit Cyclic(std::shared_ptr<const PatrolSetup> s) : s_(std::move(s)) {}
  const char* name() const override { return "cyclic"; }
  void set_team(const std::vector<std::string>& members, const std::vector<Vec2>& where, int me) override {
    const Spread sp = spread(s_->tour, s_->graph, members, where, me);
    cursor_ = index_at(s_->tour, sp.base + sp.rank * s_->tour.length / sp.count);
  }
  int next(int at, Vec2, const PatrolKnowledge&) override {
    const auto& v = s_->tour.vertices;
    if (at >= 0 && at == v[cursor_]) cursor_ = (cursor_ + 1) % v.size();
    return v[cursor_];
  }
  int64_t walk_index() const override { return static_cast<int64_t>(cursor_); }
  // At a vertex (the cursor has moved on to the next): my arc is that of the vertex before
  // the cursor; a mate's is its target's arc less what it still has to drive. Hold while the
  // gap to the robot ahead is shorter than the gap to the one behind by more than a tenth of
  // the even spacing: half the difference, at cruise speed.
  double hold(const PatrolKnowledge& k) const override {
    const ClosedWalk& w = s_->tour;
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
  size_t cursor_ = 0;
};

class Partition : public PatrolStrategy {
 public:
  explicit Partition(std::shared_ptr<const PatrolSetup> s) : s_(std::move(s)) {}
  const char* name() const override { return "partition"; }
  void set_team(const std::vector<std::string>& members, const std::vector<Vec2>& where, int me) override {
    const ClosedWalk& w = s_->tour;
    const Spread sp = spread(w, s_->graph, members, where, me);
    const double gap = w.length / sp.count;
    const double from = sp.base + sp.rank * gap;
    std::set<int> region;
    for (size_t i = 0; i < w.vertices.size(); ++i) {
      const double rel = circ(w.arc[i] - from, w.length);
      if (rel < gap - 1e-9) region.insert(w.vertices[i]);
    }
    if (region.empty()) region.insert(w.vertices[index_at(w, from)]);
    own_ = closed_walk(s_->graph, s_->distances, std::vector<int>(region.begin(), region.end()));
    // Start at the vertex of the region nearest to where I am.
    const Vec2 p = where[me];
    cursor_ = 0;
    double bd = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < own_.vertices.size(); ++i) {
      const double d = (s_->graph.vertex(own_.vertices[i]).position - p).norm();
      if (d < bd - 1e-9) {
        bd = d;
        cursor_ = i;
      }
    }
  }
  int next(int at, Vec2, const PatrolKnowledge&) override {
    const auto& v = own_.vertices;
    if (at >= 0 && at == v[cursor_] && v.size() > 1) cursor_ = (cursor_ + 1) % v.size();
    return v[cursor_];
  }

 private:
  std::shared_ptr<const PatrolSetup> s_;
  ClosedWalk own_;
  size_t cursor_ = 0;
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
    for (int pass = 0; pass < 2; ++pass) {
      int best = -1;
      double bu = -std::numeric_limits<double>::infinity();
      for (size_t u = 0; u < n; ++u) {
        const int ui = static_cast<int>(u);
        if (ui == at && n > 1) continue;
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

const std::vector<std::string>& strategy_names() {
  static const std::vector<std::string> names{"cyclic", "partition", "greedy"};
  return names;
}

Result<std::unique_ptr<PatrolStrategy>> make_strategy(const std::string& name, std::shared_ptr<const PatrolSetup> setup,
                                                       const StrategyParams& params) {
  if (!setup || setup->graph.size() == 0) return bad_input("", 0, "graph", "the patrol graph is empty");
  if (name == "cyclic") return std::unique_ptr<PatrolStrategy>(std::make_unique<Cyclic>(setup));
  if (name == "partition") return std::unique_ptr<PatrolStrategy>(std::make_unique<Partition>(setup));
  if (name == "greedy") {
    if (!(params.theta >= 0) || !std::isfinite(params.theta)) return bad_input("", 0, "theta", "must be a finite number >= 0");
    return std::unique_ptr<PatrolStrategy>(std::make_unique<Greedy>(setup, params.theta));
  }
  return bad_input("", 0, "strategy", "unknown patrol strategy '" + name + "' (cyclic, partition, greedy)");
}

}  // namespace vigil::planning::patrol
