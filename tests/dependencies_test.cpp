// Tests that every dependency of the design is found, links and works on this machine, so later
// parts only use them: OSMesa gives an off-screen GL context and renders, Cyclone DDS creates a
// participant on the shipped loopback configuration, OMPL plans in a 2D box, urdfdom parses,
// Box2D steps, OpenCV and Eigen compute.
#include <gtest/gtest.h>

#include <GL/osmesa.h>
#include <GL/gl.h>
#include <box2d/box2d.h>
#include <dds/dds.h>

#include <Eigen/Dense>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/SimpleSetup.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <opencv2/imgproc.hpp>
#include <urdf_parser/urdf_parser.h>

#include "tests/test_util.h"

namespace {

TEST(Dependencies, OsmesaRendersOffScreen) {
  const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 24, OSMESA_PROFILE, OSMESA_COMPAT_PROFILE, 0};
  OSMesaContext ctx = OSMesaCreateContextAttribs(attribs, nullptr);
  ASSERT_NE(ctx, nullptr);
  std::vector<unsigned char> buf(64 * 48 * 4);
  ASSERT_TRUE(OSMesaMakeCurrent(ctx, buf.data(), GL_UNSIGNED_BYTE, 64, 48));
  glClearColor(1.0f, 0.0f, 0.0f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT);
  glFinish();
  EXPECT_EQ(buf[0], 255);
  EXPECT_EQ(buf[1], 0);
  OSMesaDestroyContext(ctx);
}

TEST(Dependencies, CycloneDdsParticipantOnLoopback) {
  const std::string cfg =
      "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface address=\"127.0.0.1\"/>"
      "</Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto"
      "</ParticipantIndex><MaxAutoParticipantIndex>20</MaxAutoParticipantIndex><Peers><Peer address=\"127.0.0.1\"/>"
      "</Peers></Discovery></Domain></CycloneDDS>";
  const dds_entity_t domain = dds_create_domain(77, cfg.c_str());
  ASSERT_GT(domain, 0) << dds_strretcode(domain);
  const dds_entity_t participant = dds_create_participant(77, nullptr, nullptr);
  EXPECT_GT(participant, 0) << dds_strretcode(participant);
  dds_delete(domain);
}

TEST(Dependencies, OmplPlansInABox) {
  namespace ob = ompl::base;
  namespace og = ompl::geometric;
  auto space = std::make_shared<ob::RealVectorStateSpace>(2);
  ob::RealVectorBounds bounds(2);
  bounds.setLow(0);
  bounds.setHigh(10);
  space->setBounds(bounds);
  og::SimpleSetup ss(space);
  // A wall at x in [4, 6] with a gap above y = 8.
  ss.setStateValidityChecker([](const ob::State* s) {
    const auto* v = s->as<ob::RealVectorStateSpace::StateType>();
    return !(v->values[0] > 4 && v->values[0] < 6 && v->values[1] < 8);
  });
  ob::ScopedState<> start(space), goal(space);
  start[0] = 1;
  start[1] = 1;
  goal[0] = 9;
  goal[1] = 1;
  ss.setStartAndGoalStates(start, goal);
  ss.setPlanner(std::make_shared<og::RRTConnect>(ss.getSpaceInformation()));
  ompl::msg::setLogLevel(ompl::msg::LOG_NONE);
  ASSERT_TRUE(ss.solve(2.0));
  EXPECT_TRUE(ss.haveExactSolutionPath());
}

TEST(Dependencies, UrdfdomBox2dOpenCvEigen) {
  auto model = urdf::parseURDF(
      "<robot name='r'><link name='base_link'><collision><geometry><box size='1 2 3'/></geometry></collision></link></robot>");
  ASSERT_TRUE(model);
  EXPECT_EQ(model->getName(), "r");

  b2World world(b2Vec2(0, -10));
  b2BodyDef def;
  def.type = b2_dynamicBody;
  b2Body* body = world.CreateBody(&def);
  b2CircleShape c;
  c.m_radius = 0.5f;
  body->CreateFixture(&c, 1.0f);
  for (int i = 0; i < 60; ++i) world.Step(1.0f / 60, 8, 3);
  EXPECT_NEAR(body->GetPosition().y, -5.0, 0.2);  // free fall for one second

  cv::Mat img = cv::Mat::zeros(10, 10, CV_8U);
  cv::rectangle(img, {2, 2}, {5, 5}, 255, cv::FILLED);
  EXPECT_EQ(cv::countNonZero(img), 16);

  Eigen::Matrix2d m;
  m << 2, 0, 0, 4;
  EXPECT_DOUBLE_EQ(m.inverse()(1, 1), 0.25);
}

}  // namespace
