#include "vision/event_eval.h"

#include "common/lines.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

namespace vigil::vision {

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

void finish(EventScore* s, const std::vector<double>& lat, const std::vector<double>& err) {
  s->precision = s->reported ? static_cast<double>(s->matched) / s->reported : 1.0;
  s->recall = s->truth ? static_cast<double>(s->matched) / s->truth : 1.0;
  s->latency_s = median(lat);
  s->localisation_error_m = median(err);
}

}  // namespace

Result<std::vector<TruthEvent>> load_truth_events(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::vector<TruthEvent> out;
  const Status st = for_each_line(path, [&](std::string_view text, int line) -> Status {
    // Cheap filter: most lines are ticks.
    if (text.find("\"type\":\"event\"") == std::string_view::npos) return Status::Ok();
    const auto j = nlohmann::json::parse(text.begin(), text.end(), nullptr, false);
    if (j.is_discarded() || !j.is_object()) return bad_input(file, line, "", "not a JSON object");
    TruthEvent e;
    const auto kind = j.find("kind");
    if (kind == j.end() || !kind->is_string()) return bad_input(file, line, "kind", "missing or not a string");
    const auto k = parse_event_kind(kind->get<std::string>());
    if (!k) return bad_input(file, line, "kind", "unknown event kind '" + kind->get<std::string>() + "'");
    e.kind = *k;
    for (const auto& [key, dst] : {std::pair<const char*, int64_t*>{"t_ns", &e.t_ns}, {"confirmed_ns", &e.confirmed_ns}}) {
      const auto it = j.find(key);
      if (it == j.end() || !it->is_number_integer()) return bad_input(file, line, key, "missing or not an integer");
      *dst = it->get<int64_t>();
    }
    for (const auto& [key, dst] : {std::pair<const char*, double*>{"x", &e.position.x}, {"y", &e.position.y}, {"z", &e.position.z}}) {
      const auto it = j.find(key);
      if (it == j.end() || !it->is_number()) return bad_input(file, line, key, "missing or not a number");
      *dst = it->get<double>();
    }
    if (const auto o = j.find("object"); o != j.end() && o->is_string()) e.object = o->get<std::string>();
    if (const auto p = j.find("people"); p != j.end() && p->is_array()) {
      for (const auto& v : *p)
        if (v.is_string()) e.people.push_back(v.get<std::string>());
    }
    out.push_back(std::move(e));
    return Status::Ok();
  });
  if (!st) return st.error();
  return out;
}

Result<EventEvalResult> evaluate_events(const std::vector<TruthEvent>& truth, const std::vector<Event>& reports,
                                        const EventEvalOptions& o) {
  if (!(o.early_s >= 0) || !std::isfinite(o.early_s)) return bad_input("", 0, "early_s", "must be >= 0");
  if (!(o.max_latency_s >= 0) || !std::isfinite(o.max_latency_s)) return bad_input("", 0, "max_latency_s", "must be >= 0");
  if (!(o.max_distance_m > 0) || !std::isfinite(o.max_distance_m)) return bad_input("", 0, "max_distance_m", "must be > 0");
  EventEvalResult r;
  std::vector<size_t> order(truth.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return truth[a].confirmed_ns < truth[b].confirmed_ns; });
  std::vector<bool> used(reports.size(), false);
  for (size_t i = 0; i < reports.size(); ++i) used[i] = reports[i].cancelled;  // withdrawals are not reports
  for (size_t ti : order) {
    const TruthEvent& t = truth[ti];
    size_t best = reports.size();
    double best_dt = std::numeric_limits<double>::infinity();
    for (size_t ri = 0; ri < reports.size(); ++ri) {
      if (used[ri] || reports[ri].kind != t.kind) continue;
      const double dt = (reports[ri].stamp_ns - t.confirmed_ns) * 1e-9;
      if (dt < -o.early_s || dt > o.max_latency_s) continue;
      const double d = std::hypot(reports[ri].map_position.x - t.position.x, reports[ri].map_position.y - t.position.y);
      if (d > o.max_distance_m) continue;
      if (std::abs(dt) < best_dt) best_dt = std::abs(dt), best = ri;
    }
    if (best == reports.size()) {
      r.missed.push_back(ti);
      continue;
    }
    used[best] = true;
    const Event& rep = reports[best];
    r.matches.push_back({ti, best, (rep.stamp_ns - t.confirmed_ns) * 1e-9,
                         std::hypot(rep.map_position.x - t.position.x, rep.map_position.y - t.position.y)});
  }
  for (size_t ri = 0; ri < reports.size(); ++ri) {
    if (!reports[ri].cancelled && !std::any_of(r.matches.begin(), r.matches.end(), [&](const EventMatch& m) { return m.reported == ri; }))
      r.false_reports.push_back(ri);
  }
  std::map<EventKind, std::pair<std::vector<double>, std::vector<double>>> samples;
  for (const TruthEvent& t : truth) ++r.per_kind[t.kind].truth;
  for (const Event& e : reports)
    if (!e.cancelled) ++r.per_kind[e.kind].reported;
  for (const EventMatch& m : r.matches) {
    const EventKind k = truth[m.truth].kind;
    ++r.per_kind[k].matched;
    samples[k].first.push_back(m.latency_s);
    samples[k].second.push_back(m.error_m);
  }
  std::vector<double> all_lat, all_err;
  for (auto& [k, s] : r.per_kind) {
    finish(&s, samples[k].first, samples[k].second);
    r.total.truth += s.truth;
    r.total.reported += s.reported;
    r.total.matched += s.matched;
    all_lat.insert(all_lat.end(), samples[k].first.begin(), samples[k].first.end());
    all_err.insert(all_err.end(), samples[k].second.begin(), samples[k].second.end());
  }
  finish(&r.total, all_lat, all_err);
  return r;
}

}  // namespace vigil::vision
