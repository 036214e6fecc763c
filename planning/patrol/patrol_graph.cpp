#include "planning/patrol/patrol_graph.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

namespace vigil::planning::patrol {
namespace {

struct Token {
  std::string text;
  int line = 0;
};

// The file's tokens with their lines (patrolling_sim writes one per line; any whitespace is
// accepted).
std::vector<Token> tokenize(const std::string& text) {
  std::vector<Token> out;
  std::istringstream in(text);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    std::istringstream ls(line);
    std::string t;
    while (ls >> t) out.push_back({t, n});
  }
  return out;
}

class Reader {
 public:
  Reader(std::vector<Token> t, std::string file) : t_(std::move(t)), file_(std::move(file)) {}
  Result<double> number(const std::string& what) {
    if (i_ >= t_.size()) return bad_input(file_, last_line(), what, "the file ends before " + what);
    const Token& tk = t_[i_++];
    char* end = nullptr;
    const double v = std::strtod(tk.text.c_str(), &end);
    if (end == tk.text.c_str() || *end != '\0' || !std::isfinite(v)) {
      return bad_input(file_, tk.line, what, "'" + tk.text + "' is not a number");
    }
    return v;
  }
  Result<long> integer(const std::string& what, long lo, long hi) {
    const int line = i_ < t_.size() ? t_[i_].line : last_line();
    auto v = number(what);
    if (!v) return v.error();
    if (*v != std::floor(*v) || *v < lo || *v > hi) {
      return bad_input(file_, line, what,
                       "must be a whole number from " + std::to_string(lo) + " to " + std::to_string(hi));
    }
    return static_cast<long>(*v);
  }
  Result<std::string> word(const std::string& what) {
    if (i_ >= t_.size()) return bad_input(file_, last_line(), what, "the file ends before " + what);
    return t_[i_++].text;
  }
  int line() const { return i_ < t_.size() ? t_[i_].line : last_line(); }
  bool done() const { return i_ >= t_.size(); }

 private:
  int last_line() const { return t_.empty() ? 0 : t_.back().line; }
  std::vector<Token> t_;
  std::string file_;
  size_t i_ = 0;
};

bool is_compass(const std::string& s) {
  static const char* k[] = {"N", "S", "E", "W", "NE", "NW", "SE", "SW"};
  return std::find(std::begin(k), std::end(k), s) != std::end(k);
}

std::string compass(Vec2 d) {
  const double a = std::atan2(d.y, d.x) * 180.0 / M_PI;  // from +x, counter-clockwise
  static const char* k[] = {"E", "NE", "N", "NW", "W", "SW", "S", "SE"};
  int i = static_cast<int>(std::lround(a / 45.0));
  i = ((i % 8) + 8) % 8;
  return k[i];
}

}  // namespace

Result<PatrolGraph> PatrolGraph::read(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) return bad_input(file.string(), 0, "", "cannot open the patrol graph");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse(ss.str(), file.string());
}

Result<PatrolGraph> PatrolGraph::parse(const std::string& text, const std::string& file) {
  Reader r(tokenize(text), file);
  PatrolGraph g;
  g.source_ = file;
  auto n = r.integer("vertex count", 1, 100000);
  if (!n) return n.error();
  auto w = r.integer("map width", 1, 1 << 20);
  if (!w) return w.error();
  auto h = r.integer("map height", 1, 1 << 20);
  if (!h) return h.error();
  const int res_line = r.line();
  auto res = r.number("resolution");
  if (!res) return res.error();
  if (*res <= 0) return bad_input(file, res_line, "resolution", "must be positive");
  auto ox = r.number("origin x");
  if (!ox) return ox.error();
  auto oy = r.number("origin y");
  if (!oy) return oy.error();
  g.resolution_ = *res;
  g.origin_ = {*ox, *oy};
  std::vector<int> edge_lines;
  for (long i = 0; i < *n; ++i) {
    const std::string v = "vertex " + std::to_string(i);
    const int id_line = r.line();
    auto id = r.integer(v + " id", 0, *n - 1);
    if (!id) return id.error();
    if (*id != i) {
      return bad_input(file, id_line, v + " id", "ids must be 0..n-1 in order; found " + std::to_string(*id));
    }
    auto x = r.number(v + " x");
    if (!x) return x.error();
    auto y = r.number(v + " y");
    if (!y) return y.error();
    auto k = r.integer(v + " neighbour count", 0, *n - 1);
    if (!k) return k.error();
    GraphVertex gv;
    gv.id = static_cast<int>(i);
    gv.position = {*ox + *x * *res, *oy + *y * *res};
    for (long j = 0; j < *k; ++j) {
      const std::string e = v + " neighbour " + std::to_string(j);
      const int line = r.line();
      auto to = r.integer(e + " id", 0, *n - 1);
      if (!to) return to.error();
      if (*to == i) return bad_input(file, line, e + " id", "a vertex cannot be its own neighbour");
      auto dir = r.word(e + " direction");
      if (!dir) return dir.error();
      if (!is_compass(*dir)) {
        return bad_input(file, line + 1, e + " direction", "'" + *dir + "' is not a compass letter (N, S, E, W, NE, ...)");
      }
      const int cost_line = r.line();
      auto cost = r.number(e + " cost");
      if (!cost) return cost.error();
      if (*cost < 0) return bad_input(file, cost_line, e + " cost", "must not be negative");
      gv.edges.push_back({static_cast<int>(*to), *cost * *res});
    }
    g.vertices_.push_back(std::move(gv));
  }
  if (!r.done()) return bad_input(file, r.line(), "", "unexpected text after the last vertex");
  if (Status s = g.check(file); !s) return s.error();
  return g;
}

