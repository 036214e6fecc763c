// Vector floorplans: reading maps/*.floorplan.yaml, rasterising walls, doors and furniture to
// an OccupancyGrid, and exporting the map_server pair. Format: docs/MAP_FORMAT.md.
#include "world/floorplan.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "world/yaml_util.h"

namespace vigil {

namespace {

using yaml_input::InputError;
using yaml_input::Mapping;
using yaml_input::Value;

constexpr double kDegToRad = M_PI / 180.0;
// Tolerance on "within": a cell centre exactly on a boundary counts as inside.
constexpr double kEps = 1e-9;
// Largest raster a floorplan may ask for (cells).
constexpr double kMaxCells = 4.0e7;
// Smallest raster half width of a wall, in cells: thin diagonal walls stay 4-connected, so
// neither rays nor 8-connected grid paths slip between diagonal neighbours.
constexpr double kMinHalfWidthCells = 0.7072;

// Half the width a wall occupies in the raster: half its thickness, but at least one cell.
double raster_half_width(const FloorplanWall& w, double res) {
  return std::max(0.5 * w.thickness, kMinHalfWidthCells * res);
}

// Distance from p to the segment ab.
double distance_to_segment(Vec2 p, Vec2 a, Vec2 b) {
  const Vec2 ab = b - a;
  const double len2 = ab.dot(ab);
  double t = len2 > 0 ? (p - a).dot(ab) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return (p - (a + ab * t)).norm();
}

// Raster size of the plan's bounds (0 when the bounds are empty).
void raster_size(const Floorplan& plan, int* width, int* height) {
  const double res = plan.resolution;
  const double sx = plan.bounds_max.x - plan.bounds_min.x;
  const double sy = plan.bounds_max.y - plan.bounds_min.y;
  *width = (res > 0 && sx > 0) ? static_cast<int>(std::ceil(sx / res - 1e-6)) : 0;
  *height = (res > 0 && sy > 0) ? static_cast<int>(std::ceil(sy / res - 1e-6)) : 0;
}

// Calls fn(cx, cy, centre) for every cell whose centre may lie in the box [lo, hi].
template <class Fn>
void for_cells_in_box(const Floorplan& plan, int width, int height, Vec2 lo, Vec2 hi, Fn fn) {
  const double res = plan.resolution;
  const Vec2 o = plan.bounds_min;
  // Clamped in floating point first so far-away boxes cannot overflow the int conversion.
  auto index = [](double i, int n) { return static_cast<int>(std::clamp(i, -1.0, static_cast<double>(n))); };
  const int x0 = std::max(0, index(std::floor((lo.x - o.x) / res - 0.5), width));
  const int y0 = std::max(0, index(std::floor((lo.y - o.y) / res - 0.5), height));
  const int x1 = std::min(width - 1, index(std::ceil((hi.x - o.x) / res - 0.5), width));
  const int y1 = std::min(height - 1, index(std::ceil((hi.y - o.y) / res - 0.5), height));
  for (int cy = y0; cy <= y1; ++cy) {
    for (int cx = x0; cx <= x1; ++cx) {
      fn(cx, cy, Vec2{o.x + (cx + 0.5) * res, o.y + (cy + 0.5) * res});
    }
  }
}

// Calls fn for every cell whose centre lies in the oriented rectangle (centre, yaw, half sizes).
template <class Fn>
void for_cells_in_rect(const Floorplan& plan, int width, int height, Vec2 centre, double yaw,
                       double half_u, double half_v, Fn fn) {
  const Vec2 u{std::cos(yaw), std::sin(yaw)};
  const Vec2 v{-u.y, u.x};
  const double ex = std::abs(u.x) * half_u + std::abs(v.x) * half_v;
  const double ey = std::abs(u.y) * half_u + std::abs(v.y) * half_v;
  for_cells_in_box(plan, width, height, {centre.x - ex, centre.y - ey}, {centre.x + ex, centre.y + ey},
                   [&](int cx, int cy, Vec2 c) {
                     const Vec2 d = c - centre;
                     if (std::abs(d.dot(u)) <= half_u + kEps && std::abs(d.dot(v)) <= half_v + kEps) fn(cx, cy);
                   });
}

// Reads the floorplan document (throws InputError).
class FloorplanReader {
 public:
  FloorplanReader(const Value& root, Floorplan* plan) : root_(root), plan_(plan) {}

  void read() {
    const Mapping top = root_.mapping({"name", "resolution", "bounds", "wall_thickness", "wall_height",
                                       "walls", "doors", "furniture", "places"});
    plan_->name = top.require("name").identifier();
    if (auto v = top.get("resolution")) plan_->resolution = v->number_in(0.001, 10.0);
    read_bounds(top.require("bounds"));
    if (auto v = top.get("wall_thickness")) default_thickness_ = v->positive(10.0);
    if (auto v = top.get("wall_height")) default_height_ = v->positive(100.0);
    if (auto v = top.get("walls")) {
      for (const Value& item : v->items()) read_wall(item);
    }
    if (auto v = top.get("doors")) {
      for (const Value& item : v->items()) read_door(item);
    }
    if (auto v = top.get("furniture")) {
      for (const Value& item : v->items()) read_furniture(item);
    }
    if (auto v = top.get("places")) {
      const Mapping places = v->open_mapping();
      for (const auto& [name, value] : places.entries()) {
        plan_->places[name] = inside(value, value.point());
      }
    }
  }

