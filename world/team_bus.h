// The team messages' transport inside one process (`vigil run`, benchmarks, tests): what a
// controller sends in one step is delivered to its recipients (every other robot when `to` is
// empty) after the bus's latency, at the earliest the next step. Faults for testing a protocol's
// robustness: a seeded loss probability per delivery, and silences (a robot's messages, both
// ways or only those it sends, lost between two times). Deterministic: the same run gives the same deliveries.
// Between processes, DDS carries the same messages (plugins/dds_bridge).
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "common/rng.h"
#include "world/world.h"

namespace vigil {

struct TeamBusOptions {
  double latency_s = 0;          // added to every delivery (s)
  double drop_probability = 0;   // each delivery lost with this probability
  uint64_t seed = 0;
  struct Silence {
    std::string robot;
    double from = 0, to = 1e300;  // s
    bool sends_only = false;      // it still hears the others (a mate that hears it late)
  };
  std::vector<Silence> silences;
};

class LocalTeamBus {
 public:
  explicit LocalTeamBus(TeamBusOptions options = {});
  // Takes what the controllers sent and delivers what is due. Call after every step.
  void exchange(World& world);
  uint64_t sent() const { return sent_; }
  uint64_t delivered() const { return delivered_; }
  uint64_t dropped() const { return dropped_; }

 private:
  bool silenced(const std::string& robot, double t, bool sending) const;
  TeamBusOptions o_;
  Rng rng_;
  struct Pending {
    SimTime due;
    std::string to;
    TeamMessage m;
  };
  std::deque<Pending> pending_;
  uint64_t sent_ = 0, delivered_ = 0, dropped_ = 0;
};

}  // namespace vigil
