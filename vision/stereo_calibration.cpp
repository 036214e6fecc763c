#include "vision/stereo_calibration.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace vigil::vision {

namespace {

bool near_identity(const cv::Mat& m, double tol) {
  return cv::norm(m, cv::Mat::eye(m.size(), m.type()), cv::NORM_INF) <= tol;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string shape_str(const cv::Mat& m) {
  return std::to_string(m.rows) + "x" + std::to_string(m.cols);
}

// Finds the 1-based line where `key` is defined in a FileStorage YAML ("key:") or XML ("<key>")
// text, 0 when it does not appear.
int key_line(const std::vector<std::string>& lines, const std::string& key) {
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string& l = lines[i];
    const size_t b = l.find_first_not_of(" \t");
    if (b == std::string::npos) continue;
    if (l.compare(b, key.size(), key) == 0) {
      const size_t after = l.find_first_not_of(" \t", b + key.size());
      if (after != std::string::npos && l[after] == ':') return static_cast<int>(i) + 1;
    }
    if (l.compare(b, key.size() + 1, "<" + key) == 0) {
      const char c = b + key.size() + 1 < l.size() ? l[b + key.size() + 1] : '\0';
      if (c == '>' || c == ' ' || c == '\t' || c == '/') return static_cast<int>(i) + 1;
    }
  }
  return 0;
}

// The error for a file OpenCV's FileStorage parser rejected. Its parse errors read
// "FILE(LINE): what" (OpenCV 4.6 stores that text in e.func and the parser's function name in
// e.err), other failures only a description in e.err.
Error parse_error(const std::string& path, const cv::Exception& e) {
  for (const std::string& text : {e.func, e.err, e.msg}) {
    const size_t close = text.find("): ");
    const size_t open = close == std::string::npos ? close : text.rfind('(', close);
    if (open == std::string::npos) continue;
    const std::string digits = text.substr(open + 1, close - open - 1);
    if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) continue;
    std::string what = text.substr(close + 3);
    while (!what.empty() && (what.back() == '\n' || what.back() == '\'')) what.pop_back();
    return bad_input(path, std::stoi(digits), "", "malformed FileStorage file: " + what);
  }
  return bad_input(path, 0, "", "malformed FileStorage file: " + e.err);
}

// Reads one calibration file's nodes and turns every problem into an error naming file, line and
// key.
// The largest image side a rig file may give (rectification maps are made at the image's size).
constexpr double kMaxImageSide = 16384;

class CalibrationReader {
 public:
  CalibrationReader(std::string path, const cv::FileStorage& fs) : path_(std::move(path)), fs_(fs) {
    std::ifstream in(path_);
    for (std::string l; std::getline(in, l);) lines_.push_back(l);
  }

  Error error(const std::string& key, const std::string& message) const {
    return bad_input(path_, key_line(lines_, key), key, message);
  }

  // A positive integer up to `max`.
  Result<int> positive_int(const std::string& key, double max) const {
    const cv::FileNode n = fs_[key];
    if (n.empty() || n.isNone()) return error(key, "missing key");
    if (!n.isInt() && !n.isReal()) return error(key, "must be a positive integer");
    const double v = n.real();
    if (!(v > 0) || v != std::floor(v) || v > max)
      return error(key, "must be a positive integer up to " + std::to_string(static_cast<long long>(max)) + ", got " +
                            std::to_string(v));
    return static_cast<int>(v);
  }

