#!/usr/bin/python3
"""rostest node of test/tutorials/mobile_manipulator.test: what docs/tutorials/mobile_manipulator.md
promises. The robot of urdf/agent.urdf stands at the origin (odometry: twist zero) with its mast
joint at 0.6 rad (joint states: the mast leans forward, its front edge 0.585 m ahead of the base's
centre, ahead of the base's 0.3 m radius). Its timed plan waits 1 s, then drives +x at 0.5 m/s
into the shelf (face at x = 2.0). The simulated robot follows the plan exactly. While it waits
only the plan predicts a contact, and the joint states make the mast, not the base, hit first:
every report must give the mast's impact and the base's at their analytic times within 50 ms."""
import math
import sys
import unittest

import rospy
import rostest
from nav_msgs.msg import Odometry, Path
from sensor_msgs.msg import JointState

import tutorial_sim

MAST = 0.6                 # rad, mast_joint (about y: positive leans the mast towards +x)
# urdf/agent.urdf: joint 0.1 m ahead of the base centre, mast box 0.08 x 0.08 x 0.8 above it.
MAST_FRONT = 0.1 + 0.8 * math.sin(MAST) + 0.04 * math.cos(MAST)
BASE_RADIUS = 0.3
SHELF_FACE = 2.0           # config/tutorials/mobile_manipulator.yaml: 0.4 m box centred at 2.2
WAIT, SPEED = 1.0, 0.5     # the plan: stand WAIT s, then drive at SPEED
PLAN_SECONDS = 8.0
HZ = 50.0
RUN_SECONDS = 2.5          # every report is a prediction: the mast reaches the shelf at 3.83 s


def plan_x(t):
    return 0.0 if t <= WAIT else SPEED * (t - WAIT)


class MobileManipulator(unittest.TestCase):
    def test_plan_and_joints(self):
        rospy.init_node("mobile_manipulator_check")
        odom = rospy.Publisher("/my_robot/odom", Odometry, queue_size=10)
        joints = rospy.Publisher("/my_robot/joint_states", JointState, queue_size=10)
        plan = rospy.Publisher("/my_robot/timed_plan", Path, queue_size=1, latch=True)
        impacts = tutorial_sim.ImpactRecorder()
        self.assertTrue(tutorial_sim.wait_for_connections([odom, joints, plan], [impacts.sub]),
                        "vadop_monitor did not connect")
        rospy.sleep(0.5)
        start = rospy.Time.now()
        plan.publish(tutorial_sim.timed_path(
            [(start + rospy.Duration(k * 0.1), plan_x(k * 0.1), 0.0, 0.0) for k in range(int(PLAN_SECONDS * 10) + 1)]))
        rate = rospy.Rate(HZ)
        while not rospy.is_shutdown():
            now = rospy.Time.now()
            t = (now - start).to_sec()
            if t > RUN_SECONDS:
                break
            odom.publish(tutorial_sim.odometry(now, "base_link", plan_x(t), 0.0, 0.0, SPEED if t > WAIT else 0.0, 0.0))
            joints.publish(tutorial_sim.joint_state(now, {"mast_joint": MAST}))
            rate.sleep()
        rospy.sleep(0.1)

        arrays = impacts.since(start + rospy.Duration(0.2))
        self.assertGreater(len(arrays), 30)
        mast_hit = start + rospy.Duration(WAIT + (SHELF_FACE - MAST_FRONT) / SPEED)
        base_hit = start + rospy.Duration(WAIT + (SHELF_FACE - BASE_RADIUS) / SPEED)
        worst = {"mast": 0.0, "base_link": 0.0}
        for a in arrays:
            links = {}
            for i in a.impacts:
                if {i.body_a, i.body_b} != {"my_robot", "shelf"}:
                    self.fail("unexpected impact %s" % i)
                links[i.link_a or i.link_b] = i
            at = (a.header.stamp - start).to_sec()
            self.assertEqual(set(links), {"mast", "base_link"}, "at %.2f s" % at)
            self.assertEqual(a.impacts[0].link_a or a.impacts[0].link_b, "mast", "at %.2f s: the first impact is "
                             "not the mast's" % at)
            for link, hit in (("mast", mast_hit), ("base_link", base_hit)):
                error = links[link].time_to_impact - (hit - a.header.stamp).to_sec()
                worst[link] = max(worst[link], abs(error))
        rospy.loginfo("mobile_manipulator: %d reports; mast at %.4f s after the start (largest error %.2f ms), "
                      "base at %.4f s (%.2f ms)", len(arrays), (mast_hit - start).to_sec(), 1e3 * worst["mast"],
                      (base_hit - start).to_sec(), 1e3 * worst["base_link"])
        self.assertLess(worst["mast"], 0.05)
        self.assertLess(worst["base_link"], 0.05)


if __name__ == "__main__":
    rostest.rosrun("vadop", "tutorial_mobile_manipulator", MobileManipulator, sys.argv)
