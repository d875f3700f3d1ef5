#!/usr/bin/python3
"""Demo simulator for vadop_monitor: N agents (urdf/agent.urdf: a round base and a tilting
mast) wandering a 12 m x 12 m room with a pillar, several of them on collision courses.

Publishes, at ~rate Hz, for every agent i:
  /agent_<i>/odom   nav_msgs/Odometry: pose of agent_<i>/base_link in odom, twist in the
                    base frame (REP 105)
  /tf               odom -> agent_<i>/base_link, agent_<i>/base_link -> agent_<i>/mast
Agents bounce off the walls, the pillar and each other (so a predicted impact is usually
followed by a bounce rather than an overlap).

Private parameters: agents (20), rate (30 Hz), duration (0 = forever; else the node exits
after that many seconds, which ends demo.launch), seed (1), gates (false), and with gates the
bases' base_delay (0.06 s), base_linear_accel (1.0 m/s^2) and base_angular_accel (2.0 rad/s^2);
sensors (false), and with sensors laser_beams (360) and laser_rate (10 Hz).

With gates (demo.launch gates:=true) each agent's planner publishes its wandering command on
/agent_<i>/nav_vel (geometry_msgs/Twist, body frame) and the agent moves with what
vadop_monitor's gate publishes on /agent_<i>/cmd_vel (nothing received yet: standing still); a
planner whose agent has been held (scale < 5%) for a second turns in place for a while to find
another way. Each agent's base behaves as real ones do: it executes a command base_delay after
it arrives and ramps its velocity towards it at base_linear_accel / base_angular_accel instead
of jumping (the odometry reports the base's velocity). Without gates the agents follow their
planners directly, at once.

With sensors (demo.launch sensors:=true) every agent carries a level 2D laser
(agent_<i>/laser, LASER_ON_BASE in agent_<i>/base_link, on /tf_static) publishing
/agent_<i>/scan (sensor_msgs/LaserScan, ~laser_beams beams over 360 degrees at ~laser_rate Hz,
the agents' scans spread over the cycles) of the walls, the pillar, the other agents and a pallet
that is in no configuration (only the lasers see it; the agents bounce off it too). A laser
never sees its own agent. Each scan is stamped with the time of the last tf published and cast
from the agents' poses then (the monitor places it with tf at its stamp, and filters the agents
out by their poses then).

Contacts (an agent touching another agent, a wall, the pillar or the pallet) are counted as they
begin and reported at the end (and every 10 s), per minute of simulated time.
"""
import collections
import math
import os
import random
import sys

import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped, Twist
from nav_msgs.msg import Odometry

# demo_lasers.py lies beside this file (in the devel space the script runs through a relay
# elsewhere, which puts its own directory on the path).
sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from demo_lasers import PALLET, Lasers, ScanPublisher  # noqa: E402

ROOM_HALF = 6.0        # inner faces of the walls at +-6 m (config/demo.yaml)
RADIUS = 0.3           # base radius (urdf/agent.urdf)
PILLAR = (2.5, -2.5, 0.4)
MAST_ORIGIN = (0.1, 0.0, 0.3)


class Base:
    """A differential base as real ones behave: it executes each command `delay` s after its
    arrival (transport, controller cycle) and ramps its velocity towards it at `lin_acc` (m/s^2)
    and `ang_acc` (rad/s^2) instead of jumping; a command older than `cmd_timeout` s is dropped
    for zero (as diff_drive_controller's cmd_vel_timeout: a gate that falls silent, a monitor
    starved of CPU, stops the base). Nothing received yet: standing still."""

    def __init__(self, delay, lin_acc, ang_acc, cmd_timeout=0.5):
        self.delay, self.lin_acc, self.ang_acc = delay, lin_acc, ang_acc
        self.cmd_timeout = cmd_timeout
        self.pending = collections.deque()  # (arrival s, v, w); appended by the subscriber's thread
        self.target_v = self.target_w = 0.0
        self.target_since = None  # when the command now executed took effect
        self.v = self.w = 0.0

    def command(self, arrival, v, w):
        self.pending.append((arrival, v, w))

    def advance(self, now, dt):
        """The base's velocity over the step ending at `now` (the mean of its start and end,
        so that the distance covered while ramping is right)."""
        while self.pending and self.pending[0][0] + self.delay <= now:
            arrival, self.target_v, self.target_w = self.pending.popleft()
            self.target_since = arrival + self.delay
        if self.target_since is not None and now - self.target_since > self.cmd_timeout:
            self.target_v = self.target_w = 0.0
        v0, w0 = self.v, self.w
        self.v = ramp(self.v, self.target_v, self.lin_acc * dt)
        self.w = ramp(self.w, self.target_w, self.ang_acc * dt)
        return 0.5 * (v0 + self.v), 0.5 * (w0 + self.w)

    def forget_pending(self):
        """Time jumped back: arrival stamps are of the old timeline."""
        self.pending.clear()