 private:
  // bounds: {min: [x, y], max: [x, y]}
  void read_bounds(const Value& v) {
    const Mapping m = v.mapping({"min", "max"});
    const Value vmin = m.require("min");
    const Value vmax = m.require("max");
    plan_->bounds_min = vmin.point();
    plan_->bounds_max = vmax.point();
    if (std::abs(plan_->bounds_min.x) > 1e5 || std::abs(plan_->bounds_min.y) > 1e5) {
      vmin.fail("coordinates must be within 100 km of the origin");
    }
    if (plan_->bounds_max.x <= plan_->bounds_min.x || plan_->bounds_max.y <= plan_->bounds_min.y) {
      vmax.fail("must be greater than min in both x and y");
    }
    const double cells = (plan_->bounds_max.x - plan_->bounds_min.x) / plan_->resolution *
                         ((plan_->bounds_max.y - plan_->bounds_min.y) / plan_->resolution);
    if (cells > kMaxCells) {
      vmax.fail("the raster would have " + std::to_string(static_cast<long long>(cells)) +
                " cells (at most " + std::to_string(static_cast<long long>(kMaxCells)) +
                "): shrink the bounds or coarsen the resolution");
    }
  }

  // Checks a point lies inside the bounds and returns it.
  Vec2 inside(const Value& v, Vec2 p) const {
    if (p.x < plan_->bounds_min.x - kEps || p.x > plan_->bounds_max.x + kEps ||
        p.y < plan_->bounds_min.y - kEps || p.y > plan_->bounds_max.y + kEps) {
      v.fail("point (" + fmt(p.x) + ", " + fmt(p.y) + ") is outside the bounds");
    }
    return p;
  }

  static std::string fmt(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", x);
    return buf;
  }

  // A wall: {from, to} or {polyline: [[x, y], ...], closed}, with optional thickness, height.
  void read_wall(const Value& v) {
    const Mapping m = v.mapping({"from", "to", "polyline", "closed", "thickness", "height"});
    FloorplanWall proto;
    proto.thickness = default_thickness_;
    proto.height = default_height_;
    if (auto t = m.get("thickness")) proto.thickness = t->positive(10.0);
    if (auto h = m.get("height")) proto.height = h->positive(100.0);
    std::vector<std::pair<Vec2, Value>> points;
    bool closed = false;
    if (auto poly = m.get("polyline")) {
      if (m.has("from") || m.has("to")) v.fail("give either from/to or polyline, not both");
      const auto items = poly->items();
      if (items.size() < 2) poly->fail("a polyline needs at least 2 points");
      for (const Value& p : items) points.emplace_back(inside(p, p.point()), p);
      if (auto c = m.get("closed")) closed = c->boolean();
      if (closed && items.size() < 3) poly->fail("a closed polyline needs at least 3 points");
    } else {
      if (auto c = m.get("closed")) c->fail("'closed' applies only to a polyline");
      const Value from = m.require("from");
      const Value to = m.require("to");
      points.emplace_back(inside(from, from.point()), from);
      points.emplace_back(inside(to, to.point()), to);
    }
    if (closed) points.push_back(points.front());
    for (size_t i = 0; i + 1 < points.size(); ++i) {
      FloorplanWall w = proto;
      w.from = points[i].first;
      w.to = points[i + 1].first;
      if ((w.to - w.from).norm() < 1e-9) points[i + 1].second.fail("repeats the previous point (zero-length wall)");
      plan_->walls.push_back(w);
    }
  }

  // A door: {name, center: [x, y], width, yaw_deg}; must cut through a wall.
  void read_door(const Value& v) {
    const Mapping m = v.mapping({"name", "center", "width", "yaw_deg"});
    FloorplanDoor d;
    const Value name = m.require("name");
    d.name = name.identifier();
    if (!door_names_.insert(d.name).second) name.fail("duplicate door name '" + d.name + "'");
    const Value centre = m.require("center");
    d.center = inside(centre, centre.point());
    if (auto w = m.get("width")) d.width = w->positive(100.0);
    if (auto y = m.get("yaw_deg")) d.yaw = wrap_angle(y->number_in(-360.0, 360.0) * kDegToRad);
    bool on_wall = false;
    for (const auto& w : plan_->walls) {
      if (distance_to_segment(d.center, w.from, w.to) <= raster_half_width(w, plan_->resolution) + plan_->resolution) {
        on_wall = true;
      }
    }
    if (!on_wall) centre.fail("door '" + d.name + "' does not lie on any wall");
    plan_->doors.push_back(d);
  }

