// The colour MSER camera system of chapter 10.3 on a mono video, as far as it is built: the
// segmenter with region feed-forward (segmenter.h), region tracking (region_tracker.h), the
// region-based background model (10.3.3) and objects from the foreground regions.
//
// Background model (10.3.3). After `warmup_frames` (feed-forward assimilates unstable pieces
// over the first frames, so the segmentation settles), the next `learn_frames` frames build it: every region of every
// learning frame is matched against the candidates so far by the tracking features (centroid,
// second-moment width and height, mean colour; the same limits as in operation); those seen in
// at least half the learning frames, moving under `still_speed` px a frame, are the model. Afterwards each region is
// background when a model entry matches it (kd-tree candidates by centroid, then size and colour
// limits); matching entries follow their region slowly (`adapt`). A region that matches no
// entry but whose colour is the model's under it (the learned regions' mean colours, per pixel)
// is a background region whose shape changed (cut by someone passing in front): background. Any
// other region is foreground; one whose track was background is a background region behaving
// unexpectedly (counted in `moved_background`). An entry that, following its region, drifts
// from where it was learned by more than its matching radius was something moving slowly while
// the model was learned (a distant walker): it leaves the model and its region is foreground. A foreground region
// that stays still for `absorb_frames` frames is taken into the model.
//
// Objects. The foreground regions' pixels, closed with a `close_px` square, give connected
// components; those of at least `min_object_area` of the image, filled with foreground to at
// least `min_fill` of their box, are objects, linked over frames greedily by box overlap (IoU at
// least `min_iou`) with a constant-velocity prediction, kept `keep_lost` frames when unseen, and
// reported once seen `confirm_frames` frames (a new object is tentative before). A component
// holding both still foreground regions and moving ones, each of an object's size, is split in
// two (a bag just put down beside its owner walking off; a walker passing a parked robot); the
// still part of an object more than twice its size is a new object (the thing put down), the
// object going on in the moving part (the one who put it down).
//
// Object models (10.3.4, object_model.h), with `recognise`: every object keeps its foreground
// regions (centroid, second moments, mean colour, and the share of each region's boundary on
// lines) from the frame it showed the most foreground in (within 10 %: the latest such frame),
// so an object leaving the image is modelled before the border cut it. When an object that had
// been reported (or recognised) ends (unseen for `keep_lost` frames), its model goes into a hash
// table of the last `max_models` ended objects.
// A new object is looked up in it in every frame while tentative: when the vote recognises one
// (its features agreeing on a size and place), the new object takes that object's id back (a
// re-entering object), its model leaves the table, and it is reported as `recognised`.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <unordered_map>
#include <string>
#include <tuple>
#include <vector>

#include <opencv2/core.hpp>

#include "vision/mser/object_model.h"
#include "vision/mser/region_tracker.h"
#include "vision/mser/segmenter.h"

