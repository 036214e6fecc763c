// Small geometric value types shared by the world, planning and vision code (SI units,
// REP 103 frames: x forward, y left, z up; yaw counter-clockwise from +x).
#pragma once

#include <cmath>
#include <cstdint>

namespace vigil {

// Simulated time in integer nanoseconds.
using SimTime = int64_t;
constexpr SimTime kNsPerSecond = 1'000'000'000;
inline double to_seconds(SimTime t) { return static_cast<double>(t) * 1e-9; }
inline SimTime from_seconds(double s) { return static_cast<SimTime>(std::llround(s * 1e9)); }

struct Vec2 {
  double x = 0, y = 0;
  Vec2 operator+(Vec2 o) const { return {x + o.x, y + o.y}; }
  Vec2 operator-(Vec2 o) const { return {x - o.x, y - o.y}; }
  Vec2 operator*(double s) const { return {x * s, y * s}; }
  double dot(Vec2 o) const { return x * o.x + y * o.y; }
  double norm() const { return std::hypot(x, y); }
  bool operator==(const Vec2&) const = default;
};

struct Vec3 {
  double x = 0, y = 0, z = 0;
  bool operator==(const Vec3&) const = default;
};

// A planar pose in the map frame.
struct Pose2 {
  double x = 0, y = 0, yaw = 0;
  Vec2 position() const { return {x, y}; }
  bool operator==(const Pose2&) const = default;
};

// Wraps an angle to (-pi, pi].
inline double wrap_angle(double a) {
  a = std::fmod(a + M_PI, 2.0 * M_PI);
  if (a <= 0) a += 2.0 * M_PI;
  return a - M_PI;
}

}  // namespace vigil
