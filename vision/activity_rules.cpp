#include "vision/activity_rules.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace vigil::vision {

namespace {

constexpr double kNsPerS = 1e9;
constexpr double kCandidateTime = 1.0;  // s: who stood by a bag in its last measured second may have taken it

int64_t ns(double seconds) { return static_cast<int64_t>(std::llround(seconds * kNsPerS)); }

double dist(double ax, double ay, double bx, double by) { return std::hypot(ax - bx, ay - by); }

bool finite_track(const Track& t) {
  return std::isfinite(t.x) && std::isfinite(t.y) && std::isfinite(t.vx) && std::isfinite(t.vy) &&
         std::isfinite(t.height) && std::isfinite(t.width) && std::isfinite(t.confidence);
}

}  // namespace

Status ActivityRuleParams::validate() const {
  struct Check {
    const char* key;
    double value;
    bool allow_zero;
  };
  const Check checks[] = {
      {"owner_distance", owner_distance, false},      {"left_bag_distance", left_bag_distance, false},
      {"left_bag_time", left_bag_time, true},          {"exchange_distance", exchange_distance, false},
      {"pickup_distance", pickup_distance, false},     {"take_distance", take_distance, false},
      {"object_match_distance", object_match_distance, false}, {"object_still_speed", object_still_speed, false},
      {"object_confirm_time", object_confirm_time, true}, {"object_gone_time", object_gone_time, true},
      {"start_time", start_time, true},                {"person_lost_time", person_lost_time, false},
      {"touch_distance", touch_distance, false},       {"touch_time", touch_time, true},
      {"occluder_radius", occluder_radius, true},      {"robot_radius", robot_radius, true},
      {"owner_window", owner_window, true},            {"person_confirm_time", person_confirm_time, true},
      {"carry_distance", carry_distance, false},       {"touch_still_speed", touch_still_speed, false},
      {"hand_gap", hand_gap, true},                    {"object_memory_time", object_memory_time, true},
  };
  for (const auto& c : checks) {
    if (!std::isfinite(c.value) || c.value < 0 || (!c.allow_zero && c.value == 0))
      return bad_input("", 0, c.key, c.allow_zero ? "must be a finite number >= 0" : "must be a finite number > 0");
    if (c.value > 1e6) return bad_input("", 0, c.key, "must be at most 1e6");
  }
  for (size_t i = 0; i < watched.size(); ++i) {
    const auto& w = watched[i];
    const std::string key = "watched[" + std::to_string(i) + "]";
    if (w.name.empty()) return bad_input("", 0, key + ".name", "must not be empty");
    if (!std::isfinite(w.position.x) || !std::isfinite(w.position.y) || !std::isfinite(w.position.z))
      return bad_input("", 0, key + ".position", "must be finite");
  }
  if (!(zone_margin >= 0) || !std::isfinite(zone_margin)) return bad_input("", 0, "zone_margin", "must be >= 0 (m)");
  for (size_t i = 0; i < handling_zones.size(); ++i) {
    const auto& z = handling_zones[i];
    if (!std::isfinite(z.x) || !std::isfinite(z.y) || !std::isfinite(z.yaw) || !(z.size_x > 0) || !(z.size_y > 0) ||
        !std::isfinite(z.size_x) || !std::isfinite(z.size_y))
      return bad_input("", 0, "handling_zones[" + std::to_string(i) + "]", "needs a finite place and positive sizes");
  }
  return Status::Ok();
}

Result<ActivityRules> ActivityRules::create(const ActivityRuleParams& params, std::string camera,
                                            std::optional<StereoCameraModel> model) {
  if (Status s = params.validate(); !s) return s.error();
  if (camera.empty()) return bad_input("", 0, "camera", "the activity rules need a camera id");
  return ActivityRules(params, std::move(camera), std::move(model));
}

bool ActivityRules::established(const Person& p, int64_t now) const {
  return p.last_seen == now && p.sightings >= 2 && now - p.first_seen >= ns(p_.person_confirm_time);
}

const ActivityRules::Person* ActivityRules::person(int id, int64_t now) const {
  const auto it = people_.find(id);
  if (it == people_.end() || now - it->second.last_seen > ns(p_.person_lost_time)) return nullptr;
  return &it->second;
}

