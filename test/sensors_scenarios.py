#!/usr/bin/python3
"""rostest node of sensors.test (issue 49): obstacles that only a sensor sees, judged against the
test's own geometry (sensor_truth.py) of the points it published. Five scenes run at once, each
in its own place or monitor:
  a. scan wall (vadop_sensors): scan_bot drives at an oblique wall that only its own laser
     (scan_bot/laser, in tf) sees; every impact of scan_bot with front_laser must lie within
     30 ms of the first contact of the sphere with the balls of a scan published just before;
  b. gated stop (vadop_gated): gbot's planner drives it at 0.8 m/s at a wall only its laser
     sees; its base executes the gate's commands BASE_DELAY late and ramps at LINEAR_RAMP; it
     must drive at speed, then stop without touching a single published point;
  c. stale scan (vadop_stale): stale_laser's scans stop for 1.5 s: s1's gate publishes zero
     Twists with reason stale naming the sensor, s2's (ignore "stale_*") keeps forwarding, and
     s1 forwards again once the scans are back;
  d. height band (vadop_sensors): table_cam's cloud holds a table (top and edge at z 0.725 m)
     and the floor in front of it (z 0.025 m, below the sensor's min_z): tall_bot (a 1.5 m high
     box) hits the edge at the exact time, short_bot (0.5 m high) passes under with no impact;
  e. map wall (vadop_sensors): floor_map (timeout 0, published once) holds a wall of occupied
     cells behind cells of value 50 and -1; map_bot hits the wall at the exact time;
  f. a robot moving away (vadop_sensors): watch_laser, on the standing watcher, sees leaver
     (a monitored body) drive away from it towards a wall only the laser sees: leaver's own
     points are dropped (filter_margin), so its impacts with watch_laser are with the wall, at
     the exact time against the published points outside leaver's shape grown by the margin.
  g. gated stop at a fixed laser's fence (vadop_gated_fixed): fbot drives as gbot does (the
     same plan, delay and ramp) at a fence that only a laser fixed across it sees (not carried
     by fbot: a gated body's points are dropped within self_margin whichever sensor saw them,
     never within filter_margin); it must drive at speed, then stop without touching a
     published point.
Scenes a, d, e and f lie 50 m apart, so that each sees only its own sensor's obstacles."""
import math
import sys
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import TransformStamped, Twist
from nav_msgs.msg import OccupancyGrid, Odometry
from sensor_msgs import point_cloud2
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Header
from vadop.msg import GateStateArray, ImpactArray

import sensor_truth as st

ODOM_HZ = 50.0
SCAN_HZ = 10.0
PLAN_HZ = 20.0
SETTLE = 1.0          # s before the scenes start: the monitors' first cycles, every sensor fresh
DURATION = 6.0        # s of the scenes (gbot closes in on the wall ever slower: time to stand)
TOLERANCE = 0.03      # s: an impact's time against the exact one
BEAMS = 360
RANGE_MAX = 8.0
LASER_ON_BASE = (0.1, 0.0, 0.1)   # base_link -> laser (level, facing forward)
SPEED = 0.5           # m/s: the scripted bodies of a, d and e

