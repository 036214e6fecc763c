// Occupancy maps: the grid and its queries, the map_server YAML + PGM/PNG loader and writer,
// the Stage worldfile floorplan loader, wall rectangles for Box2D and the grid path planner.
#include "world/map.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <queue>
#include <sstream>
#include <system_error>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <yaml-cpp/yaml.h>

namespace vigil {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Images

namespace {

// A decoded image: `channels` interleaved samples per pixel (1 grey, 2 grey+alpha, 3 colour,
// 4 colour+alpha), each in [0, maxval]; row 0 is the image's top.
struct RawImage {
  int width = 0, height = 0, channels = 1;
  double maxval = 255;
  std::vector<uint16_t> samples;

  // Mean of the colour channels (alpha left out), scaled to 0..255, as map_server computes it.
  double grey(int col, int row) const {
    const size_t base = (static_cast<size_t>(row) * width + col) * channels;
    const int colour = (channels == 2 || channels == 4) ? channels - 1 : channels;
    double sum = 0;
    for (int k = 0; k < colour; ++k) sum += samples[base + k];
    double avg = sum / colour;
    if (maxval != 255) avg = avg * 255.0 / maxval;
    return avg;
  }
};

Error image_error(const fs::path& image, const std::string& message) {
  return bad_input(image.string(), 0, "", message);
}

// Reads the whole file; false when it cannot be opened or read.
bool read_file_bytes(const fs::path& path, std::string* out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) return false;
  *out = ss.str();
  return true;
}

// Parses a PGM (P5 binary or P2 ASCII, 8 or 16 bit) with comments in its header.
Result<RawImage> parse_pgm(const fs::path& path, const std::string& bytes) {
  size_t pos = 2;
  auto skip_space_and_comments = [&] {
    while (pos < bytes.size()) {
      const char c = bytes[pos];
      if (c == '#') {
        while (pos < bytes.size() && bytes[pos] != '\n' && bytes[pos] != '\r') ++pos;
      } else if (std::isspace(static_cast<unsigned char>(c))) {
        ++pos;
      } else {
        break;
      }
    }
  };
  auto read_uint = [&](const char* what, long* out) -> Status {
    skip_space_and_comments();
    size_t start = pos;
    while (pos < bytes.size() && std::isdigit(static_cast<unsigned char>(bytes[pos]))) ++pos;
    if (pos == start || pos - start > 9) {
      return image_error(path, std::string("corrupt PGM header: expected ") + what);
    }
    *out = std::stol(bytes.substr(start, pos - start));
    return Status::Ok();
  };
  const bool binary = bytes[1] == '5';
  long w = 0, h = 0, maxval = 0;
  if (auto s = read_uint("the width", &w); !s) return s.error();
  if (auto s = read_uint("the height", &h); !s) return s.error();
  if (auto s = read_uint("the maximum grey value", &maxval); !s) return s.error();
  if (w <= 0 || h <= 0 || w > 100000 || h > 100000) {
    return image_error(path, "corrupt PGM header: size " + std::to_string(w) + " x " +
                                 std::to_string(h) + " is not a usable map size");
  }
  if (maxval <= 0 || maxval > 65535) {
    return image_error(path, "corrupt PGM header: maximum grey value " + std::to_string(maxval) +
                                 " is outside 1..65535");
  }
  RawImage img;
  img.width = static_cast<int>(w);
  img.height = static_cast<int>(h);
  img.channels = 1;
  img.maxval = static_cast<double>(maxval);
  const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
  if (binary) {
    // Exactly one whitespace byte separates the header from the samples.
    if (pos >= bytes.size() || !std::isspace(static_cast<unsigned char>(bytes[pos]))) {
      return image_error(path, "corrupt PGM header: no whitespace before the pixel data");
    }
    ++pos;
    const size_t bps = maxval < 256 ? 1 : 2;
    const size_t have = bytes.size() - pos;
    if (have < n * bps) {
      return image_error(path, "PGM pixel data truncated: expected " + std::to_string(n * bps) +
                                   " bytes, found " + std::to_string(have));
    }
    img.samples.resize(n);
    const auto* data = reinterpret_cast<const unsigned char*>(bytes.data() + pos);
    for (size_t i = 0; i < n; ++i) {
      img.samples[i] = bps == 1 ? data[i] : static_cast<uint16_t>(data[2 * i] << 8 | data[2 * i + 1]);
    }
  } else {
    if (n > bytes.size() - pos) {  // every ASCII sample takes at least one byte
      return image_error(path, "PGM pixel data truncated: " + std::to_string(n) + " values expected");
    }
    img.samples.resize(n);
    for (size_t i = 0; i < n; ++i) {
      long value = 0;
      if (auto s = read_uint("a pixel value", &value); !s) {
        return image_error(path, "PGM pixel data truncated or corrupt at pixel " + std::to_string(i) +
                                     " of " + std::to_string(n));
      }
      if (value > maxval) {
        return image_error(path, "PGM pixel " + std::to_string(i) + " is " + std::to_string(value) +
                                     ", above the maximum grey value " + std::to_string(maxval));
      }
      img.samples[i] = static_cast<uint16_t>(value);
    }
  }
  for (uint16_t s : img.samples) {
    if (s > maxval) {
      return image_error(path, "PGM pixel value " + std::to_string(s) +
                                   " is above the maximum grey value " + std::to_string(maxval));
    }
  }
  return img;
}

// CRC-32 (ISO 3309, as PNG uses) of `n` bytes.
uint32_t crc32(const unsigned char* data, size_t n) {
  static const auto table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; ++i) c = table[(c ^ data[i]) & 0xFF] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

uint32_t read_be32(const unsigned char* p) {
  return static_cast<uint32_t>(p[0]) << 24 | static_cast<uint32_t>(p[1]) << 16 |
         static_cast<uint32_t>(p[2]) << 8 | p[3];
}

// Checks a PNG's chunk structure: IHDR first with a sane header, every chunk complete with a
// matching CRC, at least one IDAT, and IEND at the end.
Status check_png_chunks(const fs::path& path, const std::string& bytes) {
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  size_t pos = 8;
  bool seen_idat = false;
  for (int index = 0;; ++index) {
    if (bytes.size() - pos < 12) return image_error(path, "corrupt PNG: file truncated");
    const uint32_t length = read_be32(data + pos);
    const std::string type(bytes, pos + 4, 4);
    if (length > bytes.size() - pos - 12) {
      return image_error(path, "corrupt PNG: chunk " + std::to_string(index) + " is truncated");
    }
    for (char c : type) {
      if (!std::isalpha(static_cast<unsigned char>(c))) {
        return image_error(path, "corrupt PNG: chunk " + std::to_string(index) + " has an invalid type");
      }
    }
    if (crc32(data + pos + 4, length + 4) != read_be32(data + pos + 8 + length)) {
      return image_error(path, "corrupt PNG: bad checksum in chunk " + type);
    }
    if (index == 0) {
      if (type != "IHDR" || length != 13) return image_error(path, "corrupt PNG: no IHDR header chunk");
      const unsigned char* h = data + pos + 8;
      const int depth = h[8], colour = h[9];
      if (read_be32(h) == 0 || read_be32(h + 4) == 0 || read_be32(h) > 100000 || read_be32(h + 4) > 100000) {
        return image_error(path, "corrupt PNG: image size is not a usable map size");
      }
      if ((depth != 1 && depth != 2 && depth != 4 && depth != 8 && depth != 16) ||
          (colour != 0 && colour != 2 && colour != 3 && colour != 4 && colour != 6)) {
        return image_error(path, "corrupt PNG: invalid bit depth or colour type");
      }
    }
    if (type == "IDAT") seen_idat = true;
    pos += 12 + length;
    if (type == "IEND") break;
  }
  if (!seen_idat) return image_error(path, "corrupt PNG: no image data");
  return Status::Ok();
}

// Loads a map image: PGM (P5/P2) with our own parser, PNG through OpenCV after checking its
// chunks, so errors are precise and nothing is printed.
Result<RawImage> load_image(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    return image_error(path, fs::exists(path, ec) ? "map image is not a regular file"
                                                  : "map image not found");
  }
  std::string bytes;
  if (!read_file_bytes(path, &bytes)) return image_error(path, "cannot read map image");
  if (bytes.size() >= 2 && bytes[0] == 'P' && (bytes[1] == '5' || bytes[1] == '2')) {
    return parse_pgm(path, bytes);
  }
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
  if (bytes.size() < 8 || std::memcmp(bytes.data(), kPng, 8) != 0) {
    return image_error(path, "unrecognised map image format (expected PGM or PNG)");
  }
  // libpng reports damage on stderr; checking the chunks first keeps a library quiet.
  if (auto s = check_png_chunks(path, bytes); !s) return s.error();
  cv::Mat mat;
  try {
    const cv::Mat buf(1, static_cast<int>(bytes.size()), CV_8U, bytes.data());
    mat = cv::imdecode(buf, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return image_error(path, "corrupt map image: " + e.msg);
  }
  if (mat.empty()) return image_error(path, "corrupt or unreadable map image");
  if (mat.depth() != CV_8U && mat.depth() != CV_16U) {
    return image_error(path, "unsupported map image pixel type (need 8 or 16 bit)");
  }
  RawImage img;
  img.width = mat.cols;
  img.height = mat.rows;
  img.channels = mat.channels();
  img.maxval = mat.depth() == CV_8U ? 255.0 : 65535.0;
  if (img.channels < 1 || img.channels > 4) {
    return image_error(path, "unsupported number of image channels: " + std::to_string(img.channels));
  }
  img.samples.resize(static_cast<size_t>(img.width) * img.height * img.channels);
  size_t i = 0;
  for (int r = 0; r < mat.rows; ++r) {
    if (mat.depth() == CV_8U) {
      const uint8_t* row = mat.ptr<uint8_t>(r);
      for (int k = 0; k < mat.cols * img.channels; ++k) img.samples[i++] = row[k];
    } else {
      const uint16_t* row = mat.ptr<uint16_t>(r);
      for (int k = 0; k < mat.cols * img.channels; ++k) img.samples[i++] = row[k];
    }
  }
  return img;
}

// ---------------------------------------------------------------------------------------------
// map_server YAML

// Reads the keys of a map_server YAML document, each error naming the file, line and key.
class MapYamlReader {
 public:
  MapYamlReader(std::string file, const YAML::Node& root) : file_(std::move(file)), root_(std::move(root)) {}

