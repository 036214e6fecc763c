// A laser scan, shared by the simulated ranger (world/), the localisation and the local planner
// (planning/).
#pragma once

#include <vector>

#include "common/geometry.h"

namespace vigil {

// One laser scan, after Stage's ranger / ROS sensor_msgs/LaserScan.
struct LaserScan {
  SimTime stamp = 0;
  double angle_min = 0, angle_increment = 0;  // rad, in the robot frame
  double range_min = 0, range_max = 0;        // m
  std::vector<float> ranges;                  // m; range_max where nothing was hit
};

}  // namespace vigil
