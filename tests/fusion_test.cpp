// Fusion of event reports (planning/fusion): the particle filter over an event's position, the
// pure incident merger, and a stereo report's covariance (plugins/dds_bridge/event_server.h).
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Eigenvalues>

#include "planning/fusion/incident_merger.h"
#include "planning/fusion/position_filter.h"
#include "plugins/dds_bridge/event_server.h"

namespace vigil::planning::fusion {
namespace {

// A covariance with standard deviation `along` in direction `angle` and `across` across it.
Eigen::Matrix2d elongated(double angle, double along, double across) {
  const Eigen::Vector2d u(std::cos(angle), std::sin(angle)), v(-std::sin(angle), std::cos(angle));
  return along * along * u * u.transpose() + across * across * v * v.transpose();
}

// Two cameras see an event at (5, 3) from perpendicular sides: each is sure of its bearing
// (3 cm across) and unsure of its range (40 cm along), and each report is off along its range.
// Fused, the belief sits where the two ellipses cross: closer than either report, and far
// sharper than either alone.
TEST(PositionFilter, TwoCamerasFromDifferentSidesSharpenTheBelief) {
  const Eigen::Vector2d truth(5, 3);
  const Eigen::Vector2d a = truth + Eigen::Vector2d(0.35, 0.0);   // camera looking along x
  const Eigen::Vector2d b = truth + Eigen::Vector2d(0.0, -0.30);  // camera looking along y
  PositionFilter f(7);
  f.init(a, elongated(0.0, 0.4, 0.03));
  const double alone = f.major_std();
  EXPECT_NEAR(alone, 0.4, 0.05);
  ASSERT_TRUE(f.update(b, elongated(M_PI / 2, 0.4, 0.03)));
  const double fused = f.major_std();
  EXPECT_LT(fused, 0.08) << "alone " << alone;
  EXPECT_LT((f.mean() - truth).norm(), 0.08);
  EXPECT_LT((f.mean() - truth).norm(), std::min((a - truth).norm(), (b - truth).norm()) / 3);
  EXPECT_EQ(f.updates(), 1);
  EXPECT_GT(f.effective_sample_size(), 10.0);  // resampled, not collapsed to one particle
  // The same seed, the same belief, to the bit.
  PositionFilter g(7);
  g.init(a, elongated(0.0, 0.4, 0.03));
  g.update(b, elongated(M_PI / 2, 0.4, 0.03));
  EXPECT_EQ(g.mean(), f.mean());
}

// A wall at x = 5.2: the belief of an object seen by one camera looking along x, whose range
// uncertainty reaches through the wall, keeps no particle beyond it.
TEST(PositionFilter, KeepsTheBeliefOutOfWalls) {
  auto free = [](double x, double) { return x <= 5.2; };
  PositionFilter f(3, {}, free);
  f.init({5.0, 3.0}, elongated(0.0, 0.5, 0.03));
  for (const auto& p : f.particles()) EXPECT_LE(p.x(), 5.2);
  EXPECT_LT(f.mean().x(), 5.0) << "the cut-off tail pulls the mean to the free side";
}

TEST(PositionFilter, AReportInconsistentWithTheBeliefLeavesItAsItWas) {
  PositionFilter f(1);
  f.init({0, 0}, elongated(0, 0.05, 0.05));
  const Eigen::Vector2d before = f.mean();
  EXPECT_FALSE(f.update({3, 0}, elongated(0, 0.05, 0.05)));
  EXPECT_EQ(f.mean(), before);
  EXPECT_EQ(f.updates(), 0);
}

Report report(const std::string& camera, uint64_t id, double x, double y, const Eigen::Matrix2d& cov, int64_t t_ns) {
  Report r;
  r.camera = camera;
  r.id = id;
  r.kind = "left_bag";
  r.stamp_ns = t_ns;
  r.position = {x, y, 0.2};
  r.covariance = cov;
  return r;
}

TEST(IncidentMerger, ASecondCameraSReportIsFusedAndMovesTheIncident) {
  IncidentMerger m({"cam_a", "cam_b"}, {}, [](double, double) { return true; });
  auto o = m.add(report("cam_a", 4, 5.35, 3.0, elongated(0.0, 0.4, 0.03), 10'000'000'000));
  ASSERT_EQ(o.what, IncidentMerger::Outcome::kNew);
  EXPECT_EQ(o.incident.id, 1000004u);
  EXPECT_DOUBLE_EQ(o.incident.position.x, 5.35);  // one report: its own place
  o = m.add(report("cam_b", 9, 5.0, 2.7, elongated(M_PI / 2, 0.4, 0.03), 11'000'000'000));
  ASSERT_EQ(o.what, IncidentMerger::Outcome::kMerged) << o.reason;
  EXPECT_TRUE(o.moved);
  EXPECT_EQ(o.incident.id, 1000004u);
  EXPECT_EQ(o.incident.reports, 2);
  EXPECT_LT(std::hypot(o.incident.position.x - 5.0, o.incident.position.y - 3.0), 0.08);
  EXPECT_LT(std::sqrt(o.incident.covariance.eigenvalues().real().maxCoeff()), 0.08);
  EXPECT_EQ(m.incidents().size(), 1u);
  // A report with a broken covariance is refused with the reason.
  Report bad = report("cam_b", 10, 6.0, 3.0, elongated(0, 0.1, 0.1), 12'000'000'000);
  bad.covariance(0, 0) = std::nan("");
  o = m.add(bad);
  EXPECT_EQ(o.what, IncidentMerger::Outcome::kRejected);
  EXPECT_NE(o.reason.find("covariance"), std::string::npos) << o.reason;
}

// A stereo camera looking along the map's +x from 6.5 m: its report's uncertainty is long along
// x (the range: Z^2 sigma_d / (f B) = 0.21 m) and short across (Z sigma_u / f = 1.2 cm).
TEST(ReportCovariance, LongAlongTheViewingRayShortAcross) {
  vision::CameraPose pose;  // at the origin, yaw 0: looking along +x
  pose.position = {0, 0, 1.0};
  const vision::StereoCameraModel cam(vision::Intrinsics{}, 0.09, pose);
  const Eigen::Matrix2d c = dds::report_covariance(cam, {0, 0, 6.5});
  EXPECT_NEAR(std::sqrt(c(0, 0)), 6.5 * 6.5 * 0.25 / (554.256 * 0.09), 0.005);
  EXPECT_NEAR(std::sqrt(c(1, 1)), 6.5 / 554.256, 0.002);
  EXPECT_NEAR(c(0, 1), 0.0, 1e-6);
}

}  // namespace
}  // namespace vigil::planning::fusion
