// vigil report: the page a finished run opens as, checked in a real browser (Debian's headless
// Chromium): it loads without script errors, and at a given time of the run the top-down canvas
// shows the robots and the bag where the ground truth has them (pixel colours in a screenshot).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tests/test_util.h"
#include "world/scenario.h"

namespace fs = std::filesystem;
using vigil::test::Output;
using vigil::test::slurp;
using vigil::test::vigil_cmd;

namespace {

fs::path scenario(const std::string& name) { return vigil::test::source_dir() / "scenarios" / (name + ".yaml"); }

bool have_chromium() { return std::system("command -v chromium >/dev/null 2>&1") == 0; }

// Runs headless Chromium on the page at `fragment` (e.g. "#t=30") with a fixed window, device
// scale 1 and a profile of its own; `mode` is "--dump-dom" or "--screenshot=FILE". Returns stdout.
std::string chromium(const fs::path& page, const std::string& fragment, const std::string& mode, const fs::path& profile) {
  const std::string cmd = "chromium --headless --no-sandbox --disable-gpu --hide-scrollbars --force-device-scale-factor=1 "
                          "--window-size=1400,1400 --virtual-time-budget=4000 --user-data-dir=" +
                          profile.string() + " " + mode + " 'file://" + fs::absolute(page).string() + fragment + "'";
  return vigil::test::shell(cmd, false).out;
}

// An attribute of the page's <html> element in a dumped DOM ("" when absent).
std::string html_attribute(const std::string& dom, const std::string& name) {
  const std::regex re("<html[^>]*\\s" + name + "=\"([^\"]*)\"");
  std::smatch m;
  return std::regex_search(dom, m, re) ? m[1].str() : std::string();
}

std::vector<double> numbers(const std::string& csv) {
  std::vector<double> v;
  std::stringstream ss(csv);
  for (std::string item; std::getline(ss, item, ',');) v.push_back(std::stod(item));
  return v;
}

// The ground truth's entities at one tick: id -> (x, y).
std::map<std::string, std::pair<double, double>> truth_at(const fs::path& gt, int64_t t_ns) {
  std::map<std::string, std::pair<double, double>> at;
  std::istringstream lines(slurp(gt));
  for (std::string line; std::getline(lines, line);) {
    const auto j = nlohmann::json::parse(line);
    if (j.value("type", "") != "tick" || j.value("t_ns", int64_t{-1}) != t_ns) continue;
    for (const auto& e : j["entities"]) at[e["id"]] = {e["x"].get<double>(), e["y"].get<double>()};
  }
  return at;
}

// True when a pixel within `r` of (x, y) of the screenshot is within `tol` (per channel) of the colour.
bool colour_near(const cv::Mat& img, double x, double y, cv::Vec3b bgr, int r = 2, int tol = 40) {
  const int cx = static_cast<int>(std::lround(x)), cy = static_cast<int>(std::lround(y));
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      const int px = cx + dx, py = cy + dy;
      if (px < 0 || py < 0 || px >= img.cols || py >= img.rows) continue;
      const cv::Vec3b c = img.at<cv::Vec3b>(py, px);
      if (std::abs(c[0] - bgr[0]) <= tol && std::abs(c[1] - bgr[1]) <= tol && std::abs(c[2] - bgr[2]) <= tol) return true;
    }
  return false;
}

cv::Vec3b hex_bgr(const std::string& hex) {
  const int v = std::stoi(hex.substr(1), nullptr, 16);
  return cv::Vec3b(static_cast<uchar>(v & 0xFF), static_cast<uchar>((v >> 8) & 0xFF), static_cast<uchar>((v >> 16) & 0xFF));
}

}  // namespace

