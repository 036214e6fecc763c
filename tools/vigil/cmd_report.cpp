// vigil report RUN_DIR [--scenario FILE] [--out FILE] [--rate HZ]
// Writes RUN_DIR/report.html: one self-contained page (no network fetches; the page's script and
// style are tools/report/, built into the binary) that shows a finished run from the files it
// wrote. The map with the cameras' fields of view is drawn once here (as `vigil run` draws its
// top-down view) and inlined as a PNG; everything that moves is data the page's script draws on
// a canvas at any time of the run: robots (true pose, believed pose, mode-coloured trail, goal,
// role and assignment), people, objects, tracks, events (truth and reported) on a timeline, the
// camera videos beside it in step, the event, tracking, navigation and response tables from
// eval.json, and the patrol idleness over time. docs/REPORT.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "tools/vigil/commands.h"
#include "tools/vigil/run_dir.h"
#include "world/scenario.h"
#include "world/topdown.h"

namespace vigil::cli {

// tools/report/report.{html,js,css}, built in (tools/CMakeLists.txt).
extern const char kReportHtml[];
extern const char kReportJs[];
extern const char kReportCss[];

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using ojson = nlohmann::ordered_json;

std::string base64(const std::vector<uchar>& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = (uint32_t{bytes[i]} << 16) | (uint32_t{bytes[i + 1]} << 8) | bytes[i + 2];
    out += k[v >> 18];
    out += k[(v >> 12) & 63];
    out += k[(v >> 6) & 63];
    out += k[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const uint32_t v = uint32_t{bytes[i]} << 16;
    out += k[v >> 18];
    out += k[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const uint32_t v = (uint32_t{bytes[i]} << 16) | (uint32_t{bytes[i + 1]} << 8);
    out += k[v >> 18];
    out += k[(v >> 12) & 63];
    out += k[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

// Calls f(line_number, object) for every line of a JSON Lines file; a line that is not a JSON
// object is bad input naming the file and line. A missing file calls nothing.
template <typename F>
void for_each_line(const fs::path& p, F f) {
  std::ifstream in(p);
  if (!in) return;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty()) continue;
    json j = json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.is_object()) throw Exit{report(bad_input(p.string(), n, "", "not a JSON object"))};
    f(n, j);
  }
}

double r3(double v) { return std::round(v * 1000.0) / 1000.0; }

// A number that must be there and finite; else bad input naming the file, line and key.
double number(const json& j, const char* key, const fs::path& file, int line) {
  if (!j.contains(key) || !j[key].is_number()) throw Exit{report(bad_input(file.string(), line, key, "missing or not a number"))};
  const double v = j[key].get<double>();
  if (!std::isfinite(v)) throw Exit{report(bad_input(file.string(), line, key, "not finite"))};
  return v;
}

// Escapes text for inclusion inside a <script> element.
std::string script_safe(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '<' && i + 1 < s.size() && (s[i + 1] == '/' || s[i + 1] == '!')) {
      out += "\\u003c";
      continue;
    }
    out += s[i];
  }
  return out;
}

// HTML text (for the title).
std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// The template with each placeholder (found once in the template itself, not in what replaces
// another) replaced by its value.
std::string fill_template(const std::string& tmpl, const std::vector<std::pair<std::string, std::string>>& values) {
  std::vector<std::pair<size_t, size_t>> at;  // position in tmpl, index in values
  for (size_t i = 0; i < values.size(); ++i) {
    const size_t p = tmpl.find(values[i].first);
    if (p == std::string::npos) throw Exit{report(internal_error("report template has no " + values[i].first))};
    at.push_back({p, i});
  }
  std::sort(at.begin(), at.end());
  std::string out;
  size_t from = 0;
  for (const auto& [p, i] : at) {
    out.append(tmpl, from, p - from);
    out += values[i].second;
    from = p + values[i].first.size();
  }
  out.append(tmpl, from, std::string::npos);
  return out;
}

}  // namespace

