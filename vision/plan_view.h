// Plan-view maps (chapter section 10.4.2, after Harville 2004): the foreground pixels of a stereo
// camera that have a valid depth are back-projected to 3D (eq. 10.5), moved to the map frame
// (eq. 10.6), and binned into vertical bins on the floor of `cell_size` metres (eq. 10.7, 2 cm by
// default), as if seen by an overhead orthographic camera. Two statistics per bin:
//
//  - occupancy: the weighted number of points in the bin, each point weighted by Z^2 / f (the
//    chapter's weight, so an object's total does not depend on its distance). We use
//    Z^2 / (fx * fy * cell_size^2): a pixel at depth Z covers Z^2 / (fx * fy) square metres
//    seen face-on, so a bin reads "square metres of visible surface per square metre of floor"
//    and the total of an object times cell_size^2 is its visible area in m^2, the same at any
//    distance, image resolution and cell size (a constant multiple of the chapter's Z^2 / f);
//  - height: the highest point in the bin, in metres above the floor.
//
// Points below `min_height` (floor, shadows) or above `max_height` (ceiling, lamps) are ignored.
// The refinement of the raw maps: the occupancy is smoothed with a Gaussian (theta_sm), the cells
// whose smoothed occupancy is under `occupancy_threshold` are dropped (mask), and the height map,
// its empty bins filled with the local maximum (far objects leave bins without points), is masked
// by them (H_masked); these are the maps the tracker matches its templates against (eq. 10.8).
//
// Grid layout (eq. 10.7): cell (col, row) is centred on the map point
// (x_min + col * cell, y_min + row * cell); columns run along the map's +x, rows along its +y
// (so a plan-view image shown as is has y pointing down; draw_plan_view flips it).
//
// The region covered is a map-frame rectangle, given, or derived from what the camera can see:
// the bounding box of the camera's frustum between min_height and max_height above the floor and
// within max_range metres (horizontally) of the camera.
//
// A camera that cannot see the floor is refused with an Error (kBadInput), whatever the region:
// one below the floor, or one whose lowest image ray points at or above the horizon (the
// optical axis pitched up so that the floor plane is behind the camera). A level camera, or one
// looking slightly up whose lower image still sees the floor, is accepted.
//
// Speed: the per-pixel rays are precomputed (separably: a per-row and a per-column term, three
// additions per pixel); one pass over the mask touches only foreground pixels; the output maps
// are reused from call to call and only the part that held data last time is cleared.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "common/status.h"
#include "vision/stereo_camera_model.h"

namespace vigil::vision {

// An axis-aligned rectangle of the map frame (metres).
struct PlanViewRegion {
  double x_min = 0, y_min = 0, x_max = 0, y_max = 0;
};

// The plan-view grid: where cell (col, row) is.
struct PlanViewGrid {
  double x_min = 0, y_min = 0;  // map-frame centre of cell (0, 0)
  double cell = 0.02;           // cell side (m), the chapter's lambda
  int cols = 0, rows = 0;       // cells along map +x, along map +y

