// `vigil map`: inspect occupancy maps (map_server YAML or Stage worldfile floorplans).
//   vigil map info MAP     size, resolution, origin, cell counts and wall boxes of a map
//   vigil map export FLOORPLAN OUT.yaml   rasterise a vector floorplan to map_server YAML + PGM
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include "tools/vigil/commands.h"
#include "world/floorplan.h"
#include "world/map.h"

namespace vigil::cli {

namespace {

// Loads `path` with load_map, or reports the error and ends the program with its exit code.
OccupancyGrid load_or_exit(const std::string& path) {
  auto grid = load_map(path);
  if (!grid) throw Exit{report(grid.error())};
  return std::move(*grid);
}

// Prints what `vigil map info` shows about one map.
void print_map_info(const std::string& path, const OccupancyGrid& grid) {
  const size_t total = static_cast<size_t>(grid.width()) * grid.height();
  auto percent = [&](size_t n) { return total == 0 ? 0.0 : 100.0 * static_cast<double>(n) / total; };
  const size_t n_free = grid.count(Cell::kFree);
  const size_t n_occupied = grid.count(Cell::kOccupied);
  const size_t n_unknown = grid.count(Cell::kUnknown);
  std::ostringstream out;
  out << std::fixed;
  out << "map:        " << path << "\n";
  out << "size:       " << grid.width() << " x " << grid.height() << " cells, " << std::setprecision(3)
      << grid.size_x() << " x " << grid.size_y() << " m\n";
  out << "resolution: " << std::setprecision(4) << grid.resolution() << " m/cell\n";
  out << "origin:     [" << std::setprecision(3) << grid.origin().x << ", " << grid.origin().y << "]\n";
  out << std::setprecision(1);
  out << "free:       " << n_free << " (" << percent(n_free) << "%)\n";
  out << "occupied:   " << n_occupied << " (" << percent(n_occupied) << "%)\n";
  out << "unknown:    " << n_unknown << " (" << percent(n_unknown) << "%)\n";
  out << "wall boxes: " << extract_wall_boxes(grid).size() << "\n";
  std::cout << out.str();
}

}  // namespace

void add_map_command(CLI::App& app) {
  CLI::App* map = app.add_subcommand("map", "Inspect and convert occupancy maps");
  map->require_subcommand(1);

  // vigil map info MAP
  auto info_path = std::make_shared<std::string>();
  CLI::App* info = map->add_subcommand("info", "Print a map's size, resolution, cell counts and wall boxes");
  info->add_option("map", *info_path, "Map file: map_server .yaml/.yml or Stage .world")->required();
  info->callback([info_path] {
    const OccupancyGrid grid = load_or_exit(*info_path);
    print_map_info(*info_path, grid);
  });

  // vigil map export FLOORPLAN OUT.yaml: floorplan -> map_server YAML + PGM (OUT.pgm beside it).
  auto export_in = std::make_shared<std::string>();
  auto export_out = std::make_shared<std::string>();
  CLI::App* exp = map->add_subcommand("export", "Rasterise a .floorplan.yaml to map_server YAML + PGM");
  exp->add_option("floorplan", *export_in, "Vector floorplan (.floorplan.yaml)")->required();
  exp->add_option("out", *export_out, "Output map_server YAML; the PGM is written beside it")->required();
  exp->callback([export_in, export_out] {
    auto plan = load_floorplan(*export_in);
    if (!plan) throw Exit{report(plan.error())};
    if (Status s = export_floorplan(*plan, *export_out); !s) throw Exit{report(s.error())};
    const OccupancyGrid grid = plan->rasterize();
    const std::filesystem::path out(*export_out);
    std::cout << "wrote " << out.string() << " and "
              << (out.parent_path() / (out.stem().string() + ".pgm")).string() << " (" << grid.width() << " x "
              << grid.height() << " cells)\n";
  });
}

}  // namespace vigil::cli