// True when a person seen now stands between the camera and the object's place, tall enough to
// cut the line of sight to its top: a vertical cylinder against the segment camera -> object.
bool ActivityRules::hidden(const ObjectModel& o, int64_t now) const {
  if (!model_) return false;
  const Eigen::Vector3d c = model_->map_from_optical().translation();
  const double sx = o.x - c.x(), sy = o.y - c.y();
  const double len2 = sx * sx + sy * sy;
  if (len2 < 1e-9) return false;
  for (const auto& [id, p] : people_) {
    if (!established(p, now)) continue;
    const double s = ((p.x - c.x()) * sx + (p.y - c.y()) * sy) / len2;  // along the sight line
    if (s <= 0 || s >= 1) continue;
    const double off = std::hypot(c.x() + s * sx - p.x, c.y() + s * sy - p.y);
    if (off > p.width / 2 + p_.occluder_radius) continue;
    const double ray_z = c.z() + (o.z - c.z()) * s;  // height of the sight line above that point
    if (ray_z < p.height) return true;
  }
  return false;
}

Event ActivityRules::make_event(EventKind kind, int64_t now, const Point3& where, double confidence) {
  Event e;
  e.id = next_event_id_++;
  e.kind = kind;
  e.stamp_ns = now;
  e.camera = camera_;
  // At the precision the event files and messages carry (0.1 mm), so that an event read back
  // is the event written (its text included).
  auto r4 = [](double v) { return std::round(v * 1e4) / 1e4; };
  e.map_position = {r4(where.x), r4(where.y), r4(where.z)};
  if (model_) {
    const Eigen::Vector3d q = model_->optical_from_map() * Eigen::Vector3d(where.x, where.y, where.z);
    e.camera_position = {r4(q.x()), r4(q.y()), r4(q.z())};
  }
  e.confidence = std::clamp(confidence, 0.0, 1.0);
  return e;
}

