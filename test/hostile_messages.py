#!/usr/bin/python3
"""rostest node of hostile_messages.test (issue 13): publishes /clock (use_sim_time) and odometry,
sends one hostile input per phase, and checks that vadop_monitor keeps reporting.

Bodies are on a treadmill: every message states the same pose and velocity, so each array
(stamped at the cycle time) must report left <-> right in 2.5 s (gap 5 m closing at 2 m/s) and
victim <-> wall in 2.0 s (2 m at 1 m/s), less the age of the last message. Phases (each ~2 s of
simulated time after its hostile input):
  1. none (warm-up);
  2. victim odometry stamped secs = 4000000000 (aborted the node: ros::Duration out of range),
     then NaN odometry;
  3. victim odometry stamped now + 1e5 s, then good ones (blinded the victim: "out of order"
     until the clock reached the stamp; its impact disappeared once it went stale);
  4. dynamic_reconfigure horizon = nan and rate = nan (stored: every cycle failed): the
     returned config keeps the previous values;
  5. /clock jumps to 4.2e9 s (aborted the node), good messages stamped with the new clock.
"""
import math
import sys
import threading
import time
import unittest

import rospy
import rostest
from dynamic_reconfigure.client import Client
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock
from vadop.msg import ImpactArray

T0 = 1700000000  # s: a present-day epoch time
JUMP_TO = 4200000000
STEP = 0.01  # s of simulated time per 10 ms of wall time
PHASE_WALL = 2.5  # s per phase
PAIR_TTI = 2.5
VICTIM_TTI = 2.0


class SimClock(threading.Thread):
    def __init__(self):
        super().__init__(daemon=True)
        self.lock = threading.Lock()
        self.now = rospy.Time(T0)
        self.pub = rospy.Publisher("/clock", Clock, queue_size=10)
        self.running = True

    def get(self):
        with self.lock:
            return self.now

    def jump(self, secs):
        with self.lock:
            self.now = rospy.Time(secs)

    def run(self):
        while self.running:
            with self.lock:
                self.now = self.now + rospy.Duration(STEP)
                stamp = self.now
            self.pub.publish(Clock(clock=stamp))
            time.sleep(STEP)


