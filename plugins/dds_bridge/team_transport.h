// Team messages (world/plugin.h TeamMessage) over DDS: patrol visits and hellos on topic
// "vigil_team", task allocation (tokens, acknowledgements, keepers' announcements, tasks done and
// reopened) on topic "vigil_task_assignments" as TaskAssignment samples. In `vigil run` every robot gets its own participant with a writer and a
// reader; what a controller sends is written by its robot's writer and read by every other
// robot's reader (each keeps what is addressed to it or to everyone). Lockstep: after every
// step the bus waits until each recipient's reader holds everything sent to it that step, then
// delivers in the order sent, so a run gives the same bytes as with the local bus. A message
// that has not arrived after `delivery_timeout_s` is an error naming the robot (never seen on
// loopback with RELIABLE QoS). Malformed samples are counted and dropped.
#pragma once

#include <map>
#include <memory>
#include <set>
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

// A robot's published state (topic "vigil_robot_state"): its controller's own estimate, never
// the simulator's truth. Velocities are the estimate's change since the robot's previous
// sample; `mode` is the team role when it has one (patrol, respond, guard), else the
// navigator's mode.
struct RobotStateSample {
  std::string robot, mode;
  int64_t stamp_ns = 0;
  Pose2 pose;
  double linear_velocity = 0, angular_velocity = 0;
  uint64_t task = 0;
};
// Owns the strings the message points into.
struct RobotStateOut {
  vigil_msgs_RobotState msg{};
  RobotStateSample src;
};
void to_message(const RobotStateSample& s, RobotStateOut* out);
// Rejects an empty robot and non-finite numbers; the error's key names the field.
Result<RobotStateSample> from_message(const vigil_msgs_RobotState& m);

// Writes each robot's state every `period_s` of simulated time from its latest report.
class RobotStateWriter {
 public:
  static Result<std::unique_ptr<RobotStateWriter>> create(const Participant& p, double period_s);
  Status publish(const World& world, const std::string& robot);
  uint64_t written() const { return written_; }

 private:
  RobotStateWriter() = default;
  std::unique_ptr<Writer> writer_;
  double period_s_ = 0.5;
  struct Last {
    SimTime stamp = -1;
    Pose2 pose;
  };
  std::map<std::string, Last> last_;
  uint64_t written_ = 0;
};

// Allocation messages go on the task-assignment topic: the team controller's kinds "token",
// "token_ack", "token_keep", "task_done" and "task_reopen".
bool is_assignment(const TeamMessage& m);
// Owns the strings and the sequence a TaskAssignment points into.
struct TaskAssignmentOut {
  vigil_msgs_TaskAssignment msg{};
  std::string from, to, state, robot, task_kind;
  std::vector<std::string> visited;
  std::vector<char*> visited_ptrs;
};
// `m` must satisfy is_assignment(); from_assignment(to_assignment(m)) gives `m` back.
void to_assignment(const TeamMessage& m, uint64_t number, TaskAssignmentOut* out);
// Rejects an empty sender, an unknown state, a token without a task kind and non-finite
// positions; the error's key names the field.
Result<TeamMessage> from_assignment(const vigil_msgs_TaskAssignment& m, uint64_t* number);

class DdsTeamBus {
 public:
  struct Options {
    DomainOptions domain;            // session: default "team-<pid>-<n>", unique to the bus
    double delivery_timeout_s = 10;
    // Robots whose messages are lost both ways from a time (scripted radio failures).
    std::vector<std::pair<std::string, double>> silent_from;
    double state_period_s = 0.5;  // each robot's vigil_robot_state sample (0: none)
  };
  static Result<std::unique_ptr<DdsTeamBus>> create(const std::vector<std::string>& robots, const Options& options);
  ~DdsTeamBus();
  // Takes what the controllers sent, writes it, waits for it at every recipient, delivers.
  Status exchange(World& world);
  uint64_t written() const { return written_; }
  uint64_t delivered() const { return delivered_; }
  uint64_t rejected() const { return rejected_; }
  uint64_t assignments_written() const { return assignments_written_; }  // of written()
  // Task-assignment instances its writers hold registered (a finished task's are unregistered).
  size_t assignment_instances() const;
  // The domain and session (partition) the bus's participants use.
  const DomainOptions& domain() const { return options_.domain; }

 private:
  DdsTeamBus() = default;
  struct Node {
    std::string robot;
    std::unique_ptr<Participant> participant;
    std::unique_ptr<Writer> writer;
    std::unique_ptr<Reader> reader;
    std::unique_ptr<Writer> assign_writer;  // the task-assignment topic
    std::unique_ptr<Reader> assign_reader;
    std::unique_ptr<RobotStateWriter> state;  // its robot's vigil_robot_state
    uint64_t number = 0, assign_number = 0;  // messages written so far, per topic
    std::set<uint64_t> assign_instances;     // incidents it has an assignment instance of
  };
  std::vector<Node> nodes_;
  Options options_;
  uint64_t written_ = 0, delivered_ = 0, rejected_ = 0, assignments_written_ = 0;
};

// One robot's side of the team topic, for a process that runs that robot alone (`vigil
// robot-node`): no lockstep. exchange() writes what the robot's controller sent and delivers
// whatever has arrived for it (addressed to it or to everyone, from others), in arrival order.
// Messages stamped more than `stale_after_s` of simulated time before the robot's clock are
// dropped (counted): on joining, a reader receives the live writers' durable history, which
// belongs to a past the robot did not take part in. The processes share a clock by starting
// their worlds at one epoch (docs/TEAM.md).
class DdsTeamLink {
 public:
  struct Options {
    DomainOptions domain;        // session: the system's (partition vigil.<session>)
    double stale_after_s = 10.0;
    double silent_from = -1;     // s: from this time nothing leaves or reaches the robot (< 0: never)
    double state_period_s = 0.5;  // the robot's vigil_robot_state sample (0: none)
  };
  static Result<std::unique_ptr<DdsTeamLink>> create(const std::string& robot, const Options& options);
  ~DdsTeamLink();
  Status exchange(World& world);
  // Takes and drops whatever has arrived (a robot not yet on the team: catching up).
  Status discard_received();
  // Waits up to `timeout_s` for `n` other robots' readers to match this robot's writer.
  int wait_for_mates(int n, double timeout_s);
  uint64_t written() const { return written_; }
  uint64_t delivered() const { return delivered_; }
  uint64_t rejected() const { return rejected_; }
  uint64_t stale() const { return stale_; }
  uint64_t assignments_written() const { return assignments_written_; }  // of written()

 private:
  DdsTeamLink() = default;
  std::string robot_;
  Options options_;
  std::unique_ptr<Participant> participant_;
  std::unique_ptr<Writer> writer_;
  std::unique_ptr<Reader> reader_;
  std::unique_ptr<Writer> assign_writer_;
  std::unique_ptr<Reader> assign_reader_;
  std::unique_ptr<RobotStateWriter> state_;
  uint64_t number_ = 0, assign_number_ = 0;
  std::set<uint64_t> assign_instances_;  // incidents this robot has an assignment instance of
  std::map<uint64_t, double> done_at_;    // incidents whose task is done: when (simulated s)
  uint64_t written_ = 0, delivered_ = 0, rejected_ = 0, stale_ = 0, assignments_written_ = 0;
};

}  // namespace vigil::dds
