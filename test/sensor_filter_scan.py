#!/usr/bin/python3
"""rostest node (sensor_filter_scan.test): publishes two robots' odometry, the robot's tf and a
laser scan ray-cast here (the other robot's box and a wall), and checks vadop_monitor's ~impacts
and its "sensors" diagnostics against that ray cast."""
import math
import threading
import unittest

import rospy
import rostest
import tf2_ros
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from vadop.msg import ImpactArray

HALF = 0.3                  # the boxes' half size (x and y)
V_ROBOT, V_OTHER = 1.0, 1.5  # m/s along +x
X_OTHER0 = 2.0               # the other's start (the robot starts at 0)
WALL_Y = 2.0                 # a wall along x at y = 2, from x = -5 to 30
BEAMS = 361                  # over [-90, +90] degrees
RANGE_MAX = 15.0
HORIZON = 3.0
POINT_RADIUS = 0.02
RUN = 5.0                    # s
LEAD_IN = 1.0                # s of odometry before the first scan (the monitor knows both robots)
HZ_ODOM, HZ_SCAN = 50.0, 15.0


def ray_box(ox, oy, dx, dy, cx, cy):
    """Distance along the unit ray (o, d) to the axis-aligned square of half size HALF about c."""
    t0, t1 = -math.inf, math.inf
    for o, d, c in ((ox, dx, cx), (oy, dy, cy)):
        if abs(d) < 1e-12:
            if abs(o - c) > HALF:
                return None
            continue
        a, b = (c - HALF - o) / d, (c + HALF - o) / d
        t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
    return t0 if t0 <= t1 and t0 > 0 else None


def scan_truth(t):
    """The ranges from the robot's laser (at its centre) at time t and how many hit the wall."""
    rx, ox = V_ROBOT * t, X_OTHER0 + V_OTHER * t
    ranges, wall = [], 0
    for i in range(BEAMS):
        a = -math.pi / 2 + i * math.pi / (BEAMS - 1)
        dx, dy = math.cos(a), math.sin(a)
        r = ray_box(rx, 0.0, dx, dy, ox, 0.0)
        if r is None and dy > 1e-9:
            w = WALL_Y / dy
            if w < RANGE_MAX and -5.0 <= rx + w * dx <= 30.0:
                r, wall = w, wall + 1
        ranges.append(r if r is not None else math.inf)
    return ranges, wall


class SensorFilterScan(unittest.TestCase):
    def setUp(self):
        rospy.init_node("sensor_filter_scan_test", anonymous=True)
        self.lock = threading.Lock()
        self.arrays, self.kept = [], []
        self.sub = rospy.Subscriber("/vadop_monitor/impacts", ImpactArray, self.on_impacts, queue_size=100)
        self.diag = rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=20)
        self.odom = {n: rospy.Publisher("/%s/odom" % n, Odometry, queue_size=10) for n in ("robot", "other")}
        self.scan = rospy.Publisher("/robot/scan", LaserScan, queue_size=5)
        self.tf = tf2_ros.TransformBroadcaster()
        self.static_tf = tf2_ros.StaticTransformBroadcaster()

    def on_impacts(self, msg):
        with self.lock:
            self.arrays.append(msg)

    def on_diagnostics(self, msg):
        for s in msg.status:
            if s.name.endswith(": sensors"):
                values = {kv.key: kv.value for kv in s.values}
                with self.lock:
                    self.kept.append((rospy.Time.now().to_sec(), values))

    def publish_state(self, stamp, t):
        for name, x, v in (("robot", V_ROBOT * t, V_ROBOT), ("other", X_OTHER0 + V_OTHER * t, V_OTHER)):
            m = Odometry()
            m.header.stamp, m.header.frame_id, m.child_frame_id = stamp, "odom", name + "/base_link"
            m.pose.pose.position.x, m.pose.pose.orientation.w, m.twist.twist.linear.x = x, 1.0, v
            self.odom[name].publish(m)
        tr = TransformStamped()
        tr.header.stamp, tr.header.frame_id, tr.child_frame_id = stamp, "odom", "robot/base_link"
        tr.transform.translation.x, tr.transform.rotation.w = V_ROBOT * t, 1.0
        self.tf.sendTransform(tr)

    def publish_scan(self, stamp, t):
        ranges, wall = scan_truth(t)
        s = LaserScan()
        s.header.stamp, s.header.frame_id = stamp, "robot/laser"
        s.angle_min, s.angle_increment = -math.pi / 2, math.pi / (BEAMS - 1)
        s.angle_max = s.angle_min + (BEAMS - 1) * s.angle_increment
        s.range_min, s.range_max, s.ranges = 0.05, RANGE_MAX, ranges
        self.scan.publish(s)
        return wall

    def test_another_robot_moving_away_gives_no_sensor_impact(self):
        # The truth: kept, the other's rear face at the first scan (static) would be hit by the
        # robot's front within the horizon; the wall beside the path never is.
        gap = X_OTHER0 + (V_OTHER - V_ROBOT) * LEAD_IN - 2 * HALF - POINT_RADIUS
        self.assertLess(gap / V_ROBOT, HORIZON)
        self.assertGreater(WALL_Y - HALF - POINT_RADIUS, 0.0)
        laser = TransformStamped()
        laser.header.stamp, laser.header.frame_id, laser.child_frame_id = rospy.Time.now(), "robot/base_link", "robot/laser"
        laser.transform.rotation.w = 1.0
        self.static_tf.sendTransform(laser)
        deadline = rospy.Time.now() + rospy.Duration(30.0)
        while not rospy.is_shutdown() and rospy.Time.now() < deadline:
            if all(p.get_num_connections() > 0 for p in list(self.odom.values()) + [self.scan]):
                break
            rospy.sleep(0.1)
        start, rate = rospy.Time.now(), rospy.Rate(HZ_ODOM)
        walls, last_scan = [], -1.0
        while not rospy.is_shutdown():
            now = rospy.Time.now()
            t = (now - start).to_sec()
            if t > RUN:
                break
            self.publish_state(now, t)
            if t - last_scan >= 1.0 / HZ_SCAN and t >= LEAD_IN:
                # Stamped at the previous state (tf has it on both sides by now).
                walls.append((now.to_sec(), self.publish_scan(prev, prev_t)))
                last_scan = t
            prev, prev_t = now, t
            rate.sleep()
        rospy.sleep(0.3)
        with self.lock:
            arrays, kept = list(self.arrays), list(self.kept)
        self.assertGreater(len(arrays), 50)
        for a in arrays:
            for i in a.impacts:
                self.assertNotIn("lidar", (i.body_a, i.body_b), "an impact from the scan: %s" % i)
        # The sensor's kept points are the wall's beams (within one scan's change), never the other's.
        fresh = [(s, v) for s, v in kept if v.get("lidar: stale") == "no" and s > start.to_sec() + LEAD_IN + 0.5]
        self.assertTrue(fresh, "no fresh 'sensors' status: %s" % kept[-3:])
        for s, v in fresh:
            near = [w for ws, w in walls if s - 1.5 <= ws <= s]
            self.assertTrue(near)
            self.assertTrue(min(near) - 1 <= int(v["lidar: points"]) <= max(near) + 1,
                            "kept %s points, the wall gave %s" % (v["lidar: points"], near))
            self.assertGreater(int(v["lidar: points filtered (other bodies)"]), 0)


if __name__ == "__main__":
    rostest.rosrun("vadop", "sensor_filter_scan", SensorFilterScan)