  // A finite matrix of one of the accepted shapes (rows x cols; cols 0 = a vector of any of the
  // lengths in `lengths`). Accepts an opencv-matrix or a plain sequence of numbers.
  Result<cv::Mat> matrix(const std::string& key, int rows, int cols, bool required,
                         const std::vector<int>& lengths = {}) const {
    const cv::FileNode n = fs_[key];
    if (n.empty() || n.isNone()) {
      if (required) return error(key, "missing key");
      return cv::Mat();
    }
    cv::Mat m;
    try {
      if (n.isSeq()) {
        std::vector<double> values;
        for (const cv::FileNode& v : n) {
          if (!v.isInt() && !v.isReal()) return error(key, "sequence holds a non-number");
          values.push_back(v.real());
        }
        m = cv::Mat(values, true);
        if (cols > 0) {
          if (static_cast<int>(values.size()) != rows * cols)
            return error(key, "must hold " + std::to_string(rows * cols) + " numbers (" +
                                  std::to_string(rows) + "x" + std::to_string(cols) + "), got " +
                                  std::to_string(values.size()));
          m = m.reshape(1, rows);
        }
      } else if (n.isMap()) {
        // OpenCV allocates rows x cols before it reads the data: check the header first (a
        // corrupt rows value asked it for tens of gigabytes). Rig matrices are at most 4 x 4.
        const cv::FileNode r = n["rows"], c = n["cols"], d = n["data"];
        if (!r.isInt() || !c.isInt() || static_cast<int>(r) < 1 || static_cast<int>(c) < 1 || static_cast<int>(r) > 16 ||
            static_cast<int>(c) > 16)
          return error(key, "an opencv-matrix needs whole rows and cols between 1 and 16");
        if (!d.isSeq() || static_cast<int>(d.size()) != static_cast<int>(r) * static_cast<int>(c))
          return error(key, "an opencv-matrix's data must hold rows x cols numbers");
        n >> m;
      }
    } catch (const cv::Exception& e) {
      return error(key, "not a readable matrix: " + std::string(e.what()));
    }
    if (m.empty()) return error(key, "must be a matrix (opencv-matrix or a list of numbers)");
    if (m.channels() != 1) return error(key, "must be a single-channel matrix");
    m.convertTo(m, CV_64F);
    if (cols == 0) {
      if (m.rows != 1 && m.cols != 1) return error(key, "must be a vector, got " + shape_str(m));
      m = m.reshape(1, 1);
      bool ok = false;
      for (int len : lengths) ok = ok || m.cols == len;
      if (!ok) {
        std::string expected;
        for (int len : lengths) expected += (expected.empty() ? "" : ", ") + std::to_string(len);
        return error(key, "must hold " + expected + " coefficients, got " + std::to_string(m.cols));
      }
    } else if (rows == 3 && cols == 1 && (m.rows * m.cols == 3)) {
      m = m.reshape(1, 3);  // accept T as a row or a column
    } else if (m.rows != rows || m.cols != cols) {
      return error(key, "must be " + std::to_string(rows) + "x" + std::to_string(cols) + ", got " +
                            shape_str(m));
    }
    if (!cv::checkRange(m)) return error(key, "holds a NaN or infinite value");
    return m;
  }

  // A camera matrix: 3x3, positive focal lengths, last row 0 0 1.
  Result<cv::Mat> camera_matrix(const std::string& key) const {
    Result<cv::Mat> k = matrix(key, 3, 3, true);
    if (!k) return k;
    const cv::Mat& m = *k;
    if (!(m.at<double>(0, 0) > 0) || !(m.at<double>(1, 1) > 0))
      return error(key, "focal lengths K(0,0) and K(1,1) must be positive");
    if (m.at<double>(2, 0) != 0 || m.at<double>(2, 1) != 0 || m.at<double>(2, 2) != 1)
      return error(key, "last row must be 0 0 1");
    return k;
  }

 private:
  std::string path_;
  const cv::FileStorage& fs_;
  std::vector<std::string> lines_;
};

}  // namespace

bool StereoCalibration::has_rectification() const {
  return !R1.empty() && !R2.empty() && !P1.empty() && !P2.empty() && !Q.empty();
}

bool StereoCalibration::is_rectified_rig(double tolerance) const {
  if (K1.empty() || K2.empty() || R.empty() || T.empty()) return false;
  const bool no_distortion = (D1.empty() || cv::norm(D1, cv::NORM_INF) <= tolerance) &&
                             (D2.empty() || cv::norm(D2, cv::NORM_INF) <= tolerance);
  const double tx = std::abs(T.at<double>(0));
  return no_distortion && near_identity(R, tolerance) &&
         cv::norm(K1, K2, cv::NORM_INF) <= tolerance * std::max(1.0, cv::norm(K1, cv::NORM_INF)) &&
         std::abs(T.at<double>(1)) <= tolerance * tx && std::abs(T.at<double>(2)) <= tolerance * tx;
}

