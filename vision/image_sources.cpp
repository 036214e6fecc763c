#include "vision/image_sources.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio/registry.hpp>

namespace vigil::vision {

namespace fs = std::filesystem;

namespace {

std::string size_str(cv::Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

int64_t stamp_at(int64_t index, double fps) {
  return std::llround(static_cast<double>(index) * 1e9 / fps);
}

// 8-bit BGR from what a decoder returned (grey or BGRA are converted; other depths scaled).
cv::Mat to_bgr8(const cv::Mat& image) {
  cv::Mat out = image;
  if (out.depth() != CV_8U) {
    double scale = out.depth() == CV_16U ? 1.0 / 257.0 : 1.0;
    out.convertTo(out, CV_8U, scale);
  }
  if (out.channels() == 1) cv::cvtColor(out, out, cv::COLOR_GRAY2BGR);
  if (out.channels() == 4) cv::cvtColor(out, out, cv::COLOR_BGRA2BGR);
  return out;
}

// Glob match of a whole name with * (any run) and ? (one character).
bool glob_match(const std::string& pattern, const std::string& name) {
  size_t p = 0, n = 0, star = std::string::npos, star_n = 0;
  while (n < name.size()) {
    if (p < pattern.size() && (pattern[p] == '?' || pattern[p] == name[n])) {
      ++p;
      ++n;
    } else if (p < pattern.size() && pattern[p] == '*') {
      star = p++;
      star_n = n;
    } else if (star != std::string::npos) {
      p = star + 1;
      n = ++star_n;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
}

// A printf pattern with one integer field: prefix %[0][width]d suffix.
struct NumberPattern {
  std::string prefix, suffix;
  int width = 0;  // zero-padded width, 0 = no padding
};

std::optional<NumberPattern> parse_number_pattern(const std::string& pattern) {
  const size_t pct = pattern.find('%');
  if (pct == std::string::npos || pattern.find('%', pct + 1) != std::string::npos) return std::nullopt;
  NumberPattern np;
  np.prefix = pattern.substr(0, pct);
  size_t i = pct + 1;
  if (i < pattern.size() && pattern[i] == '0') {
    ++i;
    size_t j = i;
    while (j < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[j]))) ++j;
    if (j == i) return std::nullopt;
    np.width = std::stoi(pattern.substr(i, j - i));
    i = j;
  }
  if (i >= pattern.size() || pattern[i] != 'd') return std::nullopt;
  np.suffix = pattern.substr(i + 1);
  return np;
}

// The number in `name` when it matches the pattern as printf would have written it.
std::optional<long> match_number(const NumberPattern& np, const std::string& name) {
  if (name.size() <= np.prefix.size() + np.suffix.size()) return std::nullopt;
  if (name.compare(0, np.prefix.size(), np.prefix) != 0) return std::nullopt;
  if (name.compare(name.size() - np.suffix.size(), np.suffix.size(), np.suffix) != 0)
    return std::nullopt;
  const std::string digits =
      name.substr(np.prefix.size(), name.size() - np.prefix.size() - np.suffix.size());
  if (!std::all_of(digits.begin(), digits.end(),
                   [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
    return std::nullopt;
  const int len = static_cast<int>(digits.size());
  const bool padded_ok = len == np.width || (len > np.width && digits[0] != '0');
  const bool plain_ok = np.width == 0 && (digits == "0" || digits[0] != '0');
  if (np.width > 0 ? !padded_ok : !plain_ok) return std::nullopt;
  if (len > 9) return std::nullopt;
  return std::stol(digits);
}

Result<std::unique_ptr<MonoFrameSource>> open_mono(const std::string& what, double fps) {
  if (names_images(what)) {
    ImageSequenceOptions o;
    if (fps > 0) o.fps = fps;
    auto s = ImageSequenceSource::open(what, o);
    if (!s) return s.error();
    return std::unique_ptr<MonoFrameSource>(std::move(*s));
  }
  VideoFileOptions o;
  o.fps = fps;
  auto s = VideoFileSource::open(what, o);
  if (!s) return s.error();
  return std::unique_ptr<MonoFrameSource>(std::move(*s));
}

}  // namespace

bool is_image_pattern(const std::string& s) {
  const std::string name = fs::path(s).filename().string();
  return name.find_first_of("%*?") != std::string::npos;
}

bool names_images(const std::string& s) {
  if (is_image_pattern(s)) return true;
  std::string ext = fs::path(s).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const char* e : {".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".pgm", ".ppm", ".pnm",
                        ".webp", ".jp2", ".exr", ".hdr", ".pfm"})
    if (ext == e) return true;
  return false;
}

Result<std::vector<std::string>> list_image_files(const std::string& dir_and_pattern) {
  const fs::path full(dir_and_pattern);
  const std::string pattern = full.filename().string();
  const fs::path dir = full.has_parent_path() ? full.parent_path() : fs::path(".");
  std::error_code ec;
  if (pattern.empty())
    return bad_input(dir_and_pattern, 0, "", "no file pattern after the folder");
  if (!is_image_pattern(dir_and_pattern)) {
    if (!fs::is_regular_file(full, ec)) return bad_input(dir_and_pattern, 0, "", "image not found");
    return std::vector<std::string>{dir_and_pattern};
  }
  if (!fs::is_directory(dir, ec))
    return bad_input(dir.string(), 0, "", "folder not found (for pattern " + pattern + ")");
  std::optional<NumberPattern> number;
  if (pattern.find('%') != std::string::npos) {
    number = parse_number_pattern(pattern);
    if (!number)
      return bad_input(dir_and_pattern, 0, "",
                       "unsupported pattern: use one %d or %0Nd field, or * and ? globs");
  }
  std::vector<std::pair<long, std::string>> numbered;
  std::vector<std::string> named;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file(ec)) continue;
    const std::string name = e.path().filename().string();
    if (number) {
      if (auto n = match_number(*number, name)) numbered.emplace_back(*n, e.path().string());
    } else if (glob_match(pattern, name)) {
      named.push_back(e.path().string());
    }
  }
  if (ec) return bad_input(dir.string(), 0, "", "cannot list the folder: " + ec.message());
  std::vector<std::string> files;
  if (number) {
    std::sort(numbered.begin(), numbered.end());
    for (auto& [n, path] : numbered) files.push_back(std::move(path));
  } else {
    std::sort(named.begin(), named.end());
    files = std::move(named);
  }
  if (files.empty())
    return bad_input(dir_and_pattern, 0, "", "no file in " + dir.string() + " matches " + pattern);
  return files;
}

// ---- VideoFileSource ----

Result<std::unique_ptr<VideoFileSource>> VideoFileSource::open(const std::string& path,
                                                               const VideoFileOptions& options) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return bad_input(path, 0, "", "video file not found");
  if (!fs::is_regular_file(path, ec)) return bad_input(path, 0, "", "not a regular file");
  std::unique_ptr<VideoFileSource> s(new VideoFileSource());
  s->path_ = path;
  s->options_ = options;
  int api = options.api_preference;
  if (api != cv::CAP_ANY && !cv::videoio_registry::hasBackend(static_cast<cv::VideoCaptureAPIs>(api)))
    api = cv::CAP_ANY;
  try {
    if (!s->capture_.open(path, api) || !s->capture_.isOpened())
      return bad_input(path, 0, "",
                       "cannot open the video (not a video file, truncated, or a codec OpenCV "
                       "cannot decode)");
    if (!s->capture_.read(s->pending_) || s->pending_.empty())
      return bad_input(path, 0, "frame 0", "no frame could be decoded (corrupt or truncated file?)");
    s->announced_ = std::max<int64_t>(0, std::llround(s->capture_.get(cv::CAP_PROP_FRAME_COUNT)));
    const double file_fps = s->capture_.get(cv::CAP_PROP_FPS);
    s->fps_ = options.fps > 0 ? options.fps : (file_fps > 0 && std::isfinite(file_fps) ? file_fps : 15.0);
  } catch (const cv::Exception& e) {
    return bad_input(path, 0, "", "cannot decode the video: " + e.err);
  }
  s->pending_ = to_bgr8(s->pending_);
  s->size_ = s->pending_.size();
  return s;
}

Result<bool> VideoFileSource::next(StereoFrame* frame) {
  if (ended_) return false;
  cv::Mat image;
  if (!pending_.empty()) {
    image = pending_;
    pending_ = cv::Mat();
  } else {
    bool got = false;
    try {
      got = capture_.read(image) && !image.empty();
    } catch (const cv::Exception& e) {
      return bad_input(path_, 0, "frame " + std::to_string(index_ + 1),
                       "cannot decode the frame: " + e.err);
    }
    if (!got) {
      ended_ = true;
      if (options_.require_announced_length && index_ + 1 < announced_)
        return bad_input(path_, 0, "frame " + std::to_string(index_ + 1),
                         "the video ends after " + std::to_string(index_ + 1) +
                             " frames but its header announces " + std::to_string(announced_) +
                             " (truncated file?)");
      return false;
    }
    image = to_bgr8(image);
  }
  ++index_;
  if (image.size() != size_)
    return bad_input(path_, 0, "frame " + std::to_string(index_),
                     "frame is " + size_str(image.size()) + " but frame 0 was " + size_str(size_));
  *frame = StereoFrame{};
  frame->index = index_;
  frame->stamp_ns = stamp_at(index_, fps_);
  frame->left = image;
  return true;
}

std::string VideoFileSource::describe() const {
  return "video " + path_ + " (" + size_str(size_) + ")";
}

std::string VideoFileSource::last_frame_name() const {
  return path_ + " frame " + std::to_string(std::max<int64_t>(index_, 0));
}

// ---- ImageSequenceSource ----

Result<std::unique_ptr<ImageSequenceSource>> ImageSequenceSource::open(
    const std::string& dir_and_pattern, const ImageSequenceOptions& options) {
  auto files = list_image_files(dir_and_pattern);
  if (!files) return files.error();
  auto s = open(std::move(*files), options);
  if (s) (*s)->pattern_ = dir_and_pattern;
  return s;
}

Result<std::unique_ptr<ImageSequenceSource>> ImageSequenceSource::open(
    std::vector<std::string> files, const ImageSequenceOptions& options) {
  if (files.empty()) return bad_input("", 0, "files", "an image sequence needs at least one image");
  if (!(options.fps > 0)) return bad_input("", 0, "fps", "must be positive");
  std::unique_ptr<ImageSequenceSource> s(new ImageSequenceSource());
  s->files_ = std::move(files);
  s->pattern_ = s->files_.front() + (s->files_.size() > 1 ? " ..." : "");
  s->options_ = options;
  return s;
}

Result<bool> ImageSequenceSource::next(StereoFrame* frame) {
  if (next_ >= files_.size()) return false;
  const std::string& file = files_[next_];
  cv::Mat image;
  try {
    image = cv::imread(file, cv::IMREAD_COLOR);
  } catch (const cv::Exception& e) {
    return bad_input(file, 0, "", "cannot load the image: " + e.err);
  }
  if (image.empty())
    return bad_input(file, 0, "", "cannot load the image (missing, unreadable or not an image)");
  if (next_ == 0) size_ = image.size();
  if (image.size() != size_)
    return bad_input(file, 0, "",
                     "image is " + size_str(image.size()) + " but the sequence's first image (" +
                         files_.front() + ") is " + size_str(size_));
  *frame = StereoFrame{};
  frame->index = static_cast<int64_t>(next_);
  frame->stamp_ns = stamp_at(frame->index, options_.fps);
  frame->left = image;
  ++next_;
  return true;
}

std::string ImageSequenceSource::describe() const {
  return "images " + pattern_ + " (" + std::to_string(files_.size()) + " files)";
}

std::string ImageSequenceSource::last_frame_name() const {
  return files_[next_ == 0 ? 0 : next_ - 1];
}

// ---- StereoSequenceSource ----

Result<std::unique_ptr<StereoSequenceSource>> StereoSequenceSource::open(
    const std::string& left, const std::string& right, const std::string& calibration_path,
    const StereoSequenceOptions& options) {
  auto l = open_mono(left, options.fps);
  if (!l) return l.error();
  auto r = open_mono(right, options.fps);
  if (!r) return r.error();
  std::optional<StereoCalibration> calibration;
  if (!calibration_path.empty()) {
    auto c = load_stereo_calibration(calibration_path);
    if (!c) return c.error();
    calibration = std::move(*c);
  }
  auto s = open(std::move(*l), std::move(*r), std::move(calibration), options);
  if (s) (*s)->calibration_path_ = calibration_path;
  return s;
}

Result<std::unique_ptr<StereoSequenceSource>> StereoSequenceSource::open(
    std::unique_ptr<MonoFrameSource> left, std::unique_ptr<MonoFrameSource> right,
    std::optional<StereoCalibration> calibration, const StereoSequenceOptions& options) {
  if (!left || !right) return internal_error("StereoSequenceSource needs two mono sources");
  // Image lists have known lengths: check them now rather than at the end.
  const auto* li = dynamic_cast<const ImageSequenceSource*>(left.get());
  const auto* ri = dynamic_cast<const ImageSequenceSource*>(right.get());
  if (li && ri && li->files().size() != ri->files().size())
    return bad_input("", 0, "right",
                     right->describe() + " has " + std::to_string(ri->files().size()) +
                         " images but " + left->describe() + " has " +
                         std::to_string(li->files().size()));
  if (options.fps < 0) return bad_input("", 0, "fps", "must be positive");

  std::unique_ptr<StereoSequenceSource> s(new StereoSequenceSource());
  s->left_ = std::move(left);
  s->right_ = std::move(right);
  s->options_ = options;
  if (calibration) {
    StereoCalibration& c = *calibration;
    if (!c.is_rectified_rig()) {
      if (!c.has_rectification()) {
        if (Status st = compute_rectification(&c, options.rectify_alpha); !st) return st;
      }
      try {
        cv::initUndistortRectifyMap(c.K1, c.D1, c.R1, c.P1, c.image_size, CV_16SC2,
                                    s->map_left_[0], s->map_left_[1]);
        cv::initUndistortRectifyMap(c.K2, c.D2, c.R2, c.P2, c.image_size, CV_16SC2,
                                    s->map_right_[0], s->map_right_[1]);
      } catch (const cv::Exception& e) {
        return internal_error("cannot build the rectification maps: " + e.err);
      }
    }
    const std::optional<CameraPose> pose = options.pose ? options.pose : c.pose;
    auto model = rectified_camera_model(c, pose.value_or(CameraPose{}));
    if (!model) return model.error();
    s->has_pose_ = pose.has_value();
    s->model_ = *model;
    s->calibration_ = std::move(calibration);
  }
  if (options.matcher) {
    auto m = StereoMatcher::create(*options.matcher);
    if (!m) return m.error();
    s->matcher_ = std::move(*m);
  }
  return s;
}

Result<bool> StereoSequenceSource::next(StereoFrame* frame) {
  StereoFrame l, r;
  Result<bool> got_left = left_->next(&l);
  if (!got_left) return got_left.error();
  Result<bool> got_right = right_->next(&r);
  if (!got_right) return got_right.error();
  if (*got_left != *got_right) {
    if (*got_left)
      return bad_input(left_->last_frame_name(), 0, "",
                       "no right frame for it: " + right_->describe() + " ended after " +
                           std::to_string(index_) + " frames");
    return bad_input(right_->last_frame_name(), 0, "",
                     "no left frame for it: " + left_->describe() + " ended after " +
                         std::to_string(index_) + " frames");
  }
  if (!*got_left) return false;
  if (l.left.size() != r.left.size())
    return bad_input(right_->last_frame_name(), 0, "",
                     "right image is " + size_str(r.left.size()) + " but the left one (" +
                         left_->last_frame_name() + ") is " + size_str(l.left.size()));
  if (calibration_ && l.left.size() != calibration_->image_size)
    return bad_input(left_->last_frame_name(), 0, "",
                     "image is " + size_str(l.left.size()) + " but the calibration" +
                         (calibration_path_.empty() ? "" : " (" + calibration_path_ + ")") +
                         " is for " + size_str(calibration_->image_size));
  *frame = StereoFrame{};
  frame->index = index_;
  frame->stamp_ns = options_.fps > 0 ? stamp_at(index_, options_.fps) : l.stamp_ns;
  try {
    if (rectifies()) {
      cv::remap(l.left, frame->left, map_left_[0], map_left_[1], cv::INTER_LINEAR);
      cv::remap(r.left, frame->right, map_right_[0], map_right_[1], cv::INTER_LINEAR);
    } else {
      frame->left = l.left;
      frame->right = r.left;
    }
  } catch (const cv::Exception& e) {
    return internal_error("rectification failed on " + left_->last_frame_name() + ": " + e.err);
  }
  if (matcher_) {
    Result<cv::Mat> d = matcher_->compute(frame->left, frame->right);
    if (!d) {
      Error e = d.error();
      e.file = left_->last_frame_name();
      return e;
    }
    frame->disparity = *d;
    if (model_) frame->depth = depth_from_disparity(frame->disparity, *model_);
  }
  ++index_;
  return true;
}

std::string StereoSequenceSource::describe() const {
  std::string s = "stereo [" + left_->describe() + "] + [" + right_->describe() + "]";
  if (calibration_) {
    s += calibration_path_.empty() ? ", calibrated" : ", calibration " + calibration_path_;
    if (rectifies()) s += ", rectified";
  }
  if (matcher_)
    s += matcher_->params().algorithm == StereoAlgorithm::kBM ? ", disparity BM" : ", disparity SGBM";
  return s;
}

// ---- open_frame_source ----

namespace {

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (;;) {
    const size_t end = s.find(sep, start);
    parts.push_back(s.substr(start, end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return parts;
}

Error spec_error(const std::string& spec, const std::string& key, const std::string& message) {
  return bad_input("", 0, key, message + " (in frame source spec '" + spec + "')");
}

Result<int> parse_int(const std::string& spec, const std::string& key, const std::string& v) {
  int out = 0;
  const auto [ptr, ec] = std::from_chars(v.data(), v.data() + v.size(), out);
  if (ec != std::errc() || ptr != v.data() + v.size() || v.empty())
    return spec_error(spec, key, "not an integer: '" + v + "'");
  return out;
}

Result<double> parse_double(const std::string& spec, const std::string& key, const std::string& v) {
  char* end = nullptr;
  const double out = std::strtod(v.c_str(), &end);
  if (v.empty() || end != v.c_str() + v.size() || !std::isfinite(out))
    return spec_error(spec, key, "not a number: '" + v + "'");
  return out;
}

}  // namespace

Result<SourceSpec> parse_source_spec(const std::string& spec) {
  const size_t colon = spec.find(':');
  if (colon == std::string::npos)
    return spec_error(spec, "scheme", "expected video:, images:, stereo: or render: before the path");
  SourceSpec out;
  out.scheme = spec.substr(0, colon);
  std::vector<std::string> parts = split(spec.substr(colon + 1), ';');
  out.body = parts.front();
  if (out.body.empty()) return spec_error(spec, out.scheme, "no path after '" + out.scheme + ":'");
  for (size_t i = 1; i < parts.size(); ++i) {
    const size_t eq = parts[i].find('=');
    if (eq == std::string::npos || eq == 0)
      return spec_error(spec, parts[i], "options are written key=value");
    out.options[parts[i].substr(0, eq)] = parts[i].substr(eq + 1);
  }
  return out;
}

Result<double> take_fps_option(const std::string& spec, std::map<std::string, std::string>* options) {
  double fps = 0;
  if (auto it = options->find("fps"); it != options->end()) {
    auto v = parse_double(spec, "fps", it->second);
    if (!v) return v.error();
    if (!(*v > 0)) return spec_error(spec, "fps", "must be positive");
    fps = *v;
    options->erase(it);
  }
  return fps;
}

Result<std::optional<StereoMatcherParams>> take_matcher_options(const std::string& spec,
                                                                std::map<std::string, std::string>* options,
                                                                const std::vector<std::string>& other_keys) {
  std::string algorithm = "none";
  if (auto it = options->find("disparity"); it != options->end()) {
    algorithm = it->second;
    options->erase(it);
  }
  StereoMatcherParams mp;
  if (algorithm != "none") {
    auto a = parse_stereo_algorithm(algorithm);
    if (!a) return spec_error(spec, "disparity", a.error().message);
    if (*a == StereoAlgorithm::kBM) mp = StereoMatcherParams::bm();
  }
  const std::map<std::string, int*> int_fields = {
      {"num_disparities", &mp.num_disparities},
      {"min_disparity", &mp.min_disparity},
      {"block_size", &mp.block_size},
      {"uniqueness_ratio", &mp.uniqueness_ratio},
      {"speckle_window_size", &mp.speckle_window_size},
      {"speckle_range", &mp.speckle_range},
      {"disp12_max_diff", &mp.disp12_max_diff},
      {"p1", &mp.p1},
      {"p2", &mp.p2},
  };
  for (auto it = options->begin(); it != options->end();) {
    const auto& [key, value] = *it;
    const bool other = std::find(other_keys.begin(), other_keys.end(), key) != other_keys.end();
    if (other) {
      ++it;
      continue;
    }
    if (!int_fields.count(key) && key != "mode" && key != "subpixel")
      return spec_error(spec, key, "unknown option for this source");
    if (algorithm == "none") return spec_error(spec, key, "a matcher option needs disparity=sgbm or disparity=bm");
    if (auto f = int_fields.find(key); f != int_fields.end()) {
      auto v = parse_int(spec, key, value);
      if (!v) return v.error();
      *f->second = *v;
    } else if (key == "subpixel") {
      if (value != "fit" && value != "cancel") return spec_error(spec, key, "expected fit or cancel, got '" + value + "'");
      mp.half_pixel_pass = value == "cancel";
    } else {
      auto m = parse_sgbm_mode(value);
      if (!m) return spec_error(spec, key, m.error().message);
      mp.mode = *m;
    }
    it = options->erase(it);
  }
  if (algorithm == "none") return std::optional<StereoMatcherParams>();
  if (Status st = mp.validate(); !st) return spec_error(spec, st.error().key, st.error().message);
  return std::optional<StereoMatcherParams>(mp);
}

Result<std::unique_ptr<FrameSource>> open_frame_source(const std::string& spec) {
  auto parsed = parse_source_spec(spec);
  if (!parsed) return parsed.error();
  const std::string& scheme = parsed->scheme;
  const std::string& body = parsed->body;
  auto& opts = parsed->options;
  auto fps = take_fps_option(spec, &opts);
  if (!fps) return fps.error();

  if (scheme == "video" || scheme == "images") {
    if (!opts.empty())
      return spec_error(spec, opts.begin()->first, "unknown option for " + scheme + ": sources");
    if (scheme == "video") {
      VideoFileOptions o;
      o.fps = *fps;
      auto s = VideoFileSource::open(body, o);
      if (!s) return s.error();
      return std::unique_ptr<FrameSource>(std::move(*s));
    }
    ImageSequenceOptions o;
    if (*fps > 0) o.fps = *fps;
    auto s = ImageSequenceSource::open(body, o);
    if (!s) return s.error();
    return std::unique_ptr<FrameSource>(std::move(*s));
  }
  if (scheme == "render")
    return spec_error(spec, "scheme",
                      "render: sources are opened by the simulator's tools (vigil track), not the vision library");
  if (scheme != "stereo")
    return spec_error(spec, "scheme", "unknown source '" + scheme + "' (expected video, images, stereo or render)");

  const std::vector<std::string> paths = split(body, ',');
  if (paths.size() < 2 || paths.size() > 3)
    return spec_error(spec, "stereo", "expected LEFT,RIGHT or LEFT,RIGHT,CALIBRATION");
  StereoSequenceOptions so;
  so.fps = *fps;
  auto matcher = take_matcher_options(spec, &opts, {"alpha", "pose"});
  if (!matcher) return matcher.error();
  so.matcher = *matcher;
  for (const auto& [key, value] : opts) {
    if (key == "pose") {
      const std::vector<std::string> parts = split(value, ',');
      if (parts.size() != 6) return spec_error(spec, key, "expected X,Y,Z,YAW,PITCH,ROLL (metres, degrees), got '" + value + "'");
      double v[6];
      for (int i = 0; i < 6; ++i) {
        auto d = parse_double(spec, key, parts[i]);
        if (!d) return d.error();
        v[i] = *d;
      }
      if (std::abs(v[4]) > 90) return spec_error(spec, key, "pitch must be within -90 and 90 degrees");
      CameraPose pose;
      pose.position = {v[0], v[1], v[2]};
      pose.yaw = v[3] * M_PI / 180;
      pose.pitch = v[4] * M_PI / 180;
      pose.roll = v[5] * M_PI / 180;
      so.pose = pose;
      continue;
    }
    if (key != "alpha") return spec_error(spec, key, "unknown option for stereo: sources");
    auto v = parse_double(spec, key, value);
    if (!v) return v.error();
    so.rectify_alpha = *v;
  }
  if (so.pose && paths.size() != 3)
    return spec_error(spec, "pose", "a pose needs a calibration (stereo:LEFT,RIGHT,CALIBRATION)");
  auto s = StereoSequenceSource::open(paths[0], paths[1], paths.size() == 3 ? paths[2] : "", so);
  if (!s) return s.error();
  return std::unique_ptr<FrameSource>(std::move(*s));
}

}  // namespace vigil::vision