Result<std::vector<Event>> ActivityRules::update(int64_t stamp_ns, const std::vector<Track>& tracks,
                                                 const std::vector<RobotPosition>& robots) {
  for (size_t i = 0; i < robots.size(); ++i)
    if (!std::isfinite(robots[i].x) || !std::isfinite(robots[i].y))
      return bad_input("", 0, "robots[" + std::to_string(i) + "]", "robot position must be finite");
  if (last_stamp_ >= 0 && stamp_ns <= last_stamp_)
    return bad_input("", 0, "t_ns",
                     "tracks out of order: tick at " + std::to_string(stamp_ns) + " ns after one at " +
                         std::to_string(last_stamp_) + " ns (camera " + camera_ + ")");
  for (const Track& t : tracks) {
    if (t.camera != camera_)
      return bad_input("", 0, "camera", "a track of camera '" + t.camera + "' given to the rules of camera '" + camera_ + "'");
    if (t.stamp_ns != stamp_ns)
      return bad_input("", 0, "t_ns", "track " + std::to_string(t.id) + " has stamp " + std::to_string(t.stamp_ns) +
                                          " ns in the tick at " + std::to_string(stamp_ns) + " ns");
    if (!finite_track(t)) return bad_input("", 0, "track", "track " + std::to_string(t.id) + " has a non-finite value");
  }
  const int64_t dt = last_stamp_ < 0 ? 0 : stamp_ns - last_stamp_;
  if (first_stamp_ < 0) first_stamp_ = stamp_ns;
  last_stamp_ = stamp_ns;

  std::vector<const Track*> bags;
  moving_bags_.clear();
  std::map<int, const Track*> by_id;
  for (const Track& t : tracks) by_id[t.id] = &t;
  for (const Track& t : tracks) {
    if (t.cls == TrackClass::kPerson) {
      Person& p = people_[t.id];
      if (p.sightings == 0 || stamp_ns - p.last_seen > ns(p_.person_lost_time)) p.first_seen = stamp_ns, p.sightings = 0;
      ++p.sightings;
      p.x = t.x;
      p.y = t.y;
      // A person the top of the image cuts is at least as tall as seen, most likely as tall as
      // anyone: her sight-line test (hidden()) takes a typical height.
      p.height = t.height > 0 ? (t.top_cut ? std::max(t.height, 1.7) : t.height) : 1.7;
      p.width = t.width > 0 ? t.width : 0.5;
      p.last_seen = stamp_ns;
      p.confidence = t.confidence;
      p.speed = std::hypot(t.vx, t.vy);
      p.vx = t.vx, p.vy = t.vy;
      p.hand_on = t.hand_on != t.id ? t.hand_on : 0;
      p.hand_seen_at = false;
      if (const auto h = by_id.find(p.hand_on); p.hand_on != 0 && h != by_id.end())
        p.hand_x = h->second->x, p.hand_y = h->second->y, p.hand_seen_at = true;
    } else if ((t.cls == TrackClass::kBag || (t.cls == TrackClass::kUnknown && in_handling_zone(t.x, t.y))) &&
               std::hypot(t.vx, t.vy) <= p_.object_still_speed) {
      bags.push_back(&t);
    } else if (t.cls == TrackClass::kBag && t.measured) {
      moving_bags_.push_back({t.x, t.y, t.id, t.vx, t.vy});
    }
  }
  // People long gone are forgotten (their ids are never reused).
  for (auto it = people_.begin(); it != people_.end();) {
    it = stamp_ns - it->second.last_seen > 10 * ns(p_.person_lost_time) ? people_.erase(it) : std::next(it);
  }
  // Who stands nearest to each bag track in its first owner_window seconds (measured frames).
  for (const Track& t : tracks) {
    if (t.cls != TrackClass::kBag) continue;
    BagTrackStart& b = bag_tracks_[t.id];
    b.last_seen = stamp_ns;
    if (!t.measured) continue;
    if (b.first < 0) b.first = stamp_ns;
    // Carried by whom: the nearest person it moves with.
    int with = -1;
    if (std::hypot(t.vx, t.vy) > p_.object_still_speed) {
      double best = p_.carry_distance;
      for (const auto& [id, p] : people_) {
        if (!established(p, stamp_ns)) continue;
        if (std::hypot(t.vx - p.vx, t.vy - p.vy) > std::max(p_.object_still_speed, 0.5 * std::hypot(t.vx, t.vy))) continue;
        const double d = dist(p.x, p.y, t.x, t.y);
        if (d <= best) best = d, with = id;
      }
    }
    b.carry_ticks = with >= 0 && with == b.carry_who ? b.carry_ticks + 1 : with >= 0 ? 1 : 0;
    b.carry_who = with;
    if (b.carry_ticks >= 3) b.carrier = with;
    if (p_.owner_window <= 0 || stamp_ns - b.first > ns(p_.owner_window)) continue;
    for (const auto& [id, p] : people_) {
      if (!established(p, stamp_ns)) continue;
      const double d = dist(p.x, p.y, t.x, t.y);
      if (d <= p_.owner_distance && d < b.distance) b.distance = d, b.nearest = id;
    }
  }
  for (auto it = bag_tracks_.begin(); it != bag_tracks_.end();) {
    it = stamp_ns - it->second.last_seen > 10 * ns(p_.person_lost_time) ? bag_tracks_.erase(it) : std::next(it);
  }

  match_objects(stamp_ns, bags, robots);
  // A robot's track measured on a confirmed object's place (a robot stopped beside a left bag, the
  // two in one blob, the bag's track taking the robot's mast) shows the place occupied: the
  // object counts as seen for the left-bag rule, as it does not leave with a robot.
  for (const Track& t : tracks) {
    if (t.cls != TrackClass::kRobot || !t.measured) continue;
    for (ObjectModel& o : objects_)
      if (o.confirmed && !o.gone && dist(t.x, t.y, o.x, o.y) <= p_.object_match_distance) o.measured_at = stamp_ns;
  }
  std::vector<Event> out;
  rule_left_bag(stamp_ns, &out);
  rule_taken(stamp_ns, dt, &out);
  rule_touch(stamp_ns, &out);
  rule_zone_touch(stamp_ns, &out);
  events_.insert(events_.end(), out.begin(), out.end());
  return out;
}

