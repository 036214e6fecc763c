#include "planning/allocation/token_passing.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace vigil::planning::allocation {

TokenAgent::TokenAgent(std::string me, TokenParams params, std::function<double(const std::string&, const TokenTask&)> cost)
    : me_(std::move(me)), p_(params), cost_(std::move(cost)) {}

void TokenAgent::set_members(std::vector<std::string> members) {
  std::sort(members.begin(), members.end());
  members_ = std::move(members);
}

void TokenAgent::create(const TokenTask& task, double now) {
  if (keepers_.count(task.id) || seen_hop_.count(task.id)) return;
  decide(task, {}, 0, now);
}

void TokenAgent::forget(uint64_t task) {
  keepers_.erase(task);
  keep_sent_.erase(task);
  seen_hop_.erase(task);
  pending_.erase(task);
  kept_.erase(std::remove_if(kept_.begin(), kept_.end(), [&](const TokenTask& t) { return t.id == task; }), kept_.end());
}

// Holding the token: keep it, or pass it to the unvisited member of least estimated cost.
void TokenAgent::decide(const TokenTask& task, std::vector<std::string> visited, int64_t hop, double now) {
  seen_hop_[task.id] = hop;
  visited.push_back(me_);
  const double mine = cost_(me_, task);
  double best_other = std::numeric_limits<double>::infinity();
  std::string next;
  for (const std::string& m : members_) {
    if (std::find(visited.begin(), visited.end(), m) != visited.end()) continue;
    const double c = cost_(m, task);
    if (c < best_other) {
      best_other = c;
      next = m;
    }
  }
  const bool keep = next.empty() || (std::isfinite(mine) && mine <= (1.0 + p_.accept_margin) * best_other);
  if (keep) {
    keepers_[task.id] = me_;
    kept_.push_back(task);
    keep_sent_[task.id] = now;
    TokenMessage k;
    k.kind = "keep";
    k.from = me_;
    k.task = task;
    k.visited = visited;
    k.hop = hop;
    out_.push_back(k);
    return;
  }
  Pending pd;
  pd.token.kind = "token";
  pd.token.from = me_;
  pd.token.to = next;
  pd.token.task = task;
  pd.token.visited = visited;
  pd.token.hop = hop + 1;
  pending_[task.id] = pd;
  send_token(task.id, now);
}

void TokenAgent::send_token(uint64_t task, double now) {
  Pending& pd = pending_[task];
  pd.sent = now;
  out_.push_back(pd.token);
}

void TokenAgent::receive(const TokenMessage& m, double now) {
  if (m.kind == "keep") {
    // Two keepers (a token taken back from a robot that was only slow): the name that sorts
    // first keeps the task.
    auto mine = std::find_if(kept_.begin(), kept_.end(), [&](const TokenTask& t) { return t.id == m.task.id; });
    if (mine != kept_.end()) {
      if (m.from > me_) return;
      kept_.erase(mine);
    }
    keepers_[m.task.id] = m.from;
    pending_.erase(m.task.id);
    return;
  }
  if (m.kind == "ack") {
    auto it = pending_.find(m.task.id);
    if (it != pending_.end() && it->second.token.to == m.from && it->second.token.hop == m.hop) pending_.erase(it);
    return;
  }
  if (m.kind == "token" && m.to == me_) {
    // Acknowledge every copy (the first ack may have been lost), act on the first only.
    TokenMessage a;
    a.kind = "ack";
    a.from = me_;
    a.to = m.from;
    a.task = m.task;
    a.hop = m.hop;
    out_.push_back(a);
    auto seen = seen_hop_.find(m.task.id);
    if (keepers_.count(m.task.id) || (seen != seen_hop_.end() && seen->second >= m.hop)) return;
    decide(m.task, m.visited, m.hop, now);
  }
}

void TokenAgent::tick(double now) {
  for (const TokenTask& t : kept_) {
    double& last = keep_sent_[t.id];
    if (now - last < p_.keep_period) continue;
    last = now;
    TokenMessage k;
    k.kind = "keep";
    k.from = me_;
    k.task = t;
    k.hop = seen_hop_.count(t.id) ? seen_hop_[t.id] : 0;
    out_.push_back(k);
  }
  for (auto it = pending_.begin(); it != pending_.end();) {
    Pending& pd = it->second;
    if (now - pd.sent < p_.ack_timeout) {
      ++it;
      continue;
    }
    if (pd.resends < p_.max_resends) {
      ++pd.resends;
      send_token(it->first, now);
      ++it;
      continue;
    }
    // The candidate is silent: take the token back and decide again without it.
    const TokenMessage tok = pd.token;
    std::vector<std::string> visited = tok.visited;
    visited.push_back(tok.to);  // skipped
    visited.erase(std::remove(visited.begin(), visited.end(), me_), visited.end());
    it = pending_.erase(it);
    seen_hop_.erase(tok.task.id);
    decide(tok.task, visited, tok.hop, now);
  }
}

std::vector<TokenMessage> TokenAgent::take_outbox() {
  std::vector<TokenMessage> o;
  o.swap(out_);
  return o;
}

}  // namespace vigil::planning::allocation
