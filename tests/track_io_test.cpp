// Tests tracks.jsonl (vision/track_io.h): the writer's exact bytes (four decimals, no "-0.0000"),
// a write/read round trip, CRLF and blank lines, and reader errors naming the file, the line and
// the key.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "vision/track_io.h"

namespace vigil::vision {
namespace {

namespace fs = std::filesystem;

fs::path temp_file(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("vigil_track_io_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d / name;
}

Track sample() {
  Track t;
  t.stamp_ns = 1500000000;
  t.camera = "cam_corridor";
  t.id = 3;
  t.cls = TrackClass::kPerson;
  t.x = 14.2;
  t.y = 3.15;
  t.vx = 0.5;
  t.vy = -0.00001;  // prints as 0.0000, not -0.0000
  t.height = 1.75;
  t.width = 0.5;
  t.confidence = 0.9;
  return t;
}

TEST(TrackIo, WriterPrintsFixedDecimalsInAFixedKeyOrder) {
  EXPECT_EQ(format_track_json(sample()),
            "{\"t_ns\":1500000000,\"camera\":\"cam_corridor\",\"id\":3,\"class\":\"person\",\"x\":14.2000,"
            "\"y\":3.1500,\"vx\":0.5000,\"vy\":0.0000,\"height\":1.7500,\"width\":0.5000,\"confidence\":0.9000}");
  Track odd = sample();
  odd.camera = "cam \"q\"";
  odd.cls = TrackClass::kUnknown;
  const std::string line = format_track_json(odd);
  EXPECT_NE(line.find("\"camera\":\"cam \\\"q\\\"\""), std::string::npos) << line;
  auto back = parse_track_json(line, "x", 1);
  ASSERT_TRUE(back) << back.error().str();
  EXPECT_EQ(back->camera, odd.camera);
  EXPECT_EQ(back->cls, TrackClass::kUnknown);
  EXPECT_TRUE(back->measured);
  // A prediction (coasting or occluded) says so after the numbers; a measured track writes nothing.
  Track predicted = sample();
  predicted.measured = false;
  const std::string pl = format_track_json(predicted);
  EXPECT_EQ(pl.substr(pl.size() - 37), "\"confidence\":0.9000,\"measured\":false}") << pl;
  auto pb = parse_track_json(pl, "x", 1);
  ASSERT_TRUE(pb) << pb.error().str();
  EXPECT_FALSE(pb->measured);
  auto bad = parse_track_json("{\"t_ns\":5,\"camera\":\"c\",\"id\":1,\"class\":\"bag\",\"x\":1,\"y\":2,\"measured\":0}", "f", 7);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().key, "measured");
  // A hand seen on another track is written while it is, and read back; a fraction is refused.
  Track handling = sample();
  handling.hand_on = 1000001;
  const std::string hl = format_track_json(handling);
  EXPECT_NE(hl.find("\"hand_on\":1000001"), std::string::npos) << hl;
  EXPECT_EQ(format_track_json(sample()).find("hand_on"), std::string::npos);
  auto hb = parse_track_json(hl, "x", 1);
  ASSERT_TRUE(hb) << hb.error().str();
  EXPECT_EQ(hb->hand_on, 1000001);
  auto frac = parse_track_json("{\"t_ns\":5,\"camera\":\"c\",\"id\":1,\"class\":\"bag\",\"x\":1,\"y\":2,\"hand_on\":1.5}", "f", 3);
  ASSERT_FALSE(frac);
  EXPECT_EQ(frac.error().key, "hand_on");
  // An object cut by the image's top edge is marked while it is, and read back.
  Track cut = sample();
  cut.top_cut = true;
  const std::string cl = format_track_json(cut);
  EXPECT_NE(cl.find("\"top_cut\":true"), std::string::npos) << cl;
  EXPECT_EQ(format_track_json(sample()).find("top_cut"), std::string::npos);
  auto cb = parse_track_json(cl, "x", 1);
  ASSERT_TRUE(cb) << cb.error().str();
  EXPECT_TRUE(cb->top_cut);
  auto notbool = parse_track_json("{\"t_ns\":5,\"camera\":\"c\",\"id\":1,\"class\":\"bag\",\"x\":1,\"y\":2,\"top_cut\":1}", "f", 4);
  ASSERT_FALSE(notbool);
  EXPECT_EQ(notbool.error().key, "top_cut");
}

TEST(TrackIo, RoundTripsThroughAFile) {
  std::vector<Track> tracks;
  for (int i = 0; i < 5; ++i) {
    Track t = sample();
    t.stamp_ns += i * 66666667;
    t.id = i;
    t.cls = i % 2 ? TrackClass::kBag : TrackClass::kRobot;
    t.x = -1.23456 * i;
    tracks.push_back(t);
  }
  const fs::path p = temp_file("round.jsonl");
  ASSERT_TRUE(save_tracks_jsonl(p, tracks));
  auto back = load_tracks_jsonl(p);
  ASSERT_TRUE(back) << back.error().str();
  ASSERT_EQ(back->size(), tracks.size());
  for (size_t i = 0; i < tracks.size(); ++i) {
    EXPECT_EQ((*back)[i].stamp_ns, tracks[i].stamp_ns);
    EXPECT_EQ((*back)[i].id, tracks[i].id);
    EXPECT_EQ((*back)[i].cls, tracks[i].cls);
    EXPECT_EQ((*back)[i].camera, "cam_corridor");
    EXPECT_NEAR((*back)[i].x, tracks[i].x, 5e-5);
    EXPECT_NEAR((*back)[i].confidence, 0.9, 1e-12);
  }
  // Writing what was read gives the same bytes.
  const fs::path q = temp_file("round2.jsonl");
  ASSERT_TRUE(save_tracks_jsonl(q, *back));
  std::ifstream a(p, std::ios::binary), b(q, std::ios::binary);
  std::stringstream sa, sb;
  sa << a.rdbuf();
  sb << b.rdbuf();
  EXPECT_EQ(sa.str(), sb.str());
}

TEST(TrackIo, ReaderAcceptsCrlfBlankLinesAndOptionalKeys) {
  const fs::path p = temp_file("crlf.jsonl");
  std::ofstream(p, std::ios::binary) << "{\"t_ns\":5,\"camera\":\"c\",\"id\":1,\"class\":\"bag\",\"x\":1,\"y\":2}\r\n\r\n"
                                     << "{\"t_ns\":6,\"camera\":\"c\",\"id\":1,\"class\":\"bag\",\"x\":1.5,\"y\":2,\"extra\":[1]}\r\n";
  auto r = load_tracks_jsonl(p);
  ASSERT_TRUE(r) << r.error().str();
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[1].stamp_ns, 6);
  EXPECT_DOUBLE_EQ((*r)[1].x, 1.5);
  EXPECT_DOUBLE_EQ((*r)[0].confidence, 0.0);
}

TEST(TrackIo, ReaderErrorsNameFileLineAndKey) {
  const std::string good = "{\"t_ns\":5,\"camera\":\"c\",\"id\":1,\"class\":\"bag\",\"x\":1,\"y\":2}\n";
  struct Case {
    std::string bad_line, expect;
  };
  const std::vector<Case> cases = {
      {"{\"t_ns\":5,\"camera\":\"c\",\"id\":1,\"class\":\"bag\",\"y\":2}", ":2: x: missing"},
      {"{\"t_ns\":5.5,\"camera\":\"c\",\"id\":1,\"class\":\"bag\",\"x\":1,\"y\":2}", ":2: t_ns: expected an integer"},
      {"{\"t_ns\":5,\"camera\":\"c\",\"id\":\"7\",\"class\":\"bag\",\"x\":1,\"y\":2}", ":2: id: expected an integer, got a string"},
      {"{\"t_ns\":5,\"camera\":\"c\",\"id\":1,\"class\":\"cat\",\"x\":1,\"y\":2}", ":2: class: unknown class 'cat'"},
      {"{\"t_ns\":5,\"camera\":\"\",\"id\":1,\"class\":\"bag\",\"x\":1,\"y\":2}", ":2: camera: empty"},
      {"{\"t_ns\":5,\"camera\":\"c\",\"id\":1,\"class\":\"bag\",\"x\":1,\"y\":2,\"vx\":\"fast\"}", ":2: vx: expected a number"},
      {"{\"t_ns\":5,\"camera\":\"c\",", ":2: not valid JSON"},
      {"[1,2]", ":2: expected a JSON object"},
  };
  int n = 0;
  for (const auto& c : cases) {
    const fs::path p = temp_file("bad" + std::to_string(n++) + ".jsonl");
    std::ofstream(p, std::ios::binary) << good << c.bad_line << "\n" << good;
    auto r = load_tracks_jsonl(p);
    ASSERT_FALSE(r) << c.bad_line;
    EXPECT_EQ(r.error().kind, ErrorKind::kBadInput);
    EXPECT_NE(r.error().str().find(p.string() + c.expect), std::string::npos) << r.error().str();
  }
  auto missing = load_tracks_jsonl("/nonexistent/tracks.jsonl");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().str().find("/nonexistent/tracks.jsonl"), std::string::npos);
}

TEST(TrackIo, WriterRefusesNonFiniteNumbers) {
  Track t = sample();
  t.vx = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(check_track(t));
  TrackJsonlWriter w;
  ASSERT_TRUE(w.open(temp_file("nan.jsonl")));
  const Status s = w.write(t);
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().message.find("vx"), std::string::npos) << s.error().str();
  EXPECT_TRUE(w.write(sample()));
  EXPECT_TRUE(w.close());
}

}  // namespace
}  // namespace vigil::vision
