// Events inside `vigil run`, through real DDS: the run's camera rules publish on one
// participant, the video server runs on another in the same process (merging, map frame,
// checks), and the incidents it publishes are written to DIR/events.jsonl. Publishing waits
// until the server has handled the report, so the file is the same for every run of a seed.
#pragma once

#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/status.h"
#include "plugins/dds_bridge/dds.h"
#include "plugins/dds_bridge/event_server.h"
#include "world/map.h"
#include "world/runner.h"
#include "world/scenario.h"

namespace vigil::dds {

// The scenario's cameras as the server knows them (id and pose).
std::vector<ServerCamera> server_cameras(const Scenario& scenario);
// Inside the map's grid and not in unknown space.
std::function<bool(double, double)> inside_map(const OccupancyGrid& map);

struct RelayOptions {
  DomainOptions domain;            // session: default "run-<pid>-<n>", unique to the relay
  MergeParams merge;
  double delivery_timeout_s = 10;  // a report the server has not received by then is an error
};

class DdsEventRelay : public RunObserver {
 public:
  static Result<std::unique_ptr<DdsEventRelay>> create(const RelayOptions& options);
  ~DdsEventRelay() override;

  // The host's event sink: publishes a camera event and waits for the server to handle it.
  Status publish(const vision::Event& e);

  Status start(const World& world, const std::filesystem::path& out_dir) override;
  Status after_step(const World&) override { return Status::Ok(); }
  Status finish(const World& world) override;

  // Every incident published, in order: new ones, withdrawals and fused updates (same id).
  const std::vector<Incident>& incidents() const { return published_; }
  size_t updates() const { return updates_; }
  // The DDS domain and session the server publishes incidents on (topic vigil_events).
  const DomainOptions& domain() const { return options_.domain; }
  const std::vector<std::string>& rejected() const { return rejected_; }

 private:
  DdsEventRelay() = default;
  RelayOptions options_;
  std::unique_ptr<Participant> camera_side_, server_side_;
  std::unique_ptr<CameraEventPublisher> publisher_;
  std::unique_ptr<EventServer> server_;
  std::vector<Incident> published_;
  std::vector<std::string> rejected_;
  int sent_ = 0, handled_ = 0;
  size_t updates_ = 0;
  std::FILE* out_ = nullptr;
  std::string out_path_;
};

}  // namespace vigil::dds
