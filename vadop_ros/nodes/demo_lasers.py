"""Simulated 2D lasers of the demo's agents (demo_sim.py with ~sensors): one level laser on every
agent, ray-cast with numpy over lasers x beams x obstacles at once, so that 20 agents' 360-beam
scans at 10 Hz cost the simulator a few milliseconds a cycle.

What a laser sees: the room's inner wall faces (the square |x|, |y| <= room_half), circles (the
pillar and every other agent's base: a laser never sees its own agent) and the pallet (an
axis-aligned box). Everything is taller than the laser's height, so the scene is 2D. It does not
model noise, beam width, the agents' masts (above the laser) or motion during a scan."""
import math

import numpy as np

LASER_ON_BASE = (0.15, 0.0, 0.2)   # m: agent_<i>/laser in agent_<i>/base_link (level, facing forward)
RANGE_MIN, RANGE_MAX = 0.05, 10.0
# A loaded pallet left in the room (centre x, y; size x, y): in no configuration, only the lasers
# see it. Off the agents' collision courses (demo_sim.make_agents), 1 m high with its load.
PALLET = ((-3.0, -3.2), (1.2, 0.8))


class Lasers:
    """Ranges of the lasers of agents at (x, y, yaw), of `beams` beams from -pi, +inf (REP 117)
    where nothing lies within RANGE_MAX."""

    def __init__(self, beams, room_half, circles, pallet):
        self.beams = beams
        self.increment = 2.0 * math.pi / beams
        self.angle_min = -math.pi
        self.room_half = room_half
        self.circles = np.asarray(circles, dtype=float).reshape(-1, 3)   # fixed: x, y, radius
        (cx, cy), (sx, sy) = pallet
        self.box_lo = np.array([cx - sx / 2, cy - sy / 2])
        self.box_hi = np.array([cx + sx / 2, cy + sy / 2])

    def ranges(self, poses, which, agent_radius):
        """(len(which), beams) float32 ranges of the lasers of agents `which` (indices into poses,
        an (n, 3) array of x, y, yaw of every agent)."""
        poses = np.asarray(poses, dtype=float)
        sel = poses[which]
        c, s = np.cos(sel[:, 2]), np.sin(sel[:, 2])
        ox = sel[:, 0] + c * LASER_ON_BASE[0] - s * LASER_ON_BASE[1]
        oy = sel[:, 1] + s * LASER_ON_BASE[0] + c * LASER_ON_BASE[1]
        angles = sel[:, 2:3] + self.angle_min + self.increment * np.arange(self.beams)[None, :]
        dx, dy = np.cos(angles), np.sin(angles)
        ox, oy = ox[:, None], oy[:, None]
        r = np.minimum(self._walls(ox, oy, dx, dy), self._box(ox, oy, dx, dy))
        # Circles: the fixed ones and every agent but the laser's own.
        agents = np.column_stack([poses[:, 0], poses[:, 1], np.full(len(poses), agent_radius)])
        circles = np.vstack([self.circles, agents])
        own = np.zeros((len(which), len(circles)), dtype=bool)
        own[np.arange(len(which)), len(self.circles) + np.asarray(which)] = True
        r = np.minimum(r, self._circles(ox, oy, dx, dy, circles, own))
        r[(r >= RANGE_MAX) | (r < RANGE_MIN)] = np.inf
        return r.astype(np.float32)

    def _walls(self, ox, oy, dx, dy):
        h = self.room_half
        with np.errstate(divide="ignore", invalid="ignore"):
            tx = np.where(dx > 0, (h - ox) / dx, np.where(dx < 0, (-h - ox) / dx, np.inf))
            ty = np.where(dy > 0, (h - oy) / dy, np.where(dy < 0, (-h - oy) / dy, np.inf))
        return np.minimum(tx, ty)

    def _box(self, ox, oy, dx, dy):
        """Slab method: the entry distance into the pallet, +inf when the ray misses it."""
        with np.errstate(divide="ignore", invalid="ignore"):
            t1x, t2x = (self.box_lo[0] - ox) / dx, (self.box_hi[0] - ox) / dx
            t1y, t2y = (self.box_lo[1] - oy) / dy, (self.box_hi[1] - oy) / dy
        near = np.maximum(np.minimum(t1x, t2x), np.minimum(t1y, t2y))
        far = np.minimum(np.maximum(t1x, t2x), np.maximum(t1y, t2y))
        hit = (near <= far) & (near > 0)
        return np.where(hit, near, np.inf)

    @staticmethod
    def _circles(ox, oy, dx, dy, circles, own):
        """The nearest entry into a circle, +inf when none (a laser inside a circle, where two
        bodies overlap, does not see that one)."""
        fx = ox[:, :, None] - circles[None, None, :, 0]   # (lasers, beams, circles)
        fy = oy[:, :, None] - circles[None, None, :, 1]
        b = fx * dx[:, :, None] + fy * dy[:, :, None]
        cc = fx * fx + fy * fy - circles[None, None, :, 2] ** 2
        disc = b * b - cc
        with np.errstate(invalid="ignore"):
            t = -b - np.sqrt(disc)
        hit = (disc >= 0) & (cc > 0) & (t > 0) & ~own[:, None, :]
        return np.where(hit, t, np.inf).min(axis=2)


class ScanPublisher:
    """Publishes the agents' scans (/agent_<i>/scan, frame agent_<i>/laser) and their mounts on
    /tf_static; each laser scans every `every` simulator cycles, the agents spread over them."""

    def __init__(self, lasers, count, every):
        import rospy
        import tf2_ros
        from geometry_msgs.msg import TransformStamped
        from sensor_msgs.msg import LaserScan
        self.lasers, self.count, self.every, self.cycle = lasers, count, max(1, every), 0
        self.msg_type = LaserScan
        self.pubs = [rospy.Publisher("/agent_%d/scan" % i, LaserScan, queue_size=2) for i in range(count)]
        mounts = []
        for i in range(count):
            t = TransformStamped()
            t.header.frame_id = "agent_%d/base_link" % i
            t.child_frame_id = "agent_%d/laser" % i
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = LASER_ON_BASE
            t.transform.rotation.w = 1.0
            mounts.append(t)
        self.static_tf = tf2_ros.StaticTransformBroadcaster()
        self.static_tf.sendTransform(mounts)

    def publish(self, poses, stamp, agent_radius):
        """The scans due this cycle, of the agents at `poses` [(x, y, yaw)] at `stamp`."""
        which = [i for i in range(self.count) if i % self.every == self.cycle % self.every]
        self.cycle += 1
        if not which:
            return
        ranges = self.lasers.ranges(poses, which, agent_radius)
        for row, i in enumerate(which):
            m = self.msg_type()
            m.header.stamp = stamp
            m.header.frame_id = "agent_%d/laser" % i
            m.angle_min = self.lasers.angle_min
            m.angle_increment = self.lasers.increment
            m.angle_max = self.lasers.angle_min + (self.lasers.beams - 1) * self.lasers.increment
            m.range_min, m.range_max = RANGE_MIN, RANGE_MAX
            m.ranges = ranges[row].tolist()
            self.pubs[i].publish(m)
