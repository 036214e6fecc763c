// Activity rules (chapter 10.5 and 10.6.1): simple rule sets on proximity and trajectories that
// turn one camera's map-frame tracks, tick by tick, into events. They read only Track records,
// so they work behind any tracker (the plan-view tracker, the ground-truth sensor model, the
// MSER tracker later).
//
// Object models. A bag-class track (or, in a handling zone, an unknown one: a laptop on the
// marked table) that stays still becomes an object model once seen for
// object_confirm_time; models are kept by place, not by track id, so a tracker that loses a bag
// and finds it again under a new id still has one object. When a model appears, the nearest
// person within owner_distance becomes its owner (the chapter: "models will be generated for
// that bag and for the nearest person"; the bag appears with its track, so the person nearest to
// the track in its first owner_window seconds counts, as do those near the model while it forms);
// a model first seen within start_time of the first tick,
// or with nobody near, has no owner ("present at the beginning of the sequence"). A bag whose
// track was seen carried in belongs to its carrier. Only person tracks that have lasted
// person_confirm_time count as owners, takers or occluders.
//
// Rules.
//  - left bag: the owner's track is farther than left_bag_distance (or gone) for left_bag_time,
//    and the bag is seen (its track measured within the last second): a bag the tracker holds
//    hidden behind someone when it falls due is reported once it is seen again, and not at all
//    if it turns out gone (picked up behind them: then bag taken). If the owner then takes the
//    bag back, a cancellation (same id, cancelled = true) follows.
//  - bag taken / exchange: the bag goes (its place is in view, not hidden behind a person, and
//    has no bag for object_gone_time; or its bag is seen carried off) and someone who stood within
//    pickup_distance of it in its last measured second (Track::measured; a tracker's coasting
//    prediction of a bag whose blob has gone says nothing about who stood by it), or by it while
//    the tracker held it unmeasured (a mono tracker holds a covered still bag: whoever covers it
//    may be picking it up out of sight), moves off with it: the one a moving bag track goes with (carry_distance, same velocity, three ticks), else
//    the first of them to move away (take_distance from the place and half that from where they
//    stood) or out of view. The owner taking it back is no event; anybody else raises "exchange"
//    when the owner stood within exchange_distance of them as they took it (on a tick, both seen,
//    within a second of the taker's last by the bag), else "bag taken"
//    (also for bags present at the start or left by another).
//  - unauthorised object: a person stands (slower than touch_still_speed) within touch_distance of a marked object (WatchedObject;
//    the operator marks what may not be handled, as the laptop of the chapter's lab) for
//    touch_time, and that object is the nearest marked one to them. Once per visit.
//    In a handling zone (HandlingZone: the operator marks a table, not the objects), the objects
//    are what the camera reports there: a person staying within touch_distance of an object
//    model lying in the zone for touch_time, the nearest such model to them, raises it unless
//    they own the model (the chapter: handling an object present at the start, or left by
//    another, is an alert; handling what one brought is not). A marked object at the model's
//    place is left to the rule above. Objects in a handling zone are judged by this rule only
//    (no left bag or bag taken for a book put on the lab table). A thing that appears in a zone
//    during the run with no established person by it as its model forms (the one who put it
//    down lost by the tracker and found again as a new track) belongs to the first person
//    established within owner_distance of it in the owner_window after.
// Small objects on tables are part of the background to a plan-view tracker, which is why
// handling them is judged against marked places rather than tracks.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/status.h"
#include "vision/event.h"
#include "vision/stereo_camera_model.h"
#include "vision/track.h"

