#include "plugins/dds_bridge/event_relay.h"

#include <unistd.h>

#include <atomic>
#include <chrono>

#include "plugins/stereo_camera/stereo_camera.h"
#include "world/world.h"

namespace vigil::dds {

std::vector<ServerCamera> server_cameras(const Scenario& scenario) {
  std::vector<ServerCamera> out;
  for (const CameraSpec& c : scenario.cameras) out.push_back({c.id, render::camera_model(c)});
  return out;
}

std::function<bool(double, double)> inside_map(const OccupancyGrid& map) {
  return [&map](double x, double y) {
    int cx = 0, cy = 0;
    return map.world_to_cell({x, y}, &cx, &cy) && map.at(cx, cy) != Cell::kUnknown;
  };
}

Result<std::unique_ptr<DdsEventRelay>> DdsEventRelay::create(const RelayOptions& options) {
  static std::atomic<int> counter{0};
  std::unique_ptr<DdsEventRelay> r(new DdsEventRelay());
  r->options_ = options;
  if (r->options_.domain.session.empty() || r->options_.domain.session == "vigil")
    r->options_.domain.session = "run-" + std::to_string(getpid()) + "-" + std::to_string(counter++);
  if (!(options.delivery_timeout_s > 0)) return bad_input("", 0, "delivery_timeout_s", "must be > 0");
  return r;
}

DdsEventRelay::~DdsEventRelay() {
  if (out_) std::fclose(out_);
}

Status DdsEventRelay::start(const World& world, const std::filesystem::path& out_dir) {
  auto cam = Participant::create(options_.domain);
  if (!cam) return cam.error();
  camera_side_ = std::move(*cam);
  auto srv = Participant::create(options_.domain);
  if (!srv) return srv.error();
  server_side_ = std::move(*srv);
  auto pub = CameraEventPublisher::create(*camera_side_);
  if (!pub) return pub.error();
  publisher_ = std::move(*pub);
  auto server = EventServer::create(
      *server_side_, IncidentMerger(server_cameras(world.scenario()), options_.merge, inside_map(world.map())));
  if (!server) return server.error();
  server_ = std::move(*server);
  if (publisher_->writer().wait_for_readers(1, options_.delivery_timeout_s) < 1)
    return internal_error("DDS: the in-process video server did not match the camera-event writer within " +
                          std::to_string(options_.delivery_timeout_s) + " s (check the Cyclone DDS configuration)");
  published_.clear();
  rejected_.clear();
  sent_ = handled_ = 0;
  if (!out_dir.empty()) {
    out_path_ = (out_dir / "events.jsonl").string();
    out_ = std::fopen(out_path_.c_str(), "wb");
    if (!out_) return bad_input(out_path_, 0, "", "cannot create file");
  }
  return Status::Ok();
}

Status DdsEventRelay::publish(const vision::Event& e) {
  if (!publisher_) return internal_error("DdsEventRelay: publish before start");
  if (Status s = publisher_->publish(e); !s) return s;
  ++sent_;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(options_.delivery_timeout_s);
  while (handled_ < sent_) {
    if (std::chrono::steady_clock::now() >= end)
      return internal_error("DDS: the video server received " + std::to_string(handled_) + " of " +
                            std::to_string(sent_) + " camera events within " +
                            std::to_string(options_.delivery_timeout_s) + " s");
    EventServer::Log log;
    if (Status s = server_->poll(0.05, &log); !s) return s;
    handled_ += log.received;
    rejected_.insert(rejected_.end(), log.rejected.begin(), log.rejected.end());
    // Fused updates reach the robots too (published_, which the run's robot side counts), but
    // events.jsonl keeps one line per incident and per withdrawal.
    for (const Incident& in : log.updated) published_.push_back(in);
    updates_ += log.updated.size();
    for (const Incident& in : log.published) {
      published_.push_back(in);
      if (out_) {
        const std::string line = vision::format_event_json(in.as_event()) + "\n";
        if (std::fwrite(line.data(), 1, line.size(), out_) != line.size()) return internal_error("cannot write " + out_path_);
      }
    }
  }
  return Status::Ok();
}

Status DdsEventRelay::finish(const World&) {
  server_.reset();
  publisher_.reset();
  server_side_.reset();
  camera_side_.reset();
  if (out_) {
    const bool ok = std::fclose(out_) == 0;
    out_ = nullptr;
    if (!ok) return internal_error("cannot write " + out_path_);
  }
  return Status::Ok();
}

}  // namespace vigil::dds
