// The system across hosts (issue 14, docs/RELIABILITY.md): camera node, video server and
// subscribers each in its own network namespace, joined by veth pairs to a bridge in a switch
// namespace, each with its own address and a Cyclone DDS configuration naming that interface and
// the other hosts as peers (docs/EVENTS.md's multi-host setup). Faults injected there: a link that
// drops a share of its packets (nftables `numgen random`; this kernel has no netem, so no delay),
// the server killed and restarted on its host mid-incident.
//
// Needs root (namespaces, links, nftables); skips with a message otherwise. Every namespace and
// link the test makes carries its process id and is removed at the end.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "tests/process_util.h"
#include "tests/test_util.h"
#include "vision/event.h"


namespace vigil {
namespace {

namespace fs = std::filesystem;
using test::slurp;

// Runs a shell command; its exit code (output to `out` when given).
int sh(const std::string& cmd, std::string* out = nullptr) {
  const std::string full = cmd + " 2>&1";
  FILE* p = popen(full.c_str(), "r");
  if (!p) return -1;
  std::string text;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) text.append(buf, n);
  const int st = pclose(p);
  if (out) *out = text;
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

// A small network of hosts: namespaces on one bridge.
class Hosts {
 public:
  // Hosts named `names`; false with `why` when this machine cannot make them.
  bool make(const std::vector<std::string>& names, std::string* why) {
    if (::geteuid() != 0) {
      *why = "needs root for network namespaces";
      return false;
    }
    if (sh("command -v ip") != 0 || sh("command -v nft") != 0) {
      *why = "needs ip (iproute2) and nft (nftables): tools/install_deps.sh installs them";
      return false;
    }
    const int pid = static_cast<int>(::getpid());
    tag_ = "vg" + std::to_string(pid % 100000);
    subnet_ = "10.213." + std::to_string(20 + pid % 200);
    sw_ = tag_ + "-sw";
    std::string out;
    auto run = [&](const std::string& c) {
      if (sh(c, &out) != 0) {
        *why = "'" + c + "' failed: " + out;
        return false;
      }
      return true;
    };
    if (!run("ip netns add " + sw_)) return false;
    made_.push_back(sw_);
    if (!run("ip -n " + sw_ + " link add br0 type bridge") || !run("ip -n " + sw_ + " link set br0 up")) return false;
    for (size_t i = 0; i < names.size(); ++i) {
      const std::string ns = tag_ + "-" + names[i], a = tag_ + "h" + std::to_string(i), b = tag_ + "s" + std::to_string(i);
      const std::string ip = subnet_ + "." + std::to_string(i + 1);
      if (!run("ip netns add " + ns)) return false;
      made_.push_back(ns);
      if (!run("ip link add " + a + " type veth peer name " + b) || !run("ip link set " + a + " netns " + ns) ||
          !run("ip link set " + b + " netns " + sw_) || !run("ip -n " + ns + " link set " + a + " name eth0") ||
          !run("ip -n " + ns + " addr add " + ip + "/24 dev eth0") || !run("ip -n " + ns + " link set eth0 up") ||
          !run("ip -n " + ns + " link set lo up") || !run("ip -n " + sw_ + " link set " + b + " master br0") ||
          !run("ip -n " + sw_ + " link set " + b + " up"))
        return false;
      hosts_.push_back({names[i], ns, ip});
    }
    return true;
  }
  ~Hosts() {
    for (auto it = made_.rbegin(); it != made_.rend(); ++it) sh("ip netns del " + *it);
  }
  struct Host {
    std::string name, ns, ip;
  };
  const Host& host(const std::string& name) const {
    for (const auto& h : hosts_)
      if (h.name == name) return h;
    static const Host none;
    ADD_FAILURE() << "no host " << name;
    return none;
  }
  // The Cyclone configuration of a host: its own interface, no multicast, every host a peer.
  fs::path config(const std::string& name, const fs::path& dir) const {
    const Host& h = host(name);
    std::string peers;
    for (const auto& o : hosts_) peers += "        <Peer address=\"" + o.ip + "\"/>\n";
    const fs::path p = dir / ("cyclone_" + name + ".xml");
    std::ofstream(p) << "<CycloneDDS>\n  <Domain id=\"any\">\n    <General>\n      <Interfaces>\n"
                        "        <NetworkInterface address=\"" + h.ip + "\"/>\n      </Interfaces>\n"
                        "      <AllowMulticast>false</AllowMulticast>\n    </General>\n    <Discovery>\n"
                        "      <ParticipantIndex>auto</ParticipantIndex>\n      <MaxAutoParticipantIndex>40</MaxAutoParticipantIndex>\n"
                        "      <Peers>\n" + peers + "      </Peers>\n    </Discovery>\n  </Domain>\n</CycloneDDS>\n";
    return p;
  }
  // Drops `percent` of the packets leaving and entering host `name` (its one link).
  bool lossy(const std::string& name, int percent) const {
    const std::string ns = host(name).ns;
    const std::string p = std::to_string(percent);
    return sh("ip netns exec " + ns + " nft add table inet vigil_fault") == 0 &&
           sh("ip netns exec " + ns + " nft add chain inet vigil_fault out '{ type filter hook output priority 0; }'") == 0 &&
           sh("ip netns exec " + ns + " nft add chain inet vigil_fault in '{ type filter hook input priority 0; }'") == 0 &&
           sh("ip netns exec " + ns + " nft add rule inet vigil_fault out oifname eth0 numgen random mod 100 '<' " + p + " counter drop") == 0 &&
           sh("ip netns exec " + ns + " nft add rule inet vigil_fault in iifname eth0 numgen random mod 100 '<' " + p + " counter drop") == 0;
  }
  // Packets the loss rules on host `name` dropped so far, both ways (their counters).
  long dropped(const std::string& name) const {
    std::string out;
    if (sh("ip netns exec " + host(name).ns + " nft list table inet vigil_fault", &out) != 0) return -1;
    long total = 0;
    for (size_t at = out.find("packets "); at != std::string::npos; at = out.find("packets ", at + 8))
      total += std::atol(out.c_str() + at + 8);
    return total;
  }
  // Packets host `name`'s link received so far (the traffic really crossed the veth pairs).
  long rx_packets(const std::string& name) const {
    std::string out;
    if (sh("ip netns exec " + host(name).ns + " cat /sys/class/net/eth0/statistics/rx_packets", &out) != 0) return -1;
    return std::atol(out.c_str());
  }