void ActivityRules::match_objects(int64_t now, const std::vector<const Track*>& bags,
                                  const std::vector<RobotPosition>& robots) {
  // Near a robot's reported position a bag track may be the robot itself: it only keeps an
  // object already confirmed there (a robot driving past a left bag), and neither starts nor
  // confirms one.
  auto near_robot = [&](const Track* t) {
    for (const RobotPosition& r : robots)
      if (dist(t->x, t->y, r.x, r.y) <= p_.robot_radius) return true;
    return false;
  };
  // Tracks to models, closest pairs first (the model's own track first at equal distance), one
  // to one: a false detection beside a bag must not take the bag's model from its track.
  struct Pair {
    double d;
    size_t track, model;
  };
  std::vector<Pair> pairs;
  for (size_t ti = 0; ti < bags.size(); ++ti) {
    const bool robot = near_robot(bags[ti]);
    for (size_t mi = 0; mi < objects_.size(); ++mi) {
      if (robot && !objects_[mi].confirmed) continue;
      const double d = dist(bags[ti]->x, bags[ti]->y, objects_[mi].x, objects_[mi].y);
      // The model's own track keeps it ahead of any nearer one (a false detection beside a bag
      // must not take its model).
      if (d <= p_.object_match_distance) pairs.push_back({d - (bags[ti]->id == objects_[mi].track ? 10.0 : 0.0), ti, mi});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return a.d != b.d ? a.d < b.d : a.track != b.track ? a.track < b.track : a.model < b.model;
  });
  std::vector<int> model_of(bags.size(), -1);
  std::vector<bool> used(objects_.size(), false);
  for (const Pair& p : pairs) {
    if (model_of[p.track] >= 0 || used[p.model]) continue;
    model_of[p.track] = static_cast<int>(p.model);
    used[p.model] = true;
  }
  for (size_t ti = 0; ti < bags.size(); ++ti) {
    const Track* t = bags[ti];
    int best = model_of[ti];
    if (best < 0) {
      // The bag of a model not seen on this tick, under the same track id, lying elsewhere: the
      // object was moved (put down a step further on, picked up and set down again), not a new
      // one; its model moves with it and keeps its owner.
      for (size_t mi = 0; mi < objects_.size() && best < 0; ++mi) {
        if (!used[mi] && objects_[mi].track == t->id && objects_[mi].last_seen != now) {
          best = static_cast<int>(mi);
          objects_[mi].sightings = 0;  // the running mean starts again at the new place
        }
      }
    }
    if (best < 0) {
      if (near_robot(t)) continue;
      // A second track on a model's place is the same object seen twice, not a new one.
      bool duplicate = false;
      for (const ObjectModel& o : objects_)
        duplicate = duplicate || dist(t->x, t->y, o.x, o.y) <= p_.object_match_distance;
      if (duplicate) continue;
      ObjectModel o;
      o.key = next_model_key_++;
      o.x = t->x;
      o.y = t->y;
      o.first_seen = now;
      // On the place of a forgotten model, and not seen carried in: that bag, seen again.
      const auto b = bag_tracks_.find(t->id);
      if (b == bag_tracks_.end() || b->second.carrier < 0) {
        auto f = std::min_element(forgotten_.begin(), forgotten_.end(), [&](const Forgotten& a, const Forgotten& c) {
          return dist(t->x, t->y, a.x, a.y) < dist(t->x, t->y, c.x, c.y);
        });
        if (f != forgotten_.end() && dist(t->x, t->y, f->x, f->y) <= p_.object_match_distance) {
          o.restored = *f;
          // Kept until the model is confirmed: a track too short to confirm one (noise, or the
          // bag glimpsed between passers-by) does not use it up.
        }
      }
      objects_.push_back(o);
      used.push_back(false);
      best = static_cast<int>(objects_.size()) - 1;
    }
    ObjectModel& o = objects_[best];
    used[best] = true;
    ++o.sightings;
    const double w = 1.0 / std::min(o.sightings, 20);  // running mean, then a slow average
    o.x += w * (t->x - o.x);
    o.y += w * (t->y - o.y);
    o.z = t->height / 2;
    o.confidence += (t->confidence - o.confidence) / o.sightings;
    o.track = t->id;
    o.last_seen = now;
    o.unseen_ns = 0;
    o.gone = false;  // seen again: whoever was near did not take it
    o.taker = -1;
    // Who stands by it is judged on frames the bag was measured on. A tracker's prediction (a bag
    // track coasting a few frames after its blob went) keeps the model, but by then whoever took
    // it has walked off with it: those near it are the ones there when it was last measured.
    // A detector misses people now and then, so those near it are whoever was within
    // pickup_distance on any measured frame of the last candidate_time (each at the place they
    // were last seen), less those since seen farther away.
    // Adds (or moves) everyone established within pickup_distance as a candidate taker.
    // Where the owner stands on a tick both are seen is kept with each candidate: the owner beside
    // the one who takes it, as they take it, makes an exchange.
    auto note_near = [&](bool seen_now_only) {
      const Person* owner = o.owner >= 0 ? person(o.owner, now) : nullptr;
      if (owner && owner->last_seen != now) owner = nullptr;
      for (const auto& [id, p] : people_) {
        if (!established(p, now) || (seen_now_only && p.last_seen != now) || dist(p.x, p.y, o.x, o.y) > p_.pickup_distance) continue;
        const int pid = id;  // a structured binding cannot be captured before C++20 in clang 14
        auto c = std::find_if(o.candidates.begin(), o.candidates.end(), [pid](const auto& c) { return c.id == pid; });
        if (c == o.candidates.end()) c = o.candidates.insert(o.candidates.end(), ObjectModel::Candidate{id});
        c->x = p.x, c->y = p.y, c->seen = now;
        if (owner && id != o.owner && p.last_seen == now) c->owner_distance = dist(owner->x, owner->y, p.x, p.y), c->owner_at = now;
      }
    };
    if (t->measured) {
      o.measured_at = now;
      const int64_t keep = ns(kCandidateTime);
      std::erase_if(o.candidates, [&](const ObjectModel::Candidate& c) {
        const auto p = people_.find(c.id);
        return now - c.seen > keep || p == people_.end() ||
               (p->second.last_seen == now && dist(p->second.x, p->second.y, o.x, o.y) > p_.pickup_distance);
      });
      note_near(false);
    } else {
      // Held, not measured: the tracker keeps a still bag at its place while something covers
      // it in the image. Whoever stands within pickup_distance of it then is the one covering
      // it, and may be picking it up out of sight: a candidate too (they are not dropped here).
      note_near(true);
    }
    if (!o.confirmed) {
      // Owner candidate: the nearest person while the model forms (on measured frames too).
      for (const auto& [id, p] : people_) {
        if (!established(p, now) || !t->measured) continue;
        const double d = dist(p.x, p.y, o.x, o.y);
        if (d <= p_.owner_distance && d < o.owner_candidate_distance) {
          o.owner_candidate_distance = d;
          o.owner_candidate = id;
        }
      }
      // ...and whoever stood nearest to this bag's track when it appeared, if the track is new
      // (a model formed on a track seen for long has its own owner candidates).
      if (auto b = bag_tracks_.find(t->id); b != bag_tracks_.end() && b->second.nearest >= 0 &&
                                            o.first_seen - b->second.first <= 2 * ns(p_.owner_window) &&
                                            b->second.distance < o.owner_candidate_distance) {
        o.owner_candidate_distance = b->second.distance;
        o.owner_candidate = b->second.nearest;
      }
      // ...but a bag seen carried in is the carrier's, whoever stands nearer when it is set down.
      if (auto b = bag_tracks_.find(t->id); b != bag_tracks_.end() && b->second.carrier >= 0) {
        o.owner_candidate = b->second.carrier;
        o.owner_candidate_distance = -1;
      }
      if (now - o.first_seen >= ns(p_.object_confirm_time) && o.sightings >= 2) {
        o.confirmed = true;
        o.at_start = o.first_seen - first_stamp_ <= ns(p_.start_time);
        o.owner = o.at_start ? -1 : o.owner_candidate;
        if (o.restored) {
          o.at_start = o.restored->at_start;
          o.owner = o.restored->owner;
          o.left_event = o.restored->left_event;
          std::erase_if(forgotten_, [&](const Forgotten& f) { return dist(f.x, f.y, o.x, o.y) <= p_.object_match_distance; });
        }
        o.confirmed_at = now;
      }
    } else if (o.owner < 0 && !o.at_start && !o.restored && now - o.confirmed_at <= ns(p_.owner_window) &&
               in_handling_zone(o.x, o.y)) {
      // A thing that appeared on a marked table during the run was put there by someone. If
      // nobody established stood by it as its model formed (the tracker lost the one who put
      // it down and found her again as a new track), the first person established beside it
      // in the owner_window after is taken as her. Handling zones only: elsewhere a model
      // without owner raises nothing, and a passer-by made its owner would leave it.
      double nd = p_.owner_distance;
      for (const auto& [id, p] : people_) {
        if (!established(p, now)) continue;
        const double d = dist(p.x, p.y, o.x, o.y);
        if (d <= nd) nd = d, o.owner = id;
      }
    }
  }
  // Models never confirmed and no longer seen were noise.
  std::erase_if(objects_, [&](const ObjectModel& o) {
    return !o.confirmed && now - o.last_seen > ns(p_.object_gone_time);
  });
}

