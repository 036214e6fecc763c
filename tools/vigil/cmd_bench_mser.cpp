// vigil bench mser: the colour MSER segmenter (vision/mser: lines, MSER tree, region expansion)
// per frame, one thread, beside OpenCV's colour cv::MSER (MSCR) and grey cv::MSER on the same
// frames in the same run: rendered lab frames and the real vtest.avi, at each size.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <opencv2/ximgproc.hpp>
#include <opencv2/ximgproc/segmentation.hpp>

#include "plugins/stereo_camera/stereo_camera.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/plugin_search.h"
#include "vision/mser/mser_system.h"
#include "vision/mser/segmenter.h"

namespace vigil::cli {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return 1e3 * std::chrono::duration<double>(Clock::now() - t0).count(); }

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Boundary pixels of a label image (4-neighbour label change; the pixel on the right / below).
cv::Mat boundaries(const cv::Mat& labels) {
  cv::Mat b = cv::Mat::zeros(labels.size(), CV_8U);
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x) {
      const int32_t l = labels.at<int32_t>(y, x);
      if ((x + 1 < labels.cols && labels.at<int32_t>(y, x + 1) != l) || (y + 1 < labels.rows && labels.at<int32_t>(y + 1, x) != l))
        b.at<uint8_t>(y, x) = 255;
    }
  return b;
}

struct Quality {
  double precision = 0, recall = 0, f = 0, under_seg = 0, regions = 0;
};

// Boundary precision and recall within `tol` px of the ground truth's boundaries, their
// F-measure, and the under-segmentation error (Neubert and Protzel's corrected form: for every
// true segment and every segment overlapping it, the smaller of the overlap and the segment's
// part outside, summed, over the image).
Quality score(const cv::Mat& seg, const cv::Mat& truth, int tol = 2) {
  Quality q;
  const cv::Mat bs = boundaries(seg), bt = boundaries(truth);
  cv::Mat ks = cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * tol + 1, 2 * tol + 1});
  cv::Mat ds, dt;
  cv::dilate(bs, ds, ks);
  cv::dilate(bt, dt, ks);
  const double ns = cv::countNonZero(bs), nt = cv::countNonZero(bt);
  q.precision = ns > 0 ? cv::countNonZero(bs & dt) / ns : 0;
  q.recall = nt > 0 ? cv::countNonZero(bt & ds) / nt : 0;
  q.f = q.precision + q.recall > 0 ? 2 * q.precision * q.recall / (q.precision + q.recall) : 0;
  std::map<std::pair<int, int>, int> overlap;
  std::map<int, int> seg_size;
  for (int y = 0; y < seg.rows; ++y)
    for (int x = 0; x < seg.cols; ++x) {
      const int s = seg.at<int32_t>(y, x), t = truth.at<int32_t>(y, x);
      ++overlap[{t, s}];
      ++seg_size[s];
    }
  double ue = 0;
  // Each overlap counts the smaller of its part inside and its segment's part outside the true
  // segment (the corrected form, which does not charge a segment's whole size for a pixel of
  // overlap).
  for (const auto& [ts, n] : overlap) ue += std::min(n, seg_size[ts.second] - n);
  q.under_seg = ue / static_cast<double>(seg.total());
  q.regions = static_cast<double>(seg_size.size());
  return q;
}

}  // namespace