def ramp(value, target, max_change):
    return value + max(-max_change, min(max_change, target - value))


class Agent:
    def __init__(self, x, y, yaw, speed, straight_for=0.0):
        self.x, self.y, self.yaw, self.v = x, y, yaw, speed
        self.wz = 0.0
        self.straight_until = straight_for  # s: no wandering before (collision courses)
        self.next_turn = straight_for
        self.mast_phase = random.uniform(0.0, 2.0 * math.pi)
        self.mast_rate = random.uniform(0.6, 1.2)
        # With gates: the gate's last output (body frame) and the planner's escape manoeuvre.
        self.out_v, self.out_w = 0.0, 0.0
        self.held_since = None   # s: when the gate started holding the agent
        self.escape_until = 0.0  # s: turning in place until then
        self.escape_w = 0.0
        self.touching = set()    # what it touches now (agent indices, "wall", "pillar")
        self.travelled = 0.0     # m
        self.speed = 0.0         # m/s: the speed it moved at over the last step
        self.base = None         # with gates: its Base

    def vel(self):
        return self.v * math.cos(self.yaw), self.v * math.sin(self.yaw)

    def set_vel(self, vx, vy):
        self.v = max(0.2, min(1.2, math.hypot(vx, vy)))
        self.yaw = math.atan2(vy, vx)


def quat_z(yaw):
    return 0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)


def quat_y(angle):
    return 0.0, math.sin(angle / 2.0), 0.0, math.cos(angle / 2.0)


def box_distance(x, y, box):
    """Distance from (x, y) to the axis-aligned box ((centre x, y), (size x, y)) and its closest point."""
    (cx, cy), (sx, sy) = box
    qx = min(max(x, cx - sx / 2), cx + sx / 2)
    qy = min(max(y, cy - sy / 2), cy + sy / 2)
    return math.hypot(x - qx, y - qy), qx, qy


def make_agents(n, pallet=None):
    agents = []
    # Collision courses first: head-on pairs along x at several y, and one crossing pair.
    courses = [
        ((-4.0, 4.0, 0.0, 0.8), (4.0, 4.0, math.pi, 0.8)),
        ((-4.5, 1.5, 0.0, 0.6), (3.5, 1.5, math.pi, 0.9)),
        ((-1.0, -4.5, math.pi / 2, 0.7), (-1.0, 3.5, -math.pi / 2, 0.7)),
        ((-5.0, -1.0, 0.0, 1.0), (0.0, -5.0, math.pi / 2, 0.8)),  # crossing at right angles
    ]
    for a, b in courses:
        if len(agents) + 2 > n:
            break
        agents.append(Agent(a[0], a[1], a[2], a[3], straight_for=8.0))
        agents.append(Agent(b[0], b[1], b[2], b[3], straight_for=8.0))
    # The others at random free places.
    tries = 0
    while len(agents) < n and tries < 100000:
        tries += 1
        x = random.uniform(-ROOM_HALF + 0.6, ROOM_HALF - 0.6)
        y = random.uniform(-ROOM_HALF + 0.6, ROOM_HALF - 0.6)
        if math.hypot(x - PILLAR[0], y - PILLAR[1]) < PILLAR[2] + RADIUS + 0.3:
            continue
        if pallet and box_distance(x, y, pallet)[0] < RADIUS + 0.3:
            continue
        if any(math.hypot(x - o.x, y - o.y) < 2 * RADIUS + 0.3 for o in agents):
            continue
        agents.append(Agent(x, y, random.uniform(-math.pi, math.pi), random.uniform(0.3, 1.0)))
    return agents