void ActivityRules::rule_left_bag(int64_t now, std::vector<Event>* out) {
  for (ObjectModel& o : objects_) {
    if (!o.confirmed || o.owner < 0 || o.left_event || o.gone || in_handling_zone(o.x, o.y)) continue;
    const Person* owner = person(o.owner, now);
    const bool attended = owner && dist(owner->x, owner->y, o.x, o.y) <= p_.left_bag_distance;
    if (attended) {
      o.owner_away_since = -1;
      continue;
    }
    if (o.owner_away_since < 0) o.owner_away_since = now;
    const bool seen = o.measured_at >= 0 && now - o.measured_at <= ns(kCandidateTime);
    if (now - o.owner_away_since >= ns(p_.left_bag_time) && seen) {
      Event e = make_event(EventKind::kLeftBag, now, {o.x, o.y, o.z}, o.confidence);
      e.object_track = o.track;
      e.people = {o.owner};
      o.left_event = e.id;
      out->push_back(e);
    }
  }
}

void ActivityRules::rule_taken(int64_t now, int64_t dt, std::vector<Event>* out) {
  std::erase_if(forgotten_, [&](const Forgotten& f) { return now - f.when > ns(p_.object_memory_time); });
  for (auto it = objects_.begin(); it != objects_.end();) {
    ObjectModel& o = *it;
    if (!o.confirmed || o.last_seen == now || in_handling_zone(o.x, o.y)) {
      ++it;
      continue;
    }
    // Its place is empty only while it is in view and nobody stands in front of it; but a bag
    // seen carried off by someone who stood by it is gone, hidden place or not.
    if (!hidden(o, now)) o.unseen_ns += dt;
    // Carried: the same person beside a moving bag on three ticks running (a bag set down a step
    // away moves for one tick only).
    const int with = carrier(o, now);
    o.carry_ticks = with >= 0 && with == o.carry_who ? o.carry_ticks + 1 : with >= 0 ? 1 : 0;
    o.carry_who = with;
    const int carried_by = o.carry_ticks >= 3 ? with : -1;
    if (!o.gone) {
      if (o.unseen_ns < ns(p_.object_gone_time) && carried_by < 0) {
        ++it;
        continue;
      }
      // Gone. Someone who stood by it when it was last seen took it, if any of them is still
      // tracked; nobody near: it was not a bag, or it left the view; forget it.
      bool any = false;
      for (const auto& c : o.candidates) any = any || person(c.id, now);
      if (!any) {
        if (now - o.last_seen > 4 * ns(p_.person_lost_time) + ns(p_.object_gone_time)) {
          if (p_.object_memory_time > 0) forgotten_.push_back({o.x, o.y, o.owner, o.at_start, o.left_event, now});
          it = objects_.erase(it);
        } else {
          ++it;
        }
        continue;
      }
      o.gone = true;
    }
    // Who moves off with it: the one a carried bag is seen with, else the first of those who
    // stood by it to move away from the place (take_distance from it and half that from where
    // they stood) or out of view.
    if (o.taker < 0) o.taker = carried_by;
    if (o.taker < 0 && o.carry_who < 0) {
      for (const auto& c : o.candidates) {
        const Person* p = person(c.id, now);
        if (!p || (dist(p->x, p->y, o.x, o.y) >= p_.take_distance && dist(p->x, p->y, c.x, c.y) >= p_.take_distance / 2)) {
          o.taker = c.id;
          break;
        }
      }
    }
    if (o.taker < 0) {
      ++it;
      continue;
    }
    const Person* t = person(o.taker, now);
    if (o.taker == o.owner) {
      if (o.left_event) {  // the owner came back for it: withdraw the report
        Event e = make_event(EventKind::kLeftBag, now, {o.x, o.y, o.z}, o.confidence);
        --next_event_id_;
        e.id = o.left_event;
        e.cancelled = true;
        e.object_track = o.track;
        e.people = {o.owner};
        out->push_back(e);
      }
    } else {
      // An exchange when the owner stood within exchange_distance of the taker as it went: on a
      // tick within kCandidateTime of the taker's last by the bag, both seen.
      bool handover = false;
      for (const auto& c : o.candidates)
        if (c.id == o.taker)
          handover = o.owner >= 0 && c.owner_at >= 0 && c.seen - c.owner_at <= ns(kCandidateTime) &&
                     c.owner_distance <= p_.exchange_distance;
      const EventKind kind = handover ? EventKind::kExchange : EventKind::kBagTaken;
      const double conf = o.confidence * (t ? std::max(0.5, t->confidence) : 0.5);
      Event e = make_event(kind, now, {o.x, o.y, o.z}, conf);
      e.object_track = o.track;
      e.people = kind == EventKind::kExchange ? std::vector<int>{o.owner, o.taker} : std::vector<int>{o.taker};
      out->push_back(e);
    }
    it = objects_.erase(it);
  }
}

