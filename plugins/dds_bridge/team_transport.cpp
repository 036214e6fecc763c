#include "plugins/dds_bridge/team_transport.h"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <map>
#include <set>

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
    bus->nodes_.push_back(std::move(n));
  }
  // Every writer matched with every reader before the first message.
  const int want = static_cast<int>(bus->nodes_.size());
  for (Node& n : bus->nodes_) {
    if (n.writer->wait_for_readers(want, options.delivery_timeout_s) < want) {
      return internal_error("DDS team bus: robot " + n.robot + "'s writer did not match every robot's reader within " +
                            std::to_string(options.delivery_timeout_s) + " s");
    }
  }
  return bus;
}

DdsTeamBus::~DdsTeamBus() = default;

Status DdsTeamBus::exchange(World& world) {
  std::vector<TeamMessage> sent = world.drain_sent();
  if (sent.empty()) return Status::Ok();
  std::map<std::string, size_t> index;
  for (size_t i = 0; i < nodes_.size(); ++i) index[nodes_[i].robot] = i;
  // (sender, number) per message, and who must receive it.
  struct Out {
    std::string from;
    uint64_t number;
    std::vector<size_t> to;
  };
  std::vector<Out> outs;
  std::vector<std::set<std::pair<std::string, uint64_t>>> expected(nodes_.size());
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
    TeamMessageOut out;
    to_message(m, ++n.number, &out);
    if (Status s = n.writer->write_raw(&out.msg); !s) return s;
    ++written_;
    Out o{m.from, n.number, {}};
    for (size_t k = 0; k < nodes_.size(); ++k) {
      if (nodes_[k].robot == m.from) continue;
      if (!m.to.empty() && m.to != nodes_[k].robot) continue;
      if (silent(nodes_[k].robot, m.sent)) continue;  // written, but the robot hears nothing
      o.to.push_back(k);
      expected[k].insert({m.from, n.number});
    }
    outs.push_back(std::move(o));
  }
  // Read until every recipient holds what it expects.
  std::vector<std::map<std::pair<std::string, uint64_t>, TeamMessage>> got(nodes_.size());
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    bool all = true;
    for (size_t k = 0; k < nodes_.size(); ++k) {
      if (got[k].size() >= expected[k].size()) continue;
      all = false;
      Status st = nodes_[k].reader->take_each([&](const void* sample, const dds_sample_info_t&) {
        uint64_t number = 0;
        auto m = from_message(*static_cast<const vigil_msgs_TeamMessage*>(sample), &number);
        if (!m) {
          ++rejected_;
          return;
        }
        const auto key = std::make_pair(m->from, number);
        if (expected[k].count(key)) got[k].emplace(key, std::move(*m));
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
        nodes_[k].reader->wait(0.002);
        break;
      }
    }
  }
  // Delivered in the order sent, as the local bus does.
  for (const Out& o : outs) {
    for (size_t k : o.to) {
      auto it = got[k].find({o.from, o.number});
      if (Status s = world.deliver(nodes_[k].robot, std::move(it->second)); !s) return s;
      ++delivered_;
    }
  }
  return Status::Ok();
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
  return link;
}

DdsTeamLink::~DdsTeamLink() = default;

int DdsTeamLink::wait_for_mates(int n, double timeout_s) {
  // Our own reader matches our writer too.
  return writer_->wait_for_readers(n + 1, timeout_s) - 1;
}

Status DdsTeamLink::discard_received() {
  return reader_->take_each([&](const void*, const dds_sample_info_t&) { ++stale_; });
}

Status DdsTeamLink::exchange(World& world) {
  const double now = to_seconds(world.time());
  const bool silent = options_.silent_from >= 0 && now >= options_.silent_from;
  for (const TeamMessage& m : world.drain_sent()) {
    if (m.from != robot_ || silent) continue;
    TeamMessageOut out;
    to_message(m, ++number_, &out);
    if (Status s = writer_->write_raw(&out.msg); !s) return s;
    ++written_;
  }
  std::vector<TeamMessage> in;
  Status st = reader_->take_each([&](const void* sample, const dds_sample_info_t&) {
    uint64_t number = 0;
    auto m = from_message(*static_cast<const vigil_msgs_TeamMessage*>(sample), &number);
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
  });
  if (!st) return st;
  if (silent) return Status::Ok();
  for (TeamMessage& m : in) {
    if (Status s = world.deliver(robot_, std::move(m)); !s) return s;
    ++delivered_;
  }
  return Status::Ok();
}

}  // namespace vigil::dds
