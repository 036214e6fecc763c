// vigil bench dds: what the event path costs on this machine, beside Cyclone's own ddsperf run
// in the same session.
//   1. Round trip: this process publishes a camera event, `vigil bench dds-echo` (another
//      process) answers each one with an incident; N sequential round trips (waitsets at both
//      ends), median and p99.
//   2. Frame to subscriber: this process runs a camera's activity rules on frames stamped with
//      CLOCK_MONOTONIC; on the frame where a left-bag rule fires, the event goes over DDS to
//      `vigil server` (a second process: checks, map frame, merging) and on to `vigil events`
//      (a third process), which prints receive time minus the frame's stamp. Median and p99.
//   3. ddsperf: `ddsperf ping waitset` against `ddsperf pong waitset` on the same loopback
//      configuration, its per-second medians and 99th percentiles.
#include <nlohmann/json.hpp>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "plugins/dds_bridge/dds.h"
#include "plugins/dds_bridge/event_server.h"
#include "plugins/stereo_camera/stereo_camera.h"
#include "tools/vigil/commands.h"
#include "vision/activity_rules.h"
#include "world/scenario.h"

extern char** environ;

namespace vigil::cli {
namespace {

namespace fs = std::filesystem;

int64_t mono_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5));
  return v[i];
}

std::string self_exe() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string("vigil") : p.string();
}

// Starts a program with stdout (and stderr) to `log`; returns the pid.
pid_t spawn(const std::vector<std::string>& args, const fs::path& log, const std::vector<std::string>& extra_env = {}) {
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  std::vector<std::string> a = args;
  std::vector<char*> argv;
  for (auto& s : a) argv.push_back(s.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_store;
  for (char** e = environ; *e; ++e) env_store.emplace_back(*e);
  env_store.insert(env_store.end(), extra_env.begin(), extra_env.end());
  std::vector<char*> envp;
  for (auto& s : env_store) envp.push_back(s.data());
  envp.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, argv[0], &fa, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&fa);
  return rc == 0 ? pid : -1;
}

