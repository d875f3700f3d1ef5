#!/usr/bin/python3
"""rostest node for gate_closed_loop.test, second part (issue 48): the velocity gates in closed loop
with bases as real robots have them, padding 0.

The simulated bases execute each cmd_vel_out BASE_DELAY s after it arrives (a queue of timed
commands) and ramp their applied velocity towards the executed command at LINEAR_RAMP m/s^2 and
ANGULAR_RAMP rad/s^2 (never a jump); they are integrated as unicycles at >= 200 Hz and publish
odometry at 50 Hz; their planners publish cmd_vel_in at 20 Hz. Ungated bodies (a walker, a
leader) move as the script says, ideally (their velocity may jump).

The same five scenes run at once in two monitors' worlds (their own topics, prefixes /bk and /nb):
vadop_braking, whose gated bodies have the braking model (max_linear_decel, max_angular_decel),
and vadop_no_braking, the same without it (the held-command rule: the mutation). Both gates have
reaction_time 0.1 s and time_before_collision 0.3 s (gate_closed_loop.test says why).
  a. head-on: two gated robots driving at each other;
  b. crossing: a gated robot crossing the lane of an ungated walker;
  c. follower: a gated robot 0.3 m behind an ungated leader that starts like a base and, at
     LEADER_STOP, stops at once;
  d. wall: a gated robot driving at a static wall (it must stop within 0.6 m of it);
  e. backing away: a gated robot touching a static block, commanded away from it (reversing).
The metric is the exact gap between the shapes (spheres and boxes, analytic) at every step;
the smallest per scene is printed with the final gap and the stopping distance."""
import collections
import math
import sys
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry

RADIUS = 0.5
BASE_DELAY = 0.06     # s from a command's arrival until the base executes it
LINEAR_RAMP = 1.0     # m/s^2: the base's applied velocity moves towards the executed command
ANGULAR_RAMP = 2.0    # rad/s^2
MAX_STEP = 0.005      # s: the longest integration step (>= 200 Hz)
ODOM_HZ = 50.0
PLAN_HZ = 20.0
SPEED = 0.9           # m/s: every planner's speed
SETTLE = 1.0          # s with everything standing still before the scenes start
DURATION = 10.0       # s of the scenes
MONITORS = {"bk": "vadop_braking", "nb": "vadop_no_braking"}

# Static obstacles (as in gate_closed_loop.test): axis-aligned boxes, centre and size (x, y).
WALL = ((124.0, 0.0), (1.0, 10.0))   # face at x = 123.5
BLOCK = ((160.0, 0.0), (1.0, 4.0))   # face at x = 160.5
WALL_START_GAP = 3.0
LEADER_STOP = 3.5    # s after the start: the leader stops at once


def sphere_gap(a, b):
    return math.hypot(a.x - b.x, a.y - b.y) - 2 * RADIUS


def box_gap(body, box):
    """Exact gap between a sphere and a static box (negative: the sphere's depth in the box)."""
    (cx, cy), (sx, sy) = box
    dx, dy = abs(body.x - cx) - sx / 2, abs(body.y - cy) - sy / 2
    if dx <= 0 and dy <= 0:
        return max(dx, dy) - RADIUS
    return math.hypot(max(dx, 0.0), max(dy, 0.0)) - RADIUS