# a: the sphere of scan_bot (the monitor's point_radius of front_laser is in sensors.test).
SCAN_BOT_RADIUS, SCAN_POINT_RADIUS = 0.4, 0.05
OBLIQUE_WALL = [(1.5 - 1.0, -2.0 * math.sin(math.pi / 3), 1.5 + 1.0, 2.0 * math.sin(math.pi / 3))]
# b: gbot and its base.
GBOT_RADIUS, GATE_POINT_RADIUS = 0.4, 0.02
GATE_WALL = [(2.5, -3.0, 2.5, 3.0)]
PLAN_SPEED = 0.8
BASE_DELAY, LINEAR_RAMP, MAX_STEP = 0.06, 1.0, 0.005
# g: the fence and the laser fixed across it (position of its frame in odom), facing fbot's path.
FENCE = [(2.5, -1.5, 2.5, 1.5)]
FENCE_LASER = (3.5, 0.0, 0.1)
# c: the phases of stale_laser (s after the start) and the command the planners give.
STALE_FROM, STALE_UNTIL, STALE_TIMEOUT, STALE_CMD = 2.0, 3.5, 0.5, 0.3
STALE_LASER = ((20.0, 0.0, 0.2), 1.0)   # position of its frame, range of every beam
# d: the table (x, y extents; top at TABLE_Z), the floor in front of it, the two boxes.
TABLE_X, TABLE_Y, TABLE_Z, FLOOR_Z, VOXEL = (2.0, 2.8), (49.0, 51.5), 0.725, 0.025, 0.05
CAM = ((3.0, 50.0, 1.2), math.pi / 2)   # table_cam in odom: translation, yaw
TALL = ("tall_bot", (0.3, 0.3, 0.75), (0.455, 49.6, 0.75))   # name, half sizes, centre at the start
SHORT = ("short_bot", (0.3, 0.3, 0.25), (0.455, 50.9, 0.25))
CLOUD_POINT_RADIUS = 0.02
# e: the grid (origin, resolution, size), its columns of occupied (100), 50 and unknown cells.
MAP_ORIGIN, MAP_RES, MAP_SIZE = (10.0, 98.0), 0.1, 40
MAP_WALL_COLUMN, MAP_FIFTY_COLUMN, MAP_UNKNOWN_COLUMN = 25, 17, 20
MAP_BOT_RADIUS, MAP_BOT_START = 0.4, (11.0, 100.03, 1.0)
MAP_BAND = (0.0, 2.0)   # the sensor's default height band
# f: the watcher (standing, its laser's base), leaver's start and radius, the wall, the margin.
WATCHER = (0.0, 146.0)
LEAVER_START, LEAVER_RADIUS = (2.0, 150.0), 0.4
LEAVER_WALL = [(4.0, 148.5, 4.0, 151.5)]
FILTER_MARGIN, WATCH_POINT_RADIUS = 0.1, 0.02   # watch_laser's defaults


def stamp_of(t):
    return rospy.Time.from_sec(t)


def odometry(stamp, frame, x, y, z, v):
    m = Odometry()
    m.header.stamp = stamp
    m.header.frame_id = "odom"
    m.child_frame_id = frame
    m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z = x, y, z
    m.pose.pose.orientation.w = 1.0
    m.twist.twist.linear.x = v
    return m


def transform(stamp, parent, child, xyz, yaw=0.0):
    t = TransformStamped()
    t.header.stamp = stamp
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz
    t.transform.rotation.z, t.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return t


class Laser:
    """A level 360-beam laser ray-casting its scene's wall segments; keeps what it published:
    (stamp s, fixed-frame points of the published ranges)."""

    def __init__(self, topic, frame, segments, circles_at=None):
        self.frame, self.segments, self.circles_at = frame, segments, circles_at
        self.pub = rospy.Publisher(topic, LaserScan, queue_size=10)
        self.inc = st.f32(2 * math.pi / BEAMS)
        self.amin = st.f32(-math.pi)
        self.published = []

    def publish(self, t, pose):
        """One scan stamped t, taken from the laser pose (x, y, z, yaw) at t."""
        x, y, z, yaw = pose
        angles = yaw + self.amin + np.arange(BEAMS) * self.inc
        circles = self.circles_at(t) if self.circles_at else []
        ranges = st.ray_cast((x, y), angles, self.segments, RANGE_MAX, circles) if self.segments else \
            np.full(BEAMS, STALE_LASER[1], dtype=st.F32)
        m = LaserScan()
        m.header.stamp = stamp_of(t)
        m.header.frame_id = self.frame
        m.angle_min, m.angle_increment = self.amin, self.inc
        m.angle_max = st.f32(self.amin + (BEAMS - 1) * self.inc)
        m.range_min, m.range_max = st.f32(0.05), st.f32(RANGE_MAX)
        m.ranges = [float(r) for r in ranges]
        self.pub.publish(m)
        self.published.append((t, st.scan_points(m.angle_min, m.angle_increment, m.ranges, m.range_min,
                                                 m.range_max, pose)))