  // The node under `key`, or a "missing key" error.
  Result<YAML::Node> required(const char* key) const {
    YAML::Node n = root_[key];
    if (!n.IsDefined()) return bad_input(file_, 0, key, "missing required key");
    return n;
  }

  Result<double> number(const YAML::Node& n, const std::string& key) const {
    double value = 0;
    if (!n.IsScalar() || !YAML::convert<double>::decode(n, value)) {
      return bad_input(file_, line(n), key, "expected a number, got " + describe(n));
    }
    if (!std::isfinite(value)) return bad_input(file_, line(n), key, "must be a finite number");
    return value;
  }

  Result<double> number(const char* key) const {
    auto n = required(key);
    if (!n) return n.error();
    return number(*n, key);
  }

  Result<std::string> string(const char* key) const {
    auto n = required(key);
    if (!n) return n.error();
    if (!n->IsScalar() || n->Scalar().empty()) {
      return bad_input(file_, line(*n), key, "expected a non-empty string, got " + describe(*n));
    }
    return n->Scalar();
  }

  int line(const YAML::Node& n) const {
    const YAML::Mark m = n.Mark();
    return m.is_null() ? 0 : m.line + 1;
  }

  const std::string& file() const { return file_; }

 private:
  static std::string describe(const YAML::Node& n) {
    if (n.IsScalar()) return "'" + n.Scalar() + "'";
    if (n.IsSequence()) return "a list";
    if (n.IsMap()) return "a mapping";
    return "nothing";
  }