std::optional<std::vector<cv::Point2f>> find_chessboard_corners(const cv::Mat& image,
                                                                const ChessboardParams& board) {
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  if (image.channels() == 4) cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  std::vector<cv::Point2f> corners;
  if (!cv::findChessboardCorners(grey, board.inner_corners, corners,
                                 cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE))
    return std::nullopt;
  int w = board.subpixel_window;
  if (w <= 0) {
    double nearest = 1e9;
    const int cols = board.inner_corners.width;
    for (size_t i = 0; i < corners.size(); ++i) {
      if ((i + 1) % cols != 0 && i + 1 < corners.size()) nearest = std::min(nearest, cv::norm(corners[i] - corners[i + 1]));
      if (i + cols < corners.size()) nearest = std::min(nearest, cv::norm(corners[i] - corners[i + cols]));
    }
    w = std::clamp(static_cast<int>(nearest / 3), 2, 11);
  }
  cv::cornerSubPix(grey, corners, cv::Size(w, w), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 30, 0.01));
  return corners;
}

Result<StereoCalibration> calibrate_stereo_chessboard(const std::vector<std::string>& left_files,
                                                      const std::vector<std::string>& right_files,
                                                      const ChessboardParams& board,
                                                      StereoCalibrationReport* report) {
  if (left_files.size() != right_files.size())
    return bad_input("", 0, "right_files",
                     std::to_string(right_files.size()) + " right images for " +
                         std::to_string(left_files.size()) + " left images");
  if (board.inner_corners.width < 2 || board.inner_corners.height < 2)
    return bad_input("", 0, "inner_corners", "a chessboard needs at least 2x2 inner corners");
  if (!(board.square_size > 0)) return bad_input("", 0, "square_size", "must be positive");

  StereoCalibrationReport rep;
  std::vector<std::vector<cv::Point2f>> left_points, right_points;
  cv::Size size;
  try {
    for (size_t i = 0; i < left_files.size(); ++i) {
      const cv::Mat l = cv::imread(left_files[i], cv::IMREAD_GRAYSCALE);
      if (l.empty()) return bad_input(left_files[i], 0, "", "cannot read the image");
      const cv::Mat r = cv::imread(right_files[i], cv::IMREAD_GRAYSCALE);
      if (r.empty()) return bad_input(right_files[i], 0, "", "cannot read the image");
      if (size.empty()) size = l.size();
      for (const auto& [img, file] : {std::pair{&l, &left_files[i]}, std::pair{&r, &right_files[i]}}) {
        if (img->size() != size)
          return bad_input(*file, 0, "",
                           "image is " + std::to_string(img->cols) + "x" + std::to_string(img->rows) +
                               " but the first is " + std::to_string(size.width) + "x" +
                               std::to_string(size.height));
      }
      auto cl = find_chessboard_corners(l, board);
      auto cr = find_chessboard_corners(r, board);
      if (!cl || !cr) {
        rep.skipped_pairs.push_back(left_files[i]);
        rep.skip_reasons.push_back(!cl && !cr ? "board not found in either view"
                                   : !cl      ? "board not found in the left view"
                                              : "board not found in the right view (" + right_files[i] + ")");
        continue;
      }
      left_points.push_back(std::move(*cl));
      right_points.push_back(std::move(*cr));
      rep.used_pairs.push_back(left_files[i]);
    }
  } catch (const cv::Exception& e) {
    return internal_error("chessboard detection failed: " + std::string(e.what()));
  }
  if (static_cast<int>(left_points.size()) < board.min_pairs) {
    if (report) *report = rep;
    return bad_input("", 0, "left_files",
                     "the chessboard was found in both views of only " +
                         std::to_string(left_points.size()) + " of " +
                         std::to_string(left_files.size()) + " pairs (need " +
                         std::to_string(board.min_pairs) + ")");
  }

  std::vector<cv::Point3f> board_points;
  for (int y = 0; y < board.inner_corners.height; ++y)
    for (int x = 0; x < board.inner_corners.width; ++x)
      board_points.emplace_back(static_cast<float>(x * board.square_size),
                                static_cast<float>(y * board.square_size), 0.0f);
  const std::vector<std::vector<cv::Point3f>> object_points(left_points.size(), board_points);

  StereoCalibration c;
  c.image_size = size;
  try {
    // Each camera alone first, then both together starting from those intrinsics.
    int lens_flags = 0;
    if (board.lens == ChessboardParams::LensModel::kRadial) lens_flags = cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_FIX_K3;
    if (board.lens == ChessboardParams::LensModel::kPinhole)
      lens_flags = cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3;
    c.D1 = cv::Mat::zeros(1, 5, CV_64F);
    c.D2 = cv::Mat::zeros(1, 5, CV_64F);
    std::vector<cv::Mat> rvecs, tvecs;
    rep.left_rms = cv::calibrateCamera(object_points, left_points, size, c.K1, c.D1, rvecs, tvecs, lens_flags);
    rep.right_rms = cv::calibrateCamera(object_points, right_points, size, c.K2, c.D2, rvecs, tvecs, lens_flags);
    cv::Mat E, F, per_view;
    rep.stereo_rms = cv::stereoCalibrate(
        object_points, left_points, right_points, c.K1, c.D1, c.K2, c.D2, size, c.R, c.T, E, F, per_view,
        cv::CALIB_USE_INTRINSIC_GUESS | lens_flags,
        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-6));
    per_view.convertTo(per_view, CV_64F);
    for (int i = 0; i < per_view.rows; ++i)
      rep.pair_rms.emplace_back(per_view.at<double>(i, 0), per_view.at<double>(i, 1));
  } catch (const cv::Exception& e) {
    return internal_error("stereo calibration failed: " + std::string(e.what()));
  }
  for (cv::Mat* m : {&c.K1, &c.D1, &c.K2, &c.D2, &c.R, &c.T}) m->convertTo(*m, CV_64F);
  c.D1 = c.D1.reshape(1, 1);
  c.D2 = c.D2.reshape(1, 1);
  c.T = c.T.reshape(1, 3);
  c.rms = rep.stereo_rms;
  if (Status s = compute_rectification(&c); !s) return s;
  if (report) *report = std::move(rep);
  return c;
}

