#!/usr/bin/python3
"""rostest node for gate_closed_loop.test: a unicycle simulator of the gated robots (it
integrates each cmd_vel_out and publishes odometry at 50 Hz) with their planners publishing
cmd_vel_in at 20 Hz, and the checks of issue 15's closed-loop cases."""
import math
import sys
import threading
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log
from vadop.msg import GateStateArray

RADIUS = 0.5
SIM_HZ = 50.0
PLAN_HZ = 20.0


class Robot:
    def __init__(self, name, x, y, yaw):
        self.name, self.x, self.y, self.yaw = name, x, y, yaw
        self.v = 0.0   # applied command (body frame)
        self.w = 0.0
        self.outputs = []  # (time, vx, wz) of every cmd_vel_out received
        self.plan = None   # (vx, wz) published on cmd_vel_in, or None: nothing
        self.publish_odom = True


class GateClosedLoop(unittest.TestCase):
    def setUp(self):
        rospy.init_node("gate_closed_loop_test", anonymous=True)
        self.lock = threading.Lock()
        self.robots = {
            "h1": Robot("h1", -3.0, 0.0, 0.0),
            "h2": Robot("h2", 3.0, 0.0, math.pi),
            "w": Robot("w", 40.0, 0.0, 0.0),  # its sphere touches the wall's face at x = 39.5
            "n": Robot("n", 80.0, 0.0, 0.0),
            "q": Robot("q", 120.0, 0.0, 0.0),
            "s": Robot("s", 160.0, 0.0, 0.0),
            # c drives +y across the path of u, an ungated agent driving +x at 1 m/s: u is in
            # front of c (x 199 to 201) from 1.5 s to 3.5 s, c would reach u's lane (y > -1)
            # at 2 s: it must wait for u, then pass.
            "c": Robot("c", 200.0, -3.0, math.pi / 2),
            "u": Robot("u", 197.5, 0.0, 0.0),
            # rot: a 4 m x 0.4 m box turning in place; the pillar (radius 0.2) 1.5 m to its side:
            # contact at a turn of acos(0.4 / 1.5) = 1.301 rad.
            "rot": Robot("rot", 240.0, 0.0, 0.0),
        }
        self.gated = [n for n in self.robots if n != "u"]
        self.min_cu = float("inf")
        self.odom_pubs = {n: rospy.Publisher("/%s/odom" % n, Odometry, queue_size=10) for n in self.robots}
        self.plan_pubs = {n: rospy.Publisher("/%s/nav_vel" % n, Twist, queue_size=10) for n in self.gated}
        self.subs = [rospy.Subscriber("/%s/cmd_vel" % n, Twist, self.on_cmd, callback_args=n, queue_size=100)
                     for n in self.gated]
        self.states = []
        self.state_sub = rospy.Subscriber("/vadop_monitor/gate_states", GateStateArray, self.on_states,
                                          queue_size=100)
        self.min_gap = float("inf")
        self.warnings = []
        self.log_sub = rospy.Subscriber("/rosout", Log, self.on_log, queue_size=1000)

    def on_cmd(self, msg, name):
        with self.lock:
            r = self.robots[name]
            r.v, r.w = msg.linear.x, msg.angular.z
            r.outputs.append((rospy.get_time(), msg.linear.x, msg.angular.z))

    def on_log(self, msg):
        if msg.level >= Log.WARN and "vadop_monitor" in msg.name:
            with self.lock:
                self.warnings.append(msg.msg)

    def on_states(self, msg):
        with self.lock:
            self.states.append(msg)

    def step(self, dt):
        with self.lock:
            for r in self.robots.values():
                r.x += r.v * math.cos(r.yaw) * dt
                r.y += r.v * math.sin(r.yaw) * dt
                r.yaw += r.w * dt
            h1, h2 = self.robots["h1"], self.robots["h2"]
            self.min_gap = min(self.min_gap, math.hypot(h1.x - h2.x, h1.y - h2.y) - 2 * RADIUS)
            c, u = self.robots["c"], self.robots["u"]
            self.min_cu = min(self.min_cu, math.hypot(c.x - u.x, c.y - u.y) - 2 * RADIUS)

    def publish_odom(self, stamp):
        with self.lock:
            for name, r in self.robots.items():
                if not r.publish_odom:
                    continue
                m = Odometry()
                m.header.stamp = stamp
                m.header.frame_id = "odom"
                m.child_frame_id = name
                m.pose.pose.position.x = r.x
                m.pose.pose.position.y = r.y
                m.pose.pose.orientation.z = math.sin(r.yaw / 2)
                m.pose.pose.orientation.w = math.cos(r.yaw / 2)
                m.twist.twist.linear.x = r.v
                m.twist.twist.angular.z = r.w
                self.odom_pubs[name].publish(m)

    def publish_plans(self):
        with self.lock:
            plans = {n: r.plan for n, r in self.robots.items() if r.plan is not None}
        for name, (vx, wz) in plans.items():
            t = Twist()
            t.linear.x = vx
            t.angular.z = wz
            self.plan_pubs[name].publish(t)

    def simulate(self, seconds):
        """Simulates for `seconds` (wall clock), odometry at SIM_HZ, plans at PLAN_HZ."""
        rate = rospy.Rate(SIM_HZ)
        last = rospy.get_time()
        end = last + seconds
        next_plan = last
        while not rospy.is_shutdown() and rospy.get_time() < end:
            now = rospy.get_time()
            self.step(now - last)
            last = now
            self.publish_odom(rospy.Time.now())
            if now >= next_plan:
                self.publish_plans()
                next_plan = now + 1.0 / PLAN_HZ
            rate.sleep()

    def outputs_since(self, name, t0):
        with self.lock:
            return [o for o in self.robots[name].outputs if o[0] >= t0]

    def test_gates_closed_loop(self):
        deadline = rospy.get_time() + 30.0
        pubs = list(self.odom_pubs.values()) + list(self.plan_pubs.values())
        while not rospy.is_shutdown() and rospy.get_time() < deadline:
            if all(p.get_num_connections() > 0 for p in pubs) and all(s.get_num_connections() > 0 for s in self.subs):
                break
            rospy.sleep(0.1)
        self.assertTrue(all(p.get_num_connections() > 0 for p in pubs), "vadop_monitor did not subscribe")
        # The monitor's first cycles with every robot standing still.
        self.simulate(1.0)

        # Head-on at 1 m/s each (6 m apart, 5 m of gap: contact at 2.5 s ungated); w drives
        # away from the wall it touches; n, q and s drive on their own.
        t0 = rospy.get_time()
        with self.lock:
            for n in ("h1", "h2", "w", "n", "q", "s", "c"):
                self.robots[n].plan = (1.0, 0.0)
            self.robots["rot"].plan = (0.0, 1.0)
            self.robots["u"].v = 1.0  # ungated: it just drives
        self.simulate(1.0)
        # n gets a NaN command: a zero command comes back.
        with self.lock:
            self.robots["n"].plan = (float("nan"), 0.0)
        t_nan = rospy.get_time()
        self.simulate(0.5)
        # q's planner stops: exactly one zero command within the next 1.5 s.
        with self.lock:
            self.robots["q"].plan = None
        t_stop = rospy.get_time()
        # s's odometry stops: every later command comes back zero.
        with self.lock:
            self.robots["s"].publish_odom = False
        t_stale = rospy.get_time()
        self.simulate(4.5)

        h1, h2 = self.robots["h1"], self.robots["h2"]
        rospy.loginfo("gate_closed_loop: h1 at %.3f, h2 at %.3f, smallest gap %.4f m", h1.x, h2.x, self.min_gap)
        self.assertGreater(self.min_gap, 0.0, "the head-on robots touched")
        self.assertLess(self.min_gap, 1.0, "the head-on robots stopped too far apart to have been gated at all")
        last_h = self.outputs_since("h1", rospy.get_time() - 0.5)
        self.assertTrue(last_h and all(abs(v) < 0.05 for _, v, _ in last_h), "h1 did not stop: %s" % last_h[-3:])

        w_out = [v for _, v, _ in self.outputs_since("w", t0 + 0.2)]
        self.assertTrue(w_out and min(w_out) == 1.0, "w, driving away from the wall, was slowed: %s" % w_out[:5])

        n_out = self.outputs_since("n", t_nan + 0.2)
        self.assertTrue(n_out and all(v == 0.0 and w == 0.0 for _, v, w in n_out), "NaN gave %s" % n_out[:3])
        with self.lock:
            nan_warnings = [w for w in self.warnings if "/n/nav_vel" in w and "NaN" in w]
        self.assertTrue(nan_warnings, "no warning about the NaN command; warnings: %s" % self.warnings[:5])

        q_out = self.outputs_since("q", t_stop + 0.1)
        zeros = [o for o in q_out if o[1] == 0.0]
        self.assertEqual(len(q_out), 1, "after the commands stopped q got %s" % q_out)
        self.assertEqual(len(zeros), 1)

        s_out = self.outputs_since("s", t_stale + 0.45)
        self.assertTrue(s_out and all(v == 0.0 for _, v, _ in s_out), "stale odometry gave %s" % s_out[:3])

        c, rot = self.robots["c"], self.robots["rot"]
        rospy.loginfo("gate_closed_loop: c at y = %.2f, closest to u %.3f m; rot turned %.3f rad", c.y, self.min_cu,
                      rot.yaw)
        self.assertGreater(self.min_cu, 0.0, "c touched the ungated agent u")
        self.assertGreater(c.y, 0.5, "c never passed the crossing")
        c_out = [v for _, v, _ in self.outputs_since("c", t0 + 0.2)]
        self.assertLess(min(c_out), 0.5, "c never slowed down for u")
        self.assertLess(rot.yaw, math.acos(0.4 / 1.5), "rot turned into the pillar")
        self.assertGreater(rot.yaw, 0.5, "rot barely turned")
        last_rot = self.outputs_since("rot", rospy.get_time() - 0.5)
        self.assertTrue(last_rot and all(abs(w) < 0.05 for _, _, w in last_rot), "rot not stopped: %s" % last_rot[-3:])

        with self.lock:
            last_states = {g.body: g for g in self.states[-1].gates}
        self.assertEqual(last_states["rot"].limiting_body, "pillar")
        self.assertEqual(last_states["s"].reason, "stale")
        self.assertEqual(last_states["n"].reason, "bad_command")
        self.assertEqual(last_states["q"].reason, "timeout")
        self.assertIn(last_states["h1"].reason, ("stop", "slow"))
        self.assertEqual(last_states["h1"].limiting_body, "h2")


if __name__ == "__main__":
    rostest.rosrun("vadop", "gate_closed_loop", GateClosedLoop, sys.argv)