  std::string file_;
  const YAML::Node root_;
};

// Classifies every pixel of `img` into a grid (image row 0 = grid's top row) with `classify`.
template <class Classify>
OccupancyGrid grid_from_image(const RawImage& img, double resolution, Pose2 origin, Classify classify) {
  OccupancyGrid grid(img.width, img.height, resolution, origin, Cell::kUnknown);
  for (int row = 0; row < img.height; ++row) {
    const int cy = img.height - 1 - row;
    for (int col = 0; col < img.width; ++col) grid.set(col, cy, classify(img.grey(col, row)));
  }
  return grid;
}

Result<OccupancyGrid> load_map_yaml_impl(const fs::path& yaml_path) {
  const std::string file = yaml_path.string();
  std::error_code ec;
  if (!fs::exists(yaml_path, ec)) return bad_input(file, 0, "", "map file not found");
  if (!fs::is_regular_file(yaml_path, ec)) return bad_input(file, 0, "", "map file is not a regular file");
  std::string text;
  if (!read_file_bytes(yaml_path, &text)) return bad_input(file, 0, "", "cannot read map file");
  YAML::Node parsed;
  try {
    parsed = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return bad_input(file, e.mark.is_null() ? 0 : e.mark.line + 1, "", "invalid YAML: " + e.msg);
  }
  const YAML::Node root = parsed;
  if (!root.IsMap()) {
    return bad_input(file, root.IsDefined() && !root.IsNull() ? root.Mark().line + 1 : 0, "",
                     "expected a mapping with image, resolution, origin, negate, occupied_thresh "
                     "and free_thresh");
  }
  MapYamlReader yaml(file, root);

  auto image_name = yaml.string("image");
  if (!image_name) return image_name.error();
  const int image_line = yaml.line(root["image"]);

  auto resolution = yaml.number("resolution");
  if (!resolution) return resolution.error();
  if (*resolution <= 0) {
    return bad_input(file, yaml.line(root["resolution"]), "resolution",
                     "must be positive (metres per pixel)");
  }

  auto origin_node = yaml.required("origin");
  if (!origin_node) return origin_node.error();
  if (!origin_node->IsSequence() || origin_node->size() != 3) {
    return bad_input(file, yaml.line(*origin_node), "origin", "expected a list [x, y, yaw]");
  }
  double origin_values[3];
  for (size_t i = 0; i < 3; ++i) {
    auto v = yaml.number((*origin_node)[i], "origin[" + std::to_string(i) + "]");
    if (!v) return v.error();
    origin_values[i] = *v;
  }
  if (origin_values[2] != 0) {
    return bad_input(file, yaml.line((*origin_node)[2]), "origin",
                     "a nonzero origin yaw (rotated map) is not supported: yaw must be 0");
  }

  auto negate_node = yaml.required("negate");
  if (!negate_node) return negate_node.error();
  bool negate = false;
  {
    int as_int = 0;
    bool as_bool = false;
    if (negate_node->IsScalar() && YAML::convert<int>::decode(*negate_node, as_int) &&
        (as_int == 0 || as_int == 1)) {
      negate = as_int == 1;
    } else if (negate_node->IsScalar() && YAML::convert<bool>::decode(*negate_node, as_bool)) {
      negate = as_bool;
    } else {
      return bad_input(file, yaml.line(*negate_node), "negate", "expected 0 or 1");
    }
  }

  auto occupied_thresh = yaml.number("occupied_thresh");
  if (!occupied_thresh) return occupied_thresh.error();
  auto free_thresh = yaml.number("free_thresh");
  if (!free_thresh) return free_thresh.error();
  if (*occupied_thresh < 0 || *occupied_thresh > 1) {
    return bad_input(file, yaml.line(root["occupied_thresh"]), "occupied_thresh", "must be in [0, 1]");
  }
  if (*free_thresh < 0 || *free_thresh > 1) {
    return bad_input(file, yaml.line(root["free_thresh"]), "free_thresh", "must be in [0, 1]");
  }
  if (*free_thresh >= *occupied_thresh) {
    return bad_input(file, yaml.line(root["free_thresh"]), "free_thresh",
                     "must be below occupied_thresh (" + std::to_string(*occupied_thresh) + ")");
  }

  if (YAML::Node mode = root["mode"]; mode.IsDefined()) {
    if (!mode.IsScalar()) return bad_input(file, yaml.line(mode), "mode", "expected trinary or scale");
    const std::string m = mode.Scalar();
    // Scale mode differs from trinary only between the thresholds, where it grades the cost;
    // a three-state grid keeps those cells unknown, exactly as trinary does.
    if (m != "trinary" && m != "scale") {
      return bad_input(file, yaml.line(mode), "mode",
                       "'" + m + "' is not supported (use trinary or scale; raw keeps pixel values "
                       "that a three-state grid cannot hold)");
    }
  }

  fs::path image_path = *image_name;
  if (image_path.is_relative()) image_path = yaml_path.parent_path() / image_path;
  auto img = load_image(image_path);
  if (!img) {
    Error e = img.error();
    e.message += " (named by 'image' at " + file + ":" + std::to_string(image_line) + ")";
    return e;
  }
  const double occ_th = *occupied_thresh, free_th = *free_thresh;
  return grid_from_image(*img, *resolution, Pose2{origin_values[0], origin_values[1], 0},
                         [&](double grey) {
                           // map_server: negate flips the grey level, then p = (255 - v) / 255.
                           const double v = negate ? 255.0 - grey : grey;
                           const double p = (255.0 - v) / 255.0;
                           if (p > occ_th) return Cell::kOccupied;
                           if (p < free_th) return Cell::kFree;
                           return Cell::kUnknown;
                         });
}

// ---------------------------------------------------------------------------------------------
// Stage worldfiles

struct WorldToken {
  enum Kind { kWord, kString, kOpen, kClose, kOpenList, kCloseList } kind;
  std::string text;
  int line;
};

// Splits a worldfile into words, quoted strings and brackets; `#` starts a comment.
Result<std::vector<WorldToken>> tokenize_world(const std::string& file, const std::string& text) {
  std::vector<WorldToken> out;
  int line = 1;
  size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    if (c == '\0') {
      // (strchr below would match the terminator and never move on)
      return bad_input(file, line, "", "a NUL byte: not a text worldfile");
    } else if (c == '\n') {
      ++line;
      ++i;
    } else if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
    } else if (c == '#') {
      while (i < text.size() && text[i] != '\n') ++i;
    } else if (c == '"') {
      const int start_line = line;
      size_t j = i + 1;
      while (j < text.size() && text[j] != '"' && text[j] != '\n') ++j;
      if (j >= text.size() || text[j] != '"') return bad_input(file, start_line, "", "unterminated string");
      out.push_back({WorldToken::kString, text.substr(i + 1, j - i - 1), start_line});
      i = j + 1;
    } else if (c == '(' || c == ')' || c == '[' || c == ']') {
      const auto kind = c == '(' ? WorldToken::kOpen
                        : c == ')' ? WorldToken::kClose
                        : c == '[' ? WorldToken::kOpenList
                                   : WorldToken::kCloseList;
      out.push_back({kind, std::string(1, c), line});
      ++i;
    } else {
      size_t j = i;
      while (j < text.size() && !std::isspace(static_cast<unsigned char>(text[j])) &&
             std::strchr("()[]\"#", text[j]) == nullptr) {
        ++j;
      }
      out.push_back({WorldToken::kWord, text.substr(i, j - i), line});
      i = j;
    }
  }
  return out;
}