  // Furniture: {name, kind, pose: [x, y, yaw_deg], size: [sx, sy, height]}.
  void read_furniture(const Value& v) {
    const Mapping m = v.mapping({"name", "kind", "pose", "size"});
    FloorplanFurniture f;
    const Value name = m.require("name");
    f.name = name.identifier();
    for (const auto& other : plan_->furniture) {
      if (other.name == f.name) name.fail("duplicate furniture name '" + f.name + "'");
    }
    if (auto k = m.get("kind")) f.kind = k->identifier();
    else f.kind = "table";
    const Value pose = m.require("pose");
    const auto p = pose.numbers(0, 2, 3);
    inside(pose, {p[0], p[1]});
    f.pose = {p[0], p[1], p.size() > 2 ? wrap_angle(p[2] * kDegToRad) : 0.0};
    if (p.size() > 2 && std::abs(p[2]) > 360.0) pose.fail("yaw must be between -360 and 360 degrees");
    if (auto s = m.get("size")) {
      const auto sz = s->numbers(3);
      for (double x : sz) {
        if (x <= 0 || x > 100) s->fail("sizes must be greater than 0 and at most 100 m");
      }
      f.size_x = sz[0];
      f.size_y = sz[1];
      f.height = sz[2];
    }
    plan_->furniture.push_back(f);
  }

  const Value& root_;
  Floorplan* plan_;
  double default_thickness_ = 0.15;
  double default_height_ = 2.7;
  std::set<std::string> door_names_;
};

}  // namespace

OccupancyGrid Floorplan::rasterize() const {
  int width = 0, height = 0;
  raster_size(*this, &width, &height);
  OccupancyGrid grid(width, height, resolution, Pose2{bounds_min.x, bounds_min.y, 0.0}, Cell::kFree);
  if (width == 0 || height == 0) return grid;
  // Walls: every cell whose centre is within half the thickness of the segment.
  double max_half = 0;
  for (const auto& w : walls) {
    const double half = raster_half_width(w, resolution);
    max_half = std::max(max_half, half);
    const Vec2 lo{std::min(w.from.x, w.to.x) - half, std::min(w.from.y, w.to.y) - half};
    const Vec2 hi{std::max(w.from.x, w.to.x) + half, std::max(w.from.y, w.to.y) + half};
    for_cells_in_box(*this, width, height, lo, hi, [&](int cx, int cy, Vec2 c) {
      if (distance_to_segment(c, w.from, w.to) <= half + kEps) grid.set(cx, cy, Cell::kOccupied);
    });
  }
  // Doors: clear width/2 along the wall and the thickest wall's half width plus a cell across.
  for (const auto& d : doors) {
    for_cells_in_rect(*this, width, height, d.center, d.yaw, 0.5 * d.width, max_half + resolution,
                      [&](int cx, int cy) { grid.set(cx, cy, Cell::kFree); });
  }
  // Furniture footprints; a piece smaller than a cell still occupies the cell of its centre.
  for (const auto& f : furniture) {
    for_cells_in_rect(*this, width, height, f.pose.position(), f.pose.yaw, 0.5 * f.size_x, 0.5 * f.size_y,
                      [&](int cx, int cy) { grid.set(cx, cy, Cell::kOccupied); });
    const double fx = std::floor((f.pose.x - bounds_min.x) / resolution);
    const double fy = std::floor((f.pose.y - bounds_min.y) / resolution);
    if (fx >= 0 && fy >= 0 && fx < width && fy < height) {
      grid.set(static_cast<int>(fx), static_cast<int>(fy), Cell::kOccupied);
    }
  }
  return grid;
}

const FloorplanFurniture* Floorplan::find_furniture(const std::string& name) const {
  for (const auto& f : furniture) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

Result<Floorplan> load_floorplan(const std::filesystem::path& path) {
  try {
    const std::string file = path.string();
    const std::string text = yaml_input::read_text_file(path);
    const YAML::Node doc = yaml_input::parse_document(text, file);
    const Value root(doc, std::make_shared<const std::string>(file), "", yaml_input::line_of(doc, 1));
    Floorplan plan;
    plan.source = path;
    FloorplanReader(root, &plan).read();
    return plan;
  } catch (const InputError& e) {
    return e.error;
  } catch (const YAML::Exception& e) {
    return bad_input(path.string(), e.mark.is_null() ? 0 : e.mark.line + 1, "", "YAML error: " + e.msg);
  } catch (const std::exception& e) {
    return internal_error(path.string() + ": " + e.what());
  } catch (...) {
    return internal_error(path.string() + ": unknown exception while parsing");
  }
}

Status export_floorplan(const Floorplan& plan, const std::filesystem::path& yaml_path) {
  try {
    return save_map_yaml(plan.rasterize(), yaml_path);
  } catch (const std::exception& e) {
    return internal_error("exporting " + yaml_path.string() + ": " + e.what());
  }
}

}  // namespace vigil
