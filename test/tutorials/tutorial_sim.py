"""Shared by the tutorials' rostests (test/tutorials/*_check.py): builders of the messages the
tutorials' inputs take (odometry, tracked objects, joint states, timed paths, tf transforms, a
laser's scan of a wall), a simulated base that executes a gate's cmd_vel_out, a recorder of
~impacts and the timing of an impact against its analytic time. It publishes nothing by itself
and runs no monitor: each check script scripts its own scene."""
import collections
import math
import threading

import rospy
from geometry_msgs.msg import PoseStamped, TransformStamped
from nav_msgs.msg import Odometry, Path
from sensor_msgs.msg import JointState, LaserScan
from vadop.msg import ImpactArray, TrackedObject


def wait_for_connections(pubs, subs, timeout=20.0):
    """Waits until every publisher has a subscriber and every subscriber a publisher."""
    deadline = rospy.get_time() + timeout
    while not rospy.is_shutdown() and rospy.get_time() < deadline:
        if all(p.get_num_connections() > 0 for p in pubs) and all(s.get_num_connections() > 0 for s in subs):
            return True
        rospy.sleep(0.1)
    return False


def odometry(stamp, child_frame, x, y, yaw, vx, wz, frame="odom"):
    """nav_msgs/Odometry of a planar robot: pose in `frame`, twist in the body frame (REP 105)."""
    m = Odometry()
    m.header.stamp = stamp
    m.header.frame_id = frame
    m.child_frame_id = child_frame
    m.pose.pose.position.x = x
    m.pose.pose.position.y = y
    m.pose.pose.orientation.z = math.sin(yaw / 2)
    m.pose.pose.orientation.w = math.cos(yaw / 2)
    m.twist.twist.linear.x = vx
    m.twist.twist.angular.z = wz
    return m


def tracked_object(obj_id, x, y, vx, vy):
    """vadop/TrackedObject with shape type 0 (the source's default_shape), upright."""
    o = TrackedObject()
    o.id = obj_id
    o.pose.position.x = x
    o.pose.position.y = y
    o.pose.orientation.w = 1.0
    o.twist.linear.x = vx
    o.twist.linear.y = vy
    return o


def joint_state(stamp, positions, velocities=None):
    """sensor_msgs/JointState from {joint name: position} (and {joint name: velocity})."""
    m = JointState()
    m.header.stamp = stamp
    m.name = list(positions)
    m.position = [positions[n] for n in m.name]
    if velocities is not None:
        m.velocity = [velocities[n] for n in m.name]
    return m


def timed_path(poses, frame="odom"):
    """nav_msgs/Path of a planar plan: poses [(rospy.Time, x, y, yaw)], each stamped with the time
    the body is there (the monitor's path_topic)."""
    m = Path()
    m.header.stamp = poses[0][0]
    m.header.frame_id = frame
    for stamp, x, y, yaw in poses:
        p = PoseStamped()
        p.header.stamp = stamp
        p.header.frame_id = frame
        p.pose.position.x = x
        p.pose.position.y = y
        p.pose.orientation.z = math.sin(yaw / 2)
        p.pose.orientation.w = math.cos(yaw / 2)
        m.poses.append(p)
    return m


def transform(stamp, parent, child, x, y, yaw):
    """geometry_msgs/TransformStamped of a planar pose of `child` in `parent` (for tf2's broadcaster)."""
    t = TransformStamped()
    t.header.stamp = stamp
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.translation.x = x
    t.transform.translation.y = y
    t.transform.rotation.z = math.sin(yaw / 2)
    t.transform.rotation.w = math.cos(yaw / 2)
    return t


def scan_of_wall(stamp, frame, laser_x, laser_y, wall_x, wall_half_width, beams=181, range_max=10.0):
    """sensor_msgs/LaserScan over [-pi/2, pi/2] of a laser at (laser_x, laser_y), facing +x, that
    sees only the plane x = wall_x for |y| <= wall_half_width (other beams: +inf, out of range)."""
    m = LaserScan()
    m.header.stamp = stamp
    m.header.frame_id = frame
    m.angle_min, m.angle_max = -math.pi / 2, math.pi / 2
    m.angle_increment = math.pi / (beams - 1)
    m.range_min, m.range_max = 0.05, range_max
    for k in range(beams):
        a = m.angle_min + k * m.angle_increment
        r = float("inf")
        if math.cos(a) > 1e-9:
            d = (wall_x - laser_x) / math.cos(a)
            if 0.0 < d < range_max and abs(laser_y + d * math.sin(a)) <= wall_half_width:
                r = d
        m.ranges.append(r)
    return m


class Base:
    """A planar differential base driven by a gate's cmd_vel_out as a real one is: each command is
    executed `delay` s after it arrives and the applied velocity ramps towards it at `linear_ramp`
    m/s^2 (never a jump). Integrated as a unicycle in steps of at most `max_step` s."""

    def __init__(self, x, y, yaw, delay=0.06, linear_ramp=1.0, angular_ramp=2.0, max_step=0.005):
        self.x, self.y, self.yaw = x, y, yaw
        self.v = self.w = 0.0
        self.delay, self.linear_ramp, self.angular_ramp, self.max_step = delay, linear_ramp, angular_ramp, max_step
        self.target = (0.0, 0.0)
        self.queue = collections.deque()
        self.lock = threading.Lock()

    def on_command(self, msg):
        with self.lock:
            self.queue.append((rospy.get_time() + self.delay, msg.linear.x, msg.angular.z))

    @staticmethod
    def _towards(value, target, max_change):
        return value + max(-max_change, min(max_change, target - value))

    def advance(self, now, dt):
        """Integrates from now - dt to now."""
        with self.lock:
            steps = max(1, int(math.ceil(dt / self.max_step)))
            h = dt / steps
            for k in range(steps):
                t = now - dt + (k + 1) * h
                while self.queue and self.queue[0][0] <= t:
                    _, vx, wz = self.queue.popleft()
                    self.target = (vx, wz)
                self.v = self._towards(self.v, self.target[0], self.linear_ramp * h)
                self.w = self._towards(self.w, self.target[1], self.angular_ramp * h)
                self.x += self.v * math.cos(self.yaw) * h
                self.y += self.v * math.sin(self.yaw) * h
                self.yaw += self.w * h

    def state(self):
        with self.lock:
            return self.x, self.y, self.yaw, self.v, self.w


class ImpactRecorder:
    """Keeps every vadop/ImpactArray published on `topic`."""

    def __init__(self, topic="/vadop_monitor/impacts"):
        self.lock = threading.Lock()
        self.arrays = []
        self.sub = rospy.Subscriber(topic, ImpactArray, self._on_array, queue_size=100)

    def _on_array(self, msg):
        with self.lock:
            self.arrays.append(msg)

    def since(self, stamp):
        with self.lock:
            return [a for a in self.arrays if a.header.stamp > stamp]


def impacts_of_pair(arrays, body_a, body_b):
    """(array, impact) for each array's first impact of the pair {body_a, body_b} (either order)."""
    found = []
    for a in arrays:
        for i in a.impacts:
            if {i.body_a, i.body_b} == {body_a, body_b}:
                found.append((a, i))
                break
    return found


def timing_errors(found, contact):
    """Each impact's time_to_impact minus the analytic one (contact: the rospy.Time of contact)."""
    return [i.time_to_impact - (contact - a.header.stamp).to_sec() for a, i in found]
