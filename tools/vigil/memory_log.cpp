#include "tools/vigil/memory_log.h"

#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace vigil::cli {

double resident_mb() {
  std::ifstream f("/proc/self/statm");
  long pages_total = 0, pages_resident = 0;
  if (!(f >> pages_total >> pages_resident)) return 0;
  return static_cast<double>(pages_resident) * static_cast<double>(::sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

double heap_in_use_mb() {
  const struct mallinfo2 mi = ::mallinfo2();
  return static_cast<double>(mi.uordblks + mi.hblkhd) / (1024.0 * 1024.0);
}

Result<MemoryLog> MemoryLog::open(const std::filesystem::path& csv, double period_s) {
  MemoryLog m;
  m.csv_ = csv;
  m.period_s_ = period_s;
  if (csv.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(csv.parent_path(), ec);
  }
  m.f_ = std::fopen(csv.c_str(), "w");
  if (!m.f_) return bad_input(csv.string(), 0, "--memory-log", "cannot open for writing");
  std::fprintf(m.f_, "sim_s,wall_s,rss_mb,heap_mb\n");
  m.t0_ = std::chrono::steady_clock::now();
  return m;
}

MemoryLog::MemoryLog(MemoryLog&& o) noexcept
    : csv_(std::move(o.csv_)), f_(o.f_), period_s_(o.period_s_), next_(o.next_), t0_(o.t0_), samples_(std::move(o.samples_)) {
  o.f_ = nullptr;
}

MemoryLog::~MemoryLog() {
  if (f_) std::fclose(f_);
}

void MemoryLog::maybe_sample(double sim_s) {
  if (!f_ || sim_s < next_) return;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  const Sample s{sim_s, wall, resident_mb(), heap_in_use_mb()};
  samples_.push_back(s);
  std::fprintf(f_, "%.1f,%.2f,%.2f,%.2f\n", s.sim_s, s.wall_s, s.rss_mb, s.heap_mb);
  std::fflush(f_);
  while (next_ <= sim_s) next_ += period_s_;
}

std::string MemoryLog::finish(double sim_s, double warmup_share) {
  if (!f_) return "";
  next_ = sim_s;
  maybe_sample(sim_s);
  std::fclose(f_);
  f_ = nullptr;
  if (samples_.size() < 2) return "memory: too few samples";
  // Figures after the warm-up.
  const double warm_end = warmup_share * samples_.back().sim_s;
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, level = 0, peak = 0, first_after = -1, hy = 0, hxy = 0;
  for (const auto& s : samples_) {
    peak = std::max(peak, s.rss_mb);
    if (s.sim_s < warm_end) continue;
    if (first_after < 0) first_after = s.rss_mb;
    const double h = s.sim_s / 3600.0;
    n += 1, sx += h, sy += s.rss_mb, sxx += h * h, sxy += h * s.rss_mb, hy += s.heap_mb, hxy += h * s.heap_mb;
    level = std::max(level, s.rss_mb);
  }
  const double den = n * sxx - sx * sx;
  const double slope = n > 1 && den > 0 ? (n * sxy - sx * sy) / den : 0.0;
  const double heap_slope = n > 1 && den > 0 ? (n * hxy - sx * hy) / den : 0.0;
  const double rise = first_after >= 0 ? level - first_after : 0.0;
  // The picture: RSS (MB) over simulated minutes, the warm-up shaded.
  const int W = 960, H = 420, L = 70, R = 20, T = 40, B = 50;
  cv::Mat img(H, W, CV_8UC3, cv::Scalar(255, 255, 255));
  const double tmax = std::max(1.0, samples_.back().sim_s / 60.0), ymax = std::max(1.0, peak * 1.15);
  auto X = [&](double min) { return L + static_cast<int>(std::lround((W - L - R) * min / tmax)); };
  auto Y = [&](double mb) { return H - B - static_cast<int>(std::lround((H - T - B) * mb / ymax)); };
  cv::rectangle(img, {X(0), T}, {X(warm_end / 60.0), H - B}, cv::Scalar(235, 235, 235), cv::FILLED);
  double ystep = std::pow(10.0, std::floor(std::log10(ymax)) - 1);  // 1, 2 or 5 x 10^k, at most 8 lines
  for (double m : {2.0, 2.5, 2.0})
    if (ymax / ystep > 8) ystep *= m;
  for (double y = 0; y <= ymax; y += ystep) {
    cv::line(img, {L, Y(y)}, {W - R, Y(y)}, cv::Scalar(220, 220, 220));
    cv::putText(img, std::to_string(static_cast<int>(y)), {8, Y(y) + 5}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(60, 60, 60));
  }
  const double tstep = tmax > 30 ? 10 : tmax > 6 ? 1 : 0.5;
  for (double t = 0; t <= tmax; t += tstep) {
    cv::line(img, {X(t), H - B}, {X(t), H - B + 5}, cv::Scalar(60, 60, 60));
    char buf[16];
    std::snprintf(buf, sizeof buf, tstep < 1 ? "%.1f" : "%.0f", t);
    cv::putText(img, buf, {X(t) - 8, H - B + 20}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(60, 60, 60));
  }
  std::vector<cv::Point> pts, heap;
  for (const auto& s : samples_) {
    pts.push_back({X(s.sim_s / 60.0), Y(s.rss_mb)});
    heap.push_back({X(s.sim_s / 60.0), Y(s.heap_mb)});
  }
  cv::polylines(img, pts, false, cv::Scalar(180, 80, 20), 2, cv::LINE_AA);
  cv::polylines(img, heap, false, cv::Scalar(40, 140, 230), 2, cv::LINE_AA);
  cv::putText(img, "resident", {W - R - 170, T + 18}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(180, 80, 20), 1, cv::LINE_AA);
  cv::putText(img, "heap in use (malloc)", {W - R - 170, T + 36}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(40, 140, 230), 1,
              cv::LINE_AA);
  cv::rectangle(img, {L, T}, {W - R, H - B}, cv::Scalar(60, 60, 60));
  char title[200];
  std::snprintf(title, sizeof title, "MB over simulated minutes; after warm-up: resident %+.2f MB/h (peak %.0f), heap %+.2f MB/h",
                slope, peak, heap_slope);
  cv::putText(img, title, {L, 25}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(20, 20, 20), 1, cv::LINE_AA);
  std::filesystem::path png = csv_;
  png.replace_extension(".png");
  cv::imwrite(png.string(), img);
  nlohmann::ordered_json j = {{"samples", samples_.size()},     {"sim_seconds", samples_.back().sim_s},
                              {"wall_seconds", samples_.back().wall_s}, {"warmup_end_s", warm_end},
                              {"rss_after_warmup_mb", first_after}, {"rss_end_mb", samples_.back().rss_mb},
                              {"rss_peak_mb", peak},              {"slope_mb_per_hour", slope},
                              {"heap_end_mb", samples_.back().heap_mb}, {"heap_slope_mb_per_hour", heap_slope},
                              {"rise_after_warmup_mb", rise}};
  std::filesystem::path js = csv_;
  js.replace_extension(".json");
  std::ofstream(js) << j.dump(2) << "\n";
  char line[300];
  std::snprintf(line, sizeof line,
                "memory: %zu samples; resident after warm-up (%.0f s) %.1f MB, at the end %.1f MB, peak %.1f MB, slope "
                "%+.2f MB/h; heap in use at the end %.1f MB, slope %+.2f MB/h (%s, %s)",
                samples_.size(), warm_end, first_after, samples_.back().rss_mb, peak, slope, samples_.back().heap_mb,
                heap_slope, png.c_str(), js.c_str());
  return line;
}

}  // namespace vigil::cli