TEST(Report, OpensInChromiumWithoutErrorsAndDrawsRobotsAndTheBagWhereTheTruthHasThem) {
  if (!have_chromium()) GTEST_SKIP() << "chromium is not installed (tools/install_deps.sh installs it)";
  const fs::path dir = vigil::test::fresh_temp_dir("report", "run");
  const fs::path run = dir / "run";
  // dis_left_bag: two navigating robots, A puts bag1 down at about 21 s and walks away.
  Output o = vigil_cmd("run " + scenario("dis_left_bag").string() + " --sensor truth --no-video --out " + run.string() + " --quiet");
  ASSERT_EQ(o.code, 0) << o.out;
  o = vigil_cmd("eval " + run.string());
  ASSERT_EQ(o.code, 0) << o.out;
  o = vigil_cmd("report " + run.string());
  ASSERT_EQ(o.code, 0) << o.out;
  const fs::path page = run / "report.html";
  ASSERT_TRUE(fs::exists(page));
  // Self-contained: nothing fetched from a network.
  const std::string html = slurp(page);
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);
  EXPECT_EQ(html.find("href=\"http"), std::string::npos);

  const double t = 30.0;
  const std::string dom = chromium(page, "#t=30", "--dump-dom", dir / "profile");
  ASSERT_FALSE(dom.empty()) << "chromium printed nothing";
  EXPECT_EQ(html_attribute(dom, "data-errors"), "") << "script errors in the page";
  ASSERT_EQ(html_attribute(dom, "data-ready"), "1") << dom.substr(0, 400);
  EXPECT_EQ(html_attribute(dom, "data-time"), "30");
  const auto canvas = numbers(html_attribute(dom, "data-canvas"));        // left, top, width, height
  const auto transform = numbers(html_attribute(dom, "data-transform"));  // scale, origin x, origin y, height m
  ASSERT_EQ(canvas.size(), 4u);
  ASSERT_EQ(transform.size(), 4u);
  // The tables came from eval.json: the event table lists the truth event with its reported time.
  EXPECT_NE(dom.find("left_bag"), std::string::npos);

  const fs::path shot = dir / "shot.png";
  chromium(page, "#t=30", "--screenshot=" + shot.string(), dir / "profile");
  const cv::Mat img = cv::imread(shot.string());
  ASSERT_FALSE(img.empty()) << shot;
  auto to_px = [&](double x, double y) {
    return std::pair{canvas[0] + (x - transform[1]) * transform[0], canvas[1] + (transform[3] - (y - transform[2])) * transform[0]};
  };
  const auto truth = truth_at(run / "ground_truth.jsonl", static_cast<int64_t>(t * 1e9));
  ASSERT_TRUE(truth.count("robot1") && truth.count("robot2") && truth.count("bag1"));
  const cv::Vec3b robot_colour = hex_bgr("#28a028");
  for (const char* id : {"robot1", "robot2"}) {
    const auto [x, y] = to_px(truth.at(id).first, truth.at(id).second);
    EXPECT_TRUE(colour_near(img, x, y, robot_colour)) << id << " not drawn at (" << x << ", " << y << ")";
  }
  // bag1, in the scenario's colour, on the floor at 30 s.
  auto sc = vigil::load_scenario(scenario("dis_left_bag"));
  ASSERT_TRUE(sc.ok()) << sc.error().str();
  std::string bag_hex;
  for (const auto& ob : sc->objects)
    if (ob.id == "bag1") bag_hex = ob.colour;
  ASSERT_FALSE(bag_hex.empty());
  const cv::Vec3b bag_colour = hex_bgr(bag_hex);
  const auto [bx, by] = to_px(truth.at("bag1").first, truth.at("bag1").second);
  EXPECT_TRUE(colour_near(img, bx, by, bag_colour, 1, 30)) << "bag1 not drawn at (" << bx << ", " << by << ")";
  // The check can fail: 2 m beside the bag, in the free corridor, neither colour is drawn.
  const auto [fx, fy] = to_px(truth.at("bag1").first + 2.0, truth.at("bag1").second);
  EXPECT_FALSE(colour_near(img, fx, fy, bag_colour, 1, 30));
  EXPECT_FALSE(colour_near(img, fx, fy, robot_colour, 1, 30));

  // At another time the robots are elsewhere: the page follows #t=.
  const fs::path early = dir / "early.png";
  chromium(page, "#t=0", "--screenshot=" + early.string(), dir / "profile");
  const cv::Mat img0 = cv::imread(early.string());
  ASSERT_FALSE(img0.empty());
  const auto truth0 = truth_at(run / "ground_truth.jsonl", 0);
  int moved = 0;
  for (const char* id : {"robot1", "robot2"}) {
    const double d = std::hypot(truth0.at(id).first - truth.at(id).first, truth0.at(id).second - truth.at(id).second);
    if (d < 1.0) continue;
    ++moved;
    const auto [x, y] = to_px(truth.at(id).first, truth.at(id).second);
    EXPECT_FALSE(colour_near(img0, x, y, robot_colour, 1, 30)) << id << " drawn at its 30 s place at 0 s";
  }
  EXPECT_GE(moved, 1) << "no robot moved a metre in 30 s: the scenario no longer tests the time";
  fs::remove_all(dir);
}