void add_report_command(CLI::App& app) {
  struct Opts {
    std::string run, scenario, out;
    double rate = 10;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("report", "Write RUN_DIR/report.html: the run on one page, opened from disk");
  cmd->add_option("run", o->run, "a folder `vigil run` wrote")->required();
  cmd->add_option("--scenario", o->scenario, "the scenario run (default: summary.json's scenario_file)");
  cmd->add_option("--out", o->out, "the page to write (default RUN_DIR/report.html)");
  cmd->add_option("--rate", o->rate, "states per second of the animated view (default 10; the ground truth's own rate at most)")
      ->check(CLI::Range(0.1, 1000.0));
  cmd->callback([o] {
    const fs::path run = o->run;
    RunScene scene = load_run_scene(run, o->scenario);
    const fs::path out = o->out.empty() ? run / "report.html" : fs::path(o->out);
    // The videos and pictures as the page finds them: relative to the page's folder.
    std::error_code rel_ec;
    const fs::path page_dir = fs::absolute(out, rel_ec).parent_path();
    auto from_page = [&](const fs::path& in_run) {
      std::error_code ec;
      const fs::path rel = fs::relative(fs::absolute(run / in_run, ec), page_dir, ec);
      return (ec || rel.empty() ? in_run : rel).generic_string();
    };
    const json& summary = scene.summary;
    const Scenario* scenario = &scene.scenario;
    const OccupancyGrid* grid = &scene.grid;
    const TopdownRenderer view(*grid);
    const cv::Mat background = view.map_view(scenario->cameras, *grid);
    std::vector<uchar> png;
    cv::imencode(".png", background, png);

    ojson data;
    data["summary"] = summary;
    data["map"] = {{"width", background.cols},
                   {"height", background.rows},
                   {"scale", view.scale()},
                   {"origin_x", view.origin().x},
                   {"origin_y", view.origin().y},
                   {"height_m", view.height_m()},
                   {"file", scenario->map.filename().string()}};
    data["entities"] = scene_entities(*scenario);
    ojson cameras = ojson::array();
    for (const auto& c : scenario->cameras) {
      ojson cam = {{"id", c.id}, {"x", c.position.x}, {"y", c.position.y}, {"yaw", c.yaw}, {"rate_hz", c.rate_hz}};
      // Its videos, relative to the page (the page is written into the run folder by default).
      ojson videos = ojson::array();
      for (const std::string suffix : {std::string(), "_" + c.plugin}) {
        if (suffix == "_") continue;
        for (const char* ext : {".mp4", ".avi"}) {
          const fs::path v = fs::path("cameras") / (c.id + suffix + ext);
          if (fs::exists(run / v)) videos.push_back({{"file", from_page(v)}, {"what", suffix.empty() ? "camera" : c.plugin}});
        }
      }
      cam["videos"] = videos;
      cameras.push_back(cam);
    }
    data["cameras"] = cameras;

    // The ground truth at the page's rate: [t, [[id, x, y, yaw, carried], ...]], actions, events, contacts.
    const fs::path gt_path = run / "ground_truth.jsonl";
    if (!fs::exists(gt_path)) throw Exit{report(bad_input(gt_path.string(), 0, "", "missing"))};
    ojson ticks = ojson::array(), actions = ojson::array(), truth_events = ojson::array(), contacts = ojson::array();
    double next_keep = 0, last_t = 0;
    const double every = 1.0 / o->rate;
    for_each_line(gt_path, [&](int line, const json& j) {
      const std::string type = j.value("type", "");
      if (type == "tick") {
        const double t = number(j, "t_ns", gt_path, line) * 1e-9;
        last_t = t;
        if (t + 1e-9 < next_keep) return;
        next_keep = t + every;
        ojson ents = ojson::array();
        if (!j.contains("entities") || !j["entities"].is_array())
          throw Exit{report(bad_input(gt_path.string(), line, "entities", "missing or not a list"))};
        for (const auto& e : j["entities"]) {
          ojson row = {e.value("id", ""), r3(number(e, "x", gt_path, line)), r3(number(e, "y", gt_path, line)),
                       r3(e.value("yaw", 0.0))};
          if (e.contains("carried_by")) row.push_back(e.value("carried_by", std::string()));
          ents.push_back(row);
        }
        ticks.push_back({r3(t), ents});
      } else if (type == "action") {
        actions.push_back({{"t", r3(number(j, "t_ns", gt_path, line) * 1e-9)},
                           {"person", j.value("person", "")},
                           {"action", j.value("action", "")},
                           {"object", j.value("object", "")}});
      } else if (type == "event") {
        const double t = number(j, "t_ns", gt_path, line) * 1e-9;
        // Scored from when it is confirmed (a left bag: left_bag_time after the owner went away).
        const double confirmed = j.contains("confirmed_ns") ? number(j, "confirmed_ns", gt_path, line) * 1e-9 : t;
        truth_events.push_back({{"t", r3(t)},
                                {"confirmed", r3(confirmed)},
                                {"kind", j.value("kind", "")},
                                {"x", r3(j.value("x", 0.0))},
                                {"y", r3(j.value("y", 0.0))},
                                {"people", j.value("people", json::array())},
                                {"object", j.value("object", "")}});
      } else if (type == "contact") {
        contacts.push_back({{"t", r3(number(j, "start_ns", gt_path, line) * 1e-9)},
                            {"robot", j.value("robot", "")},
                            {"other", j.value("other", "")},
                            {"other_kind", j.value("other_kind", "")},
                            {"x", r3(j.value("x", 0.0))},
                            {"y", r3(j.value("y", 0.0))}});
      }
    });
    if (ticks.empty()) throw Exit{report(bad_input(gt_path.string(), 0, "", "no tick lines"))};
    data["duration"] = r3(summary.value("sim_seconds", last_t));
    data["ticks"] = ticks;
    data["actions"] = actions;
    data["truth_events"] = truth_events;
    data["contacts"] = contacts;

    // What the robots' controllers reported: [t, robot, x, y, yaw, mode, role, goal_x, goal_y, event, localized, path].
    ojson robots = ojson::array();
    const fs::path robots_path = run / "robots.jsonl";
    for_each_line(robots_path, [&](int line, const json& j) {
      robots.push_back({r3(number(j, "t_ns", robots_path, line) * 1e-9), j.value("robot", ""), r3(j.value("x", 0.0)),
                        r3(j.value("y", 0.0)), r3(j.value("yaw", 0.0)), j.value("mode", ""), j.value("role", ""),
                        r3(j.value("goal_x", 0.0)), r3(j.value("goal_y", 0.0)), j.value("event", ""),
                        j.value("localized", false),
                        j.contains("path") && j["path"].is_array() ? ojson(j["path"]) : ojson::array()});
    });
    data["robots"] = robots;

    // Reported events: the video server's incidents (events.jsonl), each camera's (camera_events.jsonl).
    auto read_events = [&](const fs::path& p) {
      ojson out = ojson::array();
      for_each_line(p, [&](int line, const json& j) {
        ojson e = {{"t", r3(number(j, "t_ns", p, line) * 1e-9)}, {"kind", j.value("kind", "")}, {"id", j.value("id", 0)},
                   {"camera", j.value("camera", "")}, {"cancelled", j.value("cancelled", false)}};
        if (j.contains("map") && j["map"].is_array() && j["map"].size() >= 2) {
          e["x"] = r3(j["map"][0].get<double>());
          e["y"] = r3(j["map"][1].get<double>());
        }
        out.push_back(e);
      });
      return out;
    };
    data["events"] = read_events(run / "events.jsonl");
    data["camera_events"] = read_events(run / "camera_events.jsonl");

    // Tracks at the page's rate per camera: [t, camera, id, class, x, y].
    ojson tracks = ojson::array();
    std::map<std::string, double> next_track_keep;
    std::map<std::string, double> keeping;  // camera -> the stamp being kept
    const fs::path tracks_path = run / "tracks.jsonl";
    for_each_line(tracks_path, [&](int line, const json& j) {
      const double t = number(j, "t_ns", tracks_path, line) * 1e-9;
      const std::string cam = j.value("camera", "");
      auto k = keeping.find(cam);
      if (k == keeping.end() || std::abs(k->second - t) > 1e-9) {
        if (t + 1e-9 < next_track_keep[cam]) return;
        keeping[cam] = t;
        next_track_keep[cam] = t + every;
      }
      tracks.push_back({r3(t), cam, j.value("id", 0), j.value("class", ""), r3(number(j, "x", tracks_path, line)),
                        r3(number(j, "y", tracks_path, line))});
    });
    data["tracks"] = tracks;

    // Scores, when `vigil eval` ran.
    if (fs::exists(run / "eval.json")) data["eval"] = read_json_object(run / "eval.json");
    // Pictures the robots took.
    ojson pictures = ojson::array();
    if (fs::is_directory(run / "pictures")) {
      std::vector<fs::path> sidecars;
      for (const auto& e : fs::directory_iterator(run / "pictures"))
        if (e.path().extension() == ".json") sidecars.push_back(e.path());
      std::sort(sidecars.begin(), sidecars.end());
      for (const auto& p : sidecars) {
        ojson pic = read_json_object(p);
        pic["image"] = from_page(fs::path("pictures") / p.filename().replace_extension(".png"));
        pictures.push_back(pic);
      }
    }
    data["pictures"] = pictures;
    // The top-down video, when there is one.
    for (const char* f : {"topdown.mp4", "topdown.avi"})
      if (fs::exists(run / f)) {
        data["topdown_video"] = from_page(f);
        break;
      }

    const std::string html = fill_template(kReportHtml, {{"/*VIGIL_CSS*/", kReportCss},
                                                         {"/*VIGIL_DATA*/", script_safe(data.dump())},
                                                         {"VIGIL_MAP_PNG", "data:image/png;base64," + base64(png)},
                                                         {"/*VIGIL_JS*/", script_safe(kReportJs)},
                                                         {"VIGIL_TITLE", html_escape(summary.value("scenario", std::string("run")))}});
    std::ofstream f(out, std::ios::binary | std::ios::trunc);
    f << html;
    f.close();
    if (!f) throw Exit{report(bad_input(out.string(), 0, "--out", "cannot write the file"))};
    std::printf("wrote %s (%.1f MB; %zu states, %zu robot reports, %zu tracks, %zu events)\n", out.string().c_str(),
                html.size() / 1e6, ticks.size(), robots.size(), tracks.size(), data["events"].size());
  });
}

}  // namespace vigil::cli
