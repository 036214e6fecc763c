// The vision sensor that wraps any vision::Tracker (vision/tracker.h) on a scenario camera's
// rendered frames. Two trackers are built in:
//   - `planview`: the stereo plan-view tracker of chapter section 10.4. Depth comes from SGBM (or
//     BM) on the rendered pair, as a real rig's would, or from the renderer's ground truth with
//     disparity: truth;
//   - `mser`: the colour MSER system of section 10.3 on the left image alone, placed on the
//     floor with the camera's pose (vision/mser/mser_tracker.h).
// Each has its own parameters; the sensor does the rest the same way for both: the depth a
// tracker needs (matched from the pair), the tick, the tracks.
#include <functional>
#include <memory>
#include <optional>

#include "plugins/vision_sensors/vision_sensor.h"
#include "vision/mser/mser_tracker.h"
#include "vision/planview_system.h"
#include "vision/stereo_matcher.h"
#include "vision/tracker.h"

namespace vigil::sensors {

namespace {

// What a built-in tracker needs to be made: its parameters and how to build it from them.
struct TrackerKind {
  bool needs_depth = false;  // the stereo matcher's parameters are offered, and depth is matched
  std::vector<ParamSpec> params;
  std::function<Result<std::unique_ptr<vision::Tracker>>(const ParamSet&, const SensorContext&)> make;
};

class TrackerSensor : public VisionSensor {
 public:
  explicit TrackerSensor(TrackerKind kind) : kind_(std::move(kind)) {}

  std::vector<ParamSpec> params() const override {
    std::vector<ParamSpec> out = kind_.params;
    if (kind_.needs_depth) {
      out.insert(out.begin(),
                 {{"disparity", ParamType::kString, std::string("sgbm"), 0, 0, "sgbm, bm or truth (the renderer's depth)"},
                  {"num_disparities", ParamType::kInteger, 64.0, 16, 256, "stereo search range (px), a multiple of 16"},
                  {"block_size", ParamType::kInteger, 5.0, 1, 51, "stereo block size (px, odd)"},
                  {"subpixel", ParamType::kString, std::string("cancel"), 0, 0,
                   "fit (the matcher's sub-pixel fit) or cancel (plus a half-pixel-shifted pass averaged in: less pixel "
                   "locking, twice the matching time)"}});
    }
    return out;
  }

  Status configure(const ParamSet& p, const SensorContext& ctx) override {
    auto tracker = kind_.make(p, ctx);
    if (!tracker) return bad_input("", 0, tracker.error().key, tracker.error().message);
    tracker_ = std::move(*tracker);
    map_given_ = false;  // the new tracker gets the building on its first tick
    if (tracker_->needs_depth() != kind_.needs_depth) return internal_error("tracker sensor: the kind's depth flag is wrong");
    if (kind_.needs_depth) {
      const std::string disparity = p.string("disparity");
      if (disparity != "truth") {
        auto algo = vision::parse_stereo_algorithm(disparity);
        if (!algo) return bad_input("", 0, "disparity", "expected sgbm, bm or truth, got '" + disparity + "'");
        vision::StereoMatcherParams mp =
            *algo == vision::StereoAlgorithm::kBM ? vision::StereoMatcherParams::bm() : vision::StereoMatcherParams{};
        mp.num_disparities = p.integer("num_disparities");
        mp.block_size = p.integer("block_size");
        const std::string subpixel = p.string("subpixel");
        if (subpixel != "fit" && subpixel != "cancel")
          return bad_input("", 0, "subpixel", "expected fit or cancel, got '" + subpixel + "'");
        mp.half_pixel_pass = subpixel == "cancel";
        if (Status s = mp.validate(); !s) return bad_input("", 0, s.error().key, s.error().message);
        auto m = vision::StereoMatcher::create(mp);
        if (!m) return bad_input("", 0, m.error().key, m.error().message);
        matcher_ = std::move(*m);
      }
    }
    model_ = ctx.model;
    return Status::Ok();
  }

  bool wants_frames() const override { return true; }
  bool sees_hands() const override { return tracker_ && tracker_->sees_hands(); }