 private:
  std::string tag_, subnet_, sw_;
  std::vector<std::string> made_;
  std::vector<Host> hosts_;
};

pid_t spawn_on(const std::string& ns, const std::vector<std::string>& args, const fs::path& log) {
  return test::spawn_vigil(args, log, ns);
}
using test::read_events;
using test::wait_exit;
using test::wait_for_lines;

const std::string kScenario = (test::source_dir() / "scenarios" / "dis_bag_taken.yaml").string();

// What one process writes for the same scenario and sensor (vigil run, loopback).
std::string single_process_events(const fs::path& dir) {
  std::string text = slurp(kScenario);
  const std::string anchor = "  - id: cam_corridor\n";
  text.insert(text.find(anchor) + anchor.size(), "    plugin: truth\n");
  const fs::path copy = fs::path(kScenario).parent_path() / ("tmp_netns_" + std::to_string(::getpid()) + ".yaml");
  { std::ofstream(copy) << text; }
  const auto out = test::vigil_cmd("run " + copy.string() + " --out " + (dir / "run").string() + " --no-video -q");
  fs::remove(copy);
  EXPECT_EQ(out.code, 0) << out.out;
  return slurp(dir / "run" / "events.jsonl");
}

// Camera node, server and a late subscriber on three hosts, with `loss` percent of the camera
// host's packets dropped both ways: the server's incidents are those of the single process.
void three_hosts(const std::string& name, int loss) {
  Hosts net;
  std::string why;
  if (!net.make({"cam", "srv", "sub"}, &why)) GTEST_SKIP() << "no multi-host test here: " << why;
  if (loss > 0) {
    ASSERT_TRUE(net.lossy("cam", loss)) << "nftables loss rule";
  }
  const fs::path dir = test::fresh_temp_dir("netns", name);
  const std::string s = name + "-" + std::to_string(::getpid());
  const pid_t server = spawn_on(net.host("srv").ns,
                                {"server", kScenario, "--session", s, "--dds-config", net.config("srv", dir).string(), "--out",
                                 (dir / "server").string(), "--max-seconds", "120", "--idle-exit", "10"},
                                dir / "server.log");
  ASSERT_GT(server, 0);
  const pid_t cam = spawn_on(net.host("cam").ns,
                             {"camera-node", kScenario, "--camera", "cam_corridor", "--sensor", "truth", "--session", s,
                              "--dds-config", net.config("cam", dir).string(), "--wait-for-server", "30", "--linger", "3"},
                             dir / "cam.log");
  ASSERT_GT(cam, 0);
  EXPECT_EQ(wait_exit(cam), 0) << slurp(dir / "cam.log");
  ASSERT_TRUE(wait_for_lines(dir / "server" / "events.jsonl", 2, 60)) << slurp(dir / "server.log") << slurp(dir / "cam.log");
  // A subscriber on a third host, started after the camera node is gone, gets both incidents
  // from the server's durable history.
  const pid_t sub = spawn_on(net.host("sub").ns,
                             {"events", "--session", s, "--dds-config", net.config("sub", dir).string(), "--count", "2",
                              "--timeout", "60", "--text"},
                             dir / "sub.log");
  ASSERT_GT(sub, 0);
  EXPECT_EQ(wait_exit(sub), 0) << slurp(dir / "sub.log");
  EXPECT_NE(slurp(dir / "sub.log").find("left bag 20."), std::string::npos) << slurp(dir / "sub.log");
  EXPECT_NE(slurp(dir / "sub.log").find("bag taken 20."), std::string::npos) << slurp(dir / "sub.log");
  EXPECT_EQ(wait_exit(server), 0) << slurp(dir / "server.log");
  EXPECT_GT(net.rx_packets("srv"), 50) << "the server's host received over its link";
  if (loss > 0) {
    EXPECT_GT(net.dropped("cam"), 10) << "the camera host's link dropped packets";
  }
  std::printf("[netns] %s: server host received %ld packets; camera link dropped %ld\n", name.c_str(),
              net.rx_packets("srv"), loss > 0 ? net.dropped("cam") : 0L);
  EXPECT_GT(net.rx_packets("sub"), 10) << "the subscriber's host received over its link";
  EXPECT_EQ(slurp(dir / "server" / "events.jsonl"), single_process_events(dir))
      << "the incidents across hosts" << (loss ? " over the lossy link" : "") << " are the single process's";
  fs::remove_all(dir);
}

TEST(NetnsHosts, CameraServerAndSubscriberOnThreeHostsMatchOneProcess) { three_hosts("three", 0); }

// Reliable topics resend what a link drops: late, never lost.
TEST(NetnsHosts, ALinkDroppingAThirdOfItsPacketsLosesNoIncident) { three_hosts("lossy", 33); }

// The server's host: its process killed mid-incident (after the left bag, before the bag is
// taken) and started again: it gets the left bag again from the camera host's durable history
// (same incident id) and the bag taken live.
TEST(NetnsHosts, ServerRestartedOnItsHostMidIncidentRecoversBoth) {
  Hosts net;
  std::string why;
  if (!net.make({"cam", "srv"}, &why)) GTEST_SKIP() << "no multi-host test here: " << why;
  const fs::path dir = test::fresh_temp_dir("netns", "restart");
  const std::string s = "restart-" + std::to_string(::getpid());
  const std::string srv_cfg = net.config("srv", dir).string();
  pid_t server = spawn_on(net.host("srv").ns,
                          {"server", kScenario, "--session", s, "--dds-config", srv_cfg, "--out", (dir / "a").string(),
                           "--max-seconds", "120"},
                          dir / "a.log");
  ASSERT_GT(server, 0);
  // 5x real time: left bag at about 4.2 s of wall time, bag taken at about 7.1 s.
  const pid_t cam = spawn_on(net.host("cam").ns,
                             {"camera-node", kScenario, "--camera", "cam_corridor", "--sensor", "truth", "--session", s,
                              "--dds-config", net.config("cam", dir).string(), "--speed", "5", "--duration", "40",
                              "--wait-for-server", "30", "--linger", "5"},
                             dir / "cam.log");
  ASSERT_GT(cam, 0);
  ASSERT_TRUE(wait_for_lines(dir / "a" / "events.jsonl", 1, 60)) << slurp(dir / "a.log") << slurp(dir / "cam.log");
  kill(server, SIGKILL);
  wait_exit(server);
  server = spawn_on(net.host("srv").ns,
                    {"server", kScenario, "--session", s, "--dds-config", srv_cfg, "--out", (dir / "b").string(),
                     "--max-seconds", "120", "--idle-exit", "5"},
                    dir / "b.log");
  ASSERT_GT(server, 0);
  EXPECT_EQ(wait_exit(cam), 0) << slurp(dir / "cam.log");
  EXPECT_EQ(wait_exit(server), 0) << slurp(dir / "b.log");
  const auto before = read_events(dir / "a" / "events.jsonl");
  const auto after = read_events(dir / "b" / "events.jsonl");
  ASSERT_EQ(before.size(), 1u);
  EXPECT_EQ(before[0].kind, vision::EventKind::kLeftBag);
  ASSERT_EQ(after.size(), 2u) << slurp(dir / "b.log");
  EXPECT_EQ(after[0].kind, vision::EventKind::kLeftBag);
  EXPECT_EQ(after[0].id, before[0].id) << "the same incident, replayed";
  EXPECT_EQ(after[1].kind, vision::EventKind::kBagTaken);
  fs::remove_all(dir);
}

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::vector<std::string> report_events(const fs::path& p, const std::string& field, const std::string& value) {
  std::vector<std::string> out;
  std::istringstream in(slurp(p));
  for (std::string l; std::getline(in, l);) {
    auto j = nlohmann::json::parse(l, nullptr, false);
    if (!j.is_discarded() && j.value(field, "") == value) out.push_back(l);
  }
  return out;
}

// The whole response loop on five hosts (camera, server, two robots, an operator's subscriber),
// one clock (--epoch) at 4x real time; robot2's host loses its process at 10 s (simulated) and
// starts it again at 20 s: robot1 sees robot2 leave and come back, each incident is served.
TEST(NetnsHosts, RobotNodesOnTheirOwnHostsRespondAndAKilledOneRejoins) {
  Hosts net;
  std::string why;
  if (!net.make({"cam", "srv", "r1", "r2", "ops"}, &why)) GTEST_SKIP() << "no multi-host test here: " << why;
  const std::string scenario = (test::source_dir() / "scenarios" / "dis_team_bag_taken.yaml").string();
  const fs::path dir = test::fresh_temp_dir("netns", "robots");
  const std::string s = "robots-" + std::to_string(::getpid());
  const double speed = 4, duration = 140;
  const double epoch = unix_now() + 5 * test::slowdown();  // all processes up and found
  char ep[64];
  std::snprintf(ep, sizeof ep, "%.3f", epoch);
  auto cfg = [&](const std::string& h) { return net.config(h, dir).string(); };
  auto robot_args = [&](const std::string& id, const std::string& host, const std::string& out) {
    return std::vector<std::string>{"robot-node", scenario, "--robot", id, "--session", s, "--dds-config", cfg(host), "--out",
                                    (dir / out).string(), "--speed", std::to_string(speed), "--epoch", ep, "--duration",
                                    std::to_string(duration)};
  };
  const pid_t server = spawn_on(net.host("srv").ns,
                                {"server", scenario, "--session", s, "--dds-config", cfg("srv"), "--out", (dir / "server").string(),
                                 "--max-seconds", "90"},
                                dir / "server.log");
  const pid_t cam = spawn_on(net.host("cam").ns,
                             {"camera-node", scenario, "--camera", "cam_corridor", "--sensor", "truth", "--session", s,
                              "--dds-config", cfg("cam"), "--speed", std::to_string(speed), "--epoch", ep, "--duration",
                              std::to_string(duration), "--linger", "2"},
                             dir / "cam.log");
  const pid_t watch = spawn_on(net.host("ops").ns, {"events", "--assignments", "--session", s, "--dds-config", cfg("ops")},
                               dir / "assignments.log");
  const pid_t r1 = spawn_on(net.host("r1").ns, robot_args("robot1", "r1", "r1"), dir / "r1.log");
  pid_t r2 = spawn_on(net.host("r2").ns, robot_args("robot2", "r2", "r2"), dir / "r2.log");
  ASSERT_GT(server, 0);
  ASSERT_GT(cam, 0);
  ASSERT_GT(watch, 0);
  ASSERT_GT(r1, 0);
  ASSERT_GT(r2, 0);
  auto sleep_until_sim = [&](double t) {
    const double wall = epoch + t / speed - unix_now();
    if (wall > 0) std::this_thread::sleep_for(std::chrono::duration<double>(wall));
  };
  sleep_until_sim(10);
  kill(r2, SIGKILL);
  wait_exit(r2);
  sleep_until_sim(20);
  r2 = spawn_on(net.host("r2").ns, robot_args("robot2", "r2", "r2b"), dir / "r2b.log");
  ASSERT_GT(r2, 0);
  EXPECT_EQ(wait_exit(r1), 0) << slurp(dir / "r1.log");
  EXPECT_EQ(wait_exit(r2), 0) << slurp(dir / "r2b.log");
  EXPECT_EQ(wait_exit(cam), 0) << slurp(dir / "cam.log");
  kill(server, SIGTERM);
  EXPECT_EQ(wait_exit(server), 0) << slurp(dir / "server.log");
  kill(watch, SIGTERM);
  wait_exit(watch);
  const auto teams = report_events(dir / "r1" / "robots.jsonl", "event", "team_formed");
  ASSERT_GE(teams.size(), 2u) << slurp(dir / "r1.log");
  EXPECT_NE(teams[0].find("robot1,robot2"), std::string::npos) << teams[0];
  EXPECT_NE(teams[1].find("\"detail\":\"robot1\""), std::string::npos) << "robot2's process was killed: " << teams[1];
  EXPECT_NE(slurp(dir / "r2b.log").find("joining the team"), std::string::npos) << slurp(dir / "r2b.log");
  const auto incidents = read_events(dir / "server" / "events.jsonl");
  ASSERT_EQ(incidents.size(), 2u) << slurp(dir / "server.log");
  // Each incident assigned to a robot, and the bag taken's robot arrived.
  std::string reports = slurp(dir / "r1" / "robots.jsonl") + slurp(dir / "r2b" / "robots.jsonl");
  for (const auto& in : incidents) {
    const std::string id = "\"task_id\":" + std::to_string(in.id);
    bool assigned = false, arrived = false;
    std::istringstream lines(reports);
    for (std::string l; std::getline(lines, l);) {
      if (l.find(id) == std::string::npos) continue;
      assigned = assigned || l.find("\"task_assigned\"") != std::string::npos;
      arrived = arrived || l.find("\"arrived_at_incident\"") != std::string::npos;
    }
    EXPECT_TRUE(assigned) << "incident " << in.id << " assigned";
    if (in.kind == vision::EventKind::kBagTaken) {
      EXPECT_TRUE(arrived) << "the bag taken's robot arrives";
    }
  }
  EXPECT_NE(slurp(dir / "assignments.log").find("keep"), std::string::npos) << "the operator's host saw the keepers";
  EXPECT_GT(net.rx_packets("r2"), 100);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace vigil