class HostileMessages(unittest.TestCase):
    def setUp(self):
        rospy.init_node("hostile_messages_test", anonymous=True)
        self.clock = SimClock()
        self.clock.start()
        self.lock = threading.Lock()
        self.arrays = []
        self.sub = rospy.Subscriber("/vadop_monitor/impacts", ImpactArray, self.on_impacts, queue_size=200)
        self.pubs = {n: rospy.Publisher("/%s/odom" % n, Odometry, queue_size=20) for n in ("left", "right", "victim")}

    def tearDown(self):
        self.clock.running = False

    def on_impacts(self, msg):
        with self.lock:
            self.arrays.append(msg)

    def odom(self, name, stamp, x, y, vx, vy):
        m = Odometry()
        m.header.stamp = stamp
        m.header.frame_id = "odom"
        m.child_frame_id = name
        m.pose.pose.position.x = x
        m.pose.pose.position.y = y
        m.pose.pose.orientation.w = 1.0
        m.twist.twist.linear.x = vx
        m.twist.twist.linear.y = vy
        return m

    def publish_good(self):
        stamp = self.clock.get()
        self.pubs["left"].publish(self.odom("left", stamp, -3.0, 0.0, 1.0, 0.0))
        self.pubs["right"].publish(self.odom("right", stamp, 3.0, 0.0, -1.0, 0.0))
        self.pubs["victim"].publish(self.odom("victim", stamp, 0.0, 10.0, 0.0, 1.0))

    def run_phase(self, name):
        """Publishes good messages for PHASE_WALL s; returns the arrays stamped in the phase's last 1.5 s."""
        end = time.time() + PHASE_WALL
        while time.time() < end:
            self.publish_good()
            time.sleep(0.02)
        now = self.clock.get()
        since = now - rospy.Duration(1.5)
        time.sleep(0.3)
        with self.lock:
            arrays = [a for a in self.arrays if since <= a.header.stamp <= now]
        self.assertGreater(len(arrays), 10, "%s: only %d ImpactArrays in the last 1.5 s: is the node up?" % (name, len(arrays)))
        return arrays

    def check_impacts(self, name, arrays, victim=True):
        pair = victim_hits = 0
        for a in arrays:
            for i in a.impacts:
                self.assertTrue(math.isfinite(i.time_to_impact) and 0.0 <= i.time_to_impact <= 5.0, str(i))
                bodies = {i.body_a, i.body_b}
                self.assertIn(bodies, ({"left", "right"}, {"victim", "wall"}), "%s: unexpected pair %s" % (name, i))
                if bodies == {"left", "right"}:
                    self.assertTrue(PAIR_TTI - 0.4 < i.time_to_impact <= PAIR_TTI + 1e-3, "%s: %s" % (name, i))
                    self.assertAlmostEqual((i.time_of_impact - a.header.stamp).to_sec(), i.time_to_impact, delta=1e-6)
                    pair += 1
                else:
                    self.assertTrue(VICTIM_TTI - 0.4 < i.time_to_impact <= VICTIM_TTI + 1e-3, "%s: %s" % (name, i))
                    victim_hits += 1
        rospy.loginfo("%s: %d arrays, %d with left <-> right, %d with victim <-> wall", name, len(arrays), pair,
                      victim_hits)
        self.assertGreater(pair, 0.8 * len(arrays), "%s: the head-on pair is not reported" % name)
        if victim:
            self.assertGreater(victim_hits, 0.8 * len(arrays), "%s: the victim is not reported (blinded?)" % name)

    def test_hostile_messages(self):
        deadline = time.time() + 40.0
        while time.time() < deadline:
            if all(p.get_num_connections() > 0 for p in self.pubs.values()) and self.sub.get_num_connections() > 0:
                break
            time.sleep(0.1)
        self.assertTrue(all(p.get_num_connections() > 0 for p in self.pubs.values()), "vadop_monitor did not subscribe")
        time.sleep(0.5)

        self.check_impacts("warm-up", self.run_phase("warm-up"))

        # 2. secs = 4e9, then NaN.
        far = self.odom("victim", rospy.Time(4000000000), 0.0, 10.0, 0.0, 1.0)
        self.pubs["victim"].publish(far)
        time.sleep(0.05)
        bad = self.odom("victim", self.clock.get(), float("nan"), 10.0, 0.0, 1.0)
        self.pubs["victim"].publish(bad)
        self.check_impacts("stamp 4e9 and NaN", self.run_phase("stamp 4e9 and NaN"))

        # 3. A future stamp, then good ones: the victim must stay reported past its stale timeout.
        future = self.odom("victim", self.clock.get() + rospy.Duration(1e5), 0.0, 10.0, 0.0, 1.0)
        self.pubs["victim"].publish(future)
        time.sleep(0.05)
        self.check_impacts("future stamp", self.run_phase("future stamp"))

        # 4. dynamic_reconfigure with NaN: the previous values are kept (and published back).
        client = Client("/vadop_monitor", timeout=30.0)
        cfg = client.update_configuration({"horizon": float("nan")})
        self.assertEqual(cfg["horizon"], 5.0, "horizon nan was not refused: %s" % cfg)
        cfg = client.update_configuration({"rate": float("nan"), "padding": float("nan")})
        self.assertEqual(cfg["rate"], 30.0, "rate nan was not refused: %s" % cfg)
        self.assertEqual(cfg["padding"], 0.0, "padding nan was not refused: %s" % cfg)
        self.assertEqual(client.get_configuration(timeout=10.0)["horizon"], 5.0)
        self.check_impacts("horizon/rate nan", self.run_phase("horizon/rate nan"))

        # 5. /clock jumps to 4.2e9 s.
        self.clock.jump(JUMP_TO)
        time.sleep(0.1)
        arrays = self.run_phase("clock jump")
        self.assertTrue(all(a.header.stamp >= rospy.Time(JUMP_TO) for a in arrays))
        self.check_impacts("clock jump to 4.2e9 s", arrays)


if __name__ == "__main__":
    rostest.rosrun("vadop", "hostile_messages", HostileMessages, sys.argv)