  Status tick(const vision::StereoFrame* frame, const World& world, std::vector<vision::Track>* out) override {
    if (!frame) return internal_error(std::string(tracker_ ? tracker_->name() : "tracker") + ": a tick without a frame");
    if (!map_given_) {
      tracker_->set_static_map(world.map());  // the building, as the robots' map holds it
      map_given_ = true;
    }
    const vision::StereoFrame* in = frame;
    if (matcher_) {
      matched_ = *frame;
      const cv::Mat wanted = tracker_->depth_wanted(*frame);
      if (Status s = render::match_disparity(*matcher_, model_, &matched_, wanted); !s) return s;
      in = &matched_;
    }
    auto tracks = tracker_->process(*in);
    if (!tracks) return tracks.error();
    for (auto& t : *tracks) out->push_back(std::move(t));
    return Status::Ok();
  }

  cv::Mat annotate(const vision::StereoFrame& frame, const std::vector<vision::Track>& tracks) const override {
    return tracker_ ? tracker_->annotate(frame, tracks) : cv::Mat();
  }

 private:
  TrackerKind kind_;
  std::unique_ptr<vision::Tracker> tracker_;
  std::optional<vision::StereoMatcher> matcher_;
  vision::StereoCameraModel model_;
  vision::StereoFrame matched_;
  bool map_given_ = false;
};

TrackerKind planview_kind() {
  TrackerKind k;
  k.needs_depth = true;
  k.params = {
      {"gaussians", ParamType::kInteger, 4.0, 1, 8, "K, Gaussians per pixel"},
      {"learning_rate", ParamType::kNumber, 0.005, 1e-5, 1, "alpha of eqs. 10.2 and 10.3"},
      {"cell_size", ParamType::kNumber, 0.02, 0.005, 0.5, "plan-view cell (m)"},
      {"max_range", ParamType::kNumber, 8.0, 0.5, 100, "m from the camera covered by the plan view"},
      {"template_size", ParamType::kInteger, 40.0, 4, 400, "height and occupancy templates (cells)"},
      {"edge_radius", ParamType::kInteger, 3.0, 0, 50, "depth-edge filter window (px, 0 = off)"},
      {"edge_tolerance_px", ParamType::kNumber, 1.0, 0, 64, "depth-edge filter: disparity px behind the nearest depth"},
      {"track_threshold", ParamType::kNumber, 1.4, 0, 100, "update a track only when its score is below this"},
      {"stereo_where", ParamType::kString, std::string("foreground"), 0, 0,
       "foreground (match stereo only where the colour differs from the background, the whole image every "
       "full_stereo_every frames) or everywhere"},
      {"full_stereo_first", ParamType::kInteger, 10.0, 1, 100000,
       "with stereo_where: foreground, the first frames matched whole (the background's depth)"},
      {"full_stereo_every", ParamType::kInteger, 60.0, 0, 100000,
       "with stereo_where: foreground, one frame in this many matched whole after the first ones (0 = none)"},
      // The tracker's rules for things that stand still (docs/TRACKING.md), each to switch off.
      {"start_objects", ParamType::kBool, true, 0, 0,
       "what stands in the map's free space from the first frame is an object, not background"},
      {"split_still_frames", ParamType::kInteger, static_cast<double>(vision::PlanViewTrackerParams{}.split_still_frames), 0, 10000,
       "frames a still residual of someone's blob stays before it is born as a thing put down (0 = off)"},
      {"split_window", ParamType::kInteger, static_cast<double>(vision::PlanViewTrackerParams{}.split_window), 0, 10000,
       "frames: a track born this recently beside a missed one is not its occluder (0 = off)"},
      {"coast_min_sigmas", ParamType::kNumber, vision::PlanViewTrackerParams{}.coast_min_sigmas, 0, 100,
       "a coasting track whose speed was under this many standard deviations is held still (0 = off)"},
      {"hold_bag_on_blob", ParamType::kBool, vision::PlanViewTrackerParams{}.hold_bag_on_blob, 0, 0,
       "a bag missed while its place is still on a blob is held there as hidden"},
      {"reid", ParamType::kBool, vision::ReidParams{}.enabled, 0, 0,
       "a person who comes back (a new track) takes the id of one lost earlier dressed alike (vision/reid.h)"},
      {"reid_max_distance", ParamType::kNumber, vision::ReidParams{}.max_distance, 0, 1000,
       "colour distance (YUV) under which a new person is one lost earlier"},
  };
  k.make = [](const ParamSet& p, const SensorContext& ctx) -> Result<std::unique_ptr<vision::Tracker>> {
    vision::PlanViewSystemParams sp;
    sp.background.num_gaussians = p.integer("gaussians");
    sp.background.learning_rate = static_cast<float>(p.number("learning_rate"));
    sp.depth_filter.edge_radius = p.integer("edge_radius");
    sp.depth_filter.edge_tolerance_px = p.number("edge_tolerance_px");
    sp.plan.cell_size = p.number("cell_size");
    sp.plan.max_range = p.number("max_range");
    sp.tracking.camera = ctx.camera.id;
    sp.tracking.template_size = p.integer("template_size");
    sp.tracking.track_threshold = p.number("track_threshold");
    sp.start.enabled = p.boolean("start_objects");
    sp.tracking.split_still_frames = p.integer("split_still_frames");
    sp.tracking.split_window = p.integer("split_window");
    sp.tracking.coast_min_sigmas = p.number("coast_min_sigmas");
    sp.tracking.hold_bag_on_blob = p.boolean("hold_bag_on_blob");
    sp.reid.enabled = p.boolean("reid");
    sp.reid.max_distance = p.number("reid_max_distance");
    const std::string where = p.string("stereo_where");
    if (where != "foreground" && where != "everywhere")
      return bad_input("", 0, "stereo_where", "expected foreground or everywhere, got '" + where + "'");
    sp.depth_region.foreground_only = where == "foreground";
    sp.depth_region.full_first = p.integer("full_stereo_first");
    sp.depth_region.full_every = p.integer("full_stereo_every");
    auto sys = vision::PlanViewSystem::create(ctx.model, sp);
    if (!sys) return sys.error();
    return std::unique_ptr<vision::Tracker>(std::make_unique<vision::PlanViewSystem>(std::move(*sys)));
  };
  return k;
}

TrackerKind mser_kind() {
  TrackerKind k;
  const vision::mser::MserTrackerParams d;
  k.params = {
      {"learn_frames", ParamType::kInteger, static_cast<double>(d.system.learn_frames), 1, 1000,
       "frames that build the region background model (after the warm-up)"},
      {"warmup_frames", ParamType::kInteger, static_cast<double>(d.system.warmup_frames), 0, 1000,
       "frames for the feed-forward segmentation to settle before learning"},
      {"confirm_frames", ParamType::kInteger, static_cast<double>(d.system.confirm_frames), 1, 100,
       "an object is reported once seen this many frames running"},
      {"min_object_area", ParamType::kNumber, d.system.min_object_area, 0, 1, "smallest object, a fraction of the image"},
      {"max_range", ParamType::kNumber, d.max_range, 0.5, 100, "m from the camera to an object's foot point"},
      {"lines", ParamType::kBool, true, 0, 0, "region growth may not cross Canny line segments"},
      {"start_objects", ParamType::kBool, true, 0, 0,
       "what stands on the floor in the map's free space while the background is learned is an object, not "
       "background"},
      {"reid", ParamType::kBool, d.reid.enabled, 0, 0,
       "a person who comes back (a new track) takes the id of one lost earlier dressed alike (vision/reid.h)"},
      {"reid_max_distance", ParamType::kNumber, d.reid.max_distance, 0, 1000,
       "colour distance (YUV) under which a new person is one lost earlier"},
  };
  k.make = [](const ParamSet& p, const SensorContext& ctx) -> Result<std::unique_ptr<vision::Tracker>> {
    vision::mser::MserTrackerParams tp;
    tp.camera = ctx.camera.id;
    tp.system.learn_frames = p.integer("learn_frames");
    tp.system.warmup_frames = p.integer("warmup_frames");
    tp.system.confirm_frames = p.integer("confirm_frames");
    tp.system.min_object_area = p.number("min_object_area");
    tp.system.segmenter.use_lines = p.boolean("lines");
    tp.max_range = p.number("max_range");
    tp.floor_start_objects = p.boolean("start_objects");
    tp.reid.enabled = p.boolean("reid");
    tp.reid.max_distance = p.number("reid_max_distance");
    for (const FloorplanFurniture& f : ctx.furniture)
      tp.surfaces.push_back({f.pose.x, f.pose.y, f.pose.yaw, f.size_x, f.size_y, f.height});
    auto t = vision::mser::MserTracker::create(ctx.model, tp);
    if (!t) return t.error();
    return std::unique_ptr<vision::Tracker>(std::make_unique<vision::mser::MserTracker>(std::move(*t)));
  };
  return k;
}

}  // namespace

std::unique_ptr<VisionSensor> make_planview_sensor() { return std::make_unique<TrackerSensor>(planview_kind()); }
std::unique_ptr<VisionSensor> make_mser_sensor() { return std::make_unique<TrackerSensor>(mser_kind()); }

}  // namespace vigil::sensors
