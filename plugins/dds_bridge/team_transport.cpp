#include "plugins/dds_bridge/team_transport.h"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <map>
#include <set>
#include <tuple>
#include <algorithm>

namespace vigil::dds {

void to_message(const TeamMessage& m, uint64_t number, TeamMessageOut* out) {
  out->src = m;
  vigil_msgs_TeamMessage& x = out->msg;
  x.from = const_cast<char*>(out->src.from.c_str());
  x.number = number;
  x.to = const_cast<char*>(out->src.to.c_str());
  x.kind = const_cast<char*>(out->src.kind.c_str());
  x.sent_ns = m.sent;
  x.task = m.task;
  x.seq = m.seq;
  x.vertex = m.vertex;
  x.next_vertex = m.next_vertex;
  x.value = m.value;
  x.value2 = m.value2;
  x.position = {m.position.x, m.position.y, 0.0};
  x.text = const_cast<char*>(out->src.text.c_str());
}

Result<TeamMessage> from_message(const vigil_msgs_TeamMessage& x, uint64_t* number) {
  TeamMessage m;
  if (!x.from || !*x.from) return bad_input("", 0, "from", "empty sender");
  if (!x.kind || !*x.kind) return bad_input("", 0, "kind", "empty kind");
  if (!std::isfinite(x.value)) return bad_input("", 0, "value", "not a finite number");
  if (!std::isfinite(x.value2)) return bad_input("", 0, "value2", "not a finite number");
  if (!std::isfinite(x.position.x) || !std::isfinite(x.position.y)) return bad_input("", 0, "position", "not finite");
  m.from = x.from;
  m.to = x.to ? x.to : "";
  m.kind = x.kind;
  m.sent = x.sent_ns;
  m.task = x.task;
  m.seq = x.seq;
  m.vertex = x.vertex;
  m.next_vertex = x.next_vertex;
  m.value = x.value;
  m.value2 = x.value2;
  m.position = {x.position.x, x.position.y};
  m.text = x.text ? x.text : "";
  *number = x.number;
  return m;
}

// ---- Robot state ----

void to_message(const RobotStateSample& s, RobotStateOut* out) {
  out->src = s;
  vigil_msgs_RobotState& x = out->msg;
  x = {};
  x.robot = const_cast<char*>(out->src.robot.c_str());
  x.stamp_ns = s.stamp_ns;
  x.pose = {s.pose.x, s.pose.y, s.pose.yaw};
  x.linear_velocity = s.linear_velocity;
  x.angular_velocity = s.angular_velocity;
  x.mode = const_cast<char*>(out->src.mode.c_str());
  x.task = s.task;
}

Result<RobotStateSample> from_message(const vigil_msgs_RobotState& x) {
  if (!x.robot || !*x.robot) return bad_input("", 0, "robot", "empty robot");
  if (!std::isfinite(x.pose.x) || !std::isfinite(x.pose.y) || !std::isfinite(x.pose.z))
    return bad_input("", 0, "pose", "not finite");
  if (!std::isfinite(x.linear_velocity)) return bad_input("", 0, "linear_velocity", "not a finite number");
  if (!std::isfinite(x.angular_velocity)) return bad_input("", 0, "angular_velocity", "not a finite number");
  RobotStateSample s;
  s.robot = x.robot;
  s.mode = x.mode ? x.mode : "";
  s.stamp_ns = x.stamp_ns;
  s.pose = {x.pose.x, x.pose.y, x.pose.z};
  s.linear_velocity = x.linear_velocity;
  s.angular_velocity = x.angular_velocity;
  s.task = x.task;
  return s;
}

Result<std::unique_ptr<RobotStateWriter>> RobotStateWriter::create(const Participant& p, double period_s) {
  std::unique_ptr<RobotStateWriter> w(new RobotStateWriter());
  w->period_s_ = period_s;
  auto wr = Writer::create(p, Topic::kRobotState);
  if (!wr) return wr.error();
  w->writer_ = std::move(*wr);
  return w;
}

Status RobotStateWriter::publish(const World& world, const std::string& robot) {
  const RobotReport* r = world.last_report(robot);
  if (!r) return Status::Ok();
  Last& last = last_[robot];
  if (last.stamp >= 0 && to_seconds(r->stamp - last.stamp) < period_s_ - 1e-9) return Status::Ok();
  RobotStateSample s;
  s.robot = robot;
  s.stamp_ns = r->stamp;
  s.pose = r->pose;
  s.mode = r->role.empty() ? r->mode : r->role;
  s.task = r->task_id;
  if (last.stamp >= 0 && r->stamp > last.stamp) {
    const double dt = to_seconds(r->stamp - last.stamp);
    s.linear_velocity = std::hypot(r->pose.x - last.pose.x, r->pose.y - last.pose.y) / dt;
    s.angular_velocity = wrap_angle(r->pose.yaw - last.pose.yaw) / dt;
  }
  RobotStateOut out;
  to_message(s, &out);
  if (Status st = writer_->write_raw(&out.msg); !st) return st;
  last.stamp = r->stamp;
  last.pose = r->pose;
  ++written_;
  return Status::Ok();
}

// ---- Task assignments ----

namespace {
struct StateName {
  const char* team_kind;
  const char* state;
};
constexpr StateName kStates[] = {{"token", "token"},
                                 {"token_ack", "ack"},
                                 {"token_keep", "keep"},
                                 {"task_done", "done"},
                                 {"task_reopen", "reopen"}};
bool carries_token(const std::string& team_kind) {
  return team_kind == "token" || team_kind == "token_ack" || team_kind == "token_keep";
}
}  // namespace

namespace {
// A finished task's assignment instance of one sender, unregistered: without it every incident
// left its instances (and their history, up to the topic's depth) in the writers' and readers'
// caches for the rest of the run, a growth of megabytes an hour (found by tools/soak.sh).
Status unregister_assignment(Writer& w, const std::string& from, uint64_t incident) {
  vigil_msgs_TaskAssignment key{};
  char empty[] = "";
  key.from = const_cast<char*>(from.c_str());
  key.incident = incident;
  key.to = key.state = key.robot = key.task_kind = empty;
  return w.unregister_raw(&key);
}
// Once done, an incident's instances are kept this long (simulated s) so the last messages
// about it reach every reader first.
constexpr double kForgetDoneAfterS = 10.0;
}  // namespace

bool is_assignment(const TeamMessage& m) {
  for (const auto& s : kStates)
    if (m.kind == s.team_kind) return true;
  return false;
}

void to_assignment(const TeamMessage& m, uint64_t number, TaskAssignmentOut* out) {
  out->from = m.from;
  out->to = m.to;
  out->state.clear();
  for (const auto& s : kStates)
    if (m.kind == s.team_kind) out->state = s.state;
  out->robot = m.kind == "task_reopen" ? m.text : m.from;
  out->task_kind.clear();
  out->visited.clear();
  if (carries_token(m.kind)) {
    // The controller's token text: "<task kind>|<holder>,<holder>,...".
    const size_t bar = m.text.find('|');
    out->task_kind = m.text.substr(0, bar);
    if (bar != std::string::npos) {
      const std::string rest = m.text.substr(bar + 1);
      for (size_t a = 0; a < rest.size();) {
        const size_t b = rest.find(',', a);
        out->visited.push_back(rest.substr(a, b == std::string::npos ? std::string::npos : b - a));
        if (b == std::string::npos) break;
        a = b + 1;
      }
    }
  }
  out->visited_ptrs.clear();
  for (const std::string& v : out->visited) out->visited_ptrs.push_back(const_cast<char*>(v.c_str()));
  vigil_msgs_TaskAssignment& x = out->msg;
  x = {};
  x.from = const_cast<char*>(out->from.c_str());
  x.incident = m.task;
  x.number = number;
  x.to = const_cast<char*>(out->to.c_str());
  x.state = const_cast<char*>(out->state.c_str());
  x.robot = const_cast<char*>(out->robot.c_str());
  x.task_kind = const_cast<char*>(out->task_kind.c_str());
  x.priority = m.vertex;
  x.target = {m.position.x, m.position.y, 0.0};
  x.stamp_ns = m.sent;
  x.hop = m.seq;
  x.visited._length = x.visited._maximum = static_cast<uint32_t>(out->visited_ptrs.size());
  x.visited._buffer = out->visited_ptrs.empty() ? nullptr : out->visited_ptrs.data();
  x.visited._release = false;
}

Result<TeamMessage> from_assignment(const vigil_msgs_TaskAssignment& x, uint64_t* number) {
  if (!x.from || !*x.from) return bad_input("", 0, "from", "empty sender");
  const std::string state = x.state ? x.state : "";
  const char* kind = nullptr;
  for (const auto& s : kStates)
    if (state == s.state) kind = s.team_kind;
  if (!kind) return bad_input("", 0, "state", "'" + state + "' is not token, ack, keep, done or reopen");
  if (!std::isfinite(x.target.x) || !std::isfinite(x.target.y)) return bad_input("", 0, "target", "not finite");
  TeamMessage m;
  m.kind = kind;
  m.from = x.from;
  m.to = x.to ? x.to : "";
  m.sent = x.stamp_ns;
  m.task = x.incident;
  m.seq = x.hop;
  m.vertex = x.priority;
  m.position = {x.target.x, x.target.y};
  if (carries_token(m.kind)) {
    if (!x.task_kind || !*x.task_kind) return bad_input("", 0, "task_kind", "a token without its task's kind");
    m.text = std::string(x.task_kind) + "|";
    for (uint32_t i = 0; i < x.visited._length; ++i) {
      const char* v = x.visited._buffer[i];
      if (!v || !*v) return bad_input("", 0, "visited", "an empty holder name");
      m.text += (i ? "," : "") + std::string(v);
    }
  } else if (m.kind == "task_reopen") {
    if (!x.robot || !*x.robot) return bad_input("", 0, "robot", "a reopened task without its silent keeper");
    m.text = x.robot;
  }
  *number = x.number;
  return m;
}

Result<std::unique_ptr<DdsTeamBus>> DdsTeamBus::create(const std::vector<std::string>& robots, const Options& options) {
  static std::atomic<int> counter{0};
  std::unique_ptr<DdsTeamBus> bus(new DdsTeamBus());
  bus->options_ = options;
  if (bus->options_.domain.session.empty() || bus->options_.domain.session == "vigil") {
    bus->options_.domain.session = "team-" + std::to_string(getpid()) + "-" + std::to_string(counter++);
  }
  for (const std::string& r : robots) {
    Node n;
    n.robot = r;
    auto p = Participant::create(bus->options_.domain);
    if (!p) return p.error();
    n.participant = std::move(*p);
    auto w = Writer::create(*n.participant, Topic::kTeam);
    if (!w) return w.error();
    n.writer = std::move(*w);
    auto rd = Reader::create(*n.participant, Topic::kTeam);
    if (!rd) return rd.error();
    n.reader = std::move(*rd);
    auto aw = Writer::create(*n.participant, Topic::kTaskAssignments);
    if (!aw) return aw.error();
    n.assign_writer = std::move(*aw);
    auto ar = Reader::create(*n.participant, Topic::kTaskAssignments);
    if (!ar) return ar.error();
    n.assign_reader = std::move(*ar);
    if (options.state_period_s > 0) {
      auto sw = RobotStateWriter::create(*n.participant, options.state_period_s);
      if (!sw) return sw.error();
      n.state = std::move(*sw);
    }
    bus->nodes_.push_back(std::move(n));
  }
  // Every writer matched with every reader before the first message.
  const int want = static_cast<int>(bus->nodes_.size());
  for (Node& n : bus->nodes_) {
    if (n.writer->wait_for_readers(want, options.delivery_timeout_s) < want ||
        n.assign_writer->wait_for_readers(want, options.delivery_timeout_s) < want) {
      return internal_error("DDS team bus: robot " + n.robot + "'s writer did not match every robot's reader within " +
                            std::to_string(options.delivery_timeout_s) + " s");
    }
  }
  return bus;
}

DdsTeamBus::~DdsTeamBus() = default;

Status DdsTeamBus::exchange(World& world) {
  for (Node& n : nodes_) {
    bool quiet = false;  // a robot whose radio failed publishes nothing
    for (const auto& [r, from] : options_.silent_from) quiet = quiet || (r == n.robot && to_seconds(world.time()) >= from);
    if (n.state && !quiet) {
      if (Status s = n.state->publish(world, n.robot); !s) return s;
    }
  }
  std::vector<TeamMessage> sent = world.drain_sent();
  if (sent.empty()) return Status::Ok();
  std::map<std::string, size_t> index;
  for (size_t i = 0; i < nodes_.size(); ++i) index[nodes_[i].robot] = i;
  // (topic, sender, number) per message, and who must receive it. Topic 0: team, 1: assignments.
  using Key = std::tuple<int, std::string, uint64_t>;
  struct Out {
    Key key;
    std::vector<size_t> to;
  };
  std::vector<Out> outs;
  std::vector<std::set<Key>> expected(nodes_.size());
  auto silent = [&](const std::string& robot, SimTime t) {
    for (const auto& [r, from] : options_.silent_from)
      if (r == robot && to_seconds(t) >= from) return true;
    return false;
  };
  for (const TeamMessage& m : sent) {
    if (silent(m.from, m.sent)) continue;  // never leaves the robot
    auto it = index.find(m.from);
    if (it == index.end()) return internal_error("DDS team bus: no node for robot " + m.from);
    Node& n = nodes_[it->second];
    Key key;
    if (is_assignment(m)) {
      TaskAssignmentOut out;
      to_assignment(m, ++n.assign_number, &out);
      if (Status s = n.assign_writer->write_raw(&out.msg); !s) return s;
      n.assign_instances.insert(m.task);
      ++assignments_written_;
      key = Key{1, m.from, n.assign_number};
    } else {
      TeamMessageOut out;
      to_message(m, ++n.number, &out);
      if (Status s = n.writer->write_raw(&out.msg); !s) return s;
      key = Key{0, m.from, n.number};
    }
    ++written_;
    Out o{key, {}};
    for (size_t k = 0; k < nodes_.size(); ++k) {
      if (nodes_[k].robot == m.from) continue;
      if (!m.to.empty() && m.to != nodes_[k].robot) continue;
      if (silent(nodes_[k].robot, m.sent)) continue;  // written, but the robot hears nothing
      o.to.push_back(k);
      expected[k].insert(key);
    }
    outs.push_back(std::move(o));
  }
  // Read until every recipient holds what it expects.
  std::vector<std::map<Key, TeamMessage>> got(nodes_.size());
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    bool all = true;
    for (size_t k = 0; k < nodes_.size(); ++k) {
      if (got[k].size() >= expected[k].size()) continue;
      all = false;
      auto keep = [&](Result<TeamMessage> m, int topic, uint64_t number) {
        if (!m) {
          ++rejected_;
          return;
        }
        Key key{topic, m->from, number};
        if (expected[k].count(key)) got[k].emplace(std::move(key), std::move(*m));
      };
      Status st = nodes_[k].reader->take_each([&](const void* sample, const dds_sample_info_t&) {
        uint64_t number = 0;
        auto m = from_message(*static_cast<const vigil_msgs_TeamMessage*>(sample), &number);
        keep(std::move(m), 0, number);
      });
      if (!st) return st;
      st = nodes_[k].assign_reader->take_each([&](const void* sample, const dds_sample_info_t&) {
        uint64_t number = 0;
        auto m = from_assignment(*static_cast<const vigil_msgs_TaskAssignment*>(sample), &number);
        keep(std::move(m), 1, number);
      });
      if (!st) return st;
    }
    if (all) break;
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > options_.delivery_timeout_s) {
      for (size_t k = 0; k < nodes_.size(); ++k) {
        if (got[k].size() < expected[k].size()) {
          return internal_error("DDS team bus: robot " + nodes_[k].robot + " received " + std::to_string(got[k].size()) +
                                " of " + std::to_string(expected[k].size()) + " team messages within " +
                                std::to_string(options_.delivery_timeout_s) + " s");
        }
      }
    }
    for (size_t k = 0; k < nodes_.size(); ++k) {
      if (got[k].size() < expected[k].size()) {
        nodes_[k].reader->wait(0.001);
        nodes_[k].assign_reader->wait(0.001);
        break;
      }
    }
  }
  // Delivered in the order sent, as the local bus does.
  for (const Out& o : outs) {
    for (size_t k : o.to) {
      auto it = got[k].find(o.key);
      if (Status s = world.deliver(nodes_[k].robot, std::move(it->second)); !s) return s;
      ++delivered_;
    }
  }
  // Every reader holds what was sent (lockstep): a task done now leaves no instance behind.
  for (const TeamMessage& m : sent) {
    if (m.kind != "task_done") continue;
    for (Node& n : nodes_) {
      if (!n.assign_instances.erase(m.task)) continue;
      if (Status s = unregister_assignment(*n.assign_writer, n.robot, m.task); !s) return s;
    }
  }
  return Status::Ok();
}