// A property of the floorplan block: its values and the line it starts on.
struct WorldProperty {
  std::vector<WorldToken> values;
  int line = 0;
};

// Skips a bracketed group starting at tokens[i] (an opening bracket); returns the index after it.
Result<size_t> skip_group(const std::string& file, const std::vector<WorldToken>& t, size_t i) {
  const int open_line = t[i].line;
  int depth = 0;
  for (; i < t.size(); ++i) {
    if (t[i].kind == WorldToken::kOpen || t[i].kind == WorldToken::kOpenList) ++depth;
    if (t[i].kind == WorldToken::kClose || t[i].kind == WorldToken::kCloseList) {
      if (--depth == 0) return i + 1;
    }
  }
  return bad_input(file, open_line, "", "unclosed bracket opened here");
}

Result<double> world_number(const std::string& file, const WorldToken& tok, const std::string& key) {
  double value = 0;
  const char* b = tok.text.data();
  const char* e = b + tok.text.size();
  auto [ptr, ec] = std::from_chars(b, e, value);
  if (tok.kind != WorldToken::kWord || ec != std::errc() || ptr != e || !std::isfinite(value)) {
    return bad_input(file, tok.line, key, "expected a number, got '" + tok.text + "'");
  }
  return value;
}

// Reads the numbers of a `[a b c]` property, accepting `min_n` to `max_n` of them.
Result<std::vector<double>> world_numbers(const std::string& file, const WorldProperty& prop,
                                          const std::string& key, size_t min_n, size_t max_n) {
  const auto& v = prop.values;
  if (v.size() < 2 || v.front().kind != WorldToken::kOpenList || v.back().kind != WorldToken::kCloseList ||
      v.size() - 2 < min_n || v.size() - 2 > max_n) {
    return bad_input(file, prop.line, key,
                     "expected a list of " + std::to_string(min_n) +
                         (min_n == max_n ? "" : " to " + std::to_string(max_n)) + " numbers in [ ]");
  }
  std::vector<double> out;
  for (size_t i = 1; i + 1 < v.size(); ++i) {
    auto x = world_number(file, v[i], key);
    if (!x) return x.error();
    out.push_back(*x);
  }
  return out;
}