class Body:
    def __init__(self, name, x, y, yaw, gated=True):
        self.name, self.x, self.y, self.yaw, self.gated = name, x, y, yaw, gated
        self.v = 0.0             # applied velocity (body frame)
        self.w = 0.0
        self.target = (0.0, 0.0)   # the executed command
        self.queue = collections.deque()  # (time to execute, vx, wz), in arrival order
        self.outputs = []          # (time, vx, wz) of every cmd_vel_out
        self.plan = None           # (vx, wz) its planner publishes, or None
        self.script = None         # ungated: f(t since the start) -> (vx, wz)
        self.travelled = 0.0
        self.peak = 0.0            # the largest applied speed

    def step(self, now, t, dt):
        if self.gated:
            while self.queue and self.queue[0][0] <= now:
                self.target = self.queue.popleft()[1:]
            self.v += max(-LINEAR_RAMP * dt, min(LINEAR_RAMP * dt, self.target[0] - self.v))
            self.w += max(-ANGULAR_RAMP * dt, min(ANGULAR_RAMP * dt, self.target[1] - self.w))
        elif self.script is not None:
            self.v, self.w = self.script(t)
        # Exact unicycle arc with the applied velocity held over the step.
        yaw2 = self.yaw + self.w * dt
        if abs(self.w) > 1e-9:
            self.x += self.v / self.w * (math.sin(yaw2) - math.sin(self.yaw))
            self.y -= self.v / self.w * (math.cos(yaw2) - math.cos(self.yaw))
        else:
            self.x += self.v * math.cos(self.yaw) * dt
            self.y += self.v * math.sin(self.yaw) * dt
        self.yaw = yaw2
        self.travelled += abs(self.v) * dt
        self.peak = max(self.peak, abs(self.v))


def leader_script(t):
    # Starts like a base (1 m/s^2), so that the follower keeps its 0.3 m; then stops at once.
    if t < 0.0 or t >= LEADER_STOP:
        return 0.0, 0.0
    return min(SPEED, LINEAR_RAMP * t), 0.0


class World:
    """One monitor's five scenes (its topics under /<prefix>/)."""

    def __init__(self, prefix):
        self.prefix = prefix
        b = [Body("a1", -3.0, 0.0, 0.0), Body("a2", 3.0, 0.0, math.pi),
             # c drives +y; the walker drives +x at SPEED across c's path, timed to meet it.
             Body("c", 40.0, -3.0, math.pi / 2), Body("wk", 40.0 - 3.4, 0.0, 0.0, gated=False),
             Body("f", 80.0, 0.0, 0.0), Body("l", 81.3, 0.0, 0.0, gated=False),
             Body("wl", WALL[0][0] - WALL[1][0] / 2 - RADIUS - WALL_START_GAP, 0.0, 0.0),
             # r faces the block it touches (its sphere on the block's face) and reverses.
             Body("r", BLOCK[0][0] + BLOCK[1][0] / 2 + RADIUS, 0.0, math.pi)]
        self.bodies = {x.name: x for x in b}
        self.bodies["wk"].script = lambda t: (SPEED, 0.0) if t >= 0.0 else (0.0, 0.0)
        self.bodies["l"].script = leader_script
        self.min_gap = {s: float("inf") for s in "abcde"}
        self.gap = {}
        self.at_leader_stop = None  # (gap, follower's speed) when the leader stopped

    def gaps(self):
        b = self.bodies
        return {"a": sphere_gap(b["a1"], b["a2"]), "b": sphere_gap(b["c"], b["wk"]),
                "c": sphere_gap(b["f"], b["l"]), "d": box_gap(b["wl"], WALL), "e": box_gap(b["r"], BLOCK)}

    def step(self, now, t, dt):
        for body in self.bodies.values():
            body.step(now, t, dt)
        if self.at_leader_stop is None and t >= LEADER_STOP:
            self.at_leader_stop = (sphere_gap(self.bodies["f"], self.bodies["l"]), self.bodies["f"].v)
        self.gap = self.gaps()
        for s, g in self.gap.items():
            self.min_gap[s] = min(self.min_gap[s], g)