size_t DdsTeamBus::assignment_instances() const {
  size_t n = 0;
  for (const Node& node : nodes_) n += node.assign_instances.size();
  return n;
}

// ---- DdsTeamLink ----

Result<std::unique_ptr<DdsTeamLink>> DdsTeamLink::create(const std::string& robot, const Options& options) {
  if (robot.empty()) return bad_input("", 0, "robot", "must not be empty");
  std::unique_ptr<DdsTeamLink> link(new DdsTeamLink());
  link->robot_ = robot;
  link->options_ = options;
  auto p = Participant::create(options.domain);
  if (!p) return p.error();
  link->participant_ = std::move(*p);
  auto w = Writer::create(*link->participant_, Topic::kTeam);
  if (!w) return w.error();
  link->writer_ = std::move(*w);
  auto rd = Reader::create(*link->participant_, Topic::kTeam);
  if (!rd) return rd.error();
  link->reader_ = std::move(*rd);
  auto aw = Writer::create(*link->participant_, Topic::kTaskAssignments);
  if (!aw) return aw.error();
  link->assign_writer_ = std::move(*aw);
  auto ar = Reader::create(*link->participant_, Topic::kTaskAssignments);
  if (!ar) return ar.error();
  link->assign_reader_ = std::move(*ar);
  if (options.state_period_s > 0) {
    auto sw = RobotStateWriter::create(*link->participant_, options.state_period_s);
    if (!sw) return sw.error();
    link->state_ = std::move(*sw);
  }
  return link;
}