class Base:
    """gbot's base on a straight line: it executes each command BASE_DELAY s after its arrival and
    ramps its speed towards it at LINEAR_RAMP (never a jump), integrated in steps <= MAX_STEP."""

    def __init__(self, x):
        self.x, self.v, self.target, self.peak = x, 0.0, 0.0, 0.0
        self.queue = []        # (time to execute, speed), in arrival order
        self.trace = [(0.0, x)]   # (t, x) after every step
        self.full = False         # the gate forwarded the plan's full speed
        self.first_slowed = None  # x when the gate first forwarded less than that after it

    def advance(self, t_from, t_to):
        n = max(1, int(math.ceil((t_to - t_from) / MAX_STEP)))
        dt = (t_to - t_from) / n
        for k in range(1, n + 1):
            t = t_from + k * dt
            while self.queue and self.queue[0][0] <= t:
                self.target = self.queue.pop(0)[1]
            v0 = self.v
            self.v += max(-LINEAR_RAMP * dt, min(LINEAR_RAMP * dt, self.target - self.v))
            self.x += 0.5 * (v0 + self.v) * dt
            self.peak = max(self.peak, self.v)
            self.trace.append((t, self.x))


class Scenes:
    """Every scene's publishers, their state and what the monitors answered."""

    def __init__(self):
        self.lock = threading.Lock()
        self.tfb = tf2_ros.TransformBroadcaster()
        self.static_tfb = tf2_ros.StaticTransformBroadcaster()
        names = ["scan_bot", TALL[0], SHORT[0], "map_bot", "watcher", "leaver"]
        self.odom = {n: rospy.Publisher("/a/%s/odom" % n, Odometry, queue_size=10) for n in names}
        self.odom.update({n: rospy.Publisher("/%s/odom" % n, Odometry, queue_size=10)
                          for n in ("gs/gbot", "gf/fbot", "st/s1", "st/s2")})
        self.plans = {n: rospy.Publisher("/%s/nav_vel" % n, Twist, queue_size=10)
                      for n in ("gs/gbot", "gf/fbot", "st/s1", "st/s2")}
        self.front_laser = Laser("/a/scan", "scan_bot/laser", OBLIQUE_WALL)
        self.gate_laser = Laser("/gs/scan", "gbot/laser", GATE_WALL)
        self.stale_laser = Laser("/st/scan", "st_laser", [])
        self.fence_laser = Laser("/gf/scan", "gf_laser", FENCE)
        self.watch_laser = Laser("/a/watch_scan", "watcher/laser", LEAVER_WALL,
                                 lambda t: [(self.leaver_x(t), LEAVER_START[1], LEAVER_RADIUS)])
        self.cloud_pub = rospy.Publisher("/a/points", point_cloud2.PointCloud2, queue_size=5)
        self.map_pub = rospy.Publisher("/a/map", OccupancyGrid, queue_size=1, latch=True)
        self.impacts, self.gate_states, self.outputs = [], [], {n: [] for n in ("gs/gbot", "gf/fbot", "st/s1", "st/s2")}
        self.gbot, self.fbot = Base(0.0), Base(0.0)
        self.bases = {"gs/gbot": self.gbot, "gf/fbot": self.fbot}
        self.subs = [rospy.Subscriber("/vadop_sensors/impacts", ImpactArray, self.on_impacts, queue_size=200),
                     rospy.Subscriber("/vadop_stale/gate_states", GateStateArray, self.on_gate_states, queue_size=200)]
        self.subs += [rospy.Subscriber("/%s/cmd_vel" % n, Twist, self.on_cmd, callback_args=n, queue_size=200)
                      for n in self.outputs]
        self.cloud_world = self.table_points()
        self.t_go = None

    # --- what the monitors answer ------------------------------------------------------------
    def on_impacts(self, msg):
        with self.lock:
            self.impacts.append(msg)

    def on_gate_states(self, msg):
        with self.lock:
            self.gate_states.append((rospy.get_time(), msg))

    def on_cmd(self, msg, name):
        now = rospy.get_time()
        with self.lock:
            self.outputs[name].append((now, msg))
            base = self.bases.get(name)
            if base is not None:
                base.queue.append((now + BASE_DELAY, msg.linear.x))
                if msg.linear.x >= PLAN_SPEED - 1e-3:
                    base.full = True
                elif base.full and base.first_slowed is None:
                    base.first_slowed = base.x

    # --- the scenes' worlds ------------------------------------------------------------------
    @staticmethod
    def table_points():
        """Fixed-frame points of the table (top, its edge the first row) and the floor in front
        of it, at voxel centres (the monitor's default voxel keeps every one)."""
        def centres(lo, hi, step):
            return np.arange(lo + VOXEL / 2, hi, step)
        ys = centres(*TABLE_Y, VOXEL)
        top = [(x, y, TABLE_Z) for x in centres(*TABLE_X, VOXEL) for y in ys]
        floor = [(x, y, FLOOR_Z) for x in centres(0.0, TABLE_X[0], 2 * VOXEL) for y in ys[::2]]
        return np.array(top + floor)

    def cloud_message(self, t):
        cam = st.inverse_transform(self.cloud_world, *CAM).astype(st.F32)
        return point_cloud2.create_cloud_xyz32(Header(stamp=stamp_of(t), frame_id="table_cam"), cam.tolist())

    def published_cloud_points(self):
        """The cloud's points as published (float32 in table_cam), back in the fixed frame."""
        cam = st.inverse_transform(self.cloud_world, *CAM).astype(st.F32).astype(float)
        return st.transform(cam, *CAM)

    @staticmethod
    def map_values():
        data = np.zeros((MAP_SIZE, MAP_SIZE), dtype=int)   # [row iy][column ix]
        data[5:35, MAP_WALL_COLUMN] = 100
        data[:, MAP_FIFTY_COLUMN] = 50
        data[:, MAP_UNKNOWN_COLUMN] = -1
        return data

    def map_message(self, t):
        m = OccupancyGrid()
        m.header.stamp = stamp_of(t)
        m.header.frame_id = "odom"
        m.info.resolution = MAP_RES
        m.info.width = m.info.height = MAP_SIZE
        m.info.origin.position.x, m.info.origin.position.y = MAP_ORIGIN
        m.info.origin.orientation.w = 1.0
        m.data = self.map_values().flatten().tolist()
        return m

    def scripted_x(self, x0, t):
        return x0 + SPEED * (t - self.t_go)

    def scan_bot_x(self, t):
        return self.scripted_x(-0.3, t)

    def leaver_x(self, t):
        return self.scripted_x(LEAVER_START[0], t)

    # --- the loop ----------------------------------------------------------------------------
    def static_transforms(self):
        zero = rospy.Time(0)
        self.static_tfb.sendTransform([
            transform(zero, "scan_bot/base_link", "scan_bot/laser", LASER_ON_BASE),
            transform(zero, "gbot/base_link", "gbot/laser", LASER_ON_BASE),
            transform(zero, "watcher/base_link", "watcher/laser", LASER_ON_BASE),
            transform(zero, "odom", "st_laser", STALE_LASER[0]),
            transform(zero, "odom", "gf_laser", FENCE_LASER),
            transform(zero, "odom", "table_cam", CAM[0], CAM[1])])

    def wait_for_connections(self):
        pubs = list(self.odom.values()) + list(self.plans.values()) + [
            self.front_laser.pub, self.gate_laser.pub, self.stale_laser.pub, self.watch_laser.pub, self.cloud_pub,
            self.map_pub, self.fence_laser.pub]
        deadline = time.monotonic() + 30.0
        while not rospy.is_shutdown() and time.monotonic() < deadline:
            if all(p.get_num_connections() > 0 for p in pubs) and all(s.get_num_connections() > 0 for s in self.subs):
                return True
            time.sleep(0.1)
        return False

    def publish_state(self, t):
        """Odometry and tf of every body at t."""
        stamp = stamp_of(t)
        bodies = {"a/scan_bot": (self.scan_bot_x(t), 0.0, 0.0, SPEED),
                  "a/" + TALL[0]: (self.scripted_x(TALL[2][0], t),) + TALL[2][1:] + (SPEED,),
                  "a/" + SHORT[0]: (self.scripted_x(SHORT[2][0], t),) + SHORT[2][1:] + (SPEED,),
                  "a/map_bot": (self.scripted_x(MAP_BOT_START[0], t),) + MAP_BOT_START[1:] + (SPEED,),
                  "a/watcher": WATCHER + (0.0, 0.0),
                  "a/leaver": (self.leaver_x(t), LEAVER_START[1], 0.0, SPEED),
                  "gs/gbot": (self.gbot.x, 0.0, 0.0, self.gbot.v),
                  "gf/fbot": (self.fbot.x, 0.0, 0.0, self.fbot.v),
                  "st/s1": (0.0, 0.0, 0.0, 0.0), "st/s2": (0.0, 5.0, 0.0, 0.0)}
        for key, (x, y, z, v) in bodies.items():
            name = key.split("/")[1]
            self.odom[name if key.startswith("a/") else key].publish(odometry(stamp, name + "/base_link", x, y, z, v))
        self.tfb.sendTransform([transform(stamp, "odom", "scan_bot/base_link", bodies["a/scan_bot"][:3]),
                                transform(stamp, "odom", "gbot/base_link", bodies["gs/gbot"][:3]),
                                transform(stamp, "odom", "watcher/base_link", bodies["a/watcher"][:3])])

    @staticmethod
    def laser_pose(x_base, y_base=0.0):
        return (x_base + LASER_ON_BASE[0], y_base + LASER_ON_BASE[1], LASER_ON_BASE[2], 0.0)

    def publish_sensors(self, t, last_tf, gbot_x_then):
        self.front_laser.publish(last_tf, self.laser_pose(self.scan_bot_x(last_tf)))
        self.gate_laser.publish(last_tf, self.laser_pose(gbot_x_then))
        self.watch_laser.publish(last_tf, self.laser_pose(*WATCHER))
        self.fence_laser.publish(t, FENCE_LASER + (0.0,))
        rel = t - self.t_go
        if not STALE_FROM <= rel < STALE_UNTIL:
            self.stale_laser.publish(t, STALE_LASER[0] + (0.0,))
        self.cloud_pub.publish(self.cloud_message(t))

    def publish_plans(self, t):
        go = t >= self.t_go
        for name, speed in (("gs/gbot", PLAN_SPEED if go else 0.0), ("gf/fbot", PLAN_SPEED if go else 0.0),
                            ("st/s1", STALE_CMD), ("st/s2", STALE_CMD)):
            cmd = Twist()
            cmd.linear.x = speed
            self.plans[name].publish(cmd)

    def run(self):
        self.static_transforms()
        start = rospy.get_time()
        self.t_go = start + SETTLE
        for base in self.bases.values():
            base.trace = [(start, base.x)]
        self.map_pub.publish(self.map_message(start))
        last = start
        last_tf = None
        gbot_x_at = {}
        next_odom = next_scan = next_plan = start
        while not rospy.is_shutdown():
            t = rospy.get_time()
            if t >= self.t_go + DURATION:
                break
            with self.lock:
                for base in self.bases.values():
                    base.advance(last, t)
                gbot_x = self.gbot.x
            last = t
            if t >= next_odom:
                next_odom += 1.0 / ODOM_HZ
                self.publish_state(t)
                gbot_x_at[t] = gbot_x
                # The lasers on bodies scan from their pose at the previous tf stamp, stamped
                # with it: the monitor has the transform of every scan it receives.
                if last_tf is not None and t >= next_scan:
                    next_scan += 1.0 / SCAN_HZ
                    self.publish_sensors(t, last_tf, gbot_x_at[last_tf])
                last_tf = t
            if t >= next_plan:
                next_plan += 1.0 / PLAN_HZ
                self.publish_plans(t)
            time.sleep(0.002)