Result<OccupancyGrid> load_stage_world_impl(const fs::path& world_path) {
  const std::string file = world_path.string();
  std::error_code ec;
  if (!fs::exists(world_path, ec)) return bad_input(file, 0, "", "world file not found");
  if (!fs::is_regular_file(world_path, ec)) return bad_input(file, 0, "", "world file is not a regular file");
  std::string text;
  if (!read_file_bytes(world_path, &text)) return bad_input(file, 0, "", "cannot read world file");
  auto tokens_r = tokenize_world(file, text);
  if (!tokens_r) return tokens_r.error();
  const std::vector<WorldToken>& t = *tokens_r;

  // Find the first top-level `floorplan ( ... )`; skip includes, defines and other blocks.
  size_t i = 0;
  size_t body_begin = 0, body_end = 0;
  int block_line = 0;
  bool found = false;
  while (i < t.size() && !found) {
    if (t[i].kind == WorldToken::kOpen || t[i].kind == WorldToken::kOpenList) {
      auto next = skip_group(file, t, i);
      if (!next) return next.error();
      i = *next;
    } else if (t[i].kind == WorldToken::kWord && t[i].text == "define") {
      i += 3;  // define NAME PARENT, then its ( ... ) is skipped as a group
    } else if (t[i].kind == WorldToken::kWord && t[i].text == "floorplan" && i + 1 < t.size() &&
               t[i + 1].kind == WorldToken::kOpen) {
      auto next = skip_group(file, t, i + 1);
      if (!next) return next.error();
      block_line = t[i].line;
      body_begin = i + 2;
      body_end = *next - 1;
      found = true;
    } else if (t[i].kind == WorldToken::kClose || t[i].kind == WorldToken::kCloseList) {
      return bad_input(file, t[i].line, "", "unmatched '" + t[i].text + "'");
    } else {
      ++i;
    }
  }
  if (!found) return bad_input(file, 0, "floorplan", "no floorplan ( ... ) block in the world file");

  // Collect the block's own properties; nested model blocks are skipped.
  std::map<std::string, WorldProperty> props;
  for (size_t j = body_begin; j < body_end;) {
    if (t[j].kind != WorldToken::kWord) {
      if (t[j].kind == WorldToken::kOpen || t[j].kind == WorldToken::kOpenList) {
        auto next = skip_group(file, t, j);
        if (!next) return next.error();
        j = *next;
        continue;
      }
      return bad_input(file, t[j].line, "floorplan", "unexpected '" + t[j].text + "'");
    }
    WorldProperty prop;
    prop.line = t[j].line;
    const std::string name = t[j].text;
    ++j;
    if (j < body_end && t[j].kind == WorldToken::kOpen) {  // a nested block: skip it
      auto next = skip_group(file, t, j);
      if (!next) return next.error();
      j = *next;
      continue;
    }
    if (j < body_end && t[j].kind == WorldToken::kOpenList) {
      auto next = skip_group(file, t, j);
      if (!next) return next.error();
      prop.values.assign(t.begin() + static_cast<long>(j), t.begin() + static_cast<long>(*next));
      j = *next;
    } else if (j < body_end) {
      prop.values.push_back(t[j]);
      ++j;
    }
    props[name] = std::move(prop);
  }

  auto bitmap_it = props.find("bitmap");
  if (bitmap_it == props.end()) {
    return bad_input(file, block_line, "floorplan.bitmap", "missing: the floorplan needs a bitmap");
  }
  const WorldProperty& bitmap = bitmap_it->second;
  if (bitmap.values.size() != 1 || bitmap.values[0].kind != WorldToken::kString ||
      bitmap.values[0].text.empty()) {
    return bad_input(file, bitmap.line, "floorplan.bitmap", "expected a quoted file name");
  }
  auto size_it = props.find("size");
  if (size_it == props.end()) {
    return bad_input(file, block_line, "floorplan.size", "missing: the floorplan needs a size [x y z]");
  }
  auto size = world_numbers(file, size_it->second, "floorplan.size", 2, 3);
  if (!size) return size.error();
  if ((*size)[0] <= 0 || (*size)[1] <= 0) {
    return bad_input(file, size_it->second.line, "floorplan.size", "x and y sizes must be positive");
  }
  Pose2 pose;
  if (auto pose_it = props.find("pose"); pose_it != props.end()) {
    auto p = world_numbers(file, pose_it->second, "floorplan.pose", 3, 4);
    if (!p) return p.error();
    const double yaw = p->back();  // [x y z yaw], or Stage 2's [x y yaw]
    if (yaw != 0) {
      return bad_input(file, pose_it->second.line, "floorplan.pose",
                       "a rotated floorplan is not supported: yaw must be 0");
    }
    pose = Pose2{(*p)[0], (*p)[1], 0};
  }

  fs::path image_path = bitmap.values[0].text;
  if (image_path.is_relative()) image_path = world_path.parent_path() / image_path;
  auto img = load_image(image_path);
  if (!img) {
    Error e = img.error();
    e.message += " (named by floorplan.bitmap at " + file + ":" + std::to_string(bitmap.line) + ")";
    return e;
  }
  const double sx = (*size)[0], sy = (*size)[1];
  const double res = sx / img->width;
  const double res_y = sy / img->height;
  if (std::abs(res_y - res) > 0.02 * res) {
    return bad_input(file, size_it->second.line, "floorplan.size",
                     "size [" + std::to_string(sx) + " " + std::to_string(sy) +
                         "] does not keep the bitmap's aspect (" + std::to_string(img->width) + " x " +
                         std::to_string(img->height) + " px): non-square cells are not supported");
  }
  const Pose2 origin{pose.x - sx / 2, pose.y - sy / 2, 0};
  // Stage has no unknown space: pixels darker than half grey are walls, the rest is free.
  return grid_from_image(*img, res, origin,
                         [](double grey) { return grey < 128.0 ? Cell::kOccupied : Cell::kFree; });
}