namespace vigil::vision {

// A place the operator has marked (a table): an object seen lying there may be handled only by
// whoever put it there.
struct HandlingZone {
  std::string name;
  double x = 0, y = 0, yaw = 0;    // centre and orientation (map frame)
  double size_x = 0, size_y = 0;   // m
  bool contains(double px, double py, double margin) const;
};

// An object the operator has marked: handling it raises "unauthorised object" unless authorised.
struct WatchedObject {
  std::string name;
  Point3 position;  // map frame: centre of the object
  bool authorised = false;
};

struct ActivityRuleParams {
  double owner_distance = 1.5;       // m: the nearest person this close when a bag appears owns it
  double owner_window = 1.5;         // s from a bag track's first measured frame during which the
                                     // person nearest to it is a candidate owner, even while the bag
                                     // still moves or is then hidden (put down, its owner stepping
                                     // away in front of it: the model forms with nobody near); 0 = off
  double left_bag_distance = 3.0;    // D (m)
  double left_bag_time = 5.0;        // T (s)
  double exchange_distance = 1.5;    // m between the owner and the taker when the bag goes
  double pickup_distance = 1.2;      // m from the bag's place to a person who may have picked it up
  double take_distance = 1.0;        // m the taker must move from the place (moving away with it)
  double object_match_distance = 0.5;  // m: a bag track this close to a model is that model
  double object_still_speed = 0.3;   // m/s: faster bag tracks are carried, not lying
  double object_confirm_time = 0.5;  // s a still bag must be seen before it is a model
  double object_gone_time = 0.5;     // s a model's place must be visible and empty before it is gone
  double start_time = 1.0;           // s: models first seen this soon after the first tick were there at the start
  double person_lost_time = 1.0;     // s: a person track unseen this long is gone
  double touch_distance = 1.0;       // m from a person's centre to a marked object
  double touch_time = 1.0;           // s within touch_distance, standing (not walking past)
  double touch_still_speed = 0.4;    // m/s: a person faster than this walks past, handles nothing
  double occluder_radius = 0.3;      // m: a person this close to the line of sight hides an object
  double robot_radius = 0.5;         // m: a bag track this close to a robot's reported position (the
                                     // robot's own footprint and its localisation error) is that robot
                                     // (a far robot whose mast the camera does not resolve looks like a
                                     // bag): it does not start or confirm an object model. A bag beside
                                     // a stopped robot lies farther out and is an object like any other
  double person_confirm_time = 0.3;  // s a person track must last before it can own, take or hide a bag
  double carry_distance = 0.8;       // m: a moving bag track this close to a person is carried by them
  // s a confirmed model that vanished with nobody near (forgotten: its place looked empty, yet
  // nobody could have taken it, e.g. while people the tracker lost stood in front of it) is
  // remembered at its place: a bag seen there again within object_match_distance, and not seen
  // carried in, is that bag (its owner, whether it was there at the start, its left-bag report),
  // not a new one owned by whoever passes then. 0 = off
  double object_memory_time = 300.0;
  std::vector<WatchedObject> watched;
  std::vector<HandlingZone> handling_zones;
  double zone_margin = 0.3;          // m around a zone that still counts as on it
  // The tracker sees hands (Tracker::sees_hands: Track::hand_on names the object a person's hand
  // is on). Handling is then judged by the hand, not by distance: a person whose hand is seen on
  // an object (a marked one within object_match_distance of it, or a model in a handling zone)
  // for touch_time, standing, handles it; gaps in the hand's sighting up to hand_gap are bridged.
  // A mono camera places someone behind a table only roughly, and someone beside an object is not
  // handling it.
  bool hands_seen = false;
  double hand_gap = 0.5;             // s
  // Checks every value; the key names the parameter.
  Status validate() const;
};

class ActivityRules {
 public:
  // `camera` names the camera in the events; `model` (optional) gives the camera's pose for the
  // camera-frame position of events and for occlusion (without it no place counts as hidden).
  static Result<ActivityRules> create(const ActivityRuleParams& params, std::string camera,
                                      std::optional<StereoCameraModel> model = std::nullopt);

  // One camera tick: every track of this camera at `stamp_ns` (empty when nothing is tracked).
  // Stamps must increase; tracks of another camera or with non-finite values are errors.
  // `robots`: where the patrol robots say they are now (map frame, their own pose estimates, as
  // they publish them), so that a robot seen as a bag is not taken for a new object.
  struct RobotPosition {
    double x = 0, y = 0;
  };
  Result<std::vector<Event>> update(int64_t stamp_ns, const std::vector<Track>& tracks,
                                    const std::vector<RobotPosition>& robots = {});

  // Every event so far, in order.
  const std::vector<Event>& events() const { return events_; }

  // A bag model forgotten with nobody near it (object_memory_time): where it lay, its owner,
  // whether it was there at the start, its left-bag event, and when it was forgotten.
  struct Forgotten {
    double x = 0, y = 0;
    int owner = -1;
    bool at_start = false;
    uint64_t left_event = 0;
    int64_t when = 0;
  };
  struct ObjectModel {
    uint64_t key = 0;              // unique over the run
    int track = -1;                // the last bag track matched to it
    double x = 0, y = 0, z = 0;    // its place (running mean) and height (m)
    int64_t first_seen = 0, last_seen = 0;
    int64_t measured_at = -1;      // last tick its track was measured (not held or predicted)
    int sightings = 0;
    bool confirmed = false;
    int64_t confirmed_at = 0;
    bool at_start = false;
    int owner = -1;                // person track id, -1 none
    double owner_candidate_distance = 1e9;
    int owner_candidate = -1;
    int64_t owner_away_since = -1;
    uint64_t left_event = 0;       // id of its left-bag event, 0 = none
    int64_t unseen_ns = 0;         // visible-and-empty time since last seen
    // Everyone within pickup_distance of it when it was last measured, and where they stood:
    // who may have picked it up.
    struct Candidate {
      int id = -1;
      double x = 0, y = 0;
      int64_t seen = 0;
      double owner_distance = 1e9;  // from the owner, on the last tick both were seen (owner_at)
      int64_t owner_at = -1;
    };
    std::vector<Candidate> candidates;
    bool gone = false;             // its place has been seen empty for object_gone_time
    int taker = -1;                // who moved off with it once gone, -1 = not known yet
    int carry_who = -1, carry_ticks = 0;  // who a moving bag is seen with, on how many ticks running
    double confidence = 0;         // mean confidence of its sightings
    // A forgotten model this one was found on the place of (object_memory_time): what it takes
    // over when it is confirmed.
    std::optional<Forgotten> restored;
  };
  const std::vector<ObjectModel>& objects() const { return objects_; }

