// Token passing for tasks found while the mission runs (Farinelli, Iocchi, Nardi, Ziparo 2006):
// one token per task goes from robot to robot; a robot keeps it when its utility for the task
// clears the token's threshold, otherwise it passes it on to the mate it expects to do best
// that has not held it yet. Every robot runs one TokenAgent; messages between agents are the
// team messages the transport carries (lost, late or duplicated: the protocol survives).
//
//   token   holder -> next: the task, the robots that already held it, the best utility seen
//           and who had it, the hop count.        (seq = the token's hop, so duplicates show)
//   ack     next -> holder: got it. A token not acknowledged within `ack_timeout` is sent again,
//           then, after `max_resends`, to the next candidate (the silent robot is skipped).
//   keep    the keeper -> everyone: the task is mine (others stop holding copies). Repeated
//           every `keep_period` while kept, so a lost one (or a robot that joins late) only
//           delays the resolution of two keepers, never leaves both serving.
//
// The threshold: a robot keeps the token when its cost is within `accept_margin` of the least
// cost it estimates for any robot not yet visited (costs from the mates' last known places),
// or when no candidate is left (the last holder keeps it: a task is never dropped). The agent
// is pure logic: time and messages in, messages and decisions out, deterministic.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "common/geometry.h"

namespace vigil::planning::allocation {

struct TokenTask {
  uint64_t id = 0;
  std::string kind;
  int priority = 0;
  Vec2 where;
};

struct TokenMessage {
  std::string kind;  // token, ack, keep
  std::string from, to;  // to "" = everyone
  TokenTask task;
  std::vector<std::string> visited;  // token: who held it, in order
  int64_t hop = 0;
};

struct TokenParams {
  double accept_margin = 0.1;  // keep when my cost <= (1 + margin) x the best estimate left
  double ack_timeout = 0.5;    // s
  int max_resends = 2;
  double keep_period = 1.0;    // s between a keeper's announcements
};

class TokenAgent {
 public:
  // `cost(robot, task)`: the estimated cost (s) for any robot of the team (its own exactly, the
  // mates' from where they were last heard); infinite when the robot cannot serve it.
  TokenAgent(std::string me, TokenParams params, std::function<double(const std::string&, const TokenTask&)> cost);
  // The team's current members (me included); tokens go only to them.
  void set_members(std::vector<std::string> members);
  // A task this robot heard of first or must (re)create: it becomes the token's first holder.
  void create(const TokenTask& task, double now);
  void receive(const TokenMessage& m, double now);
  // Resends and timeouts; call every step.
  void tick(double now);
  std::vector<TokenMessage> take_outbox();
  // Tasks this robot decided to keep (in order); and every task known to be kept, by whom.
  const std::vector<TokenTask>& kept() const { return kept_; }
  const std::map<uint64_t, std::string>& keepers() const { return keepers_; }
  // Forgets a task (done or cancelled) so it can be created again if it comes back.
  void forget(uint64_t task);

 private:
  void decide(const TokenTask& task, std::vector<std::string> visited, int64_t hop, double now);
  void send_token(uint64_t task, double now);
  std::string me_;
  TokenParams p_;
  std::function<double(const std::string&, const TokenTask&)> cost_;
  std::vector<std::string> members_;
  struct Pending {
    TokenMessage token;
    double sent = 0;
    int resends = 0;
    std::set<std::string> skipped;
  };
  std::map<uint64_t, Pending> pending_;   // tokens I passed, not yet acknowledged
  std::map<uint64_t, int64_t> seen_hop_;  // the latest hop handled per task (duplicates ignored)
  std::map<uint64_t, std::string> keepers_;
  std::map<uint64_t, double> keep_sent_;  // when I last announced a task I keep
  std::vector<TokenTask> kept_;
  std::vector<TokenMessage> out_;
};

}  // namespace vigil::planning::allocation
