// Idleness, as the patrolling community measures it (Machado et al. 2002; patrolling_sim's
// monitor): a vertex's idleness at a visit is the time since its previous visit; the first visit
// of each vertex only starts its clock. Over a run: the average and the worst of those
// intervals, their standard deviation, how many there were, and interferences (two robots
// coming within a distance of each other, default 2 m).
#pragma once

#include <string>
#include <vector>

#include "common/geometry.h"

namespace vigil::planning::patrol {

struct Visit {
  double t = 0;  // s
  int vertex = -1;
  std::string robot;
};

struct IdlenessStats {
  int vertices = 0;
  int visits = 0;
  int intervals = 0;
  double average = 0, worst = 0, stddev = 0;  // s, over all intervals
  double median = 0;
  int unvisited = 0;            // vertices never visited
  double longest_open = 0;      // the longest time since a vertex's last visit at the end (s)
  std::vector<double> vertex_average;  // per vertex, the mean of its intervals (0: fewer than two visits)
};

// Visits in time order (stable for equal times).
IdlenessStats idleness(std::vector<Visit> visits, int vertex_count, double end_time);

// Turns robots' positions over time into visits: a robot visits a vertex when it comes within
// `radius` of it; it must go beyond 1.5 x radius before the same vertex counts again.
class VisitDetector {
 public:
  VisitDetector(std::vector<Vec2> vertices, double radius);
  // One sample of one robot (call in time order per robot).
  void observe(const std::string& robot, double t, Vec2 p);
  const std::vector<Visit>& visits() const { return visits_; }

 private:
  std::vector<Vec2> v_;
  double r_;
  struct Armed {
    std::vector<char> inside;
  };
  std::vector<std::pair<std::string, Armed>> robots_;
  std::vector<Visit> visits_;
};

// Counts interference episodes: a pair of robots coming within `distance` (again after
// separating beyond 1.25 x distance). Feed one time's positions at a time.
class InterferenceCounter {
 public:
  explicit InterferenceCounter(double distance = 2.0) : d_(distance) {}
  void observe(const std::vector<std::pair<std::string, Vec2>>& robots);
  int count() const { return count_; }

 private:
  double d_;
  std::vector<std::pair<std::string, std::string>> close_;
  int count_ = 0;
};

}  // namespace vigil::planning::patrol
