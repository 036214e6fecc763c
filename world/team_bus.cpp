#include "world/team_bus.h"

namespace vigil {

LocalTeamBus::LocalTeamBus(TeamBusOptions options) : o_(std::move(options)), rng_(o_.seed ^ 0x7ea3b05ull) {}

bool LocalTeamBus::silenced(const std::string& robot, double t, bool sending) const {
  for (const auto& s : o_.silences) {
    if (s.robot == robot && t >= s.from && t < s.to && (sending || !s.sends_only)) return true;
  }
  return false;
}

void LocalTeamBus::exchange(World& world) {
  const SimTime now = world.time();
  for (TeamMessage& m : world.drain_sent()) {
    ++sent_;
    std::vector<std::string> to;
    if (m.to.empty()) {
      for (const RobotEntity& r : world.robots()) {
        if (r.spec.id != m.from) to.push_back(r.spec.id);
      }
    } else {
      to.push_back(m.to);
    }
    for (const std::string& t : to) {
      // Draw for every delivery so the random stream does not depend on which are silenced.
      const bool lost = o_.drop_probability > 0 && rng_.uniform() < o_.drop_probability;
      if (lost || silenced(m.from, to_seconds(m.sent), true) || silenced(t, to_seconds(m.sent), false)) {
        ++dropped_;
        continue;
      }
      pending_.push_back({m.sent + from_seconds(o_.latency_s), t, m});
    }
  }
  // Due now (sent in an earlier step and past the latency), in send order.
  while (!pending_.empty() && pending_.front().due <= now && pending_.front().m.sent < now) {
    Pending p = std::move(pending_.front());
    pending_.pop_front();
    if (world.deliver(p.to, std::move(p.m))) ++delivered_;
    else ++dropped_;  // no such robot
  }
}

}  // namespace vigil
