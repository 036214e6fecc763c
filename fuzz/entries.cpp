#include "fuzz/entries.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string_view>

#include "planning/patrol/patrol_graph.h"
#include "plugins/dds_bridge/dds.h"
#include "plugins/dds_bridge/event_relay.h"
#include "plugins/dds_bridge/event_server.h"
#include "plugins/dds_bridge/team_transport.h"
#include "vision/event.h"
#include "vision/stereo_calibration.h"
#include "world/floorplan.h"
#include "world/map.h"
#include "world/scenario.h"

namespace vigil::fuzz {
namespace fs = std::filesystem;
namespace {

// A finding that is not a crash: the entry says what and stops the program, so the fuzzer keeps
// the input (and the replay test fails).
[[noreturn]] void finding(const std::string& what) {
  std::fprintf(stderr, "vigil fuzz finding: %s\n", what.c_str());
  std::abort();
}

// A bad file must give a bad-input error that names the file and says what is wrong.
void check_file_error(const Error& e, const char* loader) {
  if (e.message.empty()) finding(std::string(loader) + ": an error without a message: " + e.str());
  if (e.file.empty()) finding(std::string(loader) + ": an error that names no file: " + e.str());
  if (e.kind != ErrorKind::kBadInput) finding(std::string(loader) + ": a bad file reported as an internal error: " + e.str());
}

// A scratch folder of this process for the loaders that read files, removed at exit; it holds
// a small valid map image under the names the seed files refer to.
const fs::path& scratch() {
  static const fs::path dir = [] {
    std::error_code ec;
    const fs::path base = fs::temp_directory_path(ec);
    fs::path d = (ec ? fs::path("/tmp") : base) / ("vigil-fuzz-" + std::to_string(::getpid()));
    fs::create_directories(d, ec);
    if (ec) finding("cannot make the scratch folder " + d.string());
    // 8 x 6 pixels: free (254) inside, occupied (0) on the border.
    std::string pgm = "P5\n8 6\n255\n";
    for (int y = 0; y < 6; ++y)
      for (int x = 0; x < 8; ++x) pgm.push_back((x == 0 || y == 0 || x == 7 || y == 5) ? '\0' : '\xfe');
    for (const char* name : {"map.pgm", "dis_labs.pgm", "DIAG_floor1.pgm", "DIAG_labs.pgm", "cave.pgm"}) {
      std::ofstream(d / name, std::ios::binary) << pgm;
    }
    std::atexit([] {
      std::error_code e2;
      fs::remove_all(scratch(), e2);
    });
    return d;
  }();
  return dir;
}

fs::path write_scratch(const std::string& name, const uint8_t* data, size_t size) {
  const fs::path p = scratch() / name;
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!f) finding("cannot write " + p.string());
  return p;
}

std::string text_of(const uint8_t* data, size_t size) { return std::string(reinterpret_cast<const char*>(data), size); }

// ---- files ----

void scenario_entry(const uint8_t* data, size_t size) {
  // As if the file lay in scenarios/, so the shipped seeds' maps resolve.
  static const fs::path file = fs::path(VIGIL_SOURCE_DIR) / "scenarios" / "fuzz_input.yaml";
  ScenarioContext ctx;
  ctx.plugin_exists = [](const std::string& n) {
    return n == "wander" || n == "waypoint_follower" || n == "navigator" || n == "team";
  };
  auto r = parse_scenario(text_of(data, size), file, ctx);
  if (!r) check_file_error(r.error(), "parse_scenario");
}

void map_yaml_entry(const uint8_t* data, size_t size) {
  auto r = load_map_yaml(write_scratch("input.yaml", data, size));
  if (!r) check_file_error(r.error(), "load_map_yaml");
}

// The image of a map_server map: the first byte picks PGM or PNG, the rest is the file.
void map_image_entry(const uint8_t* data, size_t size) {
  if (size < 1) return;
  const bool png = data[0] & 1;
  const std::string image = png ? "input_image.png" : "input_image.pgm";
  write_scratch(image, data + 1, size - 1);
  const std::string yaml = "image: " + image +
                           "\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\n"
                           "free_thresh: 0.196\n";
  auto r = load_map_yaml(write_scratch("input_image.yaml", reinterpret_cast<const uint8_t*>(yaml.data()), yaml.size()));
  if (!r) check_file_error(r.error(), "load_map_yaml (image)");
}

void stage_world_entry(const uint8_t* data, size_t size) {
  auto r = load_stage_world(write_scratch("input.world", data, size));
  if (!r) check_file_error(r.error(), "load_stage_world");
}

void floorplan_entry(const uint8_t* data, size_t size) {
  auto r = load_floorplan(write_scratch("input.floorplan.yaml", data, size));
  if (!r) {
    check_file_error(r.error(), "load_floorplan");
    return;
  }
  (void)r->rasterize();
}

void stereo_calibration_entry(const uint8_t* data, size_t size) {
  auto r = vision::load_stereo_calibration(write_scratch("input_rig.yaml", data, size).string());
  if (!r) {
    check_file_error(r.error(), "load_stereo_calibration");
    return;
  }
  (void)vision::rectified_camera_model(*r);
}

void patrol_graph_entry(const uint8_t* data, size_t size) {
  auto r = planning::patrol::PatrolGraph::parse(text_of(data, size), "input.graph");
  if (!r) check_file_error(r.error(), "PatrolGraph::parse");
}

// The chapter's string form, and a line of events.jsonl.
void event_string_entry(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto s = vision::parse_event_string(text, "input");
  if (s) {
    // What parses prints back to a string that parses to the same event.
    auto again = vision::parse_event_string(vision::format_event_string(*s), "again");
    if (!again || again->kind != s->kind || again->cancelled != s->cancelled)
      finding("parse_event_string: the printed form of a parsed event does not parse back to it: " +
              std::string(text));
  } else if (s.error().message.empty()) {
    finding("parse_event_string: an error without a message");
  }
  auto j = vision::parse_event_json(text, "input.jsonl", 1);
  if (!j) check_file_error(j.error(), "parse_event_json");
}

// ---- DDS samples ----

// Reads fields from the fuzz bytes: what a deserialised sample of any content would hold.
class Bytes {
 public:
  Bytes(const uint8_t* d, size_t n) : d_(d), n_(n) {}
  template <class T>
  T take() {
    T v{};
    const size_t k = std::min(sizeof(T), n_);
    std::memcpy(&v, d_, k);
    d_ += k;
    n_ -= k;
    return v;
  }
  std::string str() {
    const size_t len = std::min<size_t>(take<uint8_t>() % 24, n_);
    std::string s(reinterpret_cast<const char*>(d_), len);
    d_ += len;
    n_ -= len;
    return s;
  }
  bool empty() const { return n_ == 0; }