int ActivityRules::carrier(const ObjectModel& o, int64_t now) const {
  int who = -1;
  double best = p_.carry_distance;
  for (const Spot& b : moving_bags_) {
    if (b.track != o.track) {
      const auto bt = bag_tracks_.find(b.track);
      if (bt == bag_tracks_.end() || bt->second.first < o.last_seen - ns(p_.object_gone_time)) continue;
    }
    if (dist(b.x, b.y, o.x, o.y) > p_.pickup_distance + p_.take_distance + 1.0) continue;
    for (const auto& c : o.candidates) {
      const Person* p = person(c.id, now);
      if (!p || p->last_seen != now) continue;
      // ...and moving with it: someone standing beside a bag carried past is not its carrier.
      if (std::hypot(b.vx - p->vx, b.vy - p->vy) > std::max(p_.object_still_speed, 0.5 * std::hypot(b.vx, b.vy))) continue;
      const double d = dist(b.x, b.y, p->x, p->y);
      if (d <= best) best = d, who = c.id;
    }
  }
  return who;
}

template <typename Key>
bool ActivityRules::hand_tick(std::map<Key, Visit>* visits, int person, const Key& key, bool on, const Person& p, int64_t now) {
  // Visits of this person whose hand has been off them for longer than hand_gap end.
  for (auto it = visits->begin(); it != visits->end();) {
    const bool end = it->first.first == person && !(on && it->first == key) && now - it->second.last_hand > ns(p_.hand_gap);
    it = end ? visits->erase(it) : std::next(it);
  }
  if (!on) return false;
  Visit& v = visits->try_emplace(key, Visit{now, false, now}).first->second;
  v.last_hand = now;
  if (p.speed > p_.touch_still_speed) v.since = now;  // walking past: the time starts when they stop
  if (v.reported || now - v.since < ns(p_.touch_time)) return false;
  v.reported = true;
  return true;
}