Result<PatrolGraph> PatrolGraph::from_edges(const std::vector<Vec2>& positions,
                                            const std::vector<std::pair<int, int>>& edges, double resolution) {
  PatrolGraph g;
  g.resolution_ = resolution;
  for (size_t i = 0; i < positions.size(); ++i) g.vertices_.push_back({static_cast<int>(i), positions[i], {}});
  const int n = static_cast<int>(positions.size());
  for (auto [a, b] : edges) {
    if (a < 0 || b < 0 || a >= n || b >= n || a == b) {
      return bad_input("", 0, "edges", "edge (" + std::to_string(a) + ", " + std::to_string(b) + ") is not between two vertices");
    }
    const double c = (positions[a] - positions[b]).norm();
    g.vertices_[a].edges.push_back({b, c});
    g.vertices_[b].edges.push_back({a, c});
  }
  if (Status s = g.check(""); !s) return s.error();
  return g;
}

Status PatrolGraph::check(const std::string& file) const {
  if (vertices_.empty()) return bad_input(file, 0, "vertex count", "the graph has no vertices");
  for (const GraphVertex& v : vertices_) {
    for (const GraphEdge& e : v.edges) {
      const auto& back = vertices_[e.to].edges;
      if (std::none_of(back.begin(), back.end(), [&](const GraphEdge& b) { return b.to == v.id; })) {
        return bad_input(file, 0, "vertex " + std::to_string(v.id),
                         "edge to " + std::to_string(e.to) + " is not listed back from " + std::to_string(e.to));
      }
    }
  }
  // Connected: a patrol must be able to reach every vertex.
  std::vector<char> seen(vertices_.size(), 0);
  std::vector<int> stack{0};
  seen[0] = 1;
  while (!stack.empty()) {
    const int v = stack.back();
    stack.pop_back();
    for (const GraphEdge& e : vertices_[v].edges) {
      if (!seen[e.to]) {
        seen[e.to] = 1;
        stack.push_back(e.to);
      }
    }
  }
  for (size_t i = 0; i < seen.size(); ++i) {
    if (!seen[i]) {
      return bad_input(file, 0, "vertex " + std::to_string(i), "cannot be reached from vertex 0: the graph is in pieces");
    }
  }
  return Status::Ok();
}

std::string PatrolGraph::to_text(int width_px, int height_px) const {
  std::ostringstream o;
  auto px = [&](double m) { return std::lround(m / resolution_); };
  o << vertices_.size() << "\n" << width_px << "\n" << height_px << "\n" << resolution_ << "\n"
    << origin_.x << "\n" << origin_.y << "\n\n";
  for (const GraphVertex& v : vertices_) {
    o << v.id << "\n" << px(v.position.x - origin_.x) << "\n" << px(v.position.y - origin_.y) << "\n"
      << v.edges.size() << "\n";
    for (const GraphEdge& e : v.edges) {
      o << e.to << "\n" << compass(vertices_[e.to].position - v.position) << "\n" << px(e.cost) << "\n";
    }
    o << "\n";
  }
  return o.str();
}

double PatrolGraph::total_edge_cost() const {
  double sum = 0;
  for (const GraphVertex& v : vertices_) {
    for (const GraphEdge& e : v.edges) sum += e.cost;
  }
  return sum / 2;
}

int PatrolGraph::nearest(Vec2 p) const {
  int best = 0;
  double bd = std::numeric_limits<double>::infinity();
  for (const GraphVertex& v : vertices_) {
    const double d = (v.position - p).norm();
    if (d < bd) {
      bd = d;
      best = v.id;
    }
  }
  return best;
}

GraphDistances::GraphDistances(const PatrolGraph& g) : n_(g.size()) {
  const double inf = std::numeric_limits<double>::infinity();
  d_.assign(n_ * n_, inf);
  next_.assign(n_ * n_, -1);
  for (size_t i = 0; i < n_; ++i) {
    d_[i * n_ + i] = 0;
    next_[i * n_ + i] = static_cast<int>(i);
    for (const GraphEdge& e : g.vertex(i).edges) {
      const size_t k = i * n_ + static_cast<size_t>(e.to);
      if (e.cost < d_[k]) {
        d_[k] = e.cost;
        next_[k] = e.to;
      }
    }
  }
  for (size_t k = 0; k < n_; ++k) {
    for (size_t i = 0; i < n_; ++i) {
      const double dik = d_[i * n_ + k];
      if (dik == inf) continue;
      for (size_t j = 0; j < n_; ++j) {
        const double c = dik + d_[k * n_ + j];
        if (c < d_[i * n_ + j]) {
          d_[i * n_ + j] = c;
          next_[i * n_ + j] = next_[i * n_ + k];
        }
      }
    }
  }
}

std::vector<int> GraphDistances::walk(int a, int b) const {
  std::vector<int> w{a};
  if (next_[static_cast<size_t>(a) * n_ + static_cast<size_t>(b)] < 0) return {};
  while (a != b) {
    a = next_[static_cast<size_t>(a) * n_ + static_cast<size_t>(b)];
    w.push_back(a);
  }
  return w;
}

}  // namespace vigil::planning::patrol
