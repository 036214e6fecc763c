// A light simulated robot for localisation studies, without Box2D: unicycle kinematics through
// waypoints (stopping, looping, or then wandering by its true laser), the simulator's
// Stage-like odometry (a fixed bias on the robot-frame x, y and yaw increments, as
// World::step_robots_sense), and the simulator's ranger (world/ranger.h) each period. Returns
// from the grid's edge (a beam that crossed unknown space to the map's border) are dropped as
// no return: a real laser sees no map border. Used by the MCL tests and `vigil bench mcl`.
#pragma once

#include <vector>

#include "common/geometry.h"
#include "common/laser_scan.h"
#include "common/occupancy_grid.h"
#include "common/rng.h"
#include "world/ranger.h"

namespace vigil {

class KinematicRobot {
 public:
  enum class RouteEnd { kStop, kLoop, kWander };
  struct Options {
    double period = 0.1;           // s: one step, one scan (10 Hz)
    double speed = 0.4, turn = 1.0;  // m/s, rad/s
    Pose2 laser{0.12, 0.0, 0.0};   // laser in the robot frame
    int samples = 271;             // 270 degrees, 20 m, 1 cm noise
    Vec3 bias{0.01, -0.01, 0.1};   // odometry bias on x, y, yaw increments
    uint64_t noise_seed = 7;
  };
  // `map` must outlive the robot. An empty route with kWander wanders from the start.
  KinematicRobot(const OccupancyGrid& map, Pose2 start, std::vector<Vec2> route, RouteEnd end, const Options& options);

  // Advances one period and takes a scan at the new pose.
  void step();
  // Moves the robot (kidnapping); the route goes on from waypoint `next`.
  void teleport(Pose2 p, size_t next = 0);
  void set_route(std::vector<Vec2> route);

  const Pose2& truth() const { return truth_; }
  const Pose2& odometry() const { return odom_; }
  const LaserScan& scan() const { return scan_; }
  double time() const { return t_; }
  bool route_done() const { return next_ >= route_.size(); }
  const Options& options() const { return options_; }

 private:
  void take_scan();
  const OccupancyGrid* grid_;  // the wander steers clear of occupied and unknown cells
  WallRaycaster walls_;
  ObstacleIndex bodies_;
  RangerSpec spec_;
  Options options_;
  Pose2 truth_, odom_{0.0, 0.0, 0.0};
  std::vector<Vec2> route_;
  RouteEnd end_;
  size_t next_ = 0;
  int turn_dir_ = 1;
  Rng noise_;
  LaserScan scan_;
  double t_ = 0;
};

}  // namespace vigil
