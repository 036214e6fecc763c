// vigil bench render: stereo pairs per second of the OSMesa renderer (colour, depth, disparity
// and labels read back) for a scenario camera, beside a plain scene of about 50 lit primitives
// (the scene of the peer figure in MISSION.md) rendered in the same run.
// vigil bench stereo: our StereoMatcher (SGBM, BM; float disparity out) beside OpenCV's own
// StereoSGBM / StereoBM calls on the same pair, one thread.
// vigil bench planview: the plan-view pipeline per frame (foreground, plan view, tracking; the
// disparity given) beside OpenCV's BackgroundSubtractorMOG2::apply on the same rendered frames.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "plugins/builtin.h"
#include "plugins/stereo_camera/osmesa_renderer.h"
#include "plugins/stereo_camera/render_scene.h"
#include "plugins/stereo_camera/stereo_camera.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/plugin_search.h"
#include "vision/planview_system.h"
#include "vision/stereo_matcher.h"
#include <opencv2/video/background_segm.hpp>
#include "world/world.h"

namespace vigil::cli {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A plain room of about 50 lit primitives: floor, back wall, and 48 boxes, cylinders and spheres
// on a grid in front of a level camera, four lights.
render::RenderScene plain_scene() {
  render::RenderScene s;
  auto add = [&](render::Shape shape, Eigen::Vector3d at, Eigen::Vector3d size, Eigen::Vector3f colour,
                 render::Texture tex) {
    render::Primitive p;
    p.shape = shape;
    p.pose = Eigen::Isometry3d(Eigen::Translation3d(at));
    p.size = size;
    p.colour = colour;
    p.texture = tex;
    p.label = static_cast<int32_t>(s.primitives.size());
    s.primitives.push_back(p);
  };
  add(render::Shape::kBox, {8, 0, -0.05}, {20, 20, 0.1}, {0.7f, 0.7f, 0.7f}, render::Texture::kTiles);
  add(render::Shape::kBox, {14, 0, 1.5}, {0.1, 20, 3}, {0.8f, 0.75f, 0.7f}, render::Texture::kPlaster);
  for (int i = 0; i < 48; ++i) {
    const double x = 3.0 + (i / 8) * 1.6, y = -3.5 + (i % 8) * 1.0;
    const Eigen::Vector3f c(0.3f + 0.1f * (i % 5), 0.4f + 0.08f * (i % 4), 0.5f + 0.05f * (i % 7));
    const auto shape = static_cast<render::Shape>(i % 3);
    add(shape, {x, y, 0.4}, {0.5, 0.5, 0.8}, c, render::Texture::kPaint);
  }
  for (int i = 0; i < 4; ++i) {
    render::Light l;
    l.position = Eigen::Vector3d(3.0 + 3.0 * i, 0, 2.8);
    s.lights.push_back(l);
  }
  return s;
}

struct Size {
  int w, h;
};

}  // namespace