DdsTeamLink::~DdsTeamLink() = default;

int DdsTeamLink::wait_for_mates(int n, double timeout_s) {
  // Our own readers match our writers too; mates count when they hear both topics.
  const int team = writer_->wait_for_readers(n + 1, timeout_s) - 1;
  const int assign = assign_writer_->wait_for_readers(n + 1, timeout_s) - 1;
  return std::min(team, assign);
}

Status DdsTeamLink::discard_received() {
  if (Status s = reader_->take_each([&](const void*, const dds_sample_info_t&) { ++stale_; }); !s) return s;
  return assign_reader_->take_each([&](const void*, const dds_sample_info_t&) { ++stale_; });
}

Status DdsTeamLink::exchange(World& world) {
  const double now = to_seconds(world.time());
  const bool silent = options_.silent_from >= 0 && now >= options_.silent_from;
  if (state_ && !silent) {
    if (Status s = state_->publish(world, robot_); !s) return s;
  }
  for (const TeamMessage& m : world.drain_sent()) {
    if (m.from != robot_ || silent) continue;
    if (is_assignment(m)) {
      TaskAssignmentOut out;
      to_assignment(m, ++assign_number_, &out);
      if (Status s = assign_writer_->write_raw(&out.msg); !s) return s;
      assign_instances_.insert(m.task);
      if (m.kind == "task_done") done_at_.emplace(m.task, now);
      ++assignments_written_;
    } else {
      TeamMessageOut out;
      to_message(m, ++number_, &out);
      if (Status s = writer_->write_raw(&out.msg); !s) return s;
    }
    ++written_;
  }
  std::vector<TeamMessage> in;
  auto keep = [&](Result<TeamMessage> m) {
    if (!m) {
      ++rejected_;
      return;
    }
    if (m->from == robot_ || (!m->to.empty() && m->to != robot_)) return;
    if (to_seconds(m->sent) < now - options_.stale_after_s) {
      ++stale_;
      return;
    }
    in.push_back(std::move(*m));
  };
  // Each topic in arrival order: one sender's messages about one incident keep their order.
  Status st = reader_->take_each([&](const void* sample, const dds_sample_info_t&) {
    uint64_t number = 0;
    keep(from_message(*static_cast<const vigil_msgs_TeamMessage*>(sample), &number));
  });
  if (!st) return st;
  st = assign_reader_->take_each([&](const void* sample, const dds_sample_info_t&) {
    uint64_t number = 0;
    keep(from_assignment(*static_cast<const vigil_msgs_TaskAssignment*>(sample), &number));
  });
  if (!st) return st;
  for (const TeamMessage& m : in)
    if (m.kind == "task_done") done_at_.emplace(m.task, now);
  for (auto it = done_at_.begin(); it != done_at_.end();) {
    if (now - it->second < kForgetDoneAfterS) {
      ++it;
      continue;
    }
    if (assign_instances_.erase(it->first)) {
      if (Status s = unregister_assignment(*assign_writer_, robot_, it->first); !s) return s;
    }
    it = done_at_.erase(it);
  }
  if (silent) return Status::Ok();
  for (TeamMessage& m : in) {
    if (Status s = world.deliver(robot_, std::move(m)); !s) return s;
    ++delivered_;
  }
  return Status::Ok();
}

}  // namespace vigil::dds