 private:
  const uint8_t* d_;
  size_t n_;
};

// The strings and sequences a message points into, kept alive while it is checked.
struct Store {
  std::vector<std::unique_ptr<std::string>> strings;
  std::vector<std::unique_ptr<std::vector<char*>>> string_seqs;
  std::vector<std::unique_ptr<std::vector<int32_t>>> int_seqs;
  std::vector<std::unique_ptr<std::vector<uint64_t>>> u64_seqs;
  char* str(Bytes& b) {
    strings.push_back(std::make_unique<std::string>(b.str()));
    return strings.back()->data();
  }
};

vigil_msgs_Point3 point(Bytes& b) { return {b.take<double>(), b.take<double>(), b.take<double>()}; }

// The video server's side: camera events (several, so merges and cancellations happen) into the
// server's merger with the two corridor cameras of dis_two_views; then the robots' side: a map
// event, a team message, a robot state, a task assignment.
void dds_messages_entry(const uint8_t* data, size_t size) {
  struct Server {
    std::unique_ptr<dds::IncidentMerger> merger;
  };
  static const Server server = [] {
    Server s;
    auto sc = load_scenario(fs::path(VIGIL_SOURCE_DIR) / "scenarios" / "dis_two_views.yaml");
    if (!sc) finding("cannot load the server's scenario: " + sc.error().str());
    auto fp = load_floorplan(sc->map);
    if (!fp) finding("cannot load the server's map: " + fp.error().str());
    static const OccupancyGrid grid = fp->rasterize();
    s.merger = std::make_unique<dds::IncidentMerger>(dds::server_cameras(*sc), dds::MergeParams{}, dds::inside_map(grid));
    return s;
  }();
  dds::IncidentMerger merger = *server.merger;  // a fresh server per input
  Bytes b(data, size);
  Store st;
  const std::vector<std::string> cameras = {"cam_corridor", "cam_corridor_west", "", "cam_lab"};
  for (int k = 0; !b.empty() && k < 8; ++k) {
    const uint8_t what = b.take<uint8_t>() % 5;
    if (what == 0) {
      vigil_msgs_CameraEvent m{};
      const uint8_t cam = b.take<uint8_t>();
      if (cam < 4 * 48) {
        st.strings.push_back(std::make_unique<std::string>(cameras[cam % 4]));
        m.camera = st.strings.back()->data();
      } else {
        m.camera = st.str(b);
      }
      m.id = b.take<uint8_t>();
      m.kind = static_cast<vigil_msgs_EventKind>(b.take<int32_t>() % 6);
      m.cancelled = b.take<uint8_t>() & 1;
      m.stamp_ns = b.take<int64_t>();
      m.position = point(b);
      m.object_track = b.take<int32_t>();
      m.object = st.str(b);
      st.int_seqs.push_back(std::make_unique<std::vector<int32_t>>(b.take<uint8_t>() % 6));
      for (auto& p : *st.int_seqs.back()) p = b.take<int32_t>();
      m.people = {static_cast<uint32_t>(st.int_seqs.back()->size()), static_cast<uint32_t>(st.int_seqs.back()->size()),
                  st.int_seqs.back()->data(), false};
      m.confidence = b.take<double>();
      auto e = dds::from_message(m);
      if (!e) {
        if (e.error().key.empty() || e.error().message.empty())
          finding("from_message(CameraEvent): an error that names no field: " + e.error().str());
        continue;
      }
      const auto o = merger.add(*e);
      if (o.what == dds::IncidentMerger::Outcome::kRejected && o.reason.empty())
        finding("the server rejected a camera event without a reason");
    } else if (what == 1) {
      vigil_msgs_MapEvent m{};
      m.incident = b.take<uint64_t>();
      m.kind = static_cast<vigil_msgs_EventKind>(b.take<int32_t>());
      m.cancelled = b.take<uint8_t>() & 1;
      m.stamp_ns = b.take<int64_t>();
      m.position = point(b);
      const uint32_t nc = b.take<uint8_t>() % 4, ni = b.take<uint8_t>() % 4;
      st.string_seqs.push_back(std::make_unique<std::vector<char*>>());
      for (uint32_t i = 0; i < nc; ++i) st.string_seqs.back()->push_back(st.str(b));
      st.u64_seqs.push_back(std::make_unique<std::vector<uint64_t>>(ni));
      for (auto& v : *st.u64_seqs.back()) v = b.take<uint64_t>();
      m.cameras = {nc, nc, st.string_seqs.back()->data(), false};
      m.camera_event_ids = {ni, ni, st.u64_seqs.back()->data(), false};
      m.object = st.str(b);
      m.confidence = b.take<double>();
      m.text = st.str(b);
      auto r = dds::from_message(m);
      if (!r && r.error().message.empty()) finding("from_message(MapEvent): an error without a message");
    } else if (what == 2) {
      vigil_msgs_TeamMessage m{};
      m.from = st.str(b);
      m.number = b.take<uint64_t>();
      m.to = st.str(b);
      m.kind = st.str(b);
      m.sent_ns = b.take<int64_t>();
      m.task = b.take<uint64_t>();
      m.seq = b.take<int64_t>();
      m.vertex = b.take<int32_t>();
      m.next_vertex = b.take<int32_t>();
      m.value = b.take<double>();
      m.value2 = b.take<double>();
      m.position = point(b);
      m.text = st.str(b);
      uint64_t number = 0;
      auto r = dds::from_message(m, &number);
      if (!r && r.error().message.empty()) finding("from_message(TeamMessage): an error without a message");
    } else if (what == 3) {
      vigil_msgs_RobotState m{};
      m.robot = st.str(b);
      m.stamp_ns = b.take<int64_t>();
      m.pose = point(b);
      m.linear_velocity = b.take<double>();
      m.angular_velocity = b.take<double>();
      m.mode = st.str(b);
      m.task = b.take<uint64_t>();
      auto r = dds::from_message(m);
      if (!r && r.error().message.empty()) finding("from_message(RobotState): an error without a message");
    } else {
      vigil_msgs_TaskAssignment m{};
      m.from = st.str(b);
      m.incident = b.take<uint64_t>();
      m.number = b.take<uint64_t>();
      m.to = st.str(b);
      m.state = st.str(b);
      m.robot = st.str(b);
      m.task_kind = st.str(b);
      m.priority = b.take<int32_t>();
      m.target = point(b);
      m.stamp_ns = b.take<int64_t>();
      m.hop = b.take<int64_t>();
      const uint32_t nv = b.take<uint8_t>() % 5;
      st.string_seqs.push_back(std::make_unique<std::vector<char*>>());
      for (uint32_t i = 0; i < nv; ++i) st.string_seqs.back()->push_back(st.str(b));
      m.visited = {nv, nv, st.string_seqs.back()->data(), false};
      uint64_t number = 0;
      auto r = dds::from_assignment(m, &number);
      if (!r && r.error().message.empty()) finding("from_assignment(TaskAssignment): an error without a message");
    }
  }
}

}  // namespace

const std::vector<Target>& targets() {
  static const std::vector<Target> all = {
      {"scenario", scenario_entry, "scenario YAML (world/scenario.h parse_scenario)"},
      {"map_yaml", map_yaml_entry, "map_server YAML (world/map.h load_map_yaml)"},
      {"map_image", map_image_entry, "map_server PGM or PNG image behind a valid YAML"},
      {"stage_world", stage_world_entry, "Stage worldfile (world/map.h load_stage_world)"},
      {"floorplan", floorplan_entry, "vector floorplan (world/floorplan.h load_floorplan, rasterize)"},
      {"stereo_calibration", stereo_calibration_entry, "stereo rig file (vision/stereo_calibration.h)"},
      {"patrol_graph", patrol_graph_entry, "patrolling_sim graph (PatrolGraph::parse)"},
      {"event_string", event_string_entry, "the chapter's event string form and an events.jsonl line"},
      {"dds_messages", dds_messages_entry, "DDS samples' checks: camera events into the video server's merger, "
                                           "map events, team messages, robot states, task assignments"},
  };
  return all;
}

const Target* find_target(const std::string& name) {
  for (const auto& t : targets())
    if (name == t.name) return &t;
  return nullptr;
}

}  // namespace vigil::fuzz