Status compute_rectification(StereoCalibration* c, double alpha) {
  try {
    cv::stereoRectify(c->K1, c->D1, c->K2, c->D2, c->image_size, c->R, c->T, c->R1, c->R2, c->P1,
                      c->P2, c->Q, cv::CALIB_ZERO_DISPARITY, alpha, c->image_size);
  } catch (const cv::Exception& e) {
    return internal_error("stereo rectification failed: " + std::string(e.what()));
  }
  return Status::Ok();
}

Status save_stereo_calibration(const std::string& path, const StereoCalibration& c) {
  try {
    const int mode = cv::FileStorage::WRITE |
                     (ends_with(path, ".xml") ? cv::FileStorage::FORMAT_XML
                                              : cv::FileStorage::FORMAT_YAML);
    cv::FileStorage fs(path, mode);
    if (!fs.isOpened()) return bad_input(path, 0, "", "cannot open the file for writing");
    fs << "image_width" << c.image_size.width << "image_height" << c.image_size.height;
    fs << "K1" << c.K1 << "D1" << c.D1 << "K2" << c.K2 << "D2" << c.D2 << "R" << c.R << "T" << c.T;
    if (c.has_rectification())
      fs << "R1" << c.R1 << "R2" << c.R2 << "P1" << c.P1 << "P2" << c.P2 << "Q" << c.Q;
    if (c.rms > 0) fs << "rms" << c.rms;
    if (c.pose) {
      constexpr double kDeg = 180.0 / M_PI;
      fs << "pose_position" << std::vector<double>{c.pose->position.x(), c.pose->position.y(), c.pose->position.z()};
      fs << "pose_yaw_deg" << c.pose->yaw * kDeg << "pose_pitch_deg" << c.pose->pitch * kDeg << "pose_roll_deg"
         << c.pose->roll * kDeg;
    }
    fs.release();
  } catch (const cv::Exception& e) {
    return bad_input(path, 0, "", "cannot write the calibration: " + std::string(e.what()));
  }
  return Status::Ok();
}