// Shortest decimal text that reads back as the same double.
std::string format_number(double x) {
  char buf[64];
  auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, x);
  return ec == std::errc() ? std::string(buf, ptr) : std::to_string(x);
}

// Runs a loader, turning any escaping exception into an Error naming the file.
template <class F>
Result<OccupancyGrid> guarded(const fs::path& path, F load) {
  try {
    return load();
  } catch (const std::exception& e) {
    Error err = internal_error(std::string("unexpected failure while loading the map: ") + e.what());
    err.file = path.string();
    return err;
  } catch (...) {
    Error err = internal_error("unexpected failure while loading the map");
    err.file = path.string();
    return err;
  }
}

}  // namespace

Result<OccupancyGrid> load_map_yaml(const fs::path& yaml_path) {
  return guarded(yaml_path, [&] { return load_map_yaml_impl(yaml_path); });
}

Result<OccupancyGrid> load_stage_world(const fs::path& world_path) {
  return guarded(world_path, [&] { return load_stage_world_impl(world_path); });
}

Result<OccupancyGrid> load_map(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".yaml" || ext == ".yml") return load_map_yaml(path);
  if (ext == ".world") return load_stage_world(path);
  return bad_input(path.string(), 0, "",
                   "unknown map format '" + ext + "' (expected .yaml/.yml map_server or .world Stage)");
}