void ActivityRules::rule_touch(int64_t now, std::vector<Event>* out) {
  if (p_.watched.empty()) return;
  for (const auto& [id, p] : people_) {
    if (p.last_seen != now) continue;
    if (p_.hands_seen) {
      // The marked object the hand is on: the nearest one to the handled track, within
      // object_match_distance of it.
      // Where the handled thing is: its track this tick, else the object model it last matched.
      bool known = p.hand_seen_at;
      double hx = p.hand_x, hy = p.hand_y;
      for (const ObjectModel& o : objects_)
        if (!known && p.hand_on != 0 && o.track == p.hand_on) hx = o.x, hy = o.y, known = true;
      size_t w_on = 0;
      double wd = std::numeric_limits<double>::infinity();
      for (size_t i = 0; known && i < p_.watched.size(); ++i) {
        const double d = dist(hx, hy, p_.watched[i].position.x, p_.watched[i].position.y);
        if (d < wd) wd = d, w_on = i;
      }
      const bool on = wd <= p_.object_match_distance;
      if (!hand_tick(&visits_, id, std::make_pair(id, w_on), on, p, now) || p_.watched[w_on].authorised) continue;
      const WatchedObject& w = p_.watched[w_on];
      Event e = make_event(EventKind::kUnauthorisedObject, now, w.position, p.confidence);
      e.object = w.name;
      e.people = {id};
      out->push_back(e);
      continue;
    }
    // The nearest marked object to this person.
    size_t nearest = 0;
    double nd = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < p_.watched.size(); ++i) {
      const double d = dist(p.x, p.y, p_.watched[i].position.x, p_.watched[i].position.y);
      if (d < nd) nd = d, nearest = i;
    }
    // An object the camera sees lying nearer to them than the marked one (away from the marked
    // place) is what they handle: the zone rule judges it.
    bool nearer_model = false;
    for (const ObjectModel& o : objects_) {
      if (!o.confirmed || now - o.last_seen > ns(p_.object_gone_time)) continue;
      const double d = dist(p.x, p.y, o.x, o.y);
      const WatchedObject& w = p_.watched[nearest];
      nearer_model = nearer_model || (d < nd && dist(o.x, o.y, w.position.x, w.position.y) > p_.object_match_distance);
    }
    const auto key = std::make_pair(id, nearest);
    if (nd > p_.touch_distance || nearer_model) {
      // A visit ends when the person steps back well clear (hysteresis against jitter).
      for (auto it = visits_.begin(); it != visits_.end();) {
        const auto& w = p_.watched[it->first.second];
        const bool clear = it->first.first == id && dist(p.x, p.y, w.position.x, w.position.y) > p_.touch_distance + 0.3;
        it = clear ? visits_.erase(it) : std::next(it);
      }
      continue;
    }
    auto vit = visits_.try_emplace(key, Visit{now, false}).first;
    Visit& v = vit->second;
    if (p.speed > p_.touch_still_speed) v.since = now;  // walking past: the time starts when they stop
    if (v.reported || now - v.since < ns(p_.touch_time)) continue;
    v.reported = true;
    const WatchedObject& w = p_.watched[nearest];
    if (w.authorised) continue;
    Event e = make_event(EventKind::kUnauthorisedObject, now, w.position, p.confidence);
    e.object = w.name;
    e.people = {id};
    out->push_back(e);
  }
  // Visits of people no longer seen end.
  std::erase_if(visits_, [&](const auto& kv) { return !person(kv.first.first, now); });
}