class SensorsScenarios(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("sensors_scenarios", anonymous=True)
        cls.s = Scenes()
        cls.connected = cls.s.wait_for_connections()
        if cls.connected:
            cls.s.run()
            rospy.sleep(0.3)

    def setUp(self):
        self.assertTrue(self.connected, "the monitors did not subscribe to every topic")

    def arrays(self, t_from, t_to):
        with self.s.lock:
            return [a for a in self.s.impacts if t_from <= a.header.stamp.to_sec() < t_to]

    def pair_impacts(self, arrays, body, sensor):
        """Per array: its first impact of body with sensor, or None."""
        out = []
        for a in arrays:
            found = [i for i in a.impacts if {i.body_a, i.body_b} == {body, sensor}]
            out.append(found[0] if found else None)
        return out

    def check_times(self, arrays, body, sensor, truth_of, label):
        """Every array's impact of body with sensor within TOLERANCE of truth_of(array stamp)
        (a list of acceptable exact times); returns (first error, largest error, arrays)."""
        impacts = self.pair_impacts(arrays, body, sensor)
        errors = []
        for a, i in zip(arrays, impacts):
            self.assertIsNotNone(i, "%s: no impact of %s with %s in the array at %.3f s: %s" % (
                label, body, sensor, a.header.stamp.to_sec() - self.s.t_go, [(x.body_a, x.body_b) for x in a.impacts]))
            self.assertEqual((i.link_a, i.link_b), ("", ""))
            self.assertFalse(i.in_contact, "%s: %s in contact with %s's points at %.3f s" % (
                label, body, sensor, a.header.stamp.to_sec() - self.s.t_go))
            truths = truth_of(a.header.stamp.to_sec())
            err = min(abs(i.time_of_impact.to_sec() - tt) for tt in truths)
            self.assertLess(err, TOLERANCE, "%s: impact at %.4f s, exact %s (s after the start; array at %.3f s)" % (
                label, i.time_of_impact.to_sec() - self.s.t_go, ["%.4f" % (tt - self.s.t_go) for tt in truths],
                a.header.stamp.to_sec() - self.s.t_go))
            errors.append(err)
        self.assertGreater(len(errors), 10, "%s: too few arrays checked" % label)
        return errors[0], max(errors), len(errors)

    def scan_truths(self, laser, x_of, y, radius, point_radius, label):
        """(stamp, first contact) of a sphere at (x_of(t), y, 0) with each of the laser's published
        scans (points: a function of the stamp and the scan's points), until the sphere reaches
        the first scan's contact (the scripted robot goes on through the wall after it)."""
        truths = []
        for t, pts in laser.published:
            def gap(times, pts=pts):
                c = np.column_stack([x_of(times), np.full(len(times), y), np.zeros(len(times))])
                return st.gap_sphere_balls(c, radius, pts, point_radius)
            if truths and t >= truths[0][1]:
                break
            truths.append((t, st.first_contact(gap, t, t + 6.0)))
            self.assertIsNotNone(truths[-1][1], "%s: the scan at %.3f s misses the wall in the robot's path" % (
                label, t - self.s.t_go))
        return truths

    def check_scan_scene(self, truths, body, sensor, label):
        """Every array from the first scan on (until shortly before the contact) against the exact
        contacts of the scans published within the 0.3 s before it (the one in use)."""
        spread = max(tt for _, tt in truths) - min(tt for _, tt in truths)
        first_scan, contact = truths[0][0], min(tt for _, tt in truths)
        arrays = self.arrays(first_scan + 0.15, contact - 0.2)
        first, worst, n = self.check_times(arrays, body, sensor,
                                           lambda s: [tt for t, tt in truths if s - 0.3 <= t <= s], label)
        return ("%d scans (their exact contacts spread over %.1f ms); first impact %.3f ms from the exact time, "
                "largest error %.3f ms over %d arrays" % (len(truths), 1e3 * spread, 1e3 * first, 1e3 * worst, n))

    def test_a_scan_wall(self):
        truths = self.scan_truths(self.s.front_laser, self.s.scan_bot_x, 0.0, SCAN_BOT_RADIUS, SCAN_POINT_RADIUS,
                                  "scan wall")
        rospy.loginfo("a. scan wall: %s", self.check_scan_scene(truths, "scan_bot", "front_laser", "scan wall"))

    def check_gated_stop(self, b, laser, name, label):
        """The base b drove at speed towards the laser's points and stopped short of every one
        of them (the sphere of GBOT_RADIUS along its trace against the published balls)."""
        pts = np.vstack([p for _, p in laser.published])
        trace = np.array(b.trace)
        centres = np.column_stack([trace[:, 1], np.zeros(len(trace)), np.zeros(len(trace))])
        gaps = np.concatenate([st.gap_sphere_balls(centres[k:k + 200], GBOT_RADIUS, pts, GATE_POINT_RADIUS)
                               for k in range(0, len(centres), 200)])
        final_gap = gaps[-1]
        stopping = b.x - b.first_slowed if b.first_slowed is not None else float("nan")
        rospy.loginfo("%s: top speed %.3f m/s, final speed %.4f m/s, smallest gap to the %d published "
                      "points %.4f m, final %.4f m, driven %.3f m after the gate first slowed it",
                      label, b.peak, b.v, len(pts), gaps.min(), final_gap, stopping)
        self.assertGreater(b.peak, 0.7, "%s never drove at speed" % name)
        self.assertGreater(b.x, 1.0, "%s did not drive towards the points" % name)
        self.assertGreater(gaps.min(), 0.0, "%s touched the points: gap %.4f m" % (name, gaps.min()))
        self.assertLess(abs(b.v), 0.05, "%s did not stop" % name)
        self.assertLess(final_gap, 0.6, "%s stopped %.3f m from the points" % (name, final_gap))

    def test_b_gated_stop(self):
        self.check_gated_stop(self.s.gbot, self.s.gate_laser, "gbot", "b. gated stop")

    def test_g_gated_stop_at_a_fixed_lasers_fence(self):
        self.check_gated_stop(self.s.fbot, self.s.fence_laser, "fbot", "g. gated stop at a fixed laser's fence")

    def test_c_stale_scan(self):
        go = self.s.t_go
        with self.s.lock:
            states = list(self.s.gate_states)
            out = {n: list(v) for n, v in self.s.outputs.items()}
        # Windows (s after the start), leaving the timeout and a cycle for each change.
        fresh = (0.5, STALE_FROM)
        stale = (STALE_FROM + STALE_TIMEOUT + 0.15, STALE_UNTIL)
        back = (STALE_UNTIL + 0.3, DURATION)

        def within(items, w):
            return [x for t, x in items if w[0] <= t - go < w[1]]
        for w, s1_forwards in ((fresh, True), (stale, False), (back, True)):
            for name, forwards in (("st/s1", s1_forwards), ("st/s2", True)):
                cmds = within(out[name], w)
                self.assertGreater(len(cmds), 5, "%s: too few commands in %s" % (name, w))
                want = STALE_CMD if forwards else 0.0
                self.assertTrue(all(abs(c.linear.x - want) < 1e-9 and c.angular.z == 0.0 for c in cmds),
                                "%s in %s s: published %s, expected %.1f" % (name, w, sorted({c.linear.x for c in cmds}),
                                                                            want))
            gates = [g for m in within(states, w) for g in m.gates]
            self.assertGreater(len(gates), 10)
            for g in gates:
                if g.body == "s1" and not s1_forwards:
                    self.assertEqual(g.reason, "stale")
                    self.assertIn("stale_laser", g.detail)
                    self.assertEqual(g.command_out.linear.x, 0.0)
                else:
                    self.assertEqual(g.reason, "clear", "%s in %s s: %s (%s)" % (g.body, w, g.reason, g.detail))
        detail = [g.detail for m in within(states, stale) for g in m.gates if g.body == "s1"][0]
        rospy.loginfo("c. stale scan: s1 stopped with \"%s\"; s2 (ignore stale_*) forwarded throughout", detail)

    def test_d_height_band(self):
        pts = self.s.published_cloud_points()
        band = pts[(pts[:, 2] >= 0.1) & (pts[:, 2] <= 2.0)]   # sensors.test: min_z 0.1, max_z 2.0

        def gap(times, body):
            x = self.s.scripted_x(body[2][0], times)
            c = np.column_stack([x, np.full(len(x), body[2][1]), np.full(len(x), body[2][2])])
            return st.gap_box_balls(c, body[1], band, CLOUD_POINT_RADIUS)
        go = self.s.t_go
        tall = st.first_contact(lambda ts: gap(ts, TALL), go - SETTLE, go + DURATION)
        self.assertIsNotNone(tall)
        self.assertIsNone(st.first_contact(lambda ts: gap(ts, SHORT), go - SETTLE, go + DURATION),
                          "the scene is wrong: short_bot touches the band's points")
        arrays = self.arrays(go - SETTLE + 0.3, tall - 0.2)
        first, worst, n = self.check_times(arrays, TALL[0], "table_cam", lambda s: [tall], "height band")
        everything = self.arrays(0.0, float("inf"))
        short_hits = [i for a in everything for i in a.impacts if SHORT[0] in (i.body_a, i.body_b)]
        self.assertEqual(short_hits, [], "short_bot, under the table, has impacts: %s" % short_hits[:2])
        rospy.loginfo("d. height band: %d of %d points in the band; tall_bot's first impact %.3f ms from the exact "
                      "time, largest error %.3f ms over %d arrays; short_bot: no impact in %d arrays", len(band),
                      len(pts), 1e3 * first, 1e3 * worst, n, len(everything))

    def test_e_map_wall(self):
        data = self.s.map_values()
        iy, ix = np.nonzero(data >= 65)   # the sensor's default occupied
        lo = np.column_stack([MAP_ORIGIN[0] + ix * MAP_RES, MAP_ORIGIN[1] + iy * MAP_RES, np.full(len(ix), MAP_BAND[0])])
        hi = lo + np.array([MAP_RES, MAP_RES, MAP_BAND[1] - MAP_BAND[0]])

        def gap(times):
            x = self.s.scripted_x(MAP_BOT_START[0], times)
            c = np.column_stack([x, np.full(len(x), MAP_BOT_START[1]), np.full(len(x), MAP_BOT_START[2])])
            return st.gap_sphere_boxes(c, MAP_BOT_RADIUS, lo, hi)
        go = self.s.t_go
        contact = st.first_contact(gap, go - SETTLE, go + DURATION)
        self.assertIsNotNone(contact)
        arrays = self.arrays(go - SETTLE + 0.3, contact - 0.2)
        first, worst, n = self.check_times(arrays, "map_bot", "floor_map", lambda s: [contact], "map wall")
        rospy.loginfo("e. map wall: %d occupied cells; first impact %.3f ms from the exact time, largest error "
                      "%.3f ms over %d arrays", len(ix), 1e3 * first, 1e3 * worst, n)


    def test_f_robot_moving_away(self):
        """leaver's own points (within its sphere grown by filter_margin at the scan's stamp) are
        no obstacle; the wall's points, the rest of each scan, are."""
        laser = self.s.watch_laser
        seen, kept = [], []
        for t, pts in laser.published:
            centre = np.array([self.s.leaver_x(t), LEAVER_START[1], 0.0])
            on_leaver = np.linalg.norm(pts - centre[None, :], axis=1) <= LEAVER_RADIUS + FILTER_MARGIN
            seen.append(int(on_leaver.sum()))
            kept.append((t, pts[~on_leaver]))

        class Kept:
            published = kept
        truths = self.scan_truths(Kept, self.s.leaver_x, LEAVER_START[1], LEAVER_RADIUS, WATCH_POINT_RADIUS,
                                  "moving away")
        seen = seen[:len(truths)]   # the scans before leaver reaches the wall
        self.assertGreater(min(seen), 3, "the scene is wrong: a scan with (almost) nothing of leaver in it")
        figures = self.check_scan_scene(truths, "leaver", "watch_laser", "moving away")
        watcher_hits = [i for a in self.arrays(0.0, float("inf")) for i in a.impacts if "watcher" in (i.body_a, i.body_b)]
        self.assertEqual(watcher_hits, [], "the standing watcher has impacts: %s" % watcher_hits[:2])
        rospy.loginfo("f. moving away: %d to %d of leaver's points in each scan dropped; against the rest: %s",
                      min(seen), max(seen), figures)


if __name__ == "__main__":
    rostest.rosrun("vadop", "sensors_scenarios", SensorsScenarios, sys.argv)