def plan(a, t):
    """The planner's command (body frame) of agent a at time t, with gates."""
    if t < a.escape_until:
        return 0.0, a.escape_w
    return a.v, a.wz


def bounce(a, qx, qy, reach):
    """An agent closer than `reach` to the point (qx, qy) of an obstacle reflects its velocity
    about the normal (when approaching) and is put back at that distance."""
    dx, dy = a.x - qx, a.y - qy
    d = math.hypot(dx, dy)
    if d < reach and d > 1e-9:
        nx, ny = dx / d, dy / d
        vx, vy = a.vel()
        vn = vx * nx + vy * ny
        if vn < 0:
            a.set_vel(vx - 2 * vn * nx, vy - 2 * vn * ny)
        a.x, a.y = qx + nx * reach, qy + ny * reach


def step(agents, t, dt, gated, now=0.0, pallet=None):
    """Moves every agent over dt; `now` (s, ROS time) is when the step ends (the bases' clock);
    `pallet`: a box the agents bounce off too (None: no pallet)."""
    for a in agents:
        if t >= a.next_turn:
            a.wz = random.uniform(-0.6, 0.6)
            a.next_turn = t + random.uniform(1.5, 4.0)
        if gated:
            # Held (the gate scales the command below 5%) for a second: turn in place.
            want_v, _ = plan(a, t)
            held = t >= a.escape_until and want_v > 0 and abs(a.out_v) < 0.05 * want_v
            if not held:
                a.held_since = None
            elif a.held_since is None:
                a.held_since = t
            elif t - a.held_since > 1.0:
                a.escape_until = t + random.uniform(1.0, 2.5)
                a.escape_w = random.choice((-1.0, 1.0)) * 0.8
                a.held_since = None
            v, w = a.base.advance(now, dt)
        else:
            v, w = a.v, a.wz
        a.yaw += w * dt
        a.speed = v
        a.travelled += abs(v) * dt
        vx, vy = v * math.cos(a.yaw), v * math.sin(a.yaw)
        a.x += vx * dt
        a.y += vy * dt
        # Walls: reflect.
        lim = ROOM_HALF - RADIUS
        if abs(a.x) > lim:
            a.x = math.copysign(lim, a.x)
            a.set_vel(-vx, vy)
        vx, vy = a.vel()
        if abs(a.y) > lim:
            a.y = math.copysign(lim, a.y)
            a.set_vel(vx, -vy)
        # Pillar (and pallet): reflect about the normal.
        bounce(a, PILLAR[0], PILLAR[1], PILLAR[2] + RADIUS)
        if pallet:
            _, qx, qy = box_distance(a.x, a.y, pallet)
            bounce(a, qx, qy, RADIUS)
    # Agents: elastic bounce (equal masses swap their normal velocities).
    for i in range(len(agents)):
        for j in range(i + 1, len(agents)):
            a, b = agents[i], agents[j]
            dx, dy = b.x - a.x, b.y - a.y
            d = math.hypot(dx, dy)
            if d >= 2 * RADIUS or d < 1e-9:
                continue
            nx, ny = dx / d, dy / d
            (avx, avy), (bvx, bvy) = a.vel(), b.vel()
            rel = (avx - bvx) * nx + (avy - bvy) * ny
            if rel > 0:  # approaching
                a.set_vel(avx - rel * nx, avy - rel * ny)
                b.set_vel(bvx + rel * nx, bvy + rel * ny)
                a.straight_until = b.straight_until = 0.0


