// Patrolling strategies behind one interface (after the patrolling_sim framework of Portugal and
// Iocchi). Every robot runs its own copy; what they share is what they know: the times vertices
// were last visited and where each robot is heading, passed between robots by the transport.
//   cyclic     one shortest closed walk through every vertex; the team spread evenly along it,
//              all going the same way round
//   partition  the graph cut into connected regions, balanced so that the longest region walk
//              per robot is least (partition.h): as many regions as robots where the graph has
//              room (each robot alone on its region's walk, meeting no mate), else some regions
//              patrolled by two or more robots spread along their walk as in cyclic
//   greedy     (DTA-Greedy) go next to the vertex of highest utility: its estimated idleness
//              less theta times the planned travel time to it, leaving out the vertices other
//              robots are heading for
// When the team changes (a robot leaves to respond to an incident, or comes back) every member
// recomputes its share from the same member list, so the shares stay consistent.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/status.h"
#include "planning/patrol/partition.h"
#include "planning/patrol/patrol_graph.h"
#include "planning/patrol/tour.h"

namespace vigil::planning::patrol {

// What a team patrols, shared by all its members.
struct PatrolSetup {
  PatrolGraph graph;
  GraphDistances distances;  // along the graph's edges
  CostMatrix travel;         // path lengths between vertices (m): the planner's on the map
  ClosedWalk tour;           // the shortest closed walk through every vertex
  double speed = 1.0;        // the robots' cruise speed (m/s), to turn lengths into times

  // Builds the tour; `travel` empty means the graph's own costs.
  static std::shared_ptr<const PatrolSetup> make(PatrolGraph g, CostMatrix travel, double speed);
  // The regions of a team of `count` (plan_regions, partition.h) with walks at least
  // `min_walk` long where the graph allows, computed once per count and shared by every member
  // (thread-safe).
  // `pad_short`: shorter regions are padded with detours (PartitionOptions::pad_short).
  std::shared_ptr<const GraphPartition> partition(int count, double min_walk = 0, double shared_cost = 0.1,
                                                  bool pad_short = false) const;

  struct PartitionCache;
  std::shared_ptr<PartitionCache> partitions;
};

// What one robot knows of the team's patrol.
struct PatrolKnowledge {
  double now = 0;                       // s
  std::vector<double> last_visit;       // per vertex, the latest visit known (s; the start counts as one)
  struct Intention {
    int vertex = -1;
    double eta = 0;                     // the time it expects to arrive (s)
    int64_t walk_index = -1;            // cyclic: its place on the shared walk (-1: none)
  };
  std::map<std::string, Intention> others;  // other members' current targets
  // Per vertex: I visited it and have not yet gone far enough from it for my next visit to
  // count (visits re-arm beyond 1.5 visit radii). Empty: unknown (every vertex counts).
  std::vector<char> inside;
  // Merges a visit heard from anyone.
  void visited(int vertex, double t) {
    if (vertex >= 0 && static_cast<size_t>(vertex) < last_visit.size() && t > last_visit[vertex]) last_visit[vertex] = t;
  }
};

class PatrolStrategy {
 public:
  virtual ~PatrolStrategy() = default;
  virtual const char* name() const = 0;
  // The patrolling members (sorted names) and where each is; `me` indexes both.
  virtual void set_team(const std::vector<std::string>& members, const std::vector<Vec2>& where, int me) = 0;
  // The vertex to head for next, from `p`, having just reached `at` (-1: none yet, at the start
  // or after a change of team).
  virtual int next(int at, Vec2 p, const PatrolKnowledge& k) = 0;
  // How long to wait at the vertex just reached before leaving for the next (s; 0: go on).
  // Asked every step while waiting. The cyclic strategy holds a robot that has caught up with
  // the one ahead until it is half-way between its neighbours on the walk again.
  virtual double hold(const PatrolKnowledge&) const { return 0; }
  // Where this robot is on the shared walk (cyclic: the walk index it heads for; -1: none).
  virtual int64_t walk_index() const { return -1; }
  // Cyclic: how far along the shared walk this robot is (m, in [0, length)), `remaining` metres
  // short of the walk vertex it heads for; -1 for the other strategies (no shared walk).
  virtual double phase(double /*remaining*/) const { return -1; }
  // Cyclic: the share of cruise speed (in [min_pace, 1]) that keeps the team evenly spaced
  // along the walk, from my phase and the mates' (phases < 0 are left out). A robot nearer the
  // mate ahead than the mate behind slows by the difference: a robot held up somewhere makes
  // the one behind it slow down and the one ahead of it wait, instead of the gap behind it
  // growing until a hold at a vertex catches it. 1 when spacing is even or alone.
  // `mates`: each mate's name and phase.
  virtual double pace(double /*mine*/, const std::vector<std::pair<std::string, double>>& /*mates*/) const { return 1; }
  // True when my walk is too short for visits to count on their own (a partition region under
  // min_region_walk, with region_detours): the controller drives a detour off the graph on
  // every leg too short to leave the last vertex behind.
  virtual bool short_walk() const { return false; }
};

// The pace law (cyclic): `ahead` and `behind` the arc gaps to the nearest mates either side,
// `spacing` the even gap, `band` the difference tolerated (share of the spacing):
// 1 - gain (behind - ahead - band spacing) / (2 spacing), within [min_pace, 1].
double spacing_pace(double ahead, double behind, double spacing, double gain, double min_pace, double band = 0);

struct StrategyParams {
  double theta = 4.0;      // greedy: seconds of idleness one second of travel is worth (docs/PERFORMANCE.md: 1 to 8 studied on three graphs)
  double pace_gain = 2.0;  // cyclic: how hard the pace reacts to uneven spacing (0: never slows)
  double min_pace = 0.3;   // cyclic: the slowest share of cruise speed the pace asks for
  double pace_band = 0.1;  // cyclic: uneven spacing (behind - ahead) tolerated, as a share of the even spacing
  double min_region_walk = 0;  // partition: regions' walks at least this long (m) where the graph allows
  double region_share_cost = 0.1;  // partition: a shared region's walk counts this much more per extra robot
  bool region_detours = false;  // partition: regions under min_region_walk are driven with detours (short_walk())
};

const std::vector<std::string>& strategy_names();
// Errors name the key "strategy" and list the names.
Result<std::unique_ptr<PatrolStrategy>> make_strategy(const std::string& name, std::shared_ptr<const PatrolSetup> setup,
                                                       const StrategyParams& params = {});

}  // namespace vigil::planning::patrol
