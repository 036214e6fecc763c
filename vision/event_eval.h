// Event evaluation: a run's reported events (events.jsonl) against the ground-truth events the
// simulator derived from the scripts (the "event" lines of ground_truth.jsonl). Per kind:
// precision, recall, latency (seconds from the moment the rule's own thresholds were met in the
// ground truth, e.g. owner away for T, to the report) and localisation error (metres in the
// floor plane, map frame); and the same over all kinds.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "common/status.h"
#include "vision/event.h"

namespace vigil::vision {

struct TruthEvent {
  EventKind kind = EventKind::kLeftBag;
  int64_t t_ns = 0;          // the situation arose (owner stepped away, bag picked up)
  int64_t confirmed_ns = 0;  // the rule's thresholds were met: when the report is due
  Point3 position;           // map frame
  std::string object;
  std::vector<std::string> people;
};

// The "event" lines of a ground_truth.jsonl; errors name the file, line and key.
Result<std::vector<TruthEvent>> load_truth_events(const std::filesystem::path& path);

struct EventEvalOptions {
  double early_s = 1.0;          // a report may come this long before the due moment...
  double max_latency_s = 10.0;   // ...and at most this long after it
  double max_distance_m = 1.5;   // and this close (floor plane) to the true place
};

struct EventScore {
  int truth = 0;       // ground-truth events
  int reported = 0;    // reports (cancellations are not reports)
  int matched = 0;     // true positives
  double precision = 1, recall = 1;  // 1 when there is nothing to divide
  double latency_s = 0;              // median over matches (NaN when none)
  double localisation_error_m = 0;   // median over matches (NaN when none)
};

struct EventMatch {
  size_t truth;     // index into the truth list
  size_t reported;  // index into the reports
  double latency_s, error_m;
};

struct EventEvalResult {
  std::map<EventKind, EventScore> per_kind;  // every kind present in the truth or the reports
  EventScore total;
  std::vector<EventMatch> matches;
  std::vector<size_t> missed;           // truth indices
  std::vector<size_t> false_reports;    // report indices
};

// Matches reports to truth per kind, one to one, in order of due time: each truth event takes the
// unmatched report of its kind that is closest in time within [due - early_s, due + max_latency_s]
// and within max_distance_m.
Result<EventEvalResult> evaluate_events(const std::vector<TruthEvent>& truth, const std::vector<Event>& reports,
                                        const EventEvalOptions& options = {});

}  // namespace vigil::vision