class GateBrakingLoop(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("gate_braking_loop_test", anonymous=True)
        cls.lock = threading.Lock()
        cls.worlds = {p: World(p) for p in MONITORS}
        cls.odom_pubs, cls.plan_pubs, cls.subs = {}, {}, []
        cls.slowed_at = {}  # (prefix, body) -> travelled when its gate first slowed it
        for p, world in cls.worlds.items():
            for name, body in world.bodies.items():
                cls.odom_pubs[p, name] = rospy.Publisher("/%s/%s/odom" % (p, name), Odometry, queue_size=10)
                if body.gated:
                    cls.plan_pubs[p, name] = rospy.Publisher("/%s/%s/nav_vel" % (p, name), Twist, queue_size=10)
                    cls.subs.append(rospy.Subscriber("/%s/%s/cmd_vel" % (p, name), Twist, cls.on_cmd,
                                                     callback_args=(p, name), queue_size=100))
        cls.connected = cls.wait_for_connections()
        if cls.connected:
            cls.run_scenes()

    @classmethod
    def on_cmd(cls, msg, key):
        now = time.monotonic()
        with cls.lock:
            body = cls.worlds[key[0]].bodies[key[1]]
            body.queue.append((now + BASE_DELAY, msg.linear.x, msg.angular.z))
            body.outputs.append((now - cls.t_go if hasattr(cls, "t_go") else -1.0, msg.linear.x, msg.angular.z))
            if (body.plan is not None and abs(msg.linear.x) < abs(body.plan[0]) - 1e-3
                    and key not in cls.slowed_at):
                cls.slowed_at[key] = body.travelled

    @classmethod
    def wait_for_connections(cls):
        deadline = time.monotonic() + 30.0
        pubs = list(cls.odom_pubs.values()) + list(cls.plan_pubs.values())
        while not rospy.is_shutdown() and time.monotonic() < deadline:
            if all(p.get_num_connections() > 0 for p in pubs) and all(s.get_num_connections() > 0 for s in cls.subs):
                return True
            time.sleep(0.1)
        return False

    @classmethod
    def publish_odom(cls):
        stamp = rospy.Time.now()
        with cls.lock:
            states = [(p, n, b.x, b.y, b.yaw, b.v, b.w) for p, w in cls.worlds.items() for n, b in w.bodies.items()]
        for p, name, x, y, yaw, v, w in states:
            m = Odometry()
            m.header.stamp = stamp
            m.header.frame_id = "odom"
            m.child_frame_id = "%s/%s" % (p, name)
            m.pose.pose.position.x = x
            m.pose.pose.position.y = y
            m.pose.pose.orientation.z = math.sin(yaw / 2)
            m.pose.pose.orientation.w = math.cos(yaw / 2)
            m.twist.twist.linear.x = v
            m.twist.twist.angular.z = w
            cls.odom_pubs[p, name].publish(m)

    @classmethod
    def publish_plans(cls):
        with cls.lock:
            plans = [(p, n, b.plan) for p, w in cls.worlds.items() for n, b in w.bodies.items()
                     if b.gated and b.plan is not None]
        for p, name, (vx, wz) in plans:
            t = Twist()
            t.linear.x = vx
            t.angular.z = wz
            cls.plan_pubs[p, name].publish(t)

    @classmethod
    def simulate(cls, until, t_go):
        """Runs the bases until monotonic time `until`; t_go: the scenes' start (for the scripts)."""
        last = time.monotonic()
        next_odom = next_plan = last
        while not rospy.is_shutdown():
            now = time.monotonic()
            if now >= until:
                break
            with cls.lock:
                n = max(1, int(math.ceil((now - last) / MAX_STEP)))
                for k in range(1, n + 1):
                    t_k = last + (now - last) * k / n
                    for world in cls.worlds.values():
                        world.step(t_k, t_k - t_go, (now - last) / n)
            last = now
            if now >= next_odom:
                cls.publish_odom()
                next_odom += 1.0 / ODOM_HZ
            if now >= next_plan:
                cls.publish_plans()
                next_plan += 1.0 / PLAN_HZ
            time.sleep(0.002)

    @classmethod
    def run_scenes(cls):
        t0 = time.monotonic()
        cls.t_go = t0 + SETTLE
        cls.simulate(cls.t_go, cls.t_go)  # the monitors' first cycles, all standing still
        with cls.lock:
            for world in cls.worlds.values():
                for name in ("a1", "a2", "c", "f", "wl"):
                    world.bodies[name].plan = (SPEED, 0.0)
                world.bodies["r"].plan = (-0.5, 0.0)
        cls.simulate(cls.t_go + DURATION, cls.t_go)
        with cls.lock:
            for world in cls.worlds.values():
                for body in world.bodies.values():
                    body.plan = None
        for p, world in cls.worlds.items():
            b = world.bodies
            wl_stop = b["wl"].travelled - cls.slowed_at.get((p, "wl"), b["wl"].travelled)
            f_stop = world.at_leader_stop[0] - world.gap["c"]  # the leader stands meanwhile
            rospy.loginfo("gate_braking_loop %s: smallest gap: head-on %.4f, crossing %.4f, follower %.4f, "
                          "wall %.4f, backing %.4f m", MONITORS[p], *[world.min_gap[s] for s in "abcde"])
            rospy.loginfo("gate_braking_loop %s: final gap: head-on %.4f, crossing %.4f, follower %.4f, "
                          "wall %.4f, backing %.4f m", MONITORS[p], *[world.gap[s] for s in "abcde"])
            rospy.loginfo("gate_braking_loop %s: wall robot: top speed %.3f m/s, final speed %.3f m/s, stopping "
                          "distance %.3f m (driven from its gate's first slowed command on)", MONITORS[p], b["wl"].peak,
                          b["wl"].v, wl_stop)
            rospy.loginfo("gate_braking_loop %s: follower: top speed %.3f m/s, gap %.3f m and speed %.3f m/s when the "
                          "leader stopped, %.3f m driven after it; head-on top speeds "
                          "%.3f, %.3f m/s; crossing robot: top speed %.3f m/s, reached y = %.2f", MONITORS[p],
                          b["f"].peak, world.at_leader_stop[0], world.at_leader_stop[1], f_stop, b["a1"].peak,
                          b["a2"].peak, b["c"].peak, b["c"].y)

    def setUp(self):
        self.assertTrue(self.connected, "the monitors did not subscribe to every topic")

    def test_braking_model_prevents_contact(self):
        """vadop_braking: no contact in a-d, the wall robot stops within 0.6 m, r backs away."""
        world = self.worlds["bk"]
        names = {"a": "head-on", "b": "crossing", "c": "follower", "d": "wall"}
        for s, scene in names.items():
            self.assertGreater(world.min_gap[s], 0.0, "%s touched with the braking model: gap %.4f m"
                               % (scene, world.min_gap[s]))
        self.assertGreater(world.gap["d"], 0.0)
        self.assertLessEqual(world.gap["d"], 0.6, "the wall robot stopped %.3f m from the wall" % world.gap["d"])
        self.assertLess(abs(world.bodies["wl"].v), 0.05, "the wall robot did not stop")
        # Not by standing still: each drove at speed, the head-on pair and the follower came close.
        for name in ("a1", "a2", "c", "f", "wl"):
            self.assertGreater(world.bodies[name].peak, 0.5, "%s never drove at speed" % name)
        self.assertGreater(world.bodies["wl"].peak, 0.8, "the wall robot never drove at speed")
        self.assertLess(world.gap["a"], 0.6, "the head-on robots stopped far apart")
        self.assertLess(world.at_leader_stop[0], 1.5, "the follower kept far behind the leader")
        self.assertGreater(world.bodies["c"].y, 0.5, "the crossing robot never passed the walker's lane")
        self.check_backing_away(world)

    def test_without_braking_model_touches(self):
        """vadop_no_braking (the mutation: no decelerations): the same scenes touch."""
        world = self.worlds["nb"]
        names = {"a": "head-on", "b": "crossing", "c": "follower", "d": "wall"}
        for s, scene in names.items():
            self.assertLessEqual(world.min_gap[s], 0.0, "%s did not touch without the braking model: gap %.4f m"
                                 % (scene, world.min_gap[s]))
        self.check_backing_away(world)

    def check_backing_away(self, world):
        r = world.bodies["r"]
        out = [v for t, v, _ in r.outputs if t >= 0.2]
        self.assertTrue(out and max(out) < -0.1, "r's gate held it against the block: %s" % out[:5])
        self.assertGreater(world.gap["e"], 1.0, "r did not back away from the block: gap %.3f m" % world.gap["e"])


if __name__ == "__main__":
    rostest.rosrun("vadop", "gate_braking_loop", GateBrakingLoop, sys.argv)