Status save_map_yaml(const OccupancyGrid& grid, const fs::path& yaml_path) {
  if (grid.width() <= 0 || grid.height() <= 0) {
    return bad_input(yaml_path.string(), 0, "", "cannot save an empty grid");
  }
  const std::string image_name = yaml_path.stem().string() + ".pgm";
  const fs::path image_path = yaml_path.parent_path() / image_name;

  std::string pgm = "P5\n" + std::to_string(grid.width()) + " " + std::to_string(grid.height()) + "\n255\n";
  const size_t header = pgm.size();
  pgm.resize(header + static_cast<size_t>(grid.width()) * grid.height());
  size_t i = header;
  for (int row = 0; row < grid.height(); ++row) {
    const int cy = grid.height() - 1 - row;  // image row 0 is the map's top
    for (int cx = 0; cx < grid.width(); ++cx) {
      const Cell c = grid.at(cx, cy);
      pgm[i++] = static_cast<char>(c == Cell::kFree ? 254 : c == Cell::kOccupied ? 0 : 205);
    }
  }
  {
    std::ofstream out(image_path, std::ios::binary | std::ios::trunc);
    if (!out) return bad_input(image_path.string(), 0, "", "cannot create map image");
    out.write(pgm.data(), static_cast<std::streamsize>(pgm.size()));
    if (!out) return bad_input(image_path.string(), 0, "", "cannot write map image");
  }
  const Pose2 o = grid.origin();
  const std::string yaml = "image: " + image_name + "\nresolution: " + format_number(grid.resolution()) +
                           "\norigin: [" + format_number(o.x) + ", " + format_number(o.y) + ", " +
                           format_number(o.yaw) +
                           "]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
  std::ofstream out(yaml_path, std::ios::binary | std::ios::trunc);
  if (!out) return bad_input(yaml_path.string(), 0, "", "cannot create map file");
  out << yaml;
  if (!out) return bad_input(yaml_path.string(), 0, "", "cannot write map file");
  return Status::Ok();
}