 private:
  struct Person {
    double x = 0, y = 0, height = 1.7, width = 0.5;
    int64_t first_seen = 0, last_seen = 0;
    int sightings = 0;
    double confidence = 0;
    double speed = 0;  // m/s, as the tracker gives it
    double vx = 0, vy = 0;
    int hand_on = 0;                  // the track their hand is on this tick (0: none)
    double hand_x = 0, hand_y = 0;    // ...and where that track is this tick
    bool hand_seen_at = false;        // ...if it is among this tick's tracks
  };
  // A person track seen on this tick that has lasted person_confirm_time: a single-frame false
  // detection owns nothing, takes nothing and hides nothing.
  bool established(const Person& p, int64_t now) const;
  struct Visit {
    int64_t since = 0;
    bool reported = false;
    int64_t last_hand = -1;  // hands_seen: when the hand was last seen on it
  };
  // hands_seen: one tick of a person's hand on (or off) an object; true when the visit has just
  // lasted touch_time (report it). Visits whose hand has been off longer than hand_gap end.
  template <typename Key>
  bool hand_tick(std::map<Key, Visit>* visits, int person, const Key& key, bool on, const Person& p, int64_t now);
  // A bag track's first frames: who stood nearest to it then (see owner_window).
  struct BagTrackStart {
    int64_t first = -1, last_seen = 0;
    int nearest = -1;
    double distance = 1e9;
    // Who carried it last: the person it moved with (within carry_distance, at their velocity)
    // on three measured ticks running; -1 none seen.
    int carrier = -1;
    int carry_who = -1, carry_ticks = 0;
  };

  ActivityRules(const ActivityRuleParams& p, std::string camera, std::optional<StereoCameraModel> model)
      : p_(p), camera_(std::move(camera)), model_(std::move(model)) {}

  const Person* person(int id, int64_t now) const;
  bool hidden(const ObjectModel& o, int64_t now) const;
  void match_objects(int64_t now, const std::vector<const Track*>& bags, const std::vector<RobotPosition>& robots);
  void rule_left_bag(int64_t now, std::vector<Event>* out);
  void rule_taken(int64_t now, int64_t dt, std::vector<Event>* out);
  void rule_touch(int64_t now, std::vector<Event>* out);
  Event make_event(EventKind kind, int64_t now, const Point3& where, double confidence);

  ActivityRuleParams p_;
  std::string camera_;
  std::optional<StereoCameraModel> model_;
  int64_t first_stamp_ = -1, last_stamp_ = -1;
  std::map<int, Person> people_;
  std::map<int, BagTrackStart> bag_tracks_;  // by bag track id
  std::vector<ObjectModel> objects_;
  std::vector<Forgotten> forgotten_;  // see object_memory_time
  std::map<std::pair<int, size_t>, Visit> visits_;  // (person, watched index)
  std::map<std::pair<int, uint64_t>, Visit> model_visits_;  // (person, object model key)
  uint64_t next_model_key_ = 1;
  void rule_zone_touch(int64_t now, std::vector<Event>* out);
  bool in_handling_zone(double x, double y) const;
  std::vector<Event> events_;
  uint64_t next_event_id_ = 1;
  struct Spot {
    double x = 0, y = 0;
    int track = -1;
    double vx = 0, vy = 0;
  };
  std::vector<Spot> moving_bags_;  // bag tracks of this tick that move (carried)
  // The candidate who is seen carrying the model's bag off: a moving bag track within
  // carry_distance of them that is the model's own track, or one that appeared only as the
  // model went (not a bag someone carried in past it). -1 none.
  int carrier(const ObjectModel& o, int64_t now) const;
};

}  // namespace vigil::vision