bool HandlingZone::contains(double px, double py, double margin) const {
  const double c = std::cos(yaw), s = std::sin(yaw);
  const double lx = c * (px - x) + s * (py - y), ly = -s * (px - x) + c * (py - y);
  return std::abs(lx) <= 0.5 * size_x + margin && std::abs(ly) <= 0.5 * size_y + margin;
}

bool ActivityRules::in_handling_zone(double x, double y) const {
  for (const HandlingZone& z : p_.handling_zones)
    if (z.contains(x, y, p_.zone_margin)) return true;
  return false;
}

void ActivityRules::rule_zone_touch(int64_t now, std::vector<Event>* out) {
  if (p_.handling_zones.empty()) return;
  auto in_zone = [&](const ObjectModel& o) { return in_handling_zone(o.x, o.y); };
  for (const auto& [id, p] : people_) {
    if (p.last_seen != now) continue;
    const ObjectModel* nearest = nullptr;
    double nd = std::numeric_limits<double>::infinity();
    for (const ObjectModel& o : objects_) {
      if (!o.confirmed || !in_zone(o)) continue;
      // With hands seen: the model the hand is on (its track, or the nearest to the handled one).
      const double d = !p_.hands_seen ? dist(p.x, p.y, o.x, o.y)
                       : p.hand_on == 0 ? std::numeric_limits<double>::infinity()
                       : o.track == p.hand_on ? 0.0
                       : p.hand_seen_at       ? dist(p.hand_x, p.hand_y, o.x, o.y)
                                              : std::numeric_limits<double>::infinity();
      if (d < nd) nd = d, nearest = &o;
    }
    if (p_.hands_seen) {
      const bool on = nearest && nd <= p_.object_match_distance;
      if (!hand_tick(&model_visits_, id, std::make_pair(id, on ? nearest->key : uint64_t{0}), on, p, now)) continue;
    } else if (!nearest || nd > p_.touch_distance) {
      for (auto it = model_visits_.begin(); it != model_visits_.end();) {
        bool clear = it->first.first == id;
        for (const ObjectModel& o : objects_)
          if (o.key == it->first.second) clear = clear && dist(p.x, p.y, o.x, o.y) > p_.touch_distance + 0.3;
        it = clear ? model_visits_.erase(it) : std::next(it);
      }
      continue;
    }
    if (!p_.hands_seen) {
      Visit& v = model_visits_.try_emplace({id, nearest->key}, Visit{now, false}).first->second;
      if (p.speed > p_.touch_still_speed) v.since = now;
      if (v.reported || now - v.since < ns(p_.touch_time)) continue;
      v.reported = true;
    }
    if (nearest->owner == id) continue;  // their own
    bool marked = false;                 // the operator's mark covers it
    for (const WatchedObject& w : p_.watched)
      marked = marked || dist(w.position.x, w.position.y, nearest->x, nearest->y) <= p_.object_match_distance;
    if (marked) continue;
    Event e = make_event(EventKind::kUnauthorisedObject, now, {nearest->x, nearest->y, nearest->z}, p.confidence);
    e.object_track = nearest->track;
    e.people = {id};
    out->push_back(e);
  }
  std::erase_if(model_visits_, [&](const auto& kv) { return !person(kv.first.first, now); });
}

}  // namespace vigil::vision
