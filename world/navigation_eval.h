// Navigation figures of a run, from what was recorded: the ground truth's true robot poses and
// contact lines (ground_truth.jsonl) against what the robots' controllers reported
// (robots.jsonl): localisation error per robot once localised (RMS and worst, position and
// heading), contacts per robot-hour by what was touched, goals started, reached and failed, and
// time to goal over (planned length / cruise speed).
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "world/status.h"

namespace vigil {

struct RobotNavigationFigures {
  std::string robot;
  // Localisation, over reports that say localized.
  int reports = 0, localized_reports = 0;
  double first_localized_s = -1;      // time of the first localized report (-1: never)
  double position_rms = 0, position_worst = 0;  // m
  double heading_rms = 0, heading_worst = 0;    // rad
  // Goals.
  int goals_started = 0, goals_reached = 0, goals_failed = 0;
  std::vector<std::string> failures;  // detail of each failure
  double median_time_ratio = 0, worst_time_ratio = 0;  // time to goal / (path length / cruise speed)
  // Contacts, by what was touched (person, object, robot, wall), and those the robot drove into.
  std::map<std::string, int> contacts;
  int pushing_contacts = 0;
};

struct NavigationFigures {
  double duration_s = 0;
  std::vector<RobotNavigationFigures> robots;
  int contacts_with_people_or_objects = 0, contacts_with_robots = 0, contacts_with_walls = 0;
  double contacts_per_robot_hour = 0;  // people, objects and robots
  int pushing_contacts = 0;            // of those, the robot drove into (moving towards the other)
  double pushing_contacts_per_robot_hour = 0;
};

// Reads both files; errors name the file and line.
Result<NavigationFigures> evaluate_navigation(const std::filesystem::path& ground_truth,
                                              const std::filesystem::path& robots_log);

}  // namespace vigil
