// Team messages (world/plugin.h TeamMessage: patrol visits, hellos, task tokens) over DDS,
// topic "vigil_team". In `vigil run` every robot gets its own participant with a writer and a
// reader; what a controller sends is written by its robot's writer and read by every other
// robot's reader (each keeps what is addressed to it or to everyone). Lockstep: after every
// step the bus waits until each recipient's reader holds everything sent to it that step, then
// delivers in the order sent, so a run gives the same bytes as with the local bus. A message
// that has not arrived after `delivery_timeout_s` is an error naming the robot (never seen on
// loopback with RELIABLE QoS). Malformed samples are counted and dropped.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "common/status.h"
#include "plugins/dds_bridge/dds.h"
#include "world/world.h"

namespace vigil::dds {

// Owns the strings a message points into.
struct TeamMessageOut {
  vigil_msgs_TeamMessage msg{};
  TeamMessage src;
};
void to_message(const TeamMessage& m, uint64_t number, TeamMessageOut* out);
// Rejects an empty sender or kind and non-finite numbers; the error's key names the field.
Result<TeamMessage> from_message(const vigil_msgs_TeamMessage& m, uint64_t* number);

class DdsTeamBus {
 public:
  struct Options {
    DomainOptions domain;            // session: default "team-<pid>-<n>", unique to the bus
    double delivery_timeout_s = 10;
    // Robots whose messages are lost both ways from a time (scripted radio failures).
    std::vector<std::pair<std::string, double>> silent_from;
  };
  static Result<std::unique_ptr<DdsTeamBus>> create(const std::vector<std::string>& robots, const Options& options);
  ~DdsTeamBus();
  // Takes what the controllers sent, writes it, waits for it at every recipient, delivers.
  Status exchange(World& world);
  uint64_t written() const { return written_; }
  uint64_t delivered() const { return delivered_; }
  uint64_t rejected() const { return rejected_; }

 private:
  DdsTeamBus() = default;
  struct Node {
    std::string robot;
    std::unique_ptr<Participant> participant;
    std::unique_ptr<Writer> writer;
    std::unique_ptr<Reader> reader;
    uint64_t number = 0;  // messages written so far
  };
  std::vector<Node> nodes_;
  Options options_;
  uint64_t written_ = 0, delivered_ = 0, rejected_ = 0;
};

}  // namespace vigil::dds
