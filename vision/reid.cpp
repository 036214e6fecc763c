#include "vision/reid.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

namespace vigil::vision {

namespace {

Error param_error(const std::string& key, const std::string& message) { return bad_input("", 0, key, message); }

// Frames after its first report within which a tracker track may still take a lost identity.
constexpr int kSettleFrames = 45;
// Identities given to tracker tracks whose identity a later track took (see apply()).
constexpr int kRetiredBase = 1 << 29;

// The two bands' mean colours from their sums over `n` pixels; a band under min_pixels unknown.
Appearance band_means(const std::array<double, 6>& sum, const std::array<int, 2>& n, const ReidParams& p) {
  Appearance a;
  for (int b = 0; b < 2; ++b) {
    if (n[b] < p.min_pixels) continue;
    for (int ch = 0; ch < 3; ++ch) a.yuv[3 * b + ch] = static_cast<float>(sum[3 * b + ch] / n[b]);
    a.weight[b] = static_cast<float>(n[b]);
  }
  return a;
}

}  // namespace

Status ReidParams::validate() const {
  if (!(window >= 0) || !std::isfinite(window)) return param_error("window", "must be >= 0 s");
  if (!(max_distance >= 0) || !std::isfinite(max_distance)) return param_error("max_distance", "must be >= 0");
  if (!(ambiguity_ratio > 0 && ambiguity_ratio <= 1)) return param_error("ambiguity_ratio", "must be in (0, 1]");
  if (min_pixels < 1) return param_error("min_pixels", "must be at least 1");
  if (!(depth_tolerance > 0) || !std::isfinite(depth_tolerance)) return param_error("depth_tolerance", "must be positive");
  if (min_frames < 1 || min_frames > kSettleFrames)
    return param_error("min_frames", "must be 1 to " + std::to_string(kSettleFrames));
  return Status::Ok();
}

cv::Rect track_image_box(const StereoCameraModel& camera, const Track& t, cv::Size size) {
  const double r = std::max(0.15, 0.5 * t.width);
  double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
  for (int i = 0; i < 8; ++i) {
    const double ang = i * M_PI / 4;
    for (double z : {0.0, t.height}) {
      Eigen::Vector2d px;
      if (!camera.project_map(Eigen::Vector3d(t.x + r * std::cos(ang), t.y + r * std::sin(ang), z), &px)) continue;
      u0 = std::min(u0, px.x());
      v0 = std::min(v0, px.y());
      u1 = std::max(u1, px.x());
      v1 = std::max(v1, px.y());
    }
  }
  if (u1 < u0 || v1 < v0) return {};
  return cv::Rect(cv::Point(static_cast<int>(std::floor(std::max(-1.0, u0))), static_cast<int>(std::floor(std::max(-1.0, v0)))),
                  cv::Point(static_cast<int>(std::ceil(std::min(1e5, u1))) + 1, static_cast<int>(std::ceil(std::min(1e5, v1))) + 1)) &
         cv::Rect(0, 0, size.width, size.height);
}

Appearance measure_appearance(const cv::Mat& bgr, const cv::Mat& mask, const cv::Mat& depth,
                              const StereoCameraModel& camera, const Track& t, const ReidParams& p) {
  Appearance a;
  if (bgr.empty() || bgr.type() != CV_8UC3 || mask.size() != bgr.size() || mask.type() != CV_8UC1 ||
      depth.size() != bgr.size() || depth.type() != CV_32F || !(t.height > 0))
    return a;
  const cv::Rect box = track_image_box(camera, t, bgr.size());
  if (box.empty()) return a;
  cv::Mat yuv;
  cv::cvtColor(bgr(box), yuv, cv::COLOR_BGR2YUV);
  const Eigen::Vector3d centre = camera.map_from_optical().inverse() * Eigen::Vector3d(t.x, t.y, 0.5 * t.height);
  const double zt = centre.z();
  if (!(zt > 0)) return a;
  const Eigen::Isometry3d to_map = camera.map_from_optical();
  const Intrinsics& k = camera.intrinsics();
  std::array<double, 6> sum{};
  std::array<int, 2> n{};
  const double lo0 = 0.5 * t.height, hi0 = 0.8 * t.height, lo1 = 0.1 * t.height, hi1 = 0.45 * t.height;
  for (int v = box.y; v < box.y + box.height; ++v) {
    const uint8_t* m = mask.ptr<uint8_t>(v);
    const float* d = depth.ptr<float>(v);
    const cv::Vec3b* c = yuv.ptr<cv::Vec3b>(v - box.y) - box.x;
    for (int u = box.x; u < box.x + box.width; ++u) {
      if (!m[u]) continue;
      const double z = d[u];
      if (!(z > 0) || std::abs(z - zt) > p.depth_tolerance) continue;
      // The pixel's height above the floor, from its depth.
      const Eigen::Vector3d q((u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z);
      const double h = (to_map * q).z();
      const int band = h >= lo0 && h <= hi0 ? 0 : h >= lo1 && h <= hi1 ? 1 : -1;
      if (band < 0) continue;
      for (int ch = 0; ch < 3; ++ch) sum[3 * band + ch] += c[u][ch];
      ++n[band];
    }
  }
  return band_means(sum, n, p);
}

Appearance measure_appearance_mono(const cv::Mat& bgr, const cv::Mat& mask, const cv::Rect& box_in,
                                   const StereoCameraModel& camera, double x, double y, double height,
                                   const ReidParams& p) {
  Appearance a;
  if (bgr.empty() || bgr.type() != CV_8UC3 || mask.size() != bgr.size() || mask.type() != CV_8UC1 ||
      !(height > 0) || !std::isfinite(x) || !std::isfinite(y))
    return a;
  const cv::Rect box = box_in & cv::Rect(0, 0, bgr.cols, bgr.rows);
  if (box.empty()) return a;
  const Eigen::Isometry3d to_map = camera.map_from_optical();
  const Eigen::Vector3d c = to_map.translation();
  const double range = std::hypot(x - c.x(), y - c.y());
  if (!(range > 0)) return a;
  const Intrinsics& k = camera.intrinsics();
  const double u = box.x + 0.5 * box.width;
  cv::Mat yuv;
  cv::cvtColor(bgr(box), yuv, cv::COLOR_BGR2YUV);
  std::array<double, 6> sum{};
  std::array<int, 2> n{};
  const double lo0 = 0.5 * height, hi0 = 0.8 * height, lo1 = 0.1 * height, hi1 = 0.45 * height;
  for (int v = box.y; v < box.y + box.height; ++v) {
    // The row's height above the floor where its ray is `range` from the camera, horizontally.
    const Eigen::Vector3d d = to_map.linear() * Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
    const double dh = std::hypot(d.x(), d.y());
    if (!(dh > 1e-9)) continue;
    const double h = c.z() + range / dh * d.z();
    const int band = h >= lo0 && h <= hi0 ? 0 : h >= lo1 && h <= hi1 ? 1 : -1;
    if (band < 0) continue;
    const uint8_t* m = mask.ptr<uint8_t>(v);
    const cv::Vec3b* col = yuv.ptr<cv::Vec3b>(v - box.y) - box.x;
    for (int uu = box.x; uu < box.x + box.width; ++uu) {
      if (!m[uu]) continue;
      for (int ch = 0; ch < 3; ++ch) sum[3 * band + ch] += col[uu][ch];
      ++n[band];
    }
  }
  return band_means(sum, n, p);
}

double appearance_distance(const Appearance& a, const Appearance& b) {
  double worst = -1;
  for (int band = 0; band < 2; ++band) {
    if (a.weight[band] <= 0 || b.weight[band] <= 0) continue;
    const double dy = 0.5 * (a.yuv[3 * band] - b.yuv[3 * band]);
    const double du = a.yuv[3 * band + 1] - b.yuv[3 * band + 1];
    const double dv = a.yuv[3 * band + 2] - b.yuv[3 * band + 2];
    worst = std::max(worst, std::sqrt(dy * dy + du * du + dv * dv));
  }
  return worst < 0 ? std::numeric_limits<double>::infinity() : worst;
}

namespace {

// Folds one frame's colours into an average over frames (each band counts its own frames).
void fold(Appearance* avg, const Appearance& one) {
  for (int band = 0; band < 2; ++band) {
    if (one.weight[band] <= 0) continue;
    const float n = std::min(avg->weight[band], 50.0f);  // then a running average: clothes in new light
    for (int ch = 0; ch < 3; ++ch)
      avg->yuv[3 * band + ch] = (avg->yuv[3 * band + ch] * n + one.yuv[3 * band + ch]) / (n + 1);
    avg->weight[band] = n + 1;
  }
}

}  // namespace

void Reidentifier::apply(int64_t stamp_ns, std::vector<Track>* tracks, const std::map<int, Appearance>& seen) {
  if (!p_.enabled || !tracks) return;
  for (auto& [id, who] : identities_) who.on_frame = false;
  // Identities on this frame first (through tracks already mapped), so that a new track never
  // takes one that is here.
  for (const Track& t : *tracks)
    if (auto s = sources_.find(t.id); s != sources_.end())
      if (auto w = identities_.find(s->second.identity); w != identities_.end()) w->second.on_frame = true;
  const int64_t window_ns = static_cast<int64_t>(p_.window * 1e9);
  for (Track& t : *tracks) {
    auto [it, fresh] = sources_.try_emplace(t.id);
    Source& src = it->second;
    if (fresh) {
      src.identity = t.id;  // tracker ids only grow: never an identity already given
      identities_[t.id].on_frame = true;
    }
    ++src.reported;
    Identity& own = identities_[src.identity];
    if (auto m = seen.find(t.id); m != seen.end() && t.cls == TrackClass::kPerson && t.measured) {
      fold(&own.colours, m->second);
      ++own.frames;
    }
    own.last_seen = stamp_ns;
    // A new person, once her colours are known: somebody lost earlier?
    if (!src.settled && src.identity == t.id && t.cls == TrackClass::kPerson && own.frames >= p_.min_frames) {
      src.settled = true;
      double best = std::numeric_limits<double>::infinity(), second = best;
      int best_id = 0;
      for (const auto& [id, who] : identities_) {
        if (id == src.identity || who.on_frame || who.frames < p_.min_frames) continue;
        if (stamp_ns - who.last_seen > window_ns) continue;
        const double d = appearance_distance(own.colours, who.colours);
        if (d < best) {
          second = best;
          best = d;
          best_id = id;
        } else if (d < second) {
          second = d;
        }
      }
      if (best_id != 0 && best <= p_.max_distance && best < p_.ambiguity_ratio * second) {
        Identity& lost = identities_[best_id];
        for (int band = 0; band < 2; ++band) {
          // Keep what the lost one's frames knew; add what this track saw.
          if (own.colours.weight[band] > 0 && lost.colours.weight[band] <= 0) {
            for (int ch = 0; ch < 3; ++ch) lost.colours.yuv[3 * band + ch] = own.colours.yuv[3 * band + ch];
            lost.colours.weight[band] = own.colours.weight[band];
          }
        }
        lost.frames += own.frames;
        lost.on_frame = true;
        lost.last_seen = stamp_ns;
        identities_.erase(src.identity);
        src.identity = best_id;
        ++reidentified_;
        // A tracker track that had this identity and comes back after all is somebody else now
        // (one identity is never on a frame twice): an id of its own, beyond the tracker's.
        for (auto& [tid, other] : sources_)
          if (tid != t.id && other.identity == best_id) other.identity = kRetiredBase + tid;
      }
    }
    if (!src.settled && src.reported > kSettleFrames) src.settled = true;
    t.id = src.identity;
  }
  // Forget people lost beyond the window.
  std::erase_if(identities_, [&](const auto& kv) { return !kv.second.on_frame && stamp_ns - kv.second.last_seen > window_ns; });
}

void Reidentifier::reset() {
  identities_.clear();
  sources_.clear();
  reidentified_ = 0;
}

}  // namespace vigil::vision