namespace {
Result<StereoCalibration> read_calibration(const std::string& path, const cv::FileStorage& fs);
}  // namespace

Result<StereoCalibration> load_stereo_calibration(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    return bad_input(path, 0, "", "calibration file not found");
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::READ))
      return bad_input(path, 0, "", "not an OpenCV FileStorage file");
  } catch (const cv::Exception& e) {
    return parse_error(path, e);
  } catch (const std::exception& e) {  // OpenCV's parser lets others through (found by fuzzing)
    return bad_input(path, 0, "", std::string("not a readable OpenCV FileStorage file: ") + e.what());
  }
  try {
    // A key looked up in anything but a map throws (a file whose top level is a list).
    if (!fs.root().isMap()) return bad_input(path, 0, "", "the top level must be a map of keys (image_width, K1, ...)");
    return read_calibration(path, fs);
  } catch (const cv::Exception& e) {
    return parse_error(path, e);
  } catch (const std::exception& e) {
    return bad_input(path, 0, "", std::string("not a readable OpenCV FileStorage file: ") + e.what());
  }
}

namespace {

Result<StereoCalibration> read_calibration(const std::string& path, const cv::FileStorage& fs) {
  const CalibrationReader reader(path, fs);
  StereoCalibration c;

  Result<int> w = reader.positive_int("image_width", kMaxImageSide);
  if (!w) return w.error();
  Result<int> h = reader.positive_int("image_height", kMaxImageSide);
  if (!h) return h.error();
  c.image_size = {*w, *h};

  const std::vector<int> distortion_lengths = {4, 5, 8, 12, 14};
  struct Field {
    const char* key;
    cv::Mat* out;
    int rows, cols;
    bool required;
  };
  const Field fields[] = {
      {"K1", &c.K1, 3, 3, true},  {"D1", &c.D1, 1, 0, true},  {"K2", &c.K2, 3, 3, true},
      {"D2", &c.D2, 1, 0, true},  {"R", &c.R, 3, 3, true},    {"T", &c.T, 3, 1, true},
      {"R1", &c.R1, 3, 3, false}, {"R2", &c.R2, 3, 3, false}, {"P1", &c.P1, 3, 4, false},
      {"P2", &c.P2, 3, 4, false}, {"Q", &c.Q, 4, 4, false},
  };
  for (const Field& f : fields) {
    Result<cv::Mat> m = (f.key[0] == 'K') ? reader.camera_matrix(f.key)
                                          : reader.matrix(f.key, f.rows, f.cols, f.required,
                                                          distortion_lengths);
    if (!m) return m.error();
    *f.out = *m;
  }
  // R must be a rotation.
  if (cv::norm(c.R * c.R.t(), cv::Mat::eye(3, 3, CV_64F), cv::NORM_INF) > 1e-4 ||
      std::abs(cv::determinant(c.R) - 1.0) > 1e-4)
    return reader.error("R", "is not a rotation matrix (R * R^T != I or det != 1)");
  if (!(cv::norm(c.T) > 0)) return reader.error("T", "the baseline is zero");
  // Rectification is all or nothing.
  const int present = !c.R1.empty() + !c.R2.empty() + !c.P1.empty() + !c.P2.empty() + !c.Q.empty();
  if (present != 0 && present != 5) {
    for (const char* key : {"R1", "R2", "P1", "P2", "Q"}) {
      if (fs[key].empty())
        return reader.error(key, "missing key (R1, R2, P1, P2 and Q go together)");
    }
  }
  if (const cv::FileNode n = fs["rms"]; !n.empty()) {
    if (!n.isReal() && !n.isInt()) return reader.error("rms", "must be a number");
    c.rms = n.real();
  }
  // The pose is all or nothing too.
  const char* pose_keys[] = {"pose_position", "pose_yaw_deg", "pose_pitch_deg", "pose_roll_deg"};
  int pose_present = 0;
  for (const char* key : pose_keys) pose_present += !fs[key].empty();
  if (pose_present != 0) {
    for (const char* key : pose_keys)
      if (fs[key].empty())
        return reader.error(key, "missing key (pose_position, pose_yaw_deg, pose_pitch_deg and pose_roll_deg go together)");
    Result<cv::Mat> p = reader.matrix("pose_position", 3, 1, true);
    if (!p) return p.error();
    CameraPose pose;
    pose.position = {p->at<double>(0), p->at<double>(1), p->at<double>(2)};
    double* angles[] = {&pose.yaw, &pose.pitch, &pose.roll};
    const double limits[] = {360, 90, 180};
    for (int i = 0; i < 3; ++i) {
      const char* key = pose_keys[i + 1];
      const cv::FileNode n = fs[key];
      if (!n.isReal() && !n.isInt()) return reader.error(key, "must be a number (degrees)");
      const double v = n.real();
      if (!std::isfinite(v) || std::abs(v) > limits[i])
        return reader.error(key, "must be within -" + std::to_string(static_cast<int>(limits[i])) + " and " +
                                     std::to_string(static_cast<int>(limits[i])) + " degrees");
      *angles[i] = v * M_PI / 180.0;
    }
    c.pose = pose;
  }
  return c;
}

}  // namespace