def count_contacts(agents, counts, pallet=None):
    """Counts the contacts that begin now: agent-agent pairs closer than two radii, agents at a
    wall, the pillar or the pallet (1 mm of slack: the bounces above put them exactly there)."""
    lim = ROOM_HALF - RADIUS - 1e-3
    for i, a in enumerate(agents):
        now = set()
        if abs(a.x) >= lim or abs(a.y) >= lim:
            now.add("wall")
        if math.hypot(a.x - PILLAR[0], a.y - PILLAR[1]) <= PILLAR[2] + RADIUS + 1e-3:
            now.add("pillar")
        if pallet and box_distance(a.x, a.y, pallet)[0] <= RADIUS + 1e-3:
            now.add("pallet")
        for j, b in enumerate(agents):
            if j != i and math.hypot(a.x - b.x, a.y - b.y) <= 2 * RADIUS + 1e-3:
                now.add(j)
        for what in now - a.touching:
            if what in ("wall", "pillar", "pallet"):
                counts["obstacle"] += 1
                rospy.loginfo("demo_sim: contact agent_%d - %s (agent at %.2f m/s)", i, what, a.speed)
            elif what > i:  # each pair once
                counts["agent"] += 1
                b = agents[what]
                rospy.loginfo("demo_sim: contact agent_%d - agent_%d (at %.2f and %.2f m/s)", i, what,
                              a.speed, b.speed)
        a.touching = now


def make_scans(count, rate_hz):
    """The agents' lasers (~laser_beams beams at ~laser_rate Hz), or None on bad parameters."""
    beams = int(rospy.get_param("~laser_beams", 360))
    scan_hz = float(rospy.get_param("~laser_rate", 10.0))
    if not (beams >= 1 and 0.0 < scan_hz <= rate_hz):
        rospy.logfatal("demo_sim: ~laser_beams must be >= 1 and ~laser_rate in (0, ~rate], got %d and %g",
                       beams, scan_hz)
        raise SystemExit(1)
    lasers = Lasers(beams, ROOM_HALF, [PILLAR], PALLET)
    rospy.loginfo("demo_sim: every agent has a %d-beam laser at %.0f Hz; a pallet at (%.1f, %.1f) that only "
                  "the lasers see", beams, scan_hz, PALLET[0][0], PALLET[0][1])
    return ScanPublisher(lasers, count, int(round(rate_hz / scan_hz)))


