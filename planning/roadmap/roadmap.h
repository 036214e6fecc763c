// The topological level of the two-level planner (chapter 10.6.2, after Calisi et al. 2005):
// a probabilistic roadmap over the map's free space inflated by the robot's radius, grown by
// OMPL's PRM (k nearest neighbours) from a sampler seeded by our seed, so the same map, radius,
// parameters and seed give the same roadmap. Where PRM's samples leave two parts of one
// connected free region unconnected (a narrow door), a bridge of grid-path vertices joins them,
// so a query between connected points always has a route. Queries connect the start and goal
// to the nearest visible milestones and search the graph with A*.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <vector>

#include "common/geometry.h"
#include "common/status.h"
#include "planning/grid/inflated_grid.h"

namespace vigil::planning {

struct RoadmapParams {
  double density = 1.5;       // milestones per m^2 of free space [0.05, 50]
  int min_nodes = 200;        // [2, 1e6]
  int max_nodes = 20000;      // [2, 1e6]
  int neighbours = 10;        // PRM's k nearest [1, 100]
  int connect_candidates = 24;  // milestones tried when connecting a query point [1, 1000]
  uint64_t seed = 1;
  // Checks values and ranges; the key named in the error is "roadmap.<name>".
  Status check(const std::string& file = {}, int line = 0) const;
};

class Roadmap {
 public:
  struct Stats {
    size_t nodes = 0, edges = 0;
    size_t prm_nodes = 0;   // milestones grown by OMPL's PRM
    size_t bridges = 0;     // grid bridges added between PRM components
    size_t components = 0;  // graph components after bridging
    double build_seconds = 0;
    bool from_cache = false;
  };

  // Grows the roadmap on `grid` (which must outlive it).
  static Result<Roadmap> build(const InflatedGrid& grid, const RoadmapParams& params);
  // Loads `file` if it was saved for this grid (fingerprint), radius and parameters; otherwise
  // builds and saves it there. A cache that cannot be written is not an error (stats say so).
  static Result<Roadmap> build_cached(const InflatedGrid& grid, const RoadmapParams& params,
                                      const std::filesystem::path& file);
  Status save(const std::filesystem::path& file) const;

  // A route of milestones from start to goal (both included), or nothing when the graph does
  // not connect them (or neither sees a milestone).
  std::optional<std::vector<Vec2>> route(Vec2 start, Vec2 goal) const;

  const std::vector<Vec2>& nodes() const { return nodes_; }
  const std::vector<std::pair<int, int>>& edges() const { return edges_; }
  const Stats& stats() const { return stats_; }

 private:
  void finish();  // adjacency, components
  std::vector<int> visible_nodes(Vec2 p) const;
  const InflatedGrid* grid_ = nullptr;
  RoadmapParams params_;
  std::vector<Vec2> nodes_;
  std::vector<std::pair<int, int>> edges_;
  std::vector<std::vector<std::pair<int, double>>> adjacency_;
  std::vector<int> component_;
  Stats stats_;
};

}  // namespace vigil::planning
