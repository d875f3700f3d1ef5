#!/usr/bin/python3
"""rostest node of mistakes.test: what vadop_monitor says about a topic nobody publishes and a
body whose odometry stops and comes back (its /rosout lines and its diagnostics)."""
import sys
import threading
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log


class Mistakes(unittest.TestCase):
    def setUp(self):
        rospy.init_node("mistakes_test", anonymous=True)
        self.lock = threading.Lock()
        self.logs = []    # (level, text) of vadop_monitor's lines
        self.bodies = []  # the monitor's "bodies" statuses
        rospy.Subscriber("/rosout", Log, self.on_log, queue_size=1000)
        rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=100)
        self.pub = rospy.Publisher("/a/odom", Odometry, queue_size=10)

    def on_log(self, msg):
        if msg.name.endswith("vadop_monitor"):
            with self.lock:
                self.logs.append((msg.level, msg.msg))

    def on_diagnostics(self, msg):
        for s in msg.status:
            if s.name.endswith("bodies"):
                with self.lock:
                    self.bodies.append(s)

    def publish_a(self, seconds):
        end = time.time() + seconds
        while time.time() < end and not rospy.is_shutdown():
            m = Odometry()
            m.header.stamp = rospy.Time.now()
            m.header.frame_id = "odom"
            m.child_frame_id = "a"
            m.pose.pose.orientation.w = 1.0
            self.pub.publish(m)
            time.sleep(0.05)

    def lines(self, level, *words):
        with self.lock:
            return [t for (lv, t) in self.logs if lv == level and all(w in t for w in words)]

    def test_silent_topic_and_stale_body_are_said(self):
        self.publish_a(7.0)  # past the 5 s check, "a" fresh all along
        silent = self.lines(Log.WARN, 'body "b"', "/b/odm", "no node publishes")
        self.assertEqual(len(silent), 1, "no single WARN naming body b and /b/odm: %s" % self.logs)
        self.assertEqual(self.lines(Log.WARN, 'body "a"'), [], "body a was published: %s" % self.logs)
        # b and c_0 .. c_11 silent: the first 10 named one a line, the other 3 in one line.
        self.assertEqual(len(self.lines(Log.WARN, "no node publishes", "is the topic right")), 10, self.logs)
        rest = self.lines(Log.WARN, "3 more bodies", '"c_9" (/c_9/odom)', "no node publishes their topics")
        self.assertEqual(len(rest), 1, "no single WARN for the 3 other silent bodies: %s" % self.logs)
        with self.lock:
            last = self.bodies[-1] if self.bodies else None
        self.assertIsNotNone(last, "no bodies diagnostics")
        values = {kv.key: kv.value for kv in last.values}
        self.assertIn("waiting for the first message on /b/odm", values.get("b", ""), values)
        self.assertGreaterEqual(last.level, DiagnosticStatus.WARN, last)

        time.sleep(1.5)  # a stops: stale after 0.5 s
        stale = self.lines(Log.WARN, 'body "a"', "stale", "/a/odom")
        self.assertEqual(len(stale), 1, "no single stale WARN for a: %s" % self.logs)
        self.publish_a(1.0)
        back = self.lines(Log.INFO, 'body "a"', "/a/odom", "again")
        self.assertEqual(len(back), 1, "no single INFO when a came back: %s" % self.logs)
        self.assertEqual(len(self.lines(Log.WARN, 'body "a"', "stale")), 1, "stale said more than once")


if __name__ == "__main__":
    rostest.rosrun("vadop", "mistakes", Mistakes, sys.argv)