int wait_pid(pid_t pid) {
  int st = 0;
  waitpid(pid, &st, 0);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

struct Stats {
  double median_us = 0, p99_us = 0;
  size_t n = 0;
};
Stats stats_us(const std::vector<double>& ns) {
  Stats s;
  s.n = ns.size();
  s.median_us = quantile(ns, 0.5) / 1000;
  s.p99_us = quantile(ns, 0.99) / 1000;
  return s;
}

// 1. Round trips against the echo process.
Stats round_trips(const std::string& session, int count, const fs::path& tmp) {
  const pid_t echo = spawn({self_exe(), "bench", "dds-echo", "--session", session}, tmp / "echo.log");
  if (echo < 0) throw Exit{report(internal_error("cannot start vigil bench dds-echo"))};
  dds::DomainOptions d;
  d.session = session;
  auto part = dds::Participant::create(d);
  if (!part) throw Exit{report(part.error())};
  dds::TopicQos qos;
  qos.depth = 1;  // one instance, latest only: a ping-pong
  auto w = dds::Writer::create(**part, dds::Topic::kCameraEvents, qos);
  if (!w) throw Exit{report(w.error())};
  auto r = dds::Reader::create(**part, dds::Topic::kMapEvents, qos);
  if (!r) throw Exit{report(r.error())};
  if ((*w)->wait_for_readers(1, 20) < 1) throw Exit{report(internal_error("the echo process did not appear"))};
  const int warmup = std::max(100, count / 10);
  std::vector<double> rtt;
  vision::Event e;
  e.camera = "bench";
  e.id = 1;
  std::vector<int32_t> buf;
  for (int i = 1; i <= warmup + count; ++i) {
    e.stamp_ns = i;
    const vigil_msgs_CameraEvent m = dds::to_message(e, &buf);
    const int64_t t0 = mono_ns();
    if (Status s = (*w)->write_raw(&m); !s) throw Exit{report(s.error())};
    bool back = false;
    while (!back) {
      if (!(*r)->wait(5.0)) throw Exit{report(internal_error("no answer from the echo process in 5 s"))};
      if (Status s = (*r)->take_each([&](const void* p, const dds_sample_info_t&) {
            if (static_cast<const vigil_msgs_MapEvent*>(p)->stamp_ns == i) back = true;
          });
          !s)
        throw Exit{report(s.error())};
    }
    if (i > warmup) rtt.push_back(static_cast<double>(mono_ns() - t0));
  }
  // Tell the echo to stop: stamp -1.
  e.stamp_ns = -1;
  const vigil_msgs_CameraEvent stop = dds::to_message(e, &buf);
  (void)(*w)->write_raw(&stop);
  if (wait_pid(echo) != 0) std::fprintf(stderr, "bench dds: echo process: %s\n", slurp(tmp / "echo.log").c_str());
  return stats_us(rtt);
}

// 2. Frame to subscriber through the server.
Stats frame_to_subscriber(const std::string& session, int count, const std::string& scenario_file, const fs::path& tmp) {
  auto sc = load_scenario(scenario_file, ScenarioContext{});
  if (!sc) throw Exit{report(sc.error())};
  const CameraSpec* cam = sc->cameras.empty() ? nullptr : &sc->cameras.front();
  if (!cam) throw Exit{report(bad_input(scenario_file, 0, "cameras", "the benchmark needs a camera"))};
  const std::string self = self_exe();
  const pid_t server = spawn({self, "server", scenario_file, "--session", session, "--idle-exit", "3", "--max-seconds", "300",
                              "--merge-time", "0"},
                             tmp / "server.log");
  const pid_t sub = spawn({self, "events", "--session", session, "--latency", "--count", std::to_string(count), "--timeout", "60"},
                          tmp / "latency.txt");
  if (server < 0 || sub < 0) throw Exit{report(internal_error("cannot start vigil server / vigil events"))};
  dds::DomainOptions d;
  d.session = session;
  auto part = dds::Participant::create(d);
  if (!part) throw Exit{report(part.error())};
  auto pub = dds::CameraEventPublisher::create(**part);
  if (!pub) throw Exit{report(pub.error())};
  if ((*pub)->writer().wait_for_readers(1, 20) < 1) throw Exit{report(internal_error("the server did not appear"))};
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // let the subscriber match the server
  vision::ActivityRuleParams rp;
  rp.left_bag_time = 0;
  rp.object_confirm_time = 0;
  rp.start_time = 0;  // only the very first bag counts as present at the start: trial 0 is a warm-up
  // Forget a reported bag within a few milliseconds, so the next trial can use the same spot.
  rp.person_lost_time = 0.001;
  rp.object_gone_time = 0;
  auto rules = vision::ActivityRules::create(rp, cam->id, render::camera_model(*cam));
  if (!rules) throw Exit{report(rules.error())};
  // Trial j: a bag and its owner appear at the corridor's middle (two frames), then the owner is
  // 4 m away: the rule fires on that frame, which is stamped with the clock when its processing
  // starts. An empty frame 6 ms later clears the spot.
  int fired = 0;
  for (int j = 0; j <= count; ++j) {
    const double bx = 21.0, by = 3.0;
    for (int f = 0; f < 3; ++f) {
      std::vector<vision::Track> tracks;
      const int64_t stamp = mono_ns();
      vision::Track bag, person;
      bag.stamp_ns = person.stamp_ns = stamp;
      bag.camera = person.camera = cam->id;
      bag.id = 100000 + j;
      bag.cls = vision::TrackClass::kBag;
      bag.x = bx;
      bag.y = by;
      bag.height = 0.4;
      bag.confidence = 0.9;
      person.id = 1 + j;
      person.cls = vision::TrackClass::kPerson;
      person.x = f < 2 ? bx + 0.5 : bx + 4.0;
      person.y = by;
      person.height = 1.75;
      person.confidence = 0.9;
      tracks = {bag, person};
      auto out = rules->update(stamp, tracks);
      if (!out) throw Exit{report(out.error())};
      for (const auto& e : *out) {
        if (Status s = (*pub)->publish(e); !s) throw Exit{report(s.error())};
        ++fired;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(6));
    auto out = rules->update(mono_ns(), {});
    if (!out) throw Exit{report(out.error())};
  }
  if (wait_pid(sub) != 0)
    std::fprintf(stderr, "bench dds: the subscriber did not get all %d events (%d fired): %s\n", count, fired,
                 slurp(tmp / "server.log").c_str());
  wait_pid(server);
  std::vector<double> lat;
  std::istringstream in(slurp(tmp / "latency.txt"));
  for (std::string line; std::getline(in, line);) {
    char* end = nullptr;
    const double v = std::strtod(line.c_str(), &end);
    if (end != line.c_str()) lat.push_back(v);
  }
  return stats_us(lat);
}

struct DdsperfStats {
  std::vector<double> medians_us, p99s_us;
  bool ran = false;
};

// 3. ddsperf ping/pong on the loopback configuration.
DdsperfStats run_ddsperf(int seconds, const fs::path& tmp, const std::string& mode) {
  DdsperfStats r;
  const std::string uri = "CYCLONEDDS_URI=" + dds::loopback_config();
  const pid_t pong = spawn({"ddsperf", "-D", std::to_string(seconds + 3), "pong", mode}, tmp / "pong.log", {uri});
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const pid_t ping = spawn({"ddsperf", "-D", std::to_string(seconds), "ping", mode}, tmp / "ping.log", {uri});
  if (pong < 0 || ping < 0) return r;
  const int rc = wait_pid(ping);
  kill(pong, SIGTERM);
  wait_pid(pong);
  if (rc != 0) return r;
  const std::regex line(R"(size \d+ mean [0-9.]+us min [0-9.]+us 50% ([0-9.]+)us 90% [0-9.]+us 99% ([0-9.]+)us)");
  std::istringstream in(slurp(tmp / "ping.log"));
  bool first = true;
  for (std::string l; std::getline(in, l);) {
    std::smatch m;
    if (!std::regex_search(l, m, line)) continue;
    if (first) {  // the first second includes discovery
      first = false;
      continue;
    }
    r.medians_us.push_back(std::stod(m[1]));
    r.p99s_us.push_back(std::stod(m[2]));
  }
  r.ran = !r.medians_us.empty();
  return r;
}

}  // namespace

void add_bench_dds_commands(CLI::App* bench) {
  struct Opts {
    int count = 5000, events = 300, ddsperf_seconds = 6;
    bool no_ddsperf = false;
    std::string scenario, json;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = bench->add_subcommand("dds", "DDS round trips and frame-to-subscriber event latency, beside ddsperf");
  cmd->add_option("--count", o->count, "round trips to time")->capture_default_str();
  cmd->add_option("--events", o->events, "events to time from frame to subscriber")->capture_default_str();
  cmd->add_option("--ddsperf-seconds", o->ddsperf_seconds, "seconds of ddsperf ping-pong")->capture_default_str();
  cmd->add_flag("--no-ddsperf", o->no_ddsperf, "skip ddsperf");
  cmd->add_option("--json", o->json, "also write the results as JSON to this file");
  cmd->add_option("--scenario", o->scenario, "scenario whose first camera and map the server uses (default: scenarios/dis_left_bag.yaml)");
  cmd->callback([o] {
    if (o->count < 10 || o->events < 10) throw Exit{report(bad_input("", 0, "--count", "--count and --events must be at least 10"))};
    const std::string scenario =
        o->scenario.empty() ? (fs::path(VIGIL_SOURCE_DIR) / "scenarios" / "dis_left_bag.yaml").string() : o->scenario;
    const fs::path tmp = fs::temp_directory_path() / ("vigil_bench_dds_" + std::to_string(getpid()));
    fs::create_directories(tmp);
    const std::string session = "bench-" + std::to_string(getpid());
    std::fprintf(stderr, "[bench dds] %d round trips...\n", o->count);
    const Stats rt = round_trips(session + "-rt", o->count, tmp);
    std::fprintf(stderr, "[bench dds] %d events frame -> server -> subscriber...\n", o->events);
    const Stats fs_lat = frame_to_subscriber(session + "-ev", o->events, scenario, tmp);
    DdsperfStats dp_ws, dp_ls;
    if (!o->no_ddsperf) {
      std::fprintf(stderr, "[bench dds] ddsperf ping/pong for 2 x %d s...\n", o->ddsperf_seconds);
      dp_ws = run_ddsperf(o->ddsperf_seconds, tmp, "waitset");
      dp_ls = run_ddsperf(o->ddsperf_seconds, tmp, "listener");
    }
    std::printf("DDS on loopback (Cyclone %s, 2 processes unless noted)\n", "0.10");
    std::printf("%-52s %8s %10s %10s\n", "what", "n", "median_us", "p99_us");
    std::printf("%-52s %8zu %10.1f %10.1f\n", "vigil round trip (camera event -> echo -> incident)", rt.n, rt.median_us, rt.p99_us);
    std::printf("%-52s %8zu %10.1f %10.1f\n", "vigil frame -> rules -> server -> subscriber (3 proc)", fs_lat.n, fs_lat.median_us,
                fs_lat.p99_us);
    for (const auto& [name, dp] : {std::pair<const char*, const DdsperfStats*>{"ddsperf ping/pong, waitset (median of 1 s windows)", &dp_ws},
                                   {"ddsperf ping/pong, listener (median of 1 s windows)", &dp_ls}}) {
      if (dp->ran)
        std::printf("%-52s %8zu %10.1f %10.1f\n", name, dp->medians_us.size(), quantile(dp->medians_us, 0.5),
                    quantile(dp->p99s_us, 0.5));
    }
    if (!o->no_ddsperf && !dp_ws.ran) {
      std::printf("ddsperf: did not run (is cyclonedds-tools installed?)\n");
    }
    fs::remove_all(tmp);
    if (!o->json.empty()) {
      nlohmann::ordered_json rows = nlohmann::ordered_json::array();
      rows.push_back({{"what", "vigil round trip"}, {"n", rt.n}, {"median_us", rt.median_us}, {"p99_us", rt.p99_us}});
      rows.push_back({{"what", "vigil frame to subscriber"}, {"n", fs_lat.n}, {"median_us", fs_lat.median_us},
                      {"p99_us", fs_lat.p99_us}});
      for (const auto& [name, dp] : {std::pair<const char*, const DdsperfStats*>{"ddsperf waitset", &dp_ws},
                                     {"ddsperf listener", &dp_ls}}) {
        if (dp->ran)
          rows.push_back({{"what", name}, {"n", dp->medians_us.size()}, {"median_us", quantile(dp->medians_us, 0.5)},
                          {"p99_us", quantile(dp->p99s_us, 0.5)}});
      }
      std::ofstream f(o->json);
      f << rows.dump(2) << "\n";
      if (!f) throw Exit{report(bad_input(o->json, 0, "--json", "cannot write"))};
    }
  });

  // The other end of the round trips: answers every camera event with an incident.
  struct EchoOpts {
    std::string session;
  };
  auto e = std::make_shared<EchoOpts>();
  auto* echo = bench->add_subcommand("dds-echo", "(used by bench dds) answer camera events with incidents");
  echo->add_option("--session", e->session)->required();
  echo->callback([e] {
    dds::DomainOptions d;
    d.session = e->session;
    auto part = dds::Participant::create(d);
    if (!part) throw Exit{report(part.error())};
    dds::TopicQos qos;
    qos.depth = 1;
    auto r = dds::Reader::create(**part, dds::Topic::kCameraEvents, qos);
    if (!r) throw Exit{report(r.error())};
    auto w = dds::Writer::create(**part, dds::Topic::kMapEvents, qos);
    if (!w) throw Exit{report(w.error())};
    dds::Incident in;
    in.id = 1;
    dds::MapEventMessage m;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(10);
    for (bool stop = false; !stop && std::chrono::steady_clock::now() < deadline;) {
      if (!(*r)->wait(1.0)) continue;
      std::vector<int64_t> stamps;
      if (Status s = (*r)->take_each([&](const void* p, const dds_sample_info_t&) {
            stamps.push_back(static_cast<const vigil_msgs_CameraEvent*>(p)->stamp_ns);
          });
          !s)
        throw Exit{report(s.error())};
      for (int64_t t : stamps) {
        if (t < 0) {
          stop = true;
          break;
        }
        in.stamp_ns = t;
        dds::to_message(in, &m);
        if (Status s = (*w)->write_raw(&m.msg); !s) throw Exit{report(s.error())};
      }
    }
  });
}

}  // namespace vigil::cli
