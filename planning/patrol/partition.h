// Balanced partition of a patrol graph into connected regions, one per robot (the idea of
// Portugal and Rocha's multilevel subgraph patrolling, MSP, 2010: each robot patrols the
// closed walk of its own connected subgraph, so robots never meet on the way). What counts is
// the longest region walk: a region's worst idleness is about its walk over the speed, so the
// team's worst is set by the longest. On a tree (the DIAG graphs are nearly trees) the edges
// between regions are never driven, so the longest region walk can be well under the whole
// walk over the team size, which is what the cyclic strategy can at best reach.
//
// The search: seeds spread by farthest-point sampling (from several first seeds), every vertex
// to its nearest seed along the graph (regions that are connected), then a local search that
// moves one boundary vertex at a time to a neighbouring region while the regions stay
// connected and no smaller than `min_size` (and `min_walk`), accepting a move when it lowers the longest walk
// (then the sum of squared walks). Deterministic: the same graph and count give the same
// regions, so every robot computes the same partition on its own.
#pragma once

#include <vector>

#include "planning/patrol/patrol_graph.h"
#include "planning/patrol/tour.h"

namespace vigil::planning::patrol {

struct PartitionOptions {
  int restarts = 8;   // first seeds tried (spread over the vertex list)
  int min_size = 0;   // vertices per region at least (0: 2 when the graph has 2 per region, else 1)
  int max_moves = 2000;  // local-search moves per restart at most
  // A region's walk at least this long (m) where the graph allows: a robot shuttling between
  // two vertices closer than about three visit radii never leaves one far enough for the
  // next visit of it to count.
  double min_walk = 0;
  // plan_regions: regions shorter than min_walk are driven with detours off the graph that make
  // them about min_walk long (the team controller's), so they count as min_walk long rather
  // than too short. Lets a team larger than the graph's room for regions of min_walk take
  // short regions of its own instead of sharing longer ones.
  bool pad_short = false;
  // plan_regions: what several robots on one walk lose to meeting each other, as a share of
  // their walk per extra robot.
  double shared_cost = 0.1;
};

struct GraphPartition {
  std::vector<int> region;         // per vertex, its region (0..count-1)
  std::vector<ClosedWalk> walks;   // per region, the closed walk through its vertices (graph edges)
  std::vector<int> robots;         // per region, the robots that patrol it (plan_regions; else 1 each)
  double longest = 0;              // the longest region walk (m)
  int count() const { return static_cast<int>(walks.size()); }
  int slots() const;               // robots over all regions
  // The longest walk per robot: max over regions of walk / robots (m).
  double longest_share() const;
};

// Splits `g` into min(count, vertices) connected regions; `d` its shortest paths.
GraphPartition partition_graph(const PatrolGraph& g, const GraphDistances& d, int count,
                               const PartitionOptions& options = {});

// A team of `team` robots over the graph: for every region count q from 1 to `team`, the
// balanced partition into q regions, the robots shared out so that the longest walk per robot
// (walk / robots, robots of one region spread evenly along its walk) is least; the q with the
// least longest share wins, regions below the least size (or walk) counting first. Several
// robots on one walk meet one another on a tree's walk, which costs them: a region's share
// counts `options.shared_cost` more per extra robot. With enough room every robot gets its own region
// (then it is partition_graph's answer); with many robots on a graph of short dead ends (12 on
// DIAG_labs) some regions take two.
GraphPartition plan_regions(const PatrolGraph& g, const GraphDistances& d, int team, const PartitionOptions& options = {});

// Gives each member a region (the same answer for every member computing it): least total
// distance along the graph from each member's nearest vertex to the region's nearest vertex
// (min-cost assignment; a region takes as many members as its `robots`). Returns, per member,
// its region (-1 when there are more members than places).
std::vector<int> assign_regions(const PatrolGraph& g, const GraphDistances& d, const GraphPartition& p,
                                const std::vector<Vec2>& where);

}  // namespace vigil::planning::patrol