def main():
    rospy.init_node("demo_sim")
    n = int(rospy.get_param("~agents", 20))
    rate_hz = float(rospy.get_param("~rate", 30.0))
    duration = float(rospy.get_param("~duration", 0.0))
    random.seed(int(rospy.get_param("~seed", 1)))
    if n < 1:
        rospy.logfatal("demo_sim: ~agents must be >= 1, got %d", n)
        return
    pallet = PALLET if rospy.get_param("~sensors", False) else None
    agents = make_agents(n, pallet)
    if len(agents) < n:
        rospy.logwarn("demo_sim: only %d agents fit in the room", len(agents))
    scans = make_scans(len(agents), rate_hz) if pallet else None
    pubs = [rospy.Publisher("/agent_%d/odom" % i, Odometry, queue_size=5) for i in range(len(agents))]
    gated = bool(rospy.get_param("~gates", False))
    plan_pubs, subs = [], []
    if gated:
        plan_pubs = [rospy.Publisher("/agent_%d/nav_vel" % i, Twist, queue_size=5) for i in range(len(agents))]

        delay = float(rospy.get_param("~base_delay", 0.06))
        lin_acc = float(rospy.get_param("~base_linear_accel", 1.0))
        ang_acc = float(rospy.get_param("~base_angular_accel", 2.0))
        if not (delay >= 0.0 and lin_acc > 0.0 and ang_acc > 0.0):
            rospy.logfatal("demo_sim: ~base_delay must be >= 0 and ~base_linear_accel, ~base_angular_accel > 0")
            return
        for a in agents:
            a.base = Base(delay, lin_acc, ang_acc)
        rospy.loginfo("demo_sim: bases execute commands %.3f s late, ramping at %.2f m/s^2 and %.2f rad/s^2",
                      delay, lin_acc, ang_acc)

        def on_cmd(msg, a):
            a.out_v, a.out_w = msg.linear.x, msg.angular.z
            a.base.command(rospy.get_time(), msg.linear.x, msg.angular.z)

        subs = [rospy.Subscriber("/agent_%d/cmd_vel" % i, Twist, on_cmd, callback_args=a, queue_size=5)
                for i, a in enumerate(agents)]
    counts = {"agent": 0, "obstacle": 0}
    next_report = 10.0
    tfb = tf2_ros.TransformBroadcaster()
    rospy.loginfo("demo_sim: %d agents in a %.0f m x %.0f m room, %.0f Hz%s", len(agents), 2 * ROOM_HALF,
                  2 * ROOM_HALF, rate_hz, (", stopping after %.0f s" % duration) if duration > 0 else "")

    rate = rospy.Rate(rate_hz)
    start = None
    last = None
    while not rospy.is_shutdown():
        now = rospy.Time.now()
        if now.is_zero():  # use_sim_time without /clock yet
            rospy.sleep(0.05)
            continue
        if start is None:
            start = last = now
        t = (now - start).to_sec()
        if duration > 0 and t >= duration:
            rospy.loginfo("demo_sim: %.0f s elapsed, stopping", duration)
            break
        dt = (now - last).to_sec()
        # The agents are still where the last tf put them. No scan in the first second, while
        # the monitor's tf listener gets the lasers' mounts.
        if scans and dt > 0 and t >= 1.0:
            scans.publish([(a.x, a.y, a.yaw) for a in agents], last, RADIUS)
        last = now
        if dt > 0:
            step(agents, t, min(dt, 0.2), gated, now.to_sec(), pallet)
            count_contacts(agents, counts, pallet)
        if t >= next_report or (duration > 0 and t + 1.5 / rate_hz >= duration):
            next_report = t + 10.0
            minutes = max(t, 1e-9) / 60.0
            rospy.loginfo("demo_sim: gates %s, %.0f s: %d agent-agent contacts (%.1f per minute), %d with walls or "
                          "the pillar (%.1f per minute); mean speed %.2f m/s", "on" if gated else "off", t,
                          counts["agent"], counts["agent"] / minutes, counts["obstacle"], counts["obstacle"] / minutes,
                          sum(a.travelled for a in agents) / len(agents) / max(t, 1e-9))
        if gated:
            for i, a in enumerate(agents):
                cmd = Twist()
                cmd.linear.x, cmd.angular.z = plan(a, t)
                plan_pubs[i].publish(cmd)
        transforms = []
        for i, a in enumerate(agents):
            frame = "agent_%d/base_link" % i
            m = Odometry()
            m.header.stamp = now
            m.header.frame_id = "odom"
            m.child_frame_id = frame
            m.pose.pose.position.x, m.pose.pose.position.y = a.x, a.y
            q = quat_z(a.yaw)
            (m.pose.pose.orientation.x, m.pose.pose.orientation.y, m.pose.pose.orientation.z,
             m.pose.pose.orientation.w) = q
            m.twist.twist.linear.x = a.base.v if gated else a.v
            m.twist.twist.angular.z = a.base.w if gated else a.wz
            pubs[i].publish(m)

            base = TransformStamped()
            base.header.stamp = now
            base.header.frame_id = "odom"
            base.child_frame_id = frame
            base.transform.translation.x, base.transform.translation.y = a.x, a.y
            (base.transform.rotation.x, base.transform.rotation.y, base.transform.rotation.z,
             base.transform.rotation.w) = q
            transforms.append(base)

            mast = TransformStamped()
            mast.header.stamp = now
            mast.header.frame_id = frame
            mast.child_frame_id = "agent_%d/mast" % i
            (mast.transform.translation.x, mast.transform.translation.y,
             mast.transform.translation.z) = MAST_ORIGIN
            tilt = 0.35 * math.sin(a.mast_rate * t + a.mast_phase)
            (mast.transform.rotation.x, mast.transform.rotation.y, mast.transform.rotation.z,
             mast.transform.rotation.w) = quat_y(tilt)
            transforms.append(mast)
        tfb.sendTransform(transforms)
        try:
            rate.sleep()
        except rospy.ROSTimeMovedBackwardsException:
            start = last = None
            for a in agents:
                if a.base:
                    a.base.forget_pending()


if __name__ == "__main__":
    try:
        main()
    except rospy.ROSInterruptException:
        pass
