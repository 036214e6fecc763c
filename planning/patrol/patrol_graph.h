// Patrol graphs: the places a patrolling team must visit and the corridors between them, in the
// map frame. The file format is patrolling_sim's (Portugal and Iocchi), so the real DIAG graphs
// read unchanged and our own graphs (maps/*.graph) use the same: one number or letter per line;
// the vertex count, the map's width and height in pixels, its resolution (m/px) and origin
// (x, y in m); then per vertex its id, x and y in pixels (y from the bottom), its neighbour
// count and per neighbour the neighbour's id, the compass letter of its direction and the edge
// cost in pixels. Vertex ids are 0..n-1 in file order.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/status.h"

namespace vigil::planning::patrol {

struct GraphEdge {
  int to = -1;
  double cost = 0;  // m
};

struct GraphVertex {
  int id = 0;
  Vec2 position;                 // map frame (m)
  std::vector<GraphEdge> edges;  // to neighbours, as the file lists them
};

class PatrolGraph {
 public:
  PatrolGraph() = default;
  // Reads a patrolling_sim graph. Errors name the file, the line and what is wrong: a count or
  // coordinate that is not a number, an id out of order, an edge to a vertex that does not
  // exist, a negative cost, an edge listed one way only, a graph in pieces.
  static Result<PatrolGraph> read(const std::filesystem::path& file);
  static Result<PatrolGraph> parse(const std::string& text, const std::string& file_name);
  // Builds one from vertices (ids 0..n-1) and undirected edges (cost: the straight length when
  // negative); the same checks.
  static Result<PatrolGraph> from_edges(const std::vector<Vec2>& positions,
                                        const std::vector<std::pair<int, int>>& edges,
                                        double resolution = 0.05);
  // The patrolling_sim text of this graph (costs and coordinates rounded to pixels).
  std::string to_text(int map_width_px, int map_height_px) const;

  size_t size() const { return vertices_.size(); }
  const GraphVertex& vertex(size_t i) const { return vertices_[i]; }
  const std::vector<GraphVertex>& vertices() const { return vertices_; }
  double resolution() const { return resolution_; }
  Vec2 origin() const { return origin_; }
  // Sum of the undirected edges' costs (m).
  double total_edge_cost() const;
  // The vertex nearest to a point (straight-line).
  int nearest(Vec2 p) const;
  std::string source() const { return source_; }

 private:
  Status check(const std::string& file) const;
  std::vector<GraphVertex> vertices_;
  double resolution_ = 0.05;
  Vec2 origin_;
  std::string source_;
};

// All-pairs shortest path costs over a graph's edges (Floyd-Warshall), with the walk between
// any two vertices.
class GraphDistances {
 public:
  explicit GraphDistances(const PatrolGraph& g);
  double cost(int a, int b) const { return d_[static_cast<size_t>(a) * n_ + static_cast<size_t>(b)]; }
  // The vertices from a to b along edges, both ends included.
  std::vector<int> walk(int a, int b) const;
  size_t size() const { return n_; }

 private:
  size_t n_ = 0;
  std::vector<double> d_;
  std::vector<int> next_;
};

}  // namespace vigil::planning::patrol
