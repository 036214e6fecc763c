// Robot descriptions read from URDF with urdfdom: the planar footprint (from base_link's
// collision geometry), the laser mount (the link named "laser", if any), the inspection camera
// (the link named "camera", if any) and the visual parts the renderer draws.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "world/status.h"

namespace vigil {

enum class FootprintShape { kCircle, kBox };

// One visual part, in the robot's base frame.
struct RobotVisual {
  std::string link;
  enum class Shape { kBox, kCylinder, kSphere } shape = Shape::kBox;
  Vec3 origin;            // centre of the part
  Vec3 size;              // box: full extents; cylinder: (radius, radius, length); sphere: radius in x
  Vec3 rgb{0.5, 0.5, 0.5};
};

struct RobotModel {
  std::string name;
  FootprintShape footprint = FootprintShape::kCircle;
  double radius = 0.2;                 // circle footprint; for a box, its bounding circle
  double half_x = 0.2, half_y = 0.2;   // box footprint half extents
  Vec2 footprint_offset;               // footprint centre in the base frame
  Vec3 laser_offset;                   // laser origin in the base frame (zero when no laser link)
  bool has_laser_link = false;
  Vec3 camera_offset;                  // the link named "camera" (the inspection camera), base frame
  bool has_camera_link = false;
  double height = 0.5;                 // top of the tallest visual part
  std::vector<RobotVisual> visuals;
};

// Reads a URDF file; errors name the file and what is missing (a base_link, a collision
// geometry of a supported shape).
Result<RobotModel> load_robot_model(const std::filesystem::path& urdf_path);

}  // namespace vigil
