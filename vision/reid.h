// Re-identification of people by their clothes, for the stereo plan-view system. The plan-view
// tracker follows what stands on the floor; once a person leaves the camera's view (or is lost
// for longer than the tracker holds a track) and comes back, the tracker gives her a new id, and
// to the activity rules she is somebody else: an owner who takes her bag back is a thief. The
// chapter's MSER system keeps object models to "identify if a familiar object has re-entered the
// scene" (10.3.4); this is the plan-view system's counterpart, kept simple and cheap: a person is
// her two colours, the mean YUV colour of her upper body (0.5 to 0.8 of her height: a shirt) and
// of her legs (0.1 to 0.45: trousers), from the foreground pixels of the left image whose depth
// puts them on her, averaged over the frames she is seen alone. A person track the tracker starts
// takes the identity (the id) of a person lost earlier when their colours are within
// max_distance of each other and nobody else lost is nearly as close; else it keeps its own id.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <vector>

#include <opencv2/core.hpp>

#include "common/status.h"
#include "vision/stereo_camera_model.h"
#include "vision/track.h"

namespace vigil::vision {

struct ReidParams {
  bool enabled = true;
  double window = 300;          // s a lost person's colours are kept for re-identification
  double max_distance = 16;     // colour distance (see appearance_distance) of the same person
  double ambiguity_ratio = 0.7; // the best lost person must be this much nearer than the second
  int min_pixels = 40;          // foreground pixels on a band for its colour to count
  double depth_tolerance = 0.45; // m: a pixel's depth within this of the track's is on her
  int min_frames = 5;           // frames a person's colours are averaged over before she can be
                                // re-identified (as the lost one) or re-identify another
  // Checks every field; the error's key is the field's name.
  Status validate() const;
};

// A person's colours: the mean Y, U, V of her upper body and of her legs, each with the number
// of pixels (or frames, once averaged) behind it; a band with none is unknown.
struct Appearance {
  std::array<float, 6> yuv{};     // upper Y, U, V, then legs Y, U, V (0..255)
  std::array<float, 2> weight{};  // pixels (one frame) or frames (averaged) behind each band
  bool empty() const { return weight[0] <= 0 && weight[1] <= 0; }
};

// The image box of a track's cylinder (its width and height on the floor at its place), clipped
// to an image of `size`; empty when it is not in view.
cv::Rect track_image_box(const StereoCameraModel& camera, const Track& t, cv::Size size);

// The colours of track `t` on this frame: the pixels of `bgr` (the left image; converted to YUV)
// inside the image box of the track's cylinder that are set in `mask` (the foreground) and whose
// depth (`depth`, CV_32F metres along the optical axis) lies within depth_tolerance of the
// track's, binned by the height above the floor their depth gives them. Bands with fewer than
// min_pixels pixels are left unknown.
Appearance measure_appearance(const cv::Mat& bgr, const cv::Mat& mask, const cv::Mat& depth,
                              const StereoCameraModel& camera, const Track& t, const ReidParams& p);

// The same for a mono camera (the colour MSER system), which has no depth: the foreground pixels
// (`mask`) inside the person's image box `box`, each row's height above the floor taken where
// its ray reaches the person's distance from the camera (her place x, y on the map; a person
// behind a table, placed by her head, has her rows measured the same way), in the bands of her
// height `height` (m). The caller leaves out people whose boxes overlap (their colours would mix).
Appearance measure_appearance_mono(const cv::Mat& bgr, const cv::Mat& mask, const cv::Rect& box,
                                   const StereoCameraModel& camera, double x, double y, double height,
                                   const ReidParams& p);

// Distance between two people's colours: over the bands both know, the largest of
// sqrt((dY / 2)^2 + dU^2 + dV^2) (brightness changes with the light along a corridor more than
// hue does); infinity when they share no band.
double appearance_distance(const Appearance& a, const Appearance& b);

class Reidentifier {
 public:
  explicit Reidentifier(const ReidParams& p = {}) : p_(p) {}

  // Renames the tracker's tracks of one frame (stamp_ns, in order) to identities, in place.
  // `seen` holds the colours measured this frame per tracker id (people measured alone). A
  // tracker id met for the first time as a person is matched against the people lost (not on
  // this frame) within `window`, once it has min_frames frames of colours; until then, and when
  // nobody matches, it is its own identity. Ids the tracker reuses never come back: ids are
  // unique per camera, and an identity taken over is not given twice on one frame.
  void apply(int64_t stamp_ns, std::vector<Track>* tracks, const std::map<int, Appearance>& seen);
  void reset();
  // How many tracker tracks took a lost person's identity so far.
  int reidentified() const { return reidentified_; }

 private:
  struct Identity {
    Appearance colours;  // averaged
    int frames = 0;
    int64_t last_seen = 0;
    bool on_frame = false;
  };
  struct Source {
    int identity = 0;
    bool settled = false;  // matched against the lost, or too late to be
    int reported = 0;      // frames reported
  };
  ReidParams p_;
  std::map<int, Identity> identities_;  // by identity id
  std::map<int, Source> sources_;       // by tracker id
  int reidentified_ = 0;
};

}  // namespace vigil::vision
