#!/usr/bin/python3
"""rostest node of test/tutorials/fleet.test: what docs/tutorials/fleet.md promises. Four carts
(cylinders of radius 0.3 m) on their odometry topics: cart_0 and cart_1 head-on at 1 m/s each,
cart_2 and cart_3 crossing at right angles, 10 m away. Every ImpactArray must name only those two
pairs, each at its analytic time within 50 ms, and both pairs must be reported."""
import math
import sys
import unittest

import rospy
import rostest
from nav_msgs.msg import Odometry

import tutorial_sim

RADIUS = 0.3
HZ = 50.0
RUN_SECONDS = 1.4   # both contacts come later (1.7 s and 1.576 s): every report is a prediction
# Contact times (s after the start): head-on, 4 m apart, closing at 2 m/s; crossing, centres
# (10, t - 2) and (t + 8, 0), 2 x RADIUS apart when sqrt(2) (2 - t) = 0.6.
HEAD_ON = (4.0 - 2 * RADIUS) / 2.0
CROSSING = 2.0 - 2 * RADIUS / math.sqrt(2.0)


def states(t):
    """x, y, yaw, speed of each cart t s after the start."""
    return {
        "cart_0": (-2.0 + t, 0.0, 0.0, 1.0),
        "cart_1": (2.0 - t, 0.0, math.pi, 1.0),
        "cart_2": (10.0, -2.0 + t, math.pi / 2, 1.0),
        "cart_3": (8.0 + t, 0.0, 0.0, 1.0),
    }


class Fleet(unittest.TestCase):
    def test_impacts_among_the_fleet(self):
        rospy.init_node("fleet_check")
        pubs = {n: rospy.Publisher("/%s/odom" % n, Odometry, queue_size=10) for n in states(0.0)}
        impacts = tutorial_sim.ImpactRecorder()
        self.assertTrue(tutorial_sim.wait_for_connections(pubs.values(), [impacts.sub]),
                        "vadop_monitor did not connect")
        rospy.sleep(0.5)
        start = rospy.Time.now()
        rate = rospy.Rate(HZ)
        while not rospy.is_shutdown():
            now = rospy.Time.now()
            t = (now - start).to_sec()
            if t > RUN_SECONDS:
                break
            for name, (x, y, yaw, v) in states(t).items():
                pubs[name].publish(tutorial_sim.odometry(now, name, x, y, yaw, v, 0.0))
            rate.sleep()
        rospy.sleep(0.1)

        arrays = [a for a in impacts.since(start + rospy.Duration(0.2))]  # every cart heard from
        self.assertGreater(len(arrays), 20)
        for a in arrays:
            for i in a.impacts:
                if {i.body_a, i.body_b} not in [{"cart_0", "cart_1"}, {"cart_2", "cart_3"}]:
                    self.fail("unexpected pair %s" % i)
        for pair, contact in ((("cart_0", "cart_1"), HEAD_ON), (("cart_2", "cart_3"), CROSSING)):
            found = tutorial_sim.impacts_of_pair(arrays, *pair)
            self.assertGreater(len(found), len(arrays) // 2, "%s <-> %s reported %d times in %d arrays" %
                               (pair[0], pair[1], len(found), len(arrays)))
            errors = tutorial_sim.timing_errors(found, start + rospy.Duration(contact))
            worst = max(abs(e) for e in errors)
            rospy.loginfo("fleet: %s <-> %s at %.3f s after the start, %d reports, largest error %.2f ms",
                          pair[0], pair[1], contact, len(found), 1e3 * worst)
            self.assertLess(worst, 0.05)


if __name__ == "__main__":
    rostest.rosrun("vadop", "tutorial_fleet", Fleet, sys.argv)