void add_bench_camera_commands(CLI::App* bench) {
  struct RenderOpts {
    std::string scenario, camera = "cam_corridor", json;
    double at = 20;
    int pairs = 200;
    std::vector<std::string> sizes{"640x480", "320x240"};
  };
  auto ro = std::make_shared<RenderOpts>();
  ro->scenario = (std::filesystem::path(VIGIL_SOURCE_DIR) / "scenarios" / "dis_crowd.yaml").string();
  auto* render_cmd = bench->add_subcommand("render", "Stereo pairs/s of the OSMesa renderer beside a plain 50-primitive scene");
  render_cmd->add_option("--scenario", ro->scenario, "scenario (default scenarios/dis_crowd.yaml: DIS corridor, 10 people)");
  render_cmd->add_option("--camera", ro->camera, "camera id (default cam_corridor)");
  render_cmd->add_option("--at", ro->at, "simulated time of the rendered instant, s (default 20)")->check(CLI::NonNegativeNumber);
  render_cmd->add_option("--pairs", ro->pairs, "stereo pairs timed per size (default 200)")->check(CLI::PositiveNumber);
  render_cmd->add_option("--sizes", ro->sizes, "image sizes WxH (default 640x480,320x240)")->delimiter(',');
  render_cmd->add_option("--json", ro->json, "also write the results as JSON to this file");
  render_cmd->callback([ro] {
    std::vector<Size> sizes;
    for (const auto& s : ro->sizes) {
      Size z{};
      if (std::sscanf(s.c_str(), "%dx%d", &z.w, &z.h) != 2 || z.w <= 0 || z.h <= 0)
        throw Exit{report(bad_input("", 0, "--sizes", "expected WxH, got '" + s + "'"))};
      sizes.push_back(z);
    }
    auto scenario = load_scenario(ro->scenario);
    if (!scenario) throw Exit{report(scenario.error())};
    auto found = find_camera(*scenario, ro->camera, "--camera");
    if (!found) throw Exit{report(found.error())};
    const CameraSpec* cam = *found;
    WorldOptions wo;
    wo.plugins = builtin_plugin_registry();
    wo.plugin_dirs = plugin_search_path();
    auto world = World::create(*scenario, wo);
    if (!world) throw Exit{report(world.error())};
    const SimTime until = from_seconds(std::min(ro->at, scenario->duration));
    while ((*world)->time() < until) {
      if (Status s = (*world)->advance(); !s) throw Exit{report(s.error())};
    }
    const render::RenderScene plain = plain_scene();
    const char* lp_threads = std::getenv("LP_NUM_THREADS");
    std::printf("vigil bench render: %s, camera %s at t = %.1f s (%zu people in the world), %d pairs per size, "
                "llvmpipe threads %s\n",
                scenario->name.c_str(), cam->id.c_str(), to_seconds((*world)->time()), (*world)->people().size(),
                ro->pairs, lp_threads ? lp_threads : "default (one per core)");
    std::printf("%10s %28s %12s %12s %28s %12s\n", "size", "scene", "primitives", "pairs/s", "peer scene (same run)",
                "pairs/s");
    nlohmann::ordered_json results = nlohmann::ordered_json::array();
    std::string gl;
    for (const Size& z : sizes) {
      auto ours = render::bench_render(**world, *cam, z.w, z.h, ro->pairs);
      if (!ours) throw Exit{report(ours.error())};
      gl = ours->gl_renderer;
      // The plain scene, same renderer code path, same size, level camera at 1.5 m.
      vision::CameraPose pose;
      pose.position = Eigen::Vector3d(0, 0, 1.5);
      pose.pitch = 0.1;
      const vision::StereoCameraModel model(vision::Intrinsics::from_hfov(z.w, z.h, 60 * M_PI / 180), 0.09, pose);
      auto renderer = render::OsmesaRenderer::create(z.w, z.h);
      if (!renderer) throw Exit{report(renderer.error())};
      vision::StereoFrame frame;
      if (Status s = (*renderer)->render(plain, model, &frame); !s) throw Exit{report(s.error())};
      const auto t0 = Clock::now();
      for (int i = 0; i < ro->pairs; ++i) {
        if (Status s = (*renderer)->render(plain, model, &frame); !s) throw Exit{report(s.error())};
      }
      const double peer = ro->pairs / seconds_since(t0);
      char size[32];
      std::snprintf(size, sizeof size, "%dx%d", z.w, z.h);
      std::printf("%10s %28s %12zu %12.1f %28s %12.1f\n", size, (scenario->name + " " + cam->id).c_str(), ours->primitives,
                  ours->pairs_per_second, "plain, 50 primitives", peer);
      std::fflush(stdout);
      results.push_back({{"width", z.w}, {"height", z.h}, {"scenario", scenario->name}, {"camera", cam->id},
                         {"primitives", ours->primitives}, {"pairs_per_second", ours->pairs_per_second},
                         {"plain_scene_primitives", plain.primitives.size()}, {"plain_scene_pairs_per_second", peer}});
    }
    std::printf("renderer: %s; MISSION.md's peer figure: 70 to 106 pairs/s at 640x480 for ~50 lit primitives\n", gl.c_str());
    if (!ro->json.empty()) {
      std::ofstream f(ro->json);
      f << results.dump(2) << "\n";
    }
  });

  struct StereoOpts {
    std::string left, right, json;
    int repeats = 20, num_disparities = 64;
  };
  auto so = std::make_shared<StereoOpts>();
  auto* stereo_cmd = bench->add_subcommand("stereo", "StereoMatcher (SGBM, BM) beside OpenCV's own calls, one thread");
  stereo_cmd->add_option("--left", so->left, "left image (default ../shared/data/real/aloeL.jpg)");
  stereo_cmd->add_option("--right", so->right, "right image (default ../shared/data/real/aloeR.jpg)");
  stereo_cmd->add_option("--repeats", so->repeats, "timed runs per matcher (default 20)")->check(CLI::PositiveNumber);
  stereo_cmd->add_option("--num-disparities", so->num_disparities, "disparity range (default 64)");
  stereo_cmd->add_option("--json", so->json, "also write the results as JSON to this file");
  stereo_cmd->callback([so] {
    const std::filesystem::path real = std::filesystem::path(VIGIL_SOURCE_DIR) / ".." / "shared" / "data" / "real";
    const std::string lp = so->left.empty() ? (real / "aloeL.jpg").string() : so->left;
    const std::string rp = so->right.empty() ? (real / "aloeR.jpg").string() : so->right;
    cv::Mat l = cv::imread(lp), r = cv::imread(rp);
    if (l.empty()) throw Exit{report(bad_input(lp, 0, "--left", "cannot read the image"))};
    if (r.empty()) throw Exit{report(bad_input(rp, 0, "--right", "cannot read the image"))};
    if (l.size() != r.size()) throw Exit{report(bad_input(rp, 0, "--right", "not the left image's size"))};
    // Half size, as the peer figure (about 640x555 for aloe).
    if (l.cols > 1000) {
      cv::resize(l, l, {}, 0.5, 0.5, cv::INTER_AREA);
      cv::resize(r, r, {}, 0.5, 0.5, cv::INTER_AREA);
    }
    const int threads = cv::getNumThreads();
    cv::setNumThreads(1);
    std::printf("vigil bench stereo: %s (%dx%d), %d disparities, %d runs each, one thread\n",
                std::filesystem::path(lp).filename().c_str(), l.cols, l.rows, so->num_disparities, so->repeats);
    std::printf("%6s %24s %24s %20s\n", "", "vigil StereoMatcher ms", "OpenCV direct ms", "MISSION.md peer ms");
    nlohmann::ordered_json results = nlohmann::ordered_json::array();
    // The third row is SGBM with the half-pixel pass (subpixel: cancel, the planview sensor's
    // default) beside OpenCV's single SGBM call.
    for (const int row : {0, 1, 2}) {
      const auto algo = row == 1 ? vision::StereoAlgorithm::kBM : vision::StereoAlgorithm::kSGBM;
      vision::StereoMatcherParams p =
          algo == vision::StereoAlgorithm::kBM ? vision::StereoMatcherParams::bm() : vision::StereoMatcherParams{};
      p.num_disparities = so->num_disparities;
      p.half_pixel_pass = row == 2;
      auto m = vision::StereoMatcher::create(p);
      if (!m) throw Exit{report(m.error())};
      // OpenCV direct, with the same parameters, 16-bit fixed-point output.
      cv::Ptr<cv::StereoMatcher> cvm;
      cv::Mat gl, gr;
      if (algo == vision::StereoAlgorithm::kBM) {
        auto bm = cv::StereoBM::create(p.num_disparities, p.block_size);
        bm->setPreFilterCap(p.pre_filter_cap);
        bm->setUniquenessRatio(p.uniqueness_ratio);
        bm->setSpeckleWindowSize(p.speckle_window_size);
        bm->setSpeckleRange(p.speckle_range);
        bm->setDisp12MaxDiff(p.disp12_max_diff);
        bm->setTextureThreshold(p.texture_threshold);
        cvm = bm;
        cv::cvtColor(l, gl, cv::COLOR_BGR2GRAY);
        cv::cvtColor(r, gr, cv::COLOR_BGR2GRAY);
      } else {
        const int ch = l.channels();
        cvm = cv::StereoSGBM::create(p.min_disparity, p.num_disparities, p.block_size, 8 * ch * p.block_size * p.block_size,
                                     32 * ch * p.block_size * p.block_size, p.disp12_max_diff, p.pre_filter_cap,
                                     p.uniqueness_ratio, p.speckle_window_size, p.speckle_range);
        gl = l;
        gr = r;
      }
      cv::Mat d16;
      cvm->compute(gl, gr, d16);
      if (!m->compute(l, r).ok()) throw Exit{report(internal_error("StereoMatcher failed on the benchmark pair"))};
      std::vector<double> ours, direct;
      for (int i = 0; i < so->repeats; ++i) {
        auto t0 = Clock::now();
        auto d = m->compute(l, r);
        ours.push_back(1e3 * seconds_since(t0));
        t0 = Clock::now();
        cvm->compute(gl, gr, d16);
        direct.push_back(1e3 * seconds_since(t0));
      }
      std::sort(ours.begin(), ours.end());
      std::sort(direct.begin(), direct.end());
      const double mo = ours[ours.size() / 2], md = direct[direct.size() / 2];
      const char* name = row == 1 ? "BM" : row == 2 ? "SGBM+h" : "SGBM";
      std::printf("%6s %24.2f %24.2f %20s\n", name, mo, md, algo == vision::StereoAlgorithm::kBM ? "13" : "52");
      results.push_back({{"matcher", name}, {"width", l.cols}, {"height", l.rows}, {"vigil_median_ms", mo},
                         {"opencv_direct_median_ms", md}});
    }
    cv::setNumThreads(threads);
    if (!so->json.empty()) {
      std::ofstream f(so->json);
      f << results.dump(2) << "\n";
    }
  });

  struct PipelineOpts {
    std::string scenario, camera = "cam_corridor", json;
    double from = 10;
    int frames = 150;
    std::vector<std::string> sizes{"640x480", "320x240"};
  };
  auto po = std::make_shared<PipelineOpts>();
  po->scenario = (std::filesystem::path(VIGIL_SOURCE_DIR) / "scenarios" / "dis_bag_taken.yaml").string();
  auto* pv_cmd = bench->add_subcommand(
      "planview", "Plan-view pipeline (foreground, plan view, tracking; disparity given) beside MOG2 on the same frames");
  pv_cmd->add_option("--scenario", po->scenario, "scenario (default scenarios/dis_bag_taken.yaml)");
  pv_cmd->add_option("--camera", po->camera, "camera id (default cam_corridor)");
  pv_cmd->add_option("--from", po->from, "first frame's simulated time, s (default 10)")->check(CLI::NonNegativeNumber);
  pv_cmd->add_option("--frames", po->frames, "frames per size (default 150)")->check(CLI::PositiveNumber);
  pv_cmd->add_option("--sizes", po->sizes, "image sizes WxH (default 640x480,320x240)")->delimiter(',');
  pv_cmd->add_option("--json", po->json, "also write the results as JSON to this file");
  pv_cmd->callback([po] {
    auto scenario = load_scenario(po->scenario);
    if (!scenario) throw Exit{report(scenario.error())};
    nlohmann::ordered_json results = nlohmann::ordered_json::array();
    std::printf("vigil bench planview: %s, camera %s, %d frames from t = %.1f s, SGBM disparity computed first (not "
                "timed), one thread\n",
                scenario->name.c_str(), po->camera.c_str(), po->frames, po->from);
    std::printf("%10s %14s %14s %14s %14s %12s %12s %12s\n", "size", "foreground ms", "plan view ms", "tracking ms",
                "pipeline ms", "MOG2 ms", "vs MOG2", "pipeline fps");
    const int threads = cv::getNumThreads();
    for (const auto& size : po->sizes) {
      Size z{};
      if (std::sscanf(size.c_str(), "%dx%d", &z.w, &z.h) != 2 || z.w <= 0 || z.h <= 0)
        throw Exit{report(bad_input("", 0, "--sizes", "expected WxH, got '" + size + "'"))};
      Scenario sc = *scenario;
      bool found = false;
      for (auto& c : sc.cameras) {
        if (c.id != po->camera) continue;
        found = true;
        const double hfov = c.hfov.value_or(c.fx ? 2 * std::atan(0.5 * c.width / *c.fx) : 60 * M_PI / 180);
        c.hfov = hfov;
        c.fx.reset();
        c.fy.reset();
        c.cx.reset();
        c.cy.reset();
        c.width = z.w;
        c.height = z.h;
      }
      if (!found) throw Exit{report(bad_input(po->scenario, 0, "--camera", "no camera '" + po->camera + "' in the scenario"))};
      render::RenderedSourceOptions ro;
      ro.world.plugin_dirs = plugin_search_path();
      vision::StereoMatcherParams mp;
      mp.num_disparities = z.w >= 640 ? 64 : 32;
      auto matcher = vision::StereoMatcher::create(mp);
      if (!matcher) throw Exit{report(matcher.error())};
      auto src = render::RenderedStereoSource::open(sc, po->camera, ro);
      if (!src) throw Exit{report(src.error())};
      // Render and match the frames first (only from --from on, keeping only what the pipeline
      // reads): the pipeline is timed given the disparity.
      std::vector<vision::StereoFrame> frames;
      vision::StereoFrame f;
      while (static_cast<int>(frames.size()) < po->frames) {
        auto more = (*src)->next(&f);
        if (!more) throw Exit{report(more.error())};
        if (!*more) break;
        if (to_seconds(f.stamp_ns) + 1e-9 < po->from) continue;
        if (Status s = render::match_disparity(*matcher, *(*src)->camera_model(), &f); !s) throw Exit{report(s.error())};
        vision::StereoFrame kept;
        kept.index = f.index;
        kept.stamp_ns = f.stamp_ns;
        kept.left = f.left.clone();
        kept.depth = f.depth;
        frames.push_back(std::move(kept));
        f = vision::StereoFrame();
      }
      if (frames.empty()) throw Exit{report(bad_input(po->scenario, 0, "--from", "no frames after that time"))};
      cv::setNumThreads(1);
      vision::PlanViewSystemParams sp;
      sp.tracking.camera = po->camera;
      auto background = vision::YuvdBackground::create(sp.background);
      auto pipeline = vision::PlanViewPipeline::create(*(*src)->camera_model(), sp.plan, sp.tracking);
      if (!background) throw Exit{report(background.error())};
      if (!pipeline) throw Exit{report(pipeline.error())};
      auto mog2 = cv::createBackgroundSubtractorMOG2();
      double t_fg = 0, t_pv = 0, t_tr = 0, t_mog = 0;
      cv::Mat mask, mog_mask;
      vision::PlanView view;
      auto tracker = vision::PlanViewTracker::create(pipeline->builder().grid(), sp.tracking);
      if (!tracker) throw Exit{report(tracker.error())};
      size_t n_tracks = 0;
      for (const auto& fr : frames) {
        auto t0 = Clock::now();
        if (Status s = background->apply(fr.left, fr.depth, mask); !s) throw Exit{report(s.error())};
        t_fg += seconds_since(t0);
        t0 = Clock::now();
        if (Status s = pipeline->builder().build(mask, fr.depth, &view); !s) throw Exit{report(s.error())};
        t_pv += seconds_since(t0);
        t0 = Clock::now();
        auto tracks = tracker->update(view, fr.stamp_ns);
        t_tr += seconds_since(t0);
        if (!tracks) throw Exit{report(tracks.error())};
        n_tracks += tracks->size();
        t0 = Clock::now();
        mog2->apply(fr.left, mog_mask);
        t_mog += seconds_since(t0);
      }
      cv::setNumThreads(threads);
      const double n = static_cast<double>(frames.size());
      const double fg = 1e3 * t_fg / n, pv = 1e3 * t_pv / n, tr = 1e3 * t_tr / n, mog = 1e3 * t_mog / n;
      const double all = fg + pv + tr;
      std::printf("%10s %14.2f %14.2f %14.2f %14.2f %12.2f %11.2fx %12.0f\n", size.c_str(), fg, pv, tr, all, mog,
                  all / mog, 1e3 / all);
      std::fflush(stdout);
      results.push_back({{"width", z.w}, {"height", z.h}, {"frames", frames.size()}, {"track_records", n_tracks},
                         {"foreground_ms", fg}, {"plan_view_ms", pv}, {"tracking_ms", tr}, {"pipeline_ms", all},
                         {"mog2_ms", mog}, {"pipeline_over_mog2", all / mog}});
    }
    std::printf("targets: pipeline at most 2x MOG2 at the same size, at least 30 fps at 640x480\n");
    if (!po->json.empty()) {
      std::ofstream f(po->json);
      f << results.dump(2) << "\n";
    }
  });
}

}  // namespace vigil::cli