TEST(Report, ListsTheRunSVideosAndRefusesBadRunFolders) {
  if (!have_chromium()) GTEST_SKIP() << "chromium is not installed (tools/install_deps.sh installs it)";
  const fs::path dir = vigil::test::fresh_temp_dir("report", "videos");
  const fs::path run = dir / "run";
  Output o = vigil_cmd("run " + scenario("dis_left_bag").string() + " --sensor truth --duration 2 --out " + run.string() + " --quiet");
  ASSERT_EQ(o.code, 0) << o.out;
  o = vigil_cmd("report " + run.string() + " --out " + (dir / "page.html").string());
  ASSERT_EQ(o.code, 0) << o.out;
  // Written elsewhere, the page finds the videos relative to itself.
  EXPECT_NE(slurp(dir / "page.html").find("\"file\":\"run/cameras/cam_corridor.mp4\""), std::string::npos);
  o = vigil_cmd("report " + run.string());
  ASSERT_EQ(o.code, 0) << o.out;
  const std::string dom = chromium(run / "report.html", "", "--dump-dom", dir / "profile");
  EXPECT_EQ(html_attribute(dom, "data-errors"), "");
  EXPECT_EQ(html_attribute(dom, "data-ready"), "1");
  for (const char* v : {"cameras/cam_corridor.mp4", "cameras/cam_lab.mp4", "topdown.mp4"})
    EXPECT_NE(dom.find(std::string("<video muted=\"\" playsinline=\"\" preload=\"metadata\" src=\"") + v + "\""), std::string::npos) << v;
  // No eval.json: the page says how to get the tables rather than failing.
  EXPECT_NE(dom.find("No eval.json"), std::string::npos);

  // Bad input: exit 2 naming the file, the line or the key.
  o = vigil_cmd("report " + (dir / "nothing").string());
  EXPECT_EQ(o.code, 2) << o.out;
  fs::create_directories(dir / "empty");
  o = vigil_cmd("report " + (dir / "empty").string());
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("summary.json"), std::string::npos) << o.out;
  {
    std::ofstream gt(run / "ground_truth.jsonl", std::ios::app);
    gt << "{\"type\":\"tick\",\"t_ns\":\n";
  }
  const std::string gt_text = slurp(run / "ground_truth.jsonl");
  const int lines = static_cast<int>(std::count(gt_text.begin(), gt_text.end(), '\n'));
  o = vigil_cmd("report " + run.string());
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("ground_truth.jsonl:" + std::to_string(lines)), std::string::npos) << o.out;
  auto summary = nlohmann::json::parse(slurp(run / "summary.json"));
  summary.erase("scenario_file");
  std::ofstream(run / "summary.json") << summary.dump();
  o = vigil_cmd("report " + run.string());
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("scenario_file"), std::string::npos) << o.out;
  fs::remove_all(dir);
}
