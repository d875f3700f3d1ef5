// Odometry posted from a callback thread without the node's lock (BodyRegistry::postOdometry,
// the body's StateSlot) while cycles collect it on another thread (BodyRegistry::update): every
// state a cycle reads is one that was posted, whole (pose, twist, stamp and frame of the same
// message), states never go back, the last one is never lost, and every message is counted
// once: accepted, dropped as invalid or ignored as out of order.
#include "vadop_ros/body_registry.h"
#include "fake_tf.h"
#include "yaml_xmlrpc.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <string>
#include <thread>

namespace {

using vadop_ros::BodyRegistry;
using vadop_ros::InputResult;

const char* kBodies = R"(
stale_timeout: 1000.0
bodies:
  - {name: odo, odom_topic: /odo, shape: {type: sphere, radius: 0.5}}
  - {name: other, odom_topic: /other, shape: {type: sphere, radius: 0.5}}
)";

const ros::Time kBase(1000.0);

ros::Time stampOf(int k) { return kBase + ros::Duration(1e-3 * k); }
std::string frameOf(int k) { return "child_" + std::to_string(k % 7) + std::string(k % 3 == 0 ? 40 : 0, 'x'); }

// Message k: every field says k, so a state mixing two messages shows.
nav_msgs::Odometry message(int k) {
  nav_msgs::Odometry m;
  m.header.stamp = stampOf(k);
  m.header.frame_id = "odom";
  m.child_frame_id = frameOf(k);
  m.pose.pose.position.x = k;
  m.pose.pose.position.y = -k;
  m.pose.pose.position.z = 0.5 * k;
  m.pose.pose.orientation.w = 1.0;
  m.twist.twist.linear.x = 1e-3 * k;
  m.twist.twist.angular.z = -1e-3 * k;
  return m;
}

TEST(IngestThreads, CyclesReadWholeStatesAndLoseNone) {
  BodyRegistry registry(vadop_ros::parseParams(vadop_test::yaml(kBodies)),
                        [](const std::string&, std::string&) { return false; }, vadop_ros::makeDefaultMeshLoader());
  vadop_test::FakeTf tf;
  const size_t odo = static_cast<size_t>(registry.find("odo"));
  constexpr int kMessages = 200000;
  std::atomic<bool> done{false};
  uint64_t sent_invalid = 0, sent_old = 0, sent_accepted = 0;
  std::thread callback([&] {
    for (int k = 1; k <= kMessages; ++k) {
      nav_msgs::Odometry m = message(k);
      const ros::Time receipt = stampOf(k);
      if (k % 13 == 0) {
        m.twist.twist.linear.y = std::numeric_limits<double>::quiet_NaN();  // dropped, state kept
        EXPECT_EQ(registry.postOdometry(odo, m, receipt), InputResult::kInvalid);
        ++sent_invalid;
        continue;
      }
      EXPECT_EQ(registry.postOdometry(odo, m, receipt), InputResult::kAccepted);
      ++sent_accepted;
      if (k % 10 == 0) {  // its duplicate: ignored
        EXPECT_EQ(registry.postOdometry(odo, m, receipt), InputResult::kOutOfOrder);
        ++sent_old;
      }
    }
    done = true;
  });
  // The cycle: collects whatever was posted and checks the state it reads.
  const vadop_ros::Body& b = registry.bodies()[odo];
  int last_k = 0, cycles = 0, changes = 0;
  auto check = [&]() {
    registry.update(stampOf(kMessages), tf);
    ++cycles;
    if (!b.has_state) return;
    const vadop_ros::VelocityState& s = *b.velocityState();
    const int k = static_cast<int>(std::lround(s.pose.translation().x()));
    ASSERT_GE(k, 1);
    ASSERT_LE(k, kMessages);
    ASSERT_NE(k % 13, 0) << "an invalid message became the state";
    ASSERT_EQ(s.pose.translation().y(), -k) << "torn pose at k = " << k;
    ASSERT_EQ(s.pose.translation().z(), 0.5 * k) << "torn pose at k = " << k;
    ASSERT_EQ(s.v.x(), 1e-3 * k) << "torn twist at k = " << k;
    ASSERT_EQ(s.w.z(), -1e-3 * k) << "torn twist at k = " << k;
    ASSERT_EQ(s.stamp, stampOf(k)) << "torn stamp at k = " << k;
    ASSERT_EQ(s.child_frame, frameOf(k)) << "torn frame at k = " << k;
    ASSERT_EQ(s.source_frame, "odom");
    ASSERT_EQ(b.status.last_receipt, stampOf(k)) << "receipt of another message at k = " << k;
    ASSERT_GE(k, last_k) << "the state went back";
    changes += k != last_k ? 1 : 0;
    last_k = k;
  };
  while (!done) {
    check();
    if (::testing::Test::HasFatalFailure()) break;
  }
  callback.join();
  check();
  static_assert(kMessages % 13 != 0, "the last message is a valid one");
  EXPECT_EQ(last_k, kMessages) << "the last message was lost";
  EXPECT_EQ(b.status.accepted, sent_accepted);
  EXPECT_EQ(b.status.dropped_invalid, sent_invalid);
  EXPECT_EQ(b.status.dropped_out_of_order, sent_old);
  EXPECT_EQ(b.sources.front()->counts().accepted, sent_accepted);
  EXPECT_EQ(b.sources.front()->counts().dropped, sent_invalid);
  EXPECT_NE(b.status.last_invalid.find("twist.twist.linear"), std::string::npos) << b.status.last_invalid;
  // The other body got nothing.
  EXPECT_FALSE(registry.bodies()[static_cast<size_t>(registry.find("other"))].has_state);
  // Both threads really overlapped: the cycle saw many intermediate states.
  EXPECT_GT(changes, 10) << cycles << " cycles";
}

// reset() (time jumped back) clears the slot too: an older stamp is accepted afterwards, and
// nothing posted before the reset comes back.
TEST(IngestThreads, ResetClearsTheSlot) {
  BodyRegistry registry(vadop_ros::parseParams(vadop_test::yaml(kBodies)),
                        [](const std::string&, std::string&) { return false; }, vadop_ros::makeDefaultMeshLoader());
  vadop_test::FakeTf tf;
  const size_t odo = static_cast<size_t>(registry.find("odo"));
  EXPECT_EQ(registry.postOdometry(odo, message(50), stampOf(50)), InputResult::kAccepted);
  registry.reset();
  registry.update(stampOf(50), tf);
  EXPECT_FALSE(registry.bodies()[odo].has_state);
  EXPECT_EQ(registry.postOdometry(odo, message(20), stampOf(20)), InputResult::kAccepted);
  registry.update(stampOf(20), tf);
  ASSERT_TRUE(registry.bodies()[odo].has_state);
  EXPECT_EQ(registry.bodies()[odo].velocityState()->pose.translation().x(), 20.0);
}

}  // namespace
