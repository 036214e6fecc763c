// `planview`: the stereo plan-view tracker of chapter section 10.4 on a scenario camera's
// rendered frames. Depth comes from SGBM (or BM) on the rendered pair, as a real rig's would,
// or from the renderer's ground truth with disparity: truth.
#include <memory>
#include <optional>

#include "plugins/vision_sensors/vision_sensor.h"
#include "vision/planview_system.h"
#include "vision/stereo_matcher.h"

namespace vigil::sensors {

namespace {

class PlanViewSensor : public VisionSensor {
 public:
  std::vector<ParamSpec> params() const override {
    return {
        {"disparity", ParamType::kString, std::string("sgbm"), 0, 0, "sgbm, bm or truth (the renderer's depth)"},
        {"num_disparities", ParamType::kInteger, 64.0, 16, 256, "stereo search range (px), a multiple of 16"},
        {"block_size", ParamType::kInteger, 5.0, 1, 51, "stereo block size (px, odd)"},
        {"subpixel", ParamType::kString, std::string("cancel"), 0, 0,
         "fit (the matcher's sub-pixel fit) or cancel (plus a half-pixel-shifted pass averaged in: less pixel "
         "locking, twice the matching time)"},
        {"gaussians", ParamType::kInteger, 4.0, 1, 8, "K, Gaussians per pixel"},
        {"learning_rate", ParamType::kNumber, 0.005, 1e-5, 1, "alpha of eqs. 10.2 and 10.3"},
        {"cell_size", ParamType::kNumber, 0.02, 0.005, 0.5, "plan-view cell (m)"},
        {"max_range", ParamType::kNumber, 8.0, 0.5, 100, "m from the camera covered by the plan view"},
        {"template_size", ParamType::kInteger, 40.0, 4, 400, "height and occupancy templates (cells)"},
        {"edge_radius", ParamType::kInteger, 3.0, 0, 50, "depth-edge filter window (px, 0 = off)"},
        {"edge_tolerance_px", ParamType::kNumber, 1.0, 0, 64, "depth-edge filter: disparity px behind the nearest depth"},
        {"track_threshold", ParamType::kNumber, 1.4, 0, 100, "update a track only when its score is below this"},
    };
  }

  Status configure(const ParamSet& p, const SensorContext& ctx) override {
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
    model_ = ctx.model;
    auto sys = vision::PlanViewSystem::create(ctx.model, sp);
    if (!sys) return bad_input("", 0, sys.error().key, sys.error().message);
    system_.emplace(std::move(*sys));
    return Status::Ok();
  }

  bool wants_frames() const override { return true; }

  Status tick(const vision::StereoFrame* frame, const World&, std::vector<vision::Track>* out) override {
    if (!frame) return internal_error("planview: a tick without a frame");
    const vision::StereoFrame* in = frame;
    if (matcher_) {
      matched_ = *frame;
      if (Status s = render::match_disparity(*matcher_, model_, &matched_); !s) return s;
      in = &matched_;
    }
    auto tracks = system_->process(*in);
    if (!tracks) return tracks.error();
    for (auto& t : *tracks) out->push_back(std::move(t));
    return Status::Ok();
  }

 private:
  std::optional<vision::StereoMatcher> matcher_;
  std::optional<vision::PlanViewSystem> system_;
  vision::StereoCameraModel model_;
  vision::StereoFrame matched_;
};

}  // namespace

std::unique_ptr<VisionSensor> make_planview_sensor() { return std::make_unique<PlanViewSensor>(); }

}  // namespace vigil::sensors
