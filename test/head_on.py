#!/usr/bin/python3
"""rostest node: a scripted publisher of odometry for two bodies on a head-on course and two
passing each other 5 cm apart, and the checks on vadop_monitor's ~impacts (head_on.test)."""
import math
import sys
import threading
import unittest

import rospy
import rostest
from nav_msgs.msg import Odometry
from vadop.msg import ImpactArray

RADIUS = 0.5
SPEED = 1.0          # m/s, each body
START_X = 4.0        # the bodies start at -4 and +4
NEAR_MISS_GAP = 0.05  # m of clearance at the closest approach
PUBLISH_HZ = 50.0
RUN_SECONDS = 3.0     # head-on contact at (2 * START_X - 2 * RADIUS) / (2 * SPEED) = 3.5 s


class HeadOn(unittest.TestCase):
    def setUp(self):
        rospy.init_node("head_on_test", anonymous=True)
        self.lock = threading.Lock()
        self.arrays = []
        self.sub = rospy.Subscriber("/vadop_monitor/impacts", ImpactArray, self.on_impacts, queue_size=100)
        self.pubs = {name: rospy.Publisher("/%s/odom" % name, Odometry, queue_size=10)
                     for name in ("left", "right", "pass_a", "pass_b")}

    def on_impacts(self, msg):
        with self.lock:
            self.arrays.append(msg)

    # x, y and vx of each body at time t (s after the start).
    def states(self, t):
        return {
            "left": (-START_X + SPEED * t, 0.0, SPEED),
            "right": (START_X - SPEED * t, 0.0, -SPEED),
            "pass_a": (-START_X + SPEED * t, 10.0, SPEED),
            "pass_b": (START_X - SPEED * t, 10.0 + 2 * RADIUS + NEAR_MISS_GAP, -SPEED),
        }

    def publish(self, stamp, t):
        for name, (x, y, vx) in self.states(t).items():
            m = Odometry()
            m.header.stamp = stamp
            m.header.frame_id = "odom"
            m.child_frame_id = name
            m.pose.pose.position.x = x
            m.pose.pose.position.y = y
            m.pose.pose.orientation.w = 1.0
            m.twist.twist.linear.x = vx  # heading along +x: body frame = odom axes
            self.pubs[name].publish(m)

    def test_head_on_and_near_miss(self):
        # Wait for the monitor to be up and subscribed.
        deadline = rospy.Time.now() + rospy.Duration(30.0)
        while not rospy.is_shutdown() and rospy.Time.now() < deadline:
            if all(p.get_num_connections() > 0 for p in self.pubs.values()) and self.sub.get_num_connections() > 0:
                break
            rospy.sleep(0.1)
        self.assertTrue(all(p.get_num_connections() > 0 for p in self.pubs.values()), "vadop_monitor did not subscribe")
        rospy.sleep(0.5)

        start = rospy.Time.now()
        rate = rospy.Rate(PUBLISH_HZ)
        while not rospy.is_shutdown():
            now = rospy.Time.now()
            t = (now - start).to_sec()
            if t > RUN_SECONDS:
                break
            self.publish(now, t)
            rate.sleep()
        rospy.sleep(0.2)

        with self.lock:
            arrays = [a for a in self.arrays if a.header.stamp > start]
        self.assertGreater(len(arrays), 20, "too few ImpactArray messages: %d" % len(arrays))
        contact = start + rospy.Duration((2 * START_X - 2 * RADIUS) / (2 * SPEED))

        first = None
        checked = 0
        worst = 0.0
        for a in arrays:
            self.assertEqual(a.header.frame_id, "odom")
            times = [i.time_to_impact for i in a.impacts]
            self.assertEqual(times, sorted(times), "impacts not sorted by time_to_impact")
            for i in a.impacts:
                pair = {i.body_a, i.body_b}
                self.assertNotEqual(pair, {"pass_a", "pass_b"}, "near miss reported: %s" % i)
                self.assertEqual(pair, {"left", "right"}, "unexpected pair: %s" % i)
            if a.impacts:
                i = a.impacts[0]
                analytic = (contact - a.header.stamp).to_sec()
                if first is None:
                    first = (i, analytic)
                worst = max(worst, abs(i.time_to_impact - analytic))
                self.assertLess(abs(i.time_to_impact - analytic), 0.05,
                                "time_to_impact %.4f s, analytic %.4f s" % (i.time_to_impact, analytic))
                self.assertAlmostEqual((i.time_of_impact - a.header.stamp).to_sec(), i.time_to_impact, delta=1e-6)
                self.assertAlmostEqual(i.normal.x, 1.0 if i.body_a == "left" else -1.0, delta=1e-3)
                self.assertAlmostEqual(i.closing_speed, 2 * SPEED, delta=1e-3)
                self.assertFalse(i.in_contact)
                checked += 1
        self.assertIsNotNone(first, "no impact was ever published")
        i, analytic = first
        self.assertEqual((i.body_a, i.body_b), ("left", "right"))
        self.assertEqual((i.link_a, i.link_b), ("", ""))
        rospy.loginfo("first impact: %s <-> %s in %.5f s (analytic %.5f s, error %.3f ms); %d arrays with the "
                      "impact checked, largest error %.3f ms; near miss never reported in %d arrays",
                      i.body_a, i.body_b, i.time_to_impact, analytic, 1e3 * abs(i.time_to_impact - analytic), checked,
                      1e3 * worst, len(arrays))
        self.assertGreater(checked, 10)


if __name__ == "__main__":
    rostest.rosrun("vadop", "head_on", HeadOn, sys.argv)
