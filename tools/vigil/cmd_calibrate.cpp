// vigil calibrate stereo --left PATTERN --right PATTERN --board 9x6 --square 0.025 --out rig.yaml
//   Chessboard corners in each pair, each camera's calibration, the stereo calibration and the
//   rectification (vision/stereo_calibration.h), written as the rig file the frame sources read.
//   Prints each pair's reprojection RMS (left, right) and the overall RMS, names the pairs whose
//   board was not found, and writes RIG_rectified.png: the first used pair rectified side by
//   side with epipolar lines.
// vigil calibrate floor --source 'stereo:L,R,rig.yaml;disparity=sgbm' --out rig.yaml
//     (--position X,Y --heading DEG | --floor-point U,V,X,Y --floor-point U,V,X,Y)
//   The rig's height, pitch and roll over the floor from the disparity of frames of the empty
//   scene (vision/floor_fit.h), its map position and heading from the user, written into the rig
//   file, which then carries the whole pose. See docs/RIG.md.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "plugins/builtin.h"
#include "plugins/stereo_camera/stereo_camera.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/plugin_search.h"
#include "vision/floor_fit.h"
#include "vision/image_sources.h"
#include "vision/stereo_calibration.h"

namespace vigil::cli {

namespace {

namespace fs = std::filesystem;
constexpr double kDeg = 180.0 / M_PI;

// "9x6" to a size; an error naming --board otherwise.
// Numbers separated by commas, exactly `n` of them.
std::vector<double> parse_numbers(const std::string& s, size_t n, const std::string& key, const std::string& what) {
  std::vector<double> out;
  std::stringstream in(s);
  for (std::string part; std::getline(in, part, ',');) {
    char* end = nullptr;
    const double v = std::strtod(part.c_str(), &end);
    if (part.empty() || *end != '\0' || !std::isfinite(v))
      throw Exit{report(bad_input("", 0, key, "expected " + what + ", got '" + s + "'"))};
    out.push_back(v);
  }
  if (out.size() != n) throw Exit{report(bad_input("", 0, key, "expected " + what + ", got '" + s + "'"))};
  return out;
}

std::string base(const std::string& path) { return fs::path(path).filename().string(); }

// Creates the folder the rig file goes into.
void make_parent(const std::string& out) {
  const fs::path parent = fs::path(out).parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) throw Exit{report(bad_input(out, 0, "--out", "cannot create the folder " + parent.string() + ": " + ec.message()))};
}

// The first used pair rectified, side by side, with horizontal epipolar lines every 32 rows: in a
// good calibration a scene point lies on the same line in both halves.
Status write_rectified_picture(const std::string& path, const vision::StereoCalibration& c, const std::string& left,
                               const std::string& right) {
  const cv::Mat l = cv::imread(left, cv::IMREAD_COLOR), r = cv::imread(right, cv::IMREAD_COLOR);
  if (l.empty() || r.empty()) return bad_input(l.empty() ? left : right, 0, "", "cannot read the image");
  cv::Mat ml[2], mr[2], rl, rr;
  cv::initUndistortRectifyMap(c.K1, c.D1, c.R1, c.P1, c.image_size, CV_16SC2, ml[0], ml[1]);
  cv::initUndistortRectifyMap(c.K2, c.D2, c.R2, c.P2, c.image_size, CV_16SC2, mr[0], mr[1]);
  cv::remap(l, rl, ml[0], ml[1], cv::INTER_LINEAR);
  cv::remap(r, rr, mr[0], mr[1], cv::INTER_LINEAR);
  cv::Mat both;
  cv::hconcat(rl, rr, both);
  for (int y = 16; y < both.rows; y += 32)
    cv::line(both, {0, y}, {both.cols - 1, y}, y % 64 == 16 ? cv::Scalar(0, 255, 0) : cv::Scalar(0, 200, 255), 1);
  if (!cv::imwrite(path, both)) return bad_input(path, 0, "", "cannot write the picture");
  return Status::Ok();
}

// Two videos of the board: every `every`-th frame pair written as PNG files into `dir` (left_%04d.png,
// right_%04d.png), which are then calibrated like image pairs. Errors name the video and frame.
std::pair<std::vector<std::string>, std::vector<std::string>> extract_video_pairs(const std::string& left,
                                                                                   const std::string& right, int every,
                                                                                   const fs::path& dir) {
  auto l = vision::VideoFileSource::open(left);
  if (!l) {
    Error e = l.error();
    e.key = "--left";
    throw Exit{report(e)};
  }
  auto r = vision::VideoFileSource::open(right);
  if (!r) {
    Error e = r.error();
    e.key = "--right";
    throw Exit{report(e)};
  }
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Exit{report(bad_input(dir.string(), 0, "--out", "cannot create the folder: " + ec.message()))};
  std::vector<std::string> lf, rf;
  vision::StereoFrame a, b;
  for (int64_t i = 0;; ++i) {
    auto more_l = (*l)->next(&a);
    if (!more_l) throw Exit{report(more_l.error())};
    auto more_r = (*r)->next(&b);
    if (!more_r) throw Exit{report(more_r.error())};
    if (*more_l != *more_r)
      throw Exit{report(bad_input(*more_l ? right : left, 0, *more_l ? "--right" : "--left",
                                  "the video ends after " + std::to_string(i) + " frames, before the other one"))};
    if (!*more_l) break;
    if (i % every != 0) continue;
    char name[32];
    std::snprintf(name, sizeof name, "left_%04lld.png", static_cast<long long>(i));
    lf.push_back((dir / name).string());
    std::snprintf(name, sizeof name, "right_%04lld.png", static_cast<long long>(i));
    rf.push_back((dir / name).string());
    if (!cv::imwrite(lf.back(), a.left) || !cv::imwrite(rf.back(), b.left))
      throw Exit{report(bad_input(dir.string(), 0, "--out", "cannot write the extracted frames"))};
  }
  if (lf.empty()) throw Exit{report(bad_input(left, 0, "--left", "the video has no frames"))};
  return {lf, rf};
}

void add_stereo(CLI::App* calibrate) {
  struct Opts {
    std::string left, right, board = "9x6", out, picture, lens = "full";
    double square = 0.025, alpha = 0;
    int min_pairs = 3, window = 0, every = 15;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = calibrate->add_subcommand("stereo", "Calibrate a stereo rig from chessboard image pairs and write its rig file");
  cmd->add_option("--left", o->left, "left images: DIR/PATTERN (printf like left%02d.jpg, or a glob), or a video")->required();
  cmd->add_option("--right", o->right, "right images, in the same order as the left ones, or a video")->required();
  cmd->add_option("--every", o->every, "videos: use every N-th frame pair (written beside --out as RIG_frames/)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--board", o->board, "inner corners of the chessboard, COLSxROWS")->capture_default_str();
  cmd->add_option("--square", o->square, "side of a square (m); the baseline comes out in this unit")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--out", o->out, "rig file to write (OpenCV FileStorage YAML; XML when it ends in .xml)")->required();
  cmd->add_option("--picture", o->picture, "rectified first pair with epipolar lines (default: beside --out, RIG_rectified.png)");
  cmd->add_option("--alpha", o->alpha, "rectification scaling: 0 keeps only valid pixels, 1 every source pixel")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--lens", o->lens,
                  "lens model: full (k1 k2 p1 p2 k3), radial (k1 k2) or pinhole (no distortion)")
      ->capture_default_str()
      ->check(CLI::IsMember({"full", "radial", "pinhole"}));
  cmd->add_option("--corner-window", o->window, "half-size of the sub-pixel corner search window (px); 0: a third of the corner spacing, 2 to 11")
      ->capture_default_str()
      ->check(CLI::Range(0, 50));
  cmd->add_option("--min-pairs", o->min_pairs, "fewest pairs with the board found in both views")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  cmd->callback([o] {
    vision::ChessboardParams board;
    auto inner = vision::parse_board_size(o->board, "--board");
    if (!inner) throw Exit{report(inner.error())};
    board.inner_corners = *inner;
    board.square_size = o->square;
    board.min_pairs = o->min_pairs;
    board.subpixel_window = o->window;
    board.lens = o->lens == "pinhole"  ? vision::ChessboardParams::LensModel::kPinhole
                 : o->lens == "radial" ? vision::ChessboardParams::LensModel::kRadial
                                       : vision::ChessboardParams::LensModel::kFull;
    Result<std::vector<std::string>> left = std::vector<std::string>{}, right = std::vector<std::string>{};
    if (!vision::names_images(o->left) && !vision::names_images(o->right)) {
      const fs::path out = o->out;
      auto [lf, rf] = extract_video_pairs(o->left, o->right, o->every, out.parent_path() / (out.stem().string() + "_frames"));
      std::printf("videos: %zu frame pairs (every %d-th) written to %s\n", lf.size(), o->every,
                  fs::path(lf.front()).parent_path().string().c_str());
      left = lf;
      right = rf;
    } else {
      left = vision::list_image_files(o->left);
      if (!left) {
        Error e = left.error();
        e.key = "--left";
        throw Exit{report(e)};
      }
      right = vision::list_image_files(o->right);
      if (!right) {
        Error e = right.error();
        e.key = "--right";
        throw Exit{report(e)};
      }
    }
    if (left->size() != right->size())
      throw Exit{report(bad_input(o->right, 0, "--right",
                                  std::to_string(right->size()) + " right images but " + std::to_string(left->size()) +
                                      " left images (" + o->left + "): the pairs must match one to one"))};
    std::printf("calibrating %zu pairs, board %dx%d inner corners, squares %g m\n", left->size(), board.inner_corners.width,
                board.inner_corners.height, board.square_size);
    vision::StereoCalibrationReport rep;
    auto c = vision::calibrate_stereo_chessboard(*left, *right, board, &rep);
    for (size_t i = 0; i < rep.skipped_pairs.size(); ++i)
      std::printf("  skipped %s: %s\n", base(rep.skipped_pairs[i]).c_str(), rep.skip_reasons[i].c_str());
    if (!c) {
      Error e = c.error();
      if (e.key == "left_files") e.key = "--left";
      if (e.key == "right_files") e.key = "--right";
      if (e.file.empty()) e.file = o->left;
      throw Exit{report(e)};
    }
    c->pose.reset();
    if (o->alpha != 0) {
      if (Status s = vision::compute_rectification(&*c, o->alpha); !s) throw Exit{report(s.error())};
    }
    for (size_t i = 0; i < rep.used_pairs.size(); ++i) {
      const auto [l, r] = i < rep.pair_rms.size() ? rep.pair_rms[i] : std::pair{0.0, 0.0};
      std::printf("  %-24s reprojection RMS %.3f px left, %.3f px right\n", base(rep.used_pairs[i]).c_str(), l, r);
    }
    auto model = vision::rectified_camera_model(*c);
    if (!model) throw Exit{report(model.error())};
    const double baseline = cv::norm(c->T);
    std::printf("used %zu of %zu pairs; RMS reprojection error %.3f px (stereo), %.3f px left, %.3f px right\n",
                rep.used_pairs.size(), left->size(), rep.stereo_rms, rep.left_rms, rep.right_rms);
    std::printf("left  fx %.2f fy %.2f cx %.2f cy %.2f px; right fx %.2f fy %.2f cx %.2f cy %.2f px\n", c->K1.at<double>(0, 0),
                c->K1.at<double>(1, 1), c->K1.at<double>(0, 2), c->K1.at<double>(1, 2), c->K2.at<double>(0, 0),
                c->K2.at<double>(1, 1), c->K2.at<double>(0, 2), c->K2.at<double>(1, 2));
    std::printf("baseline %.4f m; rectified fx %.2f cx %.2f cy %.2f px, baseline %.4f m\n", baseline, model->intrinsics().fx,
                model->intrinsics().cx, model->intrinsics().cy, model->baseline());
    make_parent(o->out);
    if (Status s = vision::save_stereo_calibration(o->out, *c); !s) throw Exit{report(s.error())};
    std::string picture = o->picture;
    if (picture.empty()) {
      const fs::path out = o->out;
      picture = (out.parent_path() / (out.stem().string() + "_rectified.png")).string();
    }
    if (Status s = write_rectified_picture(picture, *c, rep.used_pairs.front(),
                                           (*right)[static_cast<size_t>(
                                               std::find(left->begin(), left->end(), rep.used_pairs.front()) - left->begin())]);
        !s)
      throw Exit{report(s.error())};
    std::printf("wrote %s and %s\n", o->out.c_str(), picture.c_str());
  });
}

void add_floor(CLI::App* calibrate) {
  struct Opts {
    std::string source, out, position;
    std::optional<double> heading;
    std::vector<std::string> floor_points;
    int frames = 10;
    vision::FloorFitParams fit;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = calibrate->add_subcommand(
      "floor", "Measure the rig's height, pitch and roll over the floor from the empty scene; write its pose into the rig file");
  cmd->add_option("--source", o->source,
                  "stereo frames of the empty scene with disparity: stereo:L,R,RIG;disparity=sgbm (or render:...;disparity=sgbm)")
      ->required();
  cmd->add_option("--out", o->out, "rig file to write, the source's calibration with the pose (may be the same file)")
      ->required();
  cmd->add_option("--position", o->position, "the rig's map position X,Y (m)");
  cmd->add_option("--heading", o->heading, "the rig's heading in the map frame (deg, counter-clockwise from +x)");
  cmd->add_option("--floor-point", o->floor_points,
                  "instead of --position/--heading: U,V,X,Y, a floor point seen at pixel (U, V) of the left image as "
                  "recorded whose map position is (X, Y); give two or more");
  cmd->add_option("--frames", o->frames, "frames of the source to pool")->capture_default_str()->check(CLI::Range(1, 10000));
  cmd->add_option("--max-range", o->fit.max_range, "farthest depth used (m)")->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--inlier-distance", o->fit.inlier_distance, "plane band at 1 m depth (m)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--max-tilt", o->fit.max_tilt_deg, "the floor's normal within this of the image's up (deg)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 89.0));
  cmd->callback([o] {
    const bool by_points = !o->floor_points.empty();
    if (by_points && (!o->position.empty() || o->heading))
      throw Exit{report(bad_input("", 0, "--floor-point", "give either --floor-point (twice or more) or --position and --heading"))};
    if (!by_points && (o->position.empty() || !o->heading))
      throw Exit{report(bad_input("", 0, o->position.empty() ? "--position" : "--heading",
                                  "the rig's map position and heading are needed (--position X,Y --heading DEG), or two "
                                  "--floor-point U,V,X,Y"))};
    if (by_points && o->floor_points.size() < 2)
      throw Exit{report(bad_input("", 0, "--floor-point", "give at least two floor points"))};
    std::vector<vision::FloorCorrespondence> pairs;
    for (const std::string& s : o->floor_points) {
      const auto v = parse_numbers(s, 4, "--floor-point", "U,V,X,Y (pixel and map position)");
      pairs.push_back({{v[0], v[1]}, {v[2], v[3]}});
    }

    WorldOptions wo;
    wo.plugins = builtin_plugin_registry();
    wo.plugin_dirs = plugin_search_path();
    // SGBM's default five-path pass favours fronto-parallel surfaces and biases a floor seen at a
    // slant (4 cm of height on the DIS corridor camera); offline, the full eight-path pass is
    // affordable and unbiased there. A spec that names its mode keeps it.
    std::string spec = o->source;
    if (spec.find("disparity=sgbm") != std::string::npos && spec.find("mode=") == std::string::npos) {
      spec += ";mode=hh";
      std::printf("SGBM in its full eight-path mode (mode=hh) for the slanted floor; give mode= in the source to choose\n");
    }
    auto source = render::open_any_frame_source(spec, wo);
    if (!source) throw Exit{report(source.error())};
    auto model = (*source)->camera_model();
    if (!(*source)->is_stereo() || !model)
      throw Exit{report(bad_input(o->source, 0, "--source",
                                  "the floor fit needs a calibrated stereo source (stereo:LEFT,RIGHT,RIG;disparity=sgbm); got " +
                                      (*source)->describe()))};
    // The calibration to write the pose into: the source's own, or an ideal one for rendered frames.
    vision::StereoCalibration calibration;
    if (auto* s = dynamic_cast<vision::StereoSequenceSource*>(source->get()); s && s->calibration())
      calibration = *s->calibration();
    else
      calibration = vision::ideal_calibration(*model);

    std::vector<Eigen::Vector3f> points;
    vision::StereoFrame frame;
    int n = 0;
    for (; n < o->frames; ++n) {
      auto more = (*source)->next(&frame);
      if (!more) throw Exit{report(more.error())};
      if (!*more) break;
      if (frame.disparity.empty())
        throw Exit{report(bad_input(o->source, 0, "--source",
                                    "the frames carry no disparity: add ;disparity=sgbm to the source"))};
      vision::disparity_points(frame.disparity, *model, o->fit, &points);
    }
    if (n == 0) throw Exit{report(bad_input(o->source, 0, "--source", "the source has no frames"))};
    auto fit = vision::fit_floor(points, o->fit);
    if (!fit) {
      Error e = fit.error();
      e.file = o->source;
      throw Exit{report(e)};
    }
    vision::CameraPose pose;
    if (by_points) {
      // Recorded pixels to the rectified view the model describes.
      if (!calibration.is_rectified_rig() && calibration.has_rectification()) {
        std::vector<cv::Point2d> raw, rect;
        for (const auto& p : pairs) raw.emplace_back(p.pixel.x(), p.pixel.y());
        cv::undistortPoints(raw, rect, calibration.K1, calibration.D1, calibration.R1, calibration.P1);
        for (size_t i = 0; i < pairs.size(); ++i) pairs[i].pixel = {rect[i].x, rect[i].y};
      }
      double residual = 0;
      auto placed = vision::place_rig_from_floor_points(*fit, model->intrinsics(), pairs, &residual);
      if (!placed) {
        Error e = placed.error();
        e.key = "--floor-point";
        throw Exit{report(e)};
      }
      pose = *placed;
      std::printf("placed from %zu floor points: RMS misfit %.3f m\n", pairs.size(), residual);
    } else {
      const auto xy = parse_numbers(o->position, 2, "--position", "X,Y (m)");
      pose = vision::pose_from_floor(*fit, xy[0], xy[1], *o->heading / kDeg);
    }
    std::printf("floor fit on %d frames: %d of %d points on the plane (RMS %.4f m)\n", n, fit->inliers, fit->points, fit->rms);
    std::printf("height %.4f m, pitch %.3f deg, roll %.3f deg; position (%.3f, %.3f), heading %.3f deg\n", fit->height,
                fit->pitch * kDeg, fit->roll * kDeg, pose.position.x(), pose.position.y(), pose.yaw * kDeg);
    if (calibration.pose) {
      const auto& old = *calibration.pose;
      std::printf("previous pose in the rig file: height %.4f m, pitch %.3f deg, roll %.3f deg (change %+.4f m, %+.3f, %+.3f deg)\n",
                  old.position.z(), old.pitch * kDeg, old.roll * kDeg, pose.position.z() - old.position.z(),
                  (pose.pitch - old.pitch) * kDeg, (pose.roll - old.roll) * kDeg);
    }
    calibration.pose = pose;
    make_parent(o->out);
    if (Status s = vision::save_stereo_calibration(o->out, calibration); !s) throw Exit{report(s.error())};
    std::printf("wrote %s\n", o->out.c_str());
  });
}

}  // namespace

void add_calibrate_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("calibrate", "Calibrate your own stereo rig: chessboard intrinsics, its pose over the floor");
  cmd->require_subcommand(1);
  add_stereo(cmd);
  add_floor(cmd);
}

}  // namespace vigil::cli