namespace vigil::vision::mser {

struct MserSystemParams {
  SegmenterParams segmenter;      // feed_forward is switched on
  RegionTrackerParams tracking;
  int warmup_frames = 10;  // frames for the feed-forward segmentation to settle before learning
  int learn_frames = 10;
  double still_speed = 1.0;       // px per frame
  double bg_shift = 6;            // px, plus a quarter of width + height
  double bg_size_ratio = 1.6;
  double bg_colour = 25;
  double adapt = 0.05;
  // Regions of the last learning frame left out of the model (they moved while it was learned),
  // on pixels whose colour changed over the learning frames (by more than bg_colour in a
  // channel), leave no colour in the model's picture: what they uncover is taken into the model
  // as what a released thing uncovers (see release_from_background). Off: their colours stay in
  // the picture, and the floor they uncover is foreground until absorb_frames (a ghost where a
  // robot stood at the start).
  bool unknown_moving = true;
  // What a released thing uncovers is taken into the model when the model has its colour on a
  // pixel touching it (the floor it continues; uncovered pixels are learned from the edge in),
  // not anywhere around its box (a bag put down where someone walked while the model was learned
  // would be taken in at once).
  bool uncover_touching = true;
  // A background region's pixels whose colour in the model's picture is farther than this from
  // the region's mean and from the pixel's own colour are foreground (it merged with something
  // of its colour in front: dark trousers with a dark laptop screen behind), when they are a
  // share of the region (spill_share) and touch a foreground component of an object's size;
  // they make no object of their own and count neither as still nor as moving. 0: off.
  double spill_colour = 40;
  double spill_share = 0.2;  // ...when they are between this share of the region and 1 minus it
  int absorb_frames = 1800;  // 2 min at 15 fps: a bag left in view stays foreground for the rules
  int close_px = 7;
  double min_object_area = 0.002;  // of the image
  // Where the small-things mask is set (set_small_things_mask: table tops as the camera sees
  // them), a thing lying still there (nine tenths of its component's foreground still, or the
  // still part split off a moving one) whose box's bottom middle is on the mask is an object
  // from this share of the image (a book put down on a table is under min_object_area).
  double min_still_area = 0.0005;
  double min_fill = 0.25;          // foreground pixels over box area (scattered specks are not objects)
  int confirm_frames = 3;          // an object is reported once seen this many frames running
  double min_iou = 0.25;
  // A component with still foreground regions (their centroid within `split_still_speed` px a
  // frame of where it was `still_age` frames ago, at most 32: a thing put down does not move at
  // all, a walker coming towards the camera moves slowly in the image) and moving ones, each at
  // least min_object_area, is two objects.
  bool split_still = true;
  // An object's box leaves out rows at its top and bottom with fewer foreground pixels than
  // this fraction of its typical row (thin tails: a floor line bled into the feet's region).
  // Off (0) by default: on rendered people it cuts the lower legs as often as it removes a tail.
  double thin_row = 0;
  // An object's body (ImageObject::body): its heaviest run of columns each holding at least
  // this fraction of its typical column's foreground pixels, if that stands upright
  // (split_aspect); an arm held out sideways is thin columns beyond it. 0: none (the box).
  double thin_column = 0.2;
  int still_age = 10;
  double split_still_speed = 0.2;
  int keep_lost = 5;
  // Objects merging in the image (someone walks behind someone else): a component holding the
  // foreground regions of two or more confirmed objects, each part of an object's size and at
  // least half of that object's foreground in the frame, whose last boxes stood upright (at
  // least `split_aspect` times as tall as wide) and at least `split_min_height` of the
  // component's height (people within twice each other's distance; not a bag beside its owner),
  // sharing at least half their rows with the largest's (side by side or one behind the other;
  // not the shirt above the legs of one person, apart for a moment), is parted by whose the
  // regions were (they keep their track ids through the merge, 10.3.2); another's or nobody's
  // pixels go to the part whose own pixels' box holds them (the smallest), else the largest.
  bool split_owners = true;
  double split_aspect = 1.2;
  double split_min_height = 0.5;
  // Object models (10.3.4): re-entering objects recognised by their regions.
  bool recognise = true;
  int max_models = 50;             // ended objects kept, the oldest forgotten first
  ObjectModelParams models;
};

struct ImageObject {
  int64_t id = 0;
  cv::Rect box;
  cv::Rect body;       // its upright body without what it holds out sideways (thin_column); else box
  int area = 0;        // foreground pixels
  int age = 0, lost = 0;
  cv::Point2f velocity;  // of the box centre, px per frame
  bool recognised = false;  // its id is an ended object's, recognised by its model
};

class MserSystem {
 public:
  explicit MserSystem(MserSystemParams params = {});
  // One frame (CV_8UC3). False with `error` on bad input.
  bool process(const cv::Mat& bgr, std::string* error = nullptr);
  void reset();