StereoCalibration ideal_calibration(const StereoCameraModel& model) {
  const Intrinsics& k = model.intrinsics();
  StereoCalibration c;
  c.image_size = {k.width, k.height};
  c.K1 = (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  c.K2 = c.K1.clone();
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  c.R = cv::Mat::eye(3, 3, CV_64F);
  c.T = (cv::Mat_<double>(3, 1) << -model.baseline(), 0, 0);
  c.pose = model.pose();
  return c;
}

Result<StereoCameraModel> rectified_camera_model(const StereoCalibration& c, const CameraPose& pose) {
  Intrinsics k;
  k.width = c.image_size.width;
  k.height = c.image_size.height;
  double baseline = 0;
  if (c.is_rectified_rig()) {
    // Images used as they are (see StereoSequenceSource): the model is K1 and T.
    k.fx = c.K1.at<double>(0, 0);
    k.fy = c.K1.at<double>(1, 1);
    k.cx = c.K1.at<double>(0, 2);
    k.cy = c.K1.at<double>(1, 2);
    baseline = -c.T.at<double>(0);
  } else if (c.has_rectification()) {
    if (std::abs(c.P2.at<double>(1, 3)) > std::abs(c.P2.at<double>(0, 3)))
      return bad_input("", 0, "P2", "vertical stereo rigs are not supported");
    k.fx = c.P1.at<double>(0, 0);
    k.fy = c.P1.at<double>(1, 1);
    k.cx = c.P1.at<double>(0, 2);
    k.cy = c.P1.at<double>(1, 2);
    baseline = -c.P2.at<double>(0, 3) / c.P2.at<double>(0, 0);
  } else {
    return bad_input("", 0, "P1", "the calibration has no rectification (R1, R2, P1, P2, Q)");
  }
  if (!(baseline > 0))
    return bad_input("", 0, "T",
                     "the right camera is not to the right of the left one (baseline " +
                         std::to_string(baseline) + "): are the images swapped?");
  return StereoCameraModel(k, baseline, pose);
}

Result<cv::Size> parse_board_size(const std::string& text, const std::string& key) {
  int cols = 0, rows = 0;
  char x = 0, extra = 0;
  std::istringstream in(text);
  if (!(in >> cols >> x >> rows) || (x != 'x' && x != 'X') || (in >> extra) || cols < 2 || rows < 2 || cols > 100 ||
      rows > 100)
    return bad_input("", 0, key, "expected inner corners as COLSxROWS (e.g. 9x6), got '" + text + "'");
  return cv::Size(cols, rows);
}

}  // namespace vigil::vision
