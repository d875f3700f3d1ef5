#!/usr/bin/python3
"""The nodelet vadop/MonitorNodelet (test/monitor_nodelet.test): c0 and c1 head-on along x, 4 m
apart and closing at 2 m/s (1 m of radii: contact 1.5 s after each state's stamp), published as
one vadop/BodyStateArray at 10 Hz; the nodelet's /vadop_monitor/impacts must name the pair with a
time to impact of 1.5 s minus the state's age at the cycle (under 0.5 s)."""
import threading
import unittest

import rospy
import rostest
from geometry_msgs.msg import Pose, Twist
from vadop.msg import BodyState, BodyStateArray, ImpactArray


def entry(name, x, vx):
    s = BodyState(name=name, pose=Pose(), twist=Twist())
    s.pose.position.x = x
    s.pose.orientation.w = 1.0
    s.twist.linear.x = vx
    return s


class MonitorNodeletTest(unittest.TestCase):
    def test_impact_from_the_nodelet(self):
        rospy.init_node("monitor_nodelet_test")
        got = []
        done = threading.Event()

        def on_impacts(msg):
            for i in msg.impacts:
                if {i.body_a, i.body_b} == {"c0", "c1"}:
                    got.append((msg.header.stamp, i.time_to_impact))
                    done.set()

        rospy.Subscriber("/vadop_monitor/impacts", ImpactArray, on_impacts)
        pub = rospy.Publisher("/fleet/states", BodyStateArray, queue_size=5)
        deadline = rospy.Time.now() + rospy.Duration(30.0)
        rate = rospy.Rate(10.0)
        while not done.is_set() and rospy.Time.now() < deadline and not rospy.is_shutdown():
            # Every array restarts the pair 4 m apart: contact 1.5 s after its stamp.
            msg = BodyStateArray(states=[entry("c0", -2.0, 1.0), entry("c1", 2.0, -1.0)])
            msg.header.stamp = rospy.Time.now()
            msg.header.frame_id = "odom"
            pub.publish(msg)
            rate.sleep()
        self.assertTrue(got, "no ImpactArray from the nodelet named c0 and c1 within 30 s")
        _, tti = got[0]
        # The state the cycle used is younger than 0.5 s (10 Hz states and cycle, a loaded machine).
        self.assertTrue(1.0 <= tti <= 1.5 + 1e-3, "time to impact %.3f s" % tti)


if __name__ == "__main__":
    rostest.rosrun("vadop", "monitor_nodelet", MonitorNodeletTest)
