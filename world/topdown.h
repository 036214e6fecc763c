// Top-down view of a running world, drawn with OpenCV: the map, camera fields of view (clipped by
// walls), laser scans, robots with their heading, their trail coloured by the mode their
// controller reports (driving green, avoiding orange, waiting / recovering red, localising
// purple), the pose they believe they are at (blue ring) and their goal (magenta cross), people in
// their shirt colour with a trail, objects by kind, and the time. Used for the topdown video and the final topdown.png.
#pragma once

#include <deque>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "world/world.h"

namespace vigil {

// "#rrggbb" to an OpenCV BGR colour (grey when malformed).
cv::Scalar parse_colour(const std::string& hex);

class TopdownRenderer {
 public:
  // Picks a scale so the map is at most `max_width` x `max_height` pixels.
  explicit TopdownRenderer(const World& world, int max_width = 1280, int max_height = 960);
  // Only a map (no world): for map_view(), as `vigil report` draws a finished run's background.
  explicit TopdownRenderer(const OccupancyGrid& map, int max_width = 1280, int max_height = 960);
  // Draws the world as it is now (BGR, 8-bit).
  cv::Mat draw(const World& world);
  cv::Size size() const { return background_.size(); }
  // The pixel of a map-frame point in the drawings: ((x - origin.x) * scale, (height - (y - origin.y)) * scale).
  cv::Point to_px(Vec2 p) const;
  double scale() const { return scale_; }  // pixels per metre
  Vec2 origin() const { return origin_; }  // the map's lower-left corner, map frame
  double height_m() const { return height_m_; }
  // The map with the cameras' fields of view (clipped by the map's walls) and their names:
  // what draw() puts under the entities.
  cv::Mat map_view(const std::vector<CameraSpec>& cameras, const OccupancyGrid& map) const;

 private:
  void init(const OccupancyGrid& map, int max_width, int max_height);

  cv::Mat background_;
  double scale_ = 20;  // pixels per metre
  Vec2 origin_;
  double height_m_ = 0;
  std::vector<std::deque<cv::Point>> trails_;  // per person
  struct TrailPoint {
    cv::Point p;
    cv::Scalar colour;
  };
  std::vector<std::deque<TrailPoint>> robot_trails_;  // per robot, coloured by reported mode
};

}  // namespace vigil
