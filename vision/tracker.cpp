#include "vision/tracker.h"

#include <opencv2/imgproc.hpp>

namespace vigil::vision {

cv::Mat map_clearance(const OccupancyGrid& map) {
  if (map.width() <= 0 || map.height() <= 0) return {};
  cv::Mat free_cells(map.height(), map.width(), CV_8U);
  for (int cy = 0; cy < map.height(); ++cy) {
    uint8_t* row = free_cells.ptr<uint8_t>(cy);
    for (int cx = 0; cx < map.width(); ++cx) row[cx] = map.at(cx, cy) == Cell::kFree ? 255 : 0;
  }
  cv::Mat clearance;
  cv::distanceTransform(free_cells, clearance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  clearance *= map.resolution();
  return clearance;
}

}  // namespace vigil::vision