void add_bench_mser_command(CLI::App* bench) {
  struct Opts {
    std::string scenario, camera = "cam_lab", video, json;
    int frames = 30;
    double from = 5;
    std::vector<std::string> sizes{"320x240", "640x480"};
  };
  auto o = std::make_shared<Opts>();
  o->scenario = (std::filesystem::path(VIGIL_SOURCE_DIR) / "scenarios" / "dis_lab_unauthorised.yaml").string();
  o->video = (std::filesystem::path(VIGIL_SOURCE_DIR) / ".." / "shared" / "data" / "real" / "vtest.avi").string();
  auto* cmd = bench->add_subcommand("mser", "Colour MSER segmentation per frame beside OpenCV's colour and grey cv::MSER");
  cmd->add_option("--scenario", o->scenario, "rendered frames from this scenario (default scenarios/dis_lab_unauthorised.yaml)");
  cmd->add_option("--camera", o->camera, "its camera (default cam_lab)");
  cmd->add_option("--from", o->from, "first rendered frame's time, s (default 5)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--video", o->video, "real video (default ../shared/data/real/vtest.avi; skipped when absent)");
  cmd->add_option("--frames", o->frames, "frames per source (default 30)")->check(CLI::PositiveNumber);
  cmd->add_option("--sizes", o->sizes, "image sizes WxH (default 320x240,640x480)")->delimiter(',');
  cmd->add_option("--json", o->json, "also write the results as JSON to this file");
  cmd->callback([o] {
    // The frames, at 640x480 (rendered) or as recorded, resized per size below.
    std::vector<std::pair<std::string, std::vector<cv::Mat>>> sources;
    std::vector<cv::Mat> truth_labels;  // the rendered frames' entity labels
    {
      auto scenario = load_scenario(o->scenario);
      if (!scenario) throw Exit{report(scenario.error())};
      render::RenderedSourceOptions ro;
      ro.world.plugin_dirs = plugin_search_path();
      auto src = render::RenderedStereoSource::open(*scenario, o->camera, ro);
      if (!src) throw Exit{report(src.error())};
      std::vector<cv::Mat> frames;
      vision::StereoFrame f;
      while (static_cast<int>(frames.size()) < o->frames) {
        auto more = (*src)->next(&f);
        if (!more) throw Exit{report(more.error())};
        if (!*more) break;
        if (to_seconds(f.stamp_ns) + 1e-9 < o->from) continue;
        frames.push_back(f.left.clone());
        truth_labels.push_back(f.labels.clone());
      }
      if (frames.empty()) throw Exit{report(bad_input(o->scenario, 0, "--from", "no frames after that time"))};
      sources.push_back({scenario->name + " " + o->camera, std::move(frames)});
    }
    if (std::filesystem::exists(o->video)) {
      cv::VideoCapture cap(o->video);
      if (!cap.isOpened()) throw Exit{report(bad_input(o->video, 0, "--video", "cannot open the video"))};
      std::vector<cv::Mat> frames;
      cv::Mat f;
      while (static_cast<int>(frames.size()) < o->frames && cap.read(f)) frames.push_back(f.clone());
      if (frames.empty()) throw Exit{report(bad_input(o->video, 0, "--video", "no frames"))};
      sources.push_back({std::filesystem::path(o->video).filename().string(), std::move(frames)});
    } else {
      std::printf("(%s absent: the real-video rows are skipped)\n", o->video.c_str());
    }
    const int threads = cv::getNumThreads();
    cv::setNumThreads(1);
    std::printf("vigil bench mser: %d frames per source, one thread; ours = lines + MSER tree + region expansion "
                "(the whole system adds feed-forward and the four tracking phases; the pipeline adds the background model and "
                "objects)\n",
                o->frames);
    std::printf("%-28s %9s %10s %8s %12s %8s %11s %8s %9s %9s\n", "source", "size", "ours ms", "fps", "colour MSER",
                "regions", "grey MSER", "regions", "vs colour", "regions");
    nlohmann::ordered_json results = nlohmann::ordered_json::array();
    for (const auto& [name, frames] : sources) {
      for (const auto& size : o->sizes) {
        int w = 0, h = 0;
        if (std::sscanf(size.c_str(), "%dx%d", &w, &h) != 2 || w < 3 || h < 3)
          throw Exit{report(bad_input("", 0, "--sizes", "expected WxH, got '" + size + "'"))};
        std::vector<cv::Mat> sized;
        for (const auto& f : frames) {
          cv::Mat s;
          cv::resize(f, s, cv::Size(w, h), 0, 0, w < f.cols ? cv::INTER_AREA : cv::INTER_LINEAR);
          sized.push_back(s);
        }
        vision::mser::MserSegmenter seg;
        vision::mser::Segmentation out;
        auto colour = cv::MSER::create();
        auto grey = cv::MSER::create();
        std::vector<double> t_ours, t_col, t_grey;
        double ph_tex = 0, ph_lines = 0, ph_tree = 0, ph_exp = 0;
        double n_ours = 0, n_col = 0, n_grey = 0;
        std::vector<std::vector<cv::Point>> regions;
        std::vector<cv::Rect> boxes;
        seg.segment(sized[0], &out);  // warm-up (buffers, tables)
        for (const auto& f : sized) {
          auto t0 = Clock::now();
          std::string why;
          if (!seg.segment(f, &out, &why)) throw Exit{report(internal_error("MSER segmenter: " + why))};
          t_ours.push_back(ms_since(t0));
          n_ours += out.regions.size();
          ph_tex += seg.phase_times().texture;
          ph_lines += seg.phase_times().lines;
          ph_tree += seg.phase_times().tree;
          ph_exp += seg.phase_times().expansion;
          t0 = Clock::now();
          colour->detectRegions(f, regions, boxes);
          t_col.push_back(ms_since(t0));
          n_col += regions.size();
          cv::Mat g;
          cv::cvtColor(f, g, cv::COLOR_BGR2GRAY);
          t0 = Clock::now();
          grey->detectRegions(g, regions, boxes);
          t_grey.push_back(ms_since(t0));
          n_grey += regions.size();
        }
        // Feed-forward on the same consecutive frames, and on a still scene (the first frame
        // again and again).
        vision::mser::SegmenterParams ffp;
        ffp.feed_forward = true;
        vision::mser::MserSegmenter ff(ffp), still(ffp);
        std::vector<double> t_ff, t_still;
        double seeded = 0, seeded_still = 0;
        double ff_tex = 0, ff_lines = 0, ff_tree = 0, ff_exp = 0, ff_seeds = 0;
        for (const auto& f : sized) {
          auto t0 = Clock::now();
          ff.segment(f, &out);
          t_ff.push_back(ms_since(t0));
          seeded += ff.seeded_pixels();
          ff_tex += ff.phase_times().texture, ff_lines += ff.phase_times().lines, ff_tree += ff.phase_times().tree,
              ff_exp += ff.phase_times().expansion, ff_seeds += ff.phase_times().seeds;
          t0 = Clock::now();
          still.segment(sized[0], &out);
          t_still.push_back(ms_since(t0));
          seeded_still += still.seeded_pixels();
        }
        // The whole system on the sequence: segmentation with feed-forward, the four tracking
        // phases, the background model and the objects (MserSystem::process). Its first 20
        // frames learn the background; the sequence is played forwards then backwards until
        // at least 40 frames after learning are timed.
        // Colour cv::MSER runs on each timed frame right after the system, so the two medians of
        // this ratio share the machine's load of the moment (a shared machine's speed drifts by
        // 10 to 50 % over a run).
        vision::mser::MserSystem system;
        std::vector<double> t_sys, t_core, t_col_sys;
        double st_seg = 0, st_track = 0, st_bg = 0, st_obj = 0;
        std::string why;
        for (int i = 0, n = static_cast<int>(sized.size()); static_cast<int>(t_sys.size()) < 40 && n > 1; ++i) {
          const int period = 2 * (n - 1), q = i % period, j = q < n ? q : period - q;
          auto t0 = Clock::now();
          if (!system.process(sized[j], &why)) break;
          if (system.learning()) continue;
          t_sys.push_back(ms_since(t0));
          const auto& st = system.stage_times();
          t_core.push_back(st.segmentation + st.tracking);
          st_seg += st.segmentation, st_track += st.tracking, st_bg += st.background, st_obj += st.objects;
          t0 = Clock::now();
          colour->detectRegions(sized[j], regions, boxes);
          t_col_sys.push_back(ms_since(t0));
        }
        const double msys = t_sys.empty() ? 0.0 : median(t_sys);
        const double mcore = t_core.empty() ? 0.0 : median(t_core);
        const double mcs = t_col_sys.empty() ? 0.0 : median(t_col_sys);
        const double mf = median(t_ff), ms = median(t_still);
        const double mo = median(t_ours), mc = median(t_col), mg = median(t_grey);
        const double k = 1.0 / static_cast<double>(sized.size());
        std::printf("%-28s %9s %10.2f %8.1f %12.2f %8.0f %11.2f %8.0f %8.1fx %9.0f\n", name.c_str(), size.c_str(), mo,
                    mo > 0 ? 1e3 / mo : 0.0, mc, n_col * k, mg, n_grey * k, mo > 0 ? mc / mo : 0.0, n_ours * k);
        std::printf("%-28s %9s   phases (mean ms): texture %.2f, lines %.2f, MSER tree %.2f, expansion %.2f\n", "",
                    "", ph_tex * k, ph_lines * k, ph_tree * k, ph_exp * k);
        const double px = static_cast<double>(w) * h;
        std::printf("%-28s %9s   feed-forward: %.2f ms on the sequence (%.0f%% of pixels seeded), %.2f ms on a still "
                    "scene (%.0f%% seeded; %.2fx of from scratch)\n",
                    "", "", mf, 100 * seeded * k / px, ms, 100 * seeded_still * k / px, mo > 0 ? ms / mo : 0.0);
        std::printf("%-28s %9s     its phases (mean ms): texture %.2f, lines %.2f, seeds %.2f, MSER tree %.2f, expansion %.2f\n",
                    "", "", ff_tex * k, ff_lines * k, ff_seeds * k, ff_tree * k, ff_exp * k);
        // Issue 12's whole system is the segmentation (lines, tree, expansion, feed-forward) and
        // the four tracking phases; the pipeline adds the background model and the objects.
        // Colour cv::MSER's medians from the two loops differ by up to a third when the machine's
        // load changes: the ratio is also given against the faster of the two.
        const double mc_low = std::min(mc, mcs);
        std::printf("%-28s %9s   whole system (lines, tree, expansion, feed-forward, 4 tracking phases): %.2f ms, %.1f "
                    "fps; colour MSER on the same frames, same loop: %.2f ms; %.2fx faster (%.2fx against colour MSER's "
                    "faster median, %.2f ms)\n",
                    "", "", mcore, mcore > 0 ? 1e3 / mcore : 0.0, mcs, mcore > 0 ? mcs / mcore : 0.0,
                    mcore > 0 ? mc_low / mcore : 0.0, mc_low);
        std::printf("%-28s %9s   with the background model and objects (the whole pipeline): %.2f ms, %.1f fps; %.2fx "
                    "faster\n",
                    "", "", msys, msys > 0 ? 1e3 / msys : 0.0, msys > 0 ? mcs / msys : 0.0);
        const double ks = t_sys.empty() ? 0.0 : 1.0 / static_cast<double>(t_sys.size());
        std::printf("%-28s %9s     stages (mean ms): segmentation %.2f, tracking %.2f, background %.2f, objects %.2f\n", "",
                    "", st_seg * ks, st_track * ks, st_bg * ks, st_obj * ks);
        results.push_back({{"source", name},
                           {"phase_ms", {{"texture", ph_tex * k}, {"lines", ph_lines * k}, {"tree", ph_tree * k}, {"expansion", ph_exp * k}}},
                           {"width", w},
                           {"height", h},
                           {"frames", sized.size()},
                           {"ours_median_ms", mo},
                           {"ours_regions", n_ours * k},
                           {"colour_mser_median_ms", mc},
                           {"colour_mser_regions", n_col * k},
                           {"grey_mser_median_ms", mg},
                           {"grey_mser_regions", n_grey * k},
                           {"speedup_over_colour", mo > 0 ? mc / mo : 0.0},
                           {"feed_forward_median_ms", mf},
                           {"feed_forward_seeded_share", seeded * k / px},
                           {"still_feed_forward_median_ms", ms},
                           {"still_seeded_share", seeded_still * k / px},
                           {"system_median_ms", mcore},
                           {"system_speedup_over_colour", mcore > 0 ? mcs / mcore : 0.0},
                           {"system_speedup_over_colour_faster_median", mcore > 0 ? std::min(mc, mcs) / mcore : 0.0},
                           {"pipeline_median_ms", msys},
                           {"pipeline_speedup_over_colour", msys > 0 ? mcs / msys : 0.0},
                           {"system_colour_mser_median_ms", mcs}});
      }
    }
    // Segmentation quality on the rendered frames (640x480) against the renderer's labels (each
    // person, robot and object its own segment; everything static one), beside OpenCV contrib's
    // graph segmentation (Felzenszwalb and Huttenlocher) and SLIC with about as many regions.
    nlohmann::ordered_json quality = nlohmann::ordered_json::array();
    {
      const auto& frames = sources[0].second;
      vision::mser::MserSegmenter seg;
      vision::mser::Segmentation out;
      Quality ours, graph, slic;
      auto gs = cv::ximgproc::segmentation::createGraphSegmentation(0.8, 300, 100);
      for (size_t i = 0; i < frames.size(); ++i) {
        seg.segment(frames[i], &out);
        const Quality a = score(out.labels, truth_labels[i]);
        cv::Mat g;
        gs->processImage(frames[i], g);
        const Quality b = score(g, truth_labels[i]);
        const int size = std::max(8, static_cast<int>(std::sqrt(frames[i].total() / std::max(1.0, a.regions))));
        cv::Mat lab;
        cv::cvtColor(frames[i], lab, cv::COLOR_BGR2Lab);
        auto sp = cv::ximgproc::createSuperpixelSLIC(lab, cv::ximgproc::SLIC, size, 10.0f);
        sp->iterate(10);
        sp->enforceLabelConnectivity(25);
        cv::Mat sl;
        sp->getLabels(sl);
        const Quality c = score(sl, truth_labels[i]);
        for (auto [acc, q] : {std::pair<Quality*, Quality>{&ours, a}, {&graph, b}, {&slic, c}}) {
          acc->precision += q.precision / frames.size();
          acc->recall += q.recall / frames.size();
          acc->f += q.f / frames.size();
          acc->under_seg += q.under_seg / frames.size();
          acc->regions += q.regions / frames.size();
        }
      }
      std::printf("\nsegmentation quality on %zu rendered frames of %s (640x480; boundaries within 2 px of the label "
                  "image's):\n%-26s %9s %10s %8s %10s %10s\n",
                  frames.size(), sources[0].first.c_str(), "", "regions", "precision", "recall", "F", "under-seg");
      for (auto [name, q] : {std::pair<const char*, Quality>{"colour MSER (ours)", ours}, {"graph (Felzenszwalb)", graph},
                             {"SLIC", slic}}) {
        std::printf("%-26s %9.0f %10.3f %8.3f %10.3f %10.3f\n", name, q.regions, q.precision, q.recall, q.f, q.under_seg);
        quality.push_back({{"method", name}, {"regions", q.regions}, {"boundary_precision", q.precision},
                           {"boundary_recall", q.recall}, {"boundary_f", q.f}, {"under_segmentation", q.under_seg}});
      }
    }
    cv::setNumThreads(threads);
    std::printf("targets (issue 12): the whole system (lines, tree, expansion, feed-forward, four-phase tracking) >= 3x "
                "faster than colour cv::MSER at both sizes and >= 60 fps at 320x240\n");
    if (!o->json.empty()) {
      std::ofstream f(o->json);
      nlohmann::ordered_json all = {{"speed", results}, {"quality", quality}};
      f << all.dump(2) << "\n";
    }
  });
}

}  // namespace vigil::cli