  // Map-frame centre of a (possibly fractional) cell position.
  Eigen::Vector2d to_map(double col, double row) const { return {x_min + col * cell, y_min + row * cell}; }
  // Fractional cell position of a map point (eq. 10.7 before rounding: the point's cell is the
  // rounded value).
  Eigen::Vector2d to_cell(double x, double y) const { return {(x - x_min) / cell, (y - y_min) / cell}; }
  // True when the map point falls in a cell of the grid.
  bool contains(double x, double y) const;
  // The region the cells cover.
  PlanViewRegion region() const;
  bool operator==(const PlanViewGrid& o) const;
};

struct PlanViewParams {
  double cell_size = 0.02;               // m (chapter: 2 cm)
  std::optional<PlanViewRegion> region;  // map-frame rectangle; absent: derived from the camera
  double max_range = 8.0;                // m from the camera (horizontal), for the derived region
  double floor_z = 0.0;                  // map z of the floor
  double min_height = 0.05;              // m above the floor: lower points are floor noise
  double max_height = 2.2;               // m above the floor: higher points are ceiling noise
  double max_depth = 0;                  // m along the optical axis; 0 = no limit
  double smooth_sigma = 1.5;             // cells, Gaussian smoothing of the occupancy (0 = none)
  double occupancy_threshold = 0.15;     // smoothed occupancy (m^2 of surface per m^2 of floor)
  int height_fill = 2;                   // cells: H_masked is the height map's local maximum over
                                         // (2 n + 1)^2 cells, filling the empty bins inside a blob
  int max_cells = 4000 * 4000;           // refuse regions larger than this many cells
  // Checks every field; the error's key is the field's name.
  Status validate() const;
};

// One frame's plan-view maps. Every map is CV_32F (mask CV_8U) of grid.rows x grid.cols.
struct PlanView {
  PlanViewGrid grid;
  cv::Mat occupancy;           // raw weighted point count (see the header comment)
  cv::Mat occupancy_smoothed;  // theta_sm: the occupancy smoothed
  cv::Mat height;              // highest point (m above the floor), 0 where the bin is empty
  cv::Mat height_masked;       // H_masked: the filled height (see height_fill) where the mask is set, 0 elsewhere
  cv::Mat mask;                // 255 where occupancy_smoothed >= occupancy_threshold
  cv::Rect active;             // every non-zero cell of every map lies inside (empty: none)
  Eigen::Vector2d camera_xy = Eigen::Vector2d::Zero();  // the camera's map-frame x, y
  double camera_height = 0;    // m, the camera above the floor
  // The camera's view ceiling: per cell, the height above the floor (m) where a vertical line
  // there leaves the top of the image (+infinity where it does not below max_height). An object
  // whose top reaches it is cut by the image's top edge: its plan-view height is a lower bound.
  // The same matrix every frame (the camera does not move); empty: not known.
  cv::Mat ceiling;
  double smoothing = 0;        // cells, sigma of the Gaussian that made occupancy_smoothed
  int points = 0;              // foreground points binned
  int invalid_depth = 0;       // foreground pixels skipped: depth 0, negative, NaN, inf, > max
  int out_of_band = 0;         // foreground points below min_height or above max_height
  int out_of_region = 0;       // foreground points outside the grid
};

// The region a camera sees between min_height and max_height above the floor, within max_range
// metres (horizontal) of it: the bounding rectangle of its frustum cut by that band and range
// (from a 65 x 65 grid of pixel rays). Errors when the camera does not see the floor (see the
// header comment) or sees nothing of that band.
Result<PlanViewRegion> camera_footprint(const StereoCameraModel& camera, double max_range, double floor_z = 0,
                                        double min_height = 0.05, double max_height = 2.2);

// Checks that the camera sees the floor plane in front of it (see the header comment).
Status check_camera_sees_floor(const StereoCameraModel& camera, double floor_z = 0);

class PlanViewBuilder {
 public:
  // A builder for this camera, or the Error naming the bad parameter or camera pose.
  static Result<PlanViewBuilder> create(const StereoCameraModel& camera, const PlanViewParams& params = {});

  // Builds the maps of one frame into `out`, reusing its buffers. `foreground`: CV_8U, non-zero =
  // foreground (255 by convention); `depth`: CV_32F metres along the optical axis (0, negative,
  // NaN and inf mean no depth); both the camera's image size. Errors (kBadInput) name the image
  // at fault and its size or type.
  Status build(const cv::Mat& foreground, const cv::Mat& depth, PlanView* out) const;

  const PlanViewGrid& grid() const { return grid_; }
  const PlanViewParams& params() const { return params_; }
  const StereoCameraModel& camera() const { return camera_; }

 private:
  PlanViewBuilder() = default;
  StereoCameraModel camera_;
  PlanViewParams params_;
  PlanViewGrid grid_;
  // Ray of pixel (u, v) in cell units (x, y) and metres (z): row term + column term.
  std::vector<float> col_x_, col_y_, col_z_, row_x_, row_y_, row_z_;
  float origin_x_ = 0, origin_y_ = 0, origin_z_ = 0;  // camera centre: cells (+0.5), m above floor
  float weight_ = 0;                                  // 1 / (fx * fy * cell^2)
  cv::Mat ceiling_;                                   // PlanView::ceiling
};

}  // namespace vigil::vision