// ---------------------------------------------------------------------------------------------
// Wall rectangles

std::vector<WallBox> extract_wall_boxes(const OccupancyGrid& grid) {
  struct Rect {
    int x0, x1, y0, y1;  // cells [x0, x1) x [y0, y1)
  };
  std::vector<Rect> rects;          // in order of creation: by bottom row, then by x
  std::vector<int> open_prev, open_cur;  // per x0: index of the rect whose top is the previous row
  open_prev.assign(static_cast<size_t>(grid.width()), -1);
  open_cur.assign(static_cast<size_t>(grid.width()), -1);
  for (int cy = 0; cy < grid.height(); ++cy) {
    std::fill(open_cur.begin(), open_cur.end(), -1);
    for (int cx = 0; cx < grid.width();) {
      if (grid.at(cx, cy) != Cell::kOccupied) {
        ++cx;
        continue;
      }
      const int x0 = cx;
      while (cx < grid.width() && grid.at(cx, cy) == Cell::kOccupied) ++cx;
      const int prev = open_prev[x0];
      if (prev >= 0 && rects[prev].x1 == cx) {
        rects[prev].y1 = cy + 1;
        open_cur[x0] = prev;
      } else {
        open_cur[x0] = static_cast<int>(rects.size());
        rects.push_back({x0, cx, cy, cy + 1});
      }
    }
    std::swap(open_prev, open_cur);
  }
  std::vector<WallBox> boxes;
  boxes.reserve(rects.size());
  const Pose2 o = grid.origin();
  const double r = grid.resolution();
  for (const Rect& q : rects) {
    boxes.push_back({{o.x + q.x0 * r, o.y + q.y0 * r}, {o.x + q.x1 * r, o.y + q.y1 * r}});
  }
  return boxes;
}

void prepare_simulation_map(OccupancyGrid* map) {
  // SLAM maps sprinkle specks of unknown (a few cells the robot never saw) inside rooms and
  // corridors: specks of at most kSpeckCells 4-connected unknown cells, away from the grid's
  // edge, are free floor, not pillars.
  {
    constexpr size_t kSpeckCells = 12;
    const int w = map->width(), h = map->height();
    std::vector<uint8_t> seen(static_cast<size_t>(w) * h, 0);
    std::vector<std::pair<int, int>> comp, stack;
    for (int cy = 0; cy < h; ++cy) {
      for (int cx = 0; cx < w; ++cx) {
        if (map->at(cx, cy) != Cell::kUnknown || seen[static_cast<size_t>(cy) * w + cx]) continue;
        comp.clear();
        stack.assign(1, {cx, cy});
        seen[static_cast<size_t>(cy) * w + cx] = 1;
        bool edge = false;
        while (!stack.empty()) {
          const auto [x, y] = stack.back();
          stack.pop_back();
          if (comp.size() <= kSpeckCells) comp.emplace_back(x, y);
          edge = edge || x == 0 || y == 0 || x == w - 1 || y == h - 1;
          static const int kD[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
          for (const auto& d : kD) {
            const int nx = x + d[0], ny = y + d[1];
            if (!map->in_bounds(nx, ny) || map->at(nx, ny) != Cell::kUnknown) continue;
            uint8_t& s = seen[static_cast<size_t>(ny) * w + nx];
            if (s) continue;
            s = 1;
            stack.emplace_back(nx, ny);
          }
        }
        if (!edge && comp.size() <= kSpeckCells)
          for (const auto& [x, y] : comp) map->set(x, y, Cell::kFree);
      }
    }
  }
  // Seal free space: an unknown cell next to a free one is a wall (SLAM maps leave gaps where
  // the robot saw no wall), so nothing walks or drives off the known map and lasers stop there.
  {
    std::vector<std::pair<int, int>> seal;
    for (int cy = 0; cy < map->height(); ++cy) {
      for (int cx = 0; cx < map->width(); ++cx) {
        if (map->at(cx, cy) != Cell::kUnknown) continue;
        bool touches_free = false;
        for (int dy = -1; dy <= 1 && !touches_free; ++dy)
          for (int dx = -1; dx <= 1 && !touches_free; ++dx)
            touches_free = map->in_bounds(cx + dx, cy + dy) && map->at(cx + dx, cy + dy) == Cell::kFree;
        if (touches_free) seal.emplace_back(cx, cy);
      }
    }
    for (const auto& [cx, cy] : seal) map->set(cx, cy, Cell::kOccupied);
  }
}

}  // namespace vigil