  const Segmentation& segmentation() const { return seg_out_; }
  const std::vector<int64_t>& region_tracks() const { return region_ids_; }
  const cv::Mat& foreground() const { return fg_; }  // CV_8U, 255 on foreground regions
  // Objects seen this frame (lost == 0) and confirmed.
  std::vector<ImageObject> objects() const;
  bool learning() const { return frame_ < p_.warmup_frames + p_.learn_frames; }
  int background_entries() const { return static_cast<int>(model_.size()); }
  // The model: each entry's centroid, width, height and mean colour.
  std::vector<std::tuple<cv::Point2f, float, float, cv::Vec3f>> background_model() const {
    std::vector<std::tuple<cv::Point2f, float, float, cv::Vec3f>> out;
    for (const auto& e : model_) out.push_back({e.centroid, e.width, e.height, e.colour});
    return out;
  }
  int moved_background() const { return moved_background_; }
  // Things that were there while the model was learned and are not the scene (found by whoever
  // knows its geometry, e.g. something standing on the floor in the map's free space): the
  // entries whose centroids lie in `mask` (CV_8U, the image's size, non-zero on their pixels)
  // leave the model and those pixels lose their model colour, so their regions are foreground
  // from the next frame on. What they uncover when they move off is background: a foreground
  // region mostly on those pixels that matches none of the released entries and has a colour the
  // model has beside it (the floor or wall that was behind) is taken into the model at once, as
  // is a region reaching over them with the model's colours under the rest of it. False after learning or with a mask of the
  // wrong size or type. Returns how many entries left.
  int release_from_background(const cv::Mat& mask);
  // Where small still things may lie (see min_still_area): CV_8U of the image's size, non-zero
  // there. Empty (the default): nowhere. False on a mask of the wrong type.
  bool set_small_things_mask(const cv::Mat& mask);
  const cv::Mat& released() const { return uncovered_; }
  // Regions matching no model entry but lying on the model's colours (a background region cut
  // by something in front): taken as background.
  int reshaped_background() const { return reshaped_background_; }
  int64_t frames() const { return frame_; }
  // The frame with the segmentation's mean colours, the lines (green), the foreground outlined
  // and the objects' boxes and ids.
  cv::Mat annotate(const cv::Mat& bgr) const;
  const MserSegmenter& segmenter() const { return seg_; }
  // Milliseconds of the last frame by stage: segmentation (with feed-forward), the four tracking
  // phases, the background model (learning and classifying), the objects.
  struct StageTimes {
    double segmentation = 0, tracking = 0, background = 0, objects = 0;
  };
  const StageTimes& stage_times() const { return times_; }
  // The models of ended objects, looked up when a new one appears.
  const ObjectModels& object_models() const { return models_; }

 private:
  StageTimes times_;
  struct Entry {
    cv::Point2f centroid;
    float width = 0, height = 0;
    cv::Vec3f colour;
    int count = 1;       // learning: frames it was seen in
    double moved = 0;    // learning: how far its matches' centroids were from it, summed
    cv::Point2f origin;  // where it entered the model
    bool gone = false;   // found moving: leaves the model at the end of the frame
  };
  struct TrackInfo {
    int seen = 0;
    double moved = 0;
    bool background = false;
    int still_foreground = 0;
    cv::Point2f last;
    std::array<cv::Point2f, 32> recent;  // centroids of the last frames seen (ring)
  };
  void learn();
  void classify();
  int best_entry(const std::vector<Entry>& model, const class KdTree2* tree, const Region& reg) const;
  // A colour the model has on unreleased pixels around the region's box.
  bool colour_beside(const Region& reg) const;
  // The model's colour for the region's mean on an unreleased pixel touching it.
  bool colour_touching(int r) const;
  void update_objects();
  // Per box, the foreground regions of its component, as the object model sees them.
  std::vector<std::vector<ModelRegion>> box_regions(const cv::Mat& components, const std::vector<int>& box_of_component) const;

  MserSystemParams p_;
  MserSegmenter seg_;
  RegionTracker tracker_;
  Segmentation seg_out_;
  std::vector<int64_t> region_ids_;
  std::vector<Entry> model_, candidates_;
  cv::Mat spill_;                // CV_8U: this frame's spilled foreground pixels (empty: none)
  std::vector<char> spilled_;    // per region of this frame: background that spilled over other colours
  std::vector<int> learned_as_;  // learning: the candidate each region of this frame refined or added
  cv::Mat learn_first_;          // learning: its first frame (unknown_moving)
  std::map<int64_t, TrackInfo> info_;
  cv::Mat fg_;
  cv::Mat frame_bgr_;  // this frame (a header on the caller's image, for classify)
  std::vector<ImageObject> objects_;
  int64_t next_object_ = 1;
  int64_t frame_ = 0;
  int moved_background_ = 0, reshaped_background_ = 0;
  cv::Mat model_image_;  // CV_32FC3: the learned regions' mean colours, per pixel
  cv::Mat uncovered_;    // CV_8U: released pixels not yet taken back into the model
  std::vector<Entry> released_;  // entries released, as learned
  ObjectModels models_;  // ended objects
  std::vector<int64_t> model_order_;  // their ids, oldest first
  struct ObjectView {
    std::vector<ModelRegion> regions;
    int area = 0;
  };
  std::map<int64_t, ObjectView> object_regions_;  // live objects: their fullest view's regions
  cv::Mat small_things_;  // CV_8U: where small still things may lie (set_small_things_mask)
  std::unordered_map<int64_t, int64_t> region_owner_;  // region track id -> the live object it was last part of
};

}  // namespace vigil::vision::mser
