#!/usr/bin/env python3
"""Scenario generator for vadop_monitor's scenario rostests (issue #6).

A scenario file (test/scenarios/*.yaml) holds the vadop_monitor parameters at its top level
(it is loaded into the node with <rosparam file=...>) and, under `scenario:`, the motion script:

  scenario:
    duration: 8.0            # s of bag
    seed: 1                  # noise and crowd generation (deterministic)
    urdf: {param_name: file.urdf}    # robot_description parameters (global, written without
                                     # the leading '/': rosparam would set a key "/x" globally)
                                     # -> files next to the yaml
    defaults: {rate: 30, z: 0.25}    # applied to every body script
    bodies:
      <name>:                # a configured body (bodies[].name, templates expanded)
        pose: [x, y, yaw]    # initial pose (m, m, rad) of the body frame; z from `z`
        z: 0.25
        segments:            # piecewise body-frame twist, in order; the last lasts to the end
          - {duration: 2.0, v: [vx, vy, wz]}              # constant
          - {duration: 1.0, v: [vx, vy, wz], a: [ax, ay, alpha]}   # v(t) = v + a (t - start)
        rate: 30             # odometry (and odom->child tf) rate, Hz;  phase: first stamp (s)
        frame: left          # odometry child_frame_id (default: the body name; URDF bodies:
                             # "<name>/<root link>")
        noise: {position: 0.002, yaw: 0.001, linear: 0.005, angular: 0.002}   # Gaussian sigmas
        dropouts: [[2.0, 4.0]]             # no odometry nor tf in [start, end)
        bad:                 # bad messages: replace the sample nearest to t (nan_position,
                             # inf_twist, zero_quaternion, huge_position) or add one after it
                             # (out_of_order: stamp `back` s older, with that older true pose;
                             # duplicate: the same stamp again)
          - {t: 3.0, kind: nan_position}
        joints:              # tf_prefix bodies: joint trajectories (rad, rad/s), others at 0
          shoulder: {q0: 0.0, segments: [{duration: 2, qd: 0.3}, {qd: 0.0}]}
        tf_rate: 50          # link tf rate (tf_prefix bodies)
        trajectory: {stamp: 0.5, duration: 3.0, dt: 0.1, joints: [shoulder]}
                             # one trajectory_msgs/JointTrajectory at `stamp` on the body's
                             # joint_trajectory_topic: the true joint motion over `duration`
                             # (positions and velocities every dt and at segment boundaries)
        joint_rate: 50       # sensor_msgs/JointState rate on the body's joint_states_topic
                             # (joint_states_topic bodies: the scripted joints, true values)
        path:                # the body also publishes its plan (nav_msgs/Path), see below
          {topic: /robot/plan, rate: 10, lookahead: 3.0, dt: 0.1, frame: odom, phase: 0.0}
    crowd:                   # optional: generated straight-line agents
      name: "agent_{i}"  count: 200  area: [xmin, xmax, ymin, ymax]  speed: [lo, hi]
      static_fraction: 0.1  min_gap: 0.5  rate: 10  z: 0.25
    tracker:                 # optional (or a list of them): a tracker's vadop/TrackedObjectArray
      topic: /people/tracks  # the node's `tracks` source with this topic gives prefix,
      frame: odom            # default_shape and timeout (frame: odom only)
      rate: 15               # arrays per second, first at `phase` (default 0), to the bag's end
      objects:               # each a body "<prefix>/<id>" (link empty) while alive
        - {id: "1", life: [on, off], p: [x, y], v: [vx, vy]}   # alive over [on, off) ([on]: to
                             # the end; no null: rosparam loads the file into the node, and XML-RPC
                             # has no nil), at p at time `at` (default: on), constant velocity v
        - {id: "2", lives: [{life: [..], p: [..], v: [..]}, {life: [..], ...}]}   # id reused
        - {id: "k", shape: {type: cylinder, radius: 0.25, length: 1.2}, ...}  # explicit
                             # primitive in the message (else type 0: default_shape); z: the
                             # centre (default: standing on z = 0)
        - {id: "n1", nan: true, ...}      # every copy has pose.position.x NaN: never a body
        - {id: "3", nan_at: [5.0], ...}   # the copy in the array nearest 5.0 s is NaN
        - {id: "4", decoys: [{t: 6.0, dx: 1.0}], ...}   # the array nearest 6.0 s holds the id
                             # twice: first a copy displaced by (dx, dy), then the true one
    expect: {...}            # read by scenario_check.py only

The bag (bag time = 1000 s + scenario time; ROS time 0 would mean "no clock") holds
nav_msgs/Odometry on each body's odom_topic (pose of child_frame_id in "odom"; twist in the child
frame, REP 105) and tf2_msgs/TFMessage on /tf (odom -> child at the odometry stamps, and the
links of tf_prefix bodies at tf_rate).

A body script with `path:` (the node's path_topic input) also gets nav_msgs/Path messages on
`topic` (default: the body's path_topic parameter) at `rate` Hz (default 10; first at `phase`,
default 0; none during the body's dropouts), stamped at their bag time t, header.frame_id `frame`
(default odom; the poses are always odom coordinates). Each holds PoseStamped poses of the body
frame (z from `z`, yaw only) on the TRUE (noise-free) scripted trajectory at t, t + dt, ... up to
t + lookahead (defaults 0.1 s, 3.0 s; lookahead at most 5 s), plus every boundary of the twist
segments inside (t, t + lookahead): between consecutive poses the twist is then constant unless a
segment accelerates, and the node's screw interpolation between them is exact. Each pose's
header.stamp is the bag time at which the body is there (its header.frame_id is `frame` too).

A tracker's arrays (header.frame_id `frame`, stamped at their bag time) hold every object
alive at that stamp: id, shape (type 0, or the explicit primitive: CYLINDER dimensions
[height, radius]), pose (the shape's centre, yaw along the velocity) and twist (linear velocity
in the array's frame, no rotation), in the order of `objects`.

The ground truth is computed from the continuous motion the bag samples (before noise), with
ground_truth.py only (independent of vadop_core): for every pair of collision elements that the
monitor would check (different bodies; moving-moving or moving-static), the first time their
shapes, each grown by the monitor's padding, come within 1e-6 m. Truth file (JSON):
  {"t0": 1000.0, "duration": .., "padding": .., "pairs": [{"a","la","b","lb","t","clean_since",
   "rotating"}], "bodies": {...}}
where t is scenario seconds, clean_since the start of the interval before t over which both
bodies moved as the monitor models them (constant body twist, straight or turning in place,
constant joint rates, messages flowing), and rotating whether one of them rotates there. A body
with a `path:` is modelled exactly by its path (any sequence of constant twists, arcs included)
from its first path message plus one path period on (after a dropout: from the first message
after it plus one period), over the run of unaccelerated segments (no `a`) that holds t; the
truth's "bodies" entry of such a body has "path": {"topic", "rate", "first"}.

The truth covers [0, until] (the bag's duration plus the horizon: a cycle near the end of the
bag predicts up to a horizon beyond it, and the bodies go on moving as scripted).

Tracked objects in the truth: each life of a (non-NaN) object is a body "<prefix>/<id>" that
exists over [on, off) only (contacts within the lives of both; a second life of an id is
another element of the same body, so a pair may have one entry per life, with "exists_since":
the later of the two lives' starts). clean_since is the life's start, msg_delay the longest
wait for a good copy (from the start, and between good copies across NaN ones). NaN copies
change nothing else: the motion is a straight line at constant velocity. Truth keys with
trackers: "tracks" ({body: {topic, prefix, timeout, rate, lives: [[on, off or null]], ...}}),
"ghost_window" ({prefix: s}) and "ghost_contacts": for each life ending in the bag, the object
going on straight or standing still over the ghost window after its end (timeout + 2 node
cycles + horizon: what a monitor still holding it may predict) and touching another body; a
well-designed scenario has none (scenario_check.py reports them as design errors).

CLI:  scenario_gen.py SCENARIO.yaml --bag OUT.bag --truth OUT.json [--padding P] [--until T]
"""
import argparse
import copy
import json
import math
import os
import sys
import time
import xml.etree.ElementTree as ET

import numpy as np
import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ground_truth as gt  # noqa: E402

T0 = 1000.0       # bag time of scenario time 0
FINE_DT = 0.001   # s, integration step of the body trajectories
BROAD_DT = 0.05   # s, grid of the truth's broad phase
CONTACT_GAP = 1e-6
TRUTH_EXTRA = 5.0  # s: the motion goes on after the bag (a cycle near the end looks a horizon ahead)


# ----------------------------------------------------------------------------- URDF
class Urdf:
    """Collision geometry and kinematics of a URDF (box, cylinder, sphere; no meshes)."""

    def __init__(self, text, where):
        root = ET.fromstring(text)
        self.links = {}
        self.collisions = {}  # link -> [(shape spec, (R, p))]
        for link in root.findall("link"):
            name = link.get("name")
            self.links[name] = link
            items = []
            for col in link.findall("collision"):
                origin = _origin(col.find("origin"))
                g = col.find("geometry")
                if g is None or len(g) == 0:
                    continue
                e = g[0]
                if e.tag == "box":
                    spec = {"type": "box", "size": [float(v) for v in e.get("size").split()]}
                elif e.tag == "cylinder":
                    spec = {"type": "cylinder", "radius": float(e.get("radius")), "length": float(e.get("length"))}
                elif e.tag == "sphere":
                    spec = {"type": "sphere", "radius": float(e.get("radius"))}
                else:
                    raise ValueError("%s: link %s: geometry %s not supported by the scenario truth" % (where, name, e.tag))
                items.append((spec, origin))
            self.collisions[name] = items
        self.joints = {}  # child -> (name, type, parent, origin, axis)
        for j in root.findall("joint"):
            parent = j.find("parent").get("link")
            child = j.find("child").get("link")
            axis_el = j.find("axis")
            axis = [float(v) for v in axis_el.get("xyz").split()] if axis_el is not None else [1.0, 0.0, 0.0]
            self.joints[child] = (j.get("name"), j.get("type"), parent, _origin(j.find("origin")), np.array(axis))
        roots = [n for n in self.links if n not in self.joints]
        if len(roots) != 1:
            raise ValueError("%s: expected one root link, got %s" % (where, roots))
        self.root = roots[0]

    def joint_transform(self, child, q):
        name, jtype, parent, origin, axis = self.joints[child]
        if jtype in ("revolute", "continuous"):
            return gt.compose(origin, (gt.rot_axis(axis, q), np.zeros(3)))
        if jtype == "prismatic":
            return gt.compose(origin, (np.eye(3), axis / np.linalg.norm(axis) * q))
        return origin

    def link_in_root(self, link, qs):
        """Pose of `link` in the root link frame for joint values qs (dict name -> value)."""
        pose = (np.eye(3), np.zeros(3))
        while link != self.root:
            name, _, parent, _, _ = self.joints[link]
            pose = gt.compose(self.joint_transform(link, qs.get(name, 0.0)), pose)
            link = parent
        return pose


def _origin(el):
    if el is None:
        return (np.eye(3), np.zeros(3))
    xyz = [float(v) for v in (el.get("xyz") or "0 0 0").split()]
    rpy = [float(v) for v in (el.get("rpy") or "0 0 0").split()]
    return (gt.rot_rpy(*rpy), np.array(xyz))


# ----------------------------------------------------------------------------- piecewise motion
class Piecewise:
    """Piecewise constant-rate values: segments [(start, end, value0, rate)] (vectors)."""

    def __init__(self, segments, duration, dim):
        self.segs = []
        t = 0.0
        for i, s in enumerate(segments):
            last = i == len(segments) - 1
            end = math.inf if last or s.get("duration") is None else t + float(s["duration"])
            v = np.asarray(s.get("v", s.get("qd", [0.0] * dim)), dtype=float).reshape(dim)
            a = np.asarray(s.get("a", s.get("qdd", [0.0] * dim)), dtype=float).reshape(dim)
            self.segs.append((t, end, v, a))
            if last or end == math.inf:
                break
            t = end
        if not self.segs:
            self.segs.append((0.0, math.inf, np.zeros(dim), np.zeros(dim)))

    def integral(self, t):
        """Integral of the value over [0, t]."""
        out = np.zeros_like(self.segs[0][2])
        for (s, e, v, a) in self.segs:
            if t <= s:
                break
            d = min(t, e) - s
            out = out + v * d + 0.5 * a * d * d
        return out

    def at(self, t):
        for s in self.segs:
            if t < s[1] or s is self.segs[-1]:
                return s[2] + s[3] * (max(t, s[0]) - s[0])
        raise AssertionError

    def at_vec(self, ts):
        out = np.empty((len(ts), len(self.segs[0][2])))
        for i, (s, e, v, a) in enumerate(self.segs):
            last = i == len(self.segs) - 1
            m = (ts >= s) & (ts < e) if not last else ts >= s
            if i == 0:
                m |= ts < s
            out[m] = v[None, :] + a[None, :] * (ts[m] - s)[:, None]
        return out

    def segment(self, t):
        for s in self.segs:
            if t < s[1] or s is self.segs[-1]:
                return s
        raise AssertionError


# ----------------------------------------------------------------------------- bodies
class Element:
    def __init__(self, body, link, spec, local):
        self.body = body        # BodyScript or Static
        self.link = link        # "" for a primitive body
        self.spec = spec
        self.local = local      # function(t) -> (R, p) of the element in the body frame, or a pose
        self.shape = gt.Shape.from_spec(spec)

    def key(self):
        return (self.body.name, self.link)


class Static:
    is_static = True

    def __init__(self, name, pose):
        self.name = name
        self.pose = pose
        self.elements = []


class BodyScript:
    is_static = False

    def __init__(self, name, cfg, script, duration, urdfs):
        self.name = name
        self.cfg = cfg
        self.duration = duration
        self.topic = cfg["odom_topic"]
        pose = script.get("pose", [0.0, 0.0, 0.0])
        self.x0, self.y0, self.yaw0 = float(pose[0]), float(pose[1]), float(pose[2])
        self.z = float(script.get("z", 0.0))
        self.twist = Piecewise(script.get("segments", []), duration, 3)
        self.rate = float(script.get("rate", 30.0))
        self.phase = float(script.get("phase", 0.0))
        self.noise = script.get("noise", {}) or {}
        self.dropouts = [tuple(map(float, d)) for d in script.get("dropouts", [])]
        self.bad = script.get("bad", []) or []
        self.tf_rate = float(script.get("tf_rate", 50.0))
        self.path = None
        if script.get("path"):
            ps = script["path"]
            topic = ps.get("topic", cfg.get("path_topic"))
            if not topic:
                raise ValueError("body %s: path without a topic (neither path.topic nor path_topic)" % name)
            self.path = {"topic": str(topic), "rate": float(ps.get("rate", 10.0)),
                         "lookahead": float(ps.get("lookahead", 3.0)), "dt": float(ps.get("dt", 0.1)),
                         "frame": str(ps.get("frame", "odom")), "phase": float(ps.get("phase", 0.0))}
            if not 0.0 < self.path["lookahead"] <= TRUTH_EXTRA or self.path["dt"] <= 0.0 or self.path["rate"] <= 0.0:
                raise ValueError("body %s: path needs 0 < lookahead <= %g, dt > 0, rate > 0" % (name, TRUTH_EXTRA))
        self.elements = []
        self.urdf = None
        self.links_from_tf = "tf_prefix" in cfg
        self.tf_prefix = cfg.get("tf_prefix", "")
        # joint_states_topic bodies: sensor_msgs/JointState of the scripted joints at joint_rate
        self.joint_states_topic = cfg.get("joint_states_topic")
        self.joint_rate = float(script.get("joint_rate", 50.0))
        self.links_move = self.links_from_tf or bool(self.joint_states_topic)
        # joint_trajectory_topic bodies: one trajectory_msgs/JointTrajectory (see the docstring)
        self.trajectory = None
        if script.get("trajectory"):
            ts = script["trajectory"]
            topic = ts.get("topic", cfg.get("joint_trajectory_topic"))
            if not topic:
                raise ValueError("body %s: trajectory without a topic" % name)
            self.trajectory = {"topic": str(topic), "stamp": float(ts.get("stamp", 0.5)),
                               "duration": float(ts.get("duration", 3.0)), "dt": float(ts.get("dt", 0.1)),
                               "joints": list(ts.get("joints", sorted((script.get("joints") or {}).keys())))}
        self.joints = {}
        for jn, js in (script.get("joints", {}) or {}).items():
            pw = Piecewise(js.get("segments", []), duration, 1)
            self.joints[jn] = (float(js.get("q0", 0.0)), pw)
        if "shape" in cfg:
            self.frame = script.get("frame", cfg.get("frame", name))
            ident = (np.eye(3), np.zeros(3))
            self.elements.append(Element(self, "", cfg["shape"], ident))
        else:
            self.urdf = urdfs[cfg["robot_description"].lstrip("/")]
            default_frame = (self.tf_prefix + "/" if self.tf_prefix else "") + self.urdf.root
            self.frame = script.get("frame", cfg.get("frame", default_frame))
            ref = self.frame.split("/")[-1]
            if ref not in self.urdf.links:
                ref = self.urdf.root
            self.ref_link = ref
            for link, items in self.urdf.collisions.items():
                for spec, origin in items:
                    self.elements.append(Element(self, link, spec, self._link_local(link, origin)))
        self._integrate()

    def q(self, t):
        """Joint values at t."""
        return {jn: q0 + float(pw.integral(t)[0]) for jn, (q0, pw) in self.joints.items()}

    def _link_local(self, link, origin):
        urdf = self.urdf
        if not self.links_move:
            ref_in_root = urdf.link_in_root(self.ref_link, {})
            inv = (ref_in_root[0].T, -ref_in_root[0].T @ ref_in_root[1])
            fixed = gt.compose(gt.compose(inv, urdf.link_in_root(link, {})), origin)
            return fixed
        # From tf or joint states: the link pose relative to the body frame (the reference link) at t.

        def local(t):
            qs = self.q(t)
            ref_in_root = urdf.link_in_root(self.ref_link, qs)
            inv = (ref_in_root[0].T, -ref_in_root[0].T @ ref_in_root[1])
            return gt.compose(gt.compose(inv, urdf.link_in_root(link, qs)), origin)
        return local

    def _integrate(self):
        n = int(math.ceil((self.duration + TRUTH_EXTRA) / FINE_DT)) + 2
        self.ts = np.arange(n) * FINE_DT
        # mean twist over each step (8 sub-samples: exact enough where a segment ends mid-step)
        tw = sum(self.twist.at_vec(self.ts[:-1] + (j + 0.5) / 8.0 * FINE_DT) for j in range(8)) / 8.0
        yaw = self.yaw0 + np.concatenate(([0.0], np.cumsum(tw[:, 2] * FINE_DT)))
        hm = yaw[:-1] + 0.5 * tw[:, 2] * FINE_DT
        c, s = np.cos(hm), np.sin(hm)
        self.xs = self.x0 + np.concatenate(([0.0], np.cumsum((c * tw[:, 0] - s * tw[:, 1]) * FINE_DT)))
        self.ys = self.y0 + np.concatenate(([0.0], np.cumsum((s * tw[:, 0] + c * tw[:, 1]) * FINE_DT)))
        self.yaws = yaw

    def pose2d(self, t):
        """(x, y, yaw) at scenario time t (linear interpolation of the fine trajectory)."""
        f = min(max(t / FINE_DT, 0.0), len(self.ts) - 1.000001)
        k = int(f)
        u = f - k
        return ((1 - u) * self.xs[k] + u * self.xs[k + 1], (1 - u) * self.ys[k] + u * self.ys[k + 1],
                (1 - u) * self.yaws[k] + u * self.yaws[k + 1])

    def pose(self, t):
        x, y, yaw = self.pose2d(t)
        return (gt.rot_z(yaw), np.array([x, y, self.z]))

    def poses_vec(self, ts):
        f = np.clip(ts / FINE_DT, 0.0, len(self.ts) - 1.000001)
        k = f.astype(int)
        u = f - k
        x = (1 - u) * self.xs[k] + u * self.xs[k + 1]
        y = (1 - u) * self.ys[k] + u * self.ys[k + 1]
        yaw = (1 - u) * self.yaws[k] + u * self.yaws[k + 1]
        return x, y, yaw

    def in_dropout(self, t):
        return any(a <= t < b for a, b in self.dropouts)

    def moving_joints(self):
        return bool(self.joints) and self.links_move

    # ------------------------------------------------------------------ path (nav_msgs/Path)
    def path_stamps(self):
        """Scenario times of the path messages (none during dropouts)."""
        if self.path is None:
            return []
        out = []
        k = 0
        while True:
            t = round(self.path["phase"] + k / self.path["rate"], 9)
            if t > self.duration + 1e-9:
                return out
            if not self.in_dropout(t):
                out.append(t)
            k += 1

    def path_times(self, t):
        """Times of the poses of the path message at t: t, t + dt, ... up to t + lookahead, and
        the twist segments' boundaries in between."""
        end = t + self.path["lookahead"]
        n = int(math.floor(self.path["lookahead"] / self.path["dt"] + 1e-9))
        times = [round(t + k * self.path["dt"], 9) for k in range(n + 1)]
        bounds = [s[0] for s in self.twist.segs if t < s[0] < end]
        for b in bounds:  # a sample within 1 us of a boundary gives way to it
            times = [x for x in times if abs(x - b) > 1e-6]
        return sorted(times + bounds)

    def _path_exact_since(self, t):
        """With a path: start of the interval ending at t over which the path models this body
        exactly (unaccelerated segments, path messages flowing), and whether it rotates there;
        None if the path does not model it at t."""
        segs = self.twist.segs
        seg = self.twist.segment(t)
        i = next(n for n, x in enumerate(segs) if x is seg)
        if np.any(segs[i][3]):
            return None
        k = i
        while k > 0 and not np.any(segs[k - 1][3]):
            k -= 1
        stamps = [p for p in self.path_stamps() if p <= t]
        if not stamps:
            return None
        # the latest uninterrupted run of path messages
        j = len(stamps) - 1
        while j > 0 and stamps[j] - stamps[j - 1] <= 1.5 / self.path["rate"]:
            j -= 1
        start = max(segs[k][0], stamps[j] + 1.0 / self.path["rate"])
        rotating = any(seg[2][2] != 0.0 for seg in segs[k:i + 1] if seg[1] > start)
        return start, rotating

    # Motion model of the monitor exact at t: constant body twist, no turning while driving,
    # constant joint rates; or, with a path, unaccelerated segments that the path covers.
    def exact_since(self, t):
        """Start of the interval ending at t over which the monitor's model of this body is
        exact and its messages flow; also whether it rotates there."""
        s, e, v, a = self.twist.segment(t)
        start = s
        exact = not np.any(a) and (v[2] == 0.0 or (v[0] == 0.0 and v[1] == 0.0))
        rotating = v[2] != 0.0
        if self.path is not None:
            by_path = self._path_exact_since(t)
            if by_path is not None and by_path[0] <= t and (not exact or by_path[0] < start):
                start, rotating = by_path
                exact = True
        traj = self.trajectory
        for jn, (q0, pw) in self.joints.items():
            if traj and jn in traj["joints"] and traj["stamp"] < t <= traj["stamp"] + traj["duration"]:
                # Followed through the trajectory's points (cubic Hermite: exact on constant-
                # acceleration pieces whose ends are points).
                start = max(start, traj["stamp"])
                rotating = rotating or self.links_move
                continue
            js, je, jv, ja = pw.segment(t)
            start = max(start, js)
            exact = exact and not np.any(ja)
            rotating = rotating or (self.links_move and jv[0] != 0.0)
        for (d0, d1) in self.dropouts:
            if d0 <= t:
                start = max(start, d1)
        if not exact:
            start = t  # never exact
        return start, rotating


def _expand_bodies(params):
    out = []
    for b in params.get("bodies", []) or []:
        n = b.get("count")
        if n is None:
            out.append(b)
            continue
        for i in range(int(n)):
            e = {k: (v.replace("{i}", str(i)) if isinstance(v, str) else v) for k, v in b.items() if k != "count"}
            out.append(e)
    return out


def _static_pose(p):
    pos = np.array(p.get("position", [0, 0, 0]), dtype=float) if p else np.zeros(3)
    if p and "orientation" in p:
        x, y, z, w = [float(v) for v in p["orientation"]]
        n = math.sqrt(x * x + y * y + z * z + w * w)
        x, y, z, w = x / n, y / n, z / n, w / n
        r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    elif p and "rpy" in p:
        r = gt.rot_rpy(*[float(v) for v in p["rpy"]])
    else:
        r = np.eye(3)
    return (r, pos)


def _crowd(spec, rng, duration):
    """Straight-line agents: random start poses at least min_gap apart, constant speeds."""
    count = int(spec["count"])
    x0, x1, y0, y1 = [float(v) for v in spec["area"]]
    lo, hi = [float(v) for v in spec["speed"]]
    min_gap = float(spec.get("min_gap", 0.5))
    clearance = float(spec.get("clearance", 0.6))  # body diameter
    static_fraction = float(spec.get("static_fraction", 0.0))
    pts = []
    while len(pts) < count:
        p = rng.uniform([x0, y0], [x1, y1])
        if all(np.hypot(*(p - q)) >= clearance + min_gap for q in pts):
            pts.append(p)
    scripts = {}
    for i, p in enumerate(pts):
        name = spec["name"].replace("{i}", str(i))
        yaw = float(rng.uniform(-math.pi, math.pi))
        speed = 0.0 if rng.uniform() < static_fraction else float(rng.uniform(lo, hi))
        scripts[name] = {"pose": [float(p[0]), float(p[1]), yaw], "z": float(spec.get("z", 0.0)),
                         "segments": [{"v": [speed, 0.0, 0.0]}], "rate": float(spec.get("rate", 10.0)),
                         "phase": float(rng.uniform(0.0, 1.0 / float(spec.get("rate", 10.0))))}
    return scripts


class _ConstTwist:
    """Body-frame twist of a straight-line track life (heading along its velocity)."""

    def __init__(self, speed):
        self.v = np.array([float(speed), 0.0, 0.0])

    def at(self, t):
        return self.v


class TrackLife:
    """One life of a tracked object (scenario `tracker:`): a body named "<prefix>/<id>" that
    exists over [on, off) only, on a straight line at constant velocity (exact for the truth).
    Ghosts (is_ghost) are the same object after `off` as a monitor still holding it might model
    it (going on straight, or standing at its last pose): used only to check the scenario's design."""
    is_static = False
    is_track = True
    links_from_tf = False
    joint_states_topic = None

    def __init__(self, name, oid, on, off, p_on, v, z, yaw, spec, tracker, ghost=None):
        self.name = name
        self.id = oid
        self.on = float(on)
        self.off = math.inf if off is None else float(off)
        self.v = np.array([float(v[0]), float(v[1])])
        self.p0 = np.asarray(p_on, dtype=float) - self.v * self.on  # position at t = 0 (extrapolated)
        self.z = float(z)
        speed = float(np.hypot(*self.v))
        self.yaw = math.atan2(self.v[1], self.v[0]) if speed > 0.0 else float(yaw)
        self.twist = _ConstTwist(speed)
        self.tracker = tracker
        self.rate = tracker.rate
        self.phase = self.on
        self.spec = spec
        self.ghost = ghost          # None, "straight" or "standing"
        self.is_ghost = ghost is not None
        self.msg_delay = 1.0 / tracker.rate  # updated by the tracker once the stamps are known
        self.elements = [Element(self, "", spec, (np.eye(3), np.zeros(3)))]

    def position(self, t):
        return self.p0 + self.v * t

    def exists(self, t):
        return self.on <= t < self.off

    def exists_in(self, a, b):
        """True if [a, b] meets [on, off)."""
        return self.on <= b and a < self.off

    def pose(self, t):
        x, y = self.position(t)
        return (gt.rot_z(self.yaw), np.array([x, y, self.z]))

    def pose2d(self, t):
        x, y = self.position(t)
        return x, y, self.yaw

    def poses_vec(self, ts):
        ts = np.asarray(ts, dtype=float)
        return self.p0[0] + self.v[0] * ts, self.p0[1] + self.v[1] * ts, np.full_like(ts, self.yaw)

    def exact_since(self, t):
        """Constant velocity over the whole life."""
        return self.on, False

    def ghost_of(self, kind, window):
        """The object after `off` over [off, off + window]: going on straight or standing still."""
        p = self.position(self.off)
        v = self.v if kind == "straight" else (0.0, 0.0)
        return TrackLife(self.name, self.id, self.off, self.off + window, p, v, self.z, self.yaw, self.spec,
                         self.tracker, ghost=kind)


SOLID_TYPES = {"box": 1, "sphere": 2, "cylinder": 3}


def _shape_z(spec):
    """Height of the centre of a shape standing on the floor (z = 0)."""
    if spec["type"] == "box":
        return 0.5 * float(spec["size"][2])
    if spec["type"] == "sphere":
        return float(spec["radius"])
    return 0.5 * float(spec["length"]) + (float(spec["radius"]) if spec["type"] == "capsule" else 0.0)


class Tracker:
    """A scenario `tracker:` (see the module docstring): vadop/TrackedObjectArray messages of the
    objects alive at each stamp, and the objects' lives (TrackLife) for the truth."""

    def __init__(self, spec, params, duration, where):
        self.topic = str(spec["topic"])
        sources = [s for s in (params.get("tracks") or []) if str(s.get("topic")) == self.topic]
        source = sources[0] if sources else {}
        self.prefix = str(spec.get("prefix", source.get("prefix", self.topic.rstrip("/").split("/")[-1])))
        if "prefix" in source and str(source["prefix"]) != self.prefix:
            raise ValueError("%s: tracker %s: prefix %r, the node's source says %r"
                             % (where, self.topic, self.prefix, source["prefix"]))
        self.default_shape = source.get("default_shape", spec.get("default_shape"))
        if not self.default_shape:
            raise ValueError("%s: tracker %s: no default_shape (neither the node's tracks source nor the tracker)"
                             % (where, self.topic))
        self.timeout = float(source.get("timeout", spec.get("timeout", 0.5)))
        self.in_node = bool(source)
        self.frame = str(spec.get("frame", "odom"))
        if self.frame != "odom":
            raise ValueError("%s: tracker %s: only frame odom is supported (the bag has no other tf)" % (where, self.topic))
        self.rate = float(spec.get("rate", 15.0))
        self.phase = float(spec.get("phase", 0.0))
        self.duration = duration
        self.objects = []  # dicts: id, shape (spec or None = type 0), lives [(TrackLife)], nan, nan_at, decoys
        self.lives = []    # every real life (TrackLife), in object order
        seen = set()
        for o in spec.get("objects", []) or []:
            oid = str(o["id"])
            if oid in seen:
                raise ValueError("%s: tracker %s: object id %r twice (a second life goes in `lives`)"
                                 % (where, self.topic, oid))
            seen.add(oid)
            shape = o.get("shape")
            spec_shape = shape or self.default_shape
            z = float(o.get("z", _shape_z(spec_shape)))
            lives_spec = o.get("lives") or [o]
            lives = []
            for ls in lives_spec:
                life_spec = list(ls["life"])
                on = float(life_spec[0])
                off = float(life_spec[1]) if len(life_spec) > 1 and life_spec[1] is not None else None
                v = [float(x) for x in ls.get("v", [0.0, 0.0])]
                at = float(ls.get("at", on))
                p_at = np.asarray(ls["p"], dtype=float)
                p_on = p_at + np.asarray(v) * (on - at)
                life = TrackLife("%s/%s" % (self.prefix, oid), oid, on, off, p_on, v, z, float(ls.get("yaw", 0.0)),
                                 spec_shape, self)
                if lives and life.on < lives[-1].off + self.timeout + 0.5:
                    raise ValueError("%s: tracker %s: %s: a life must start more than timeout + 0.5 s after the "
                                     "previous one ends" % (where, self.topic, oid))
                lives.append(life)
            obj = {"id": oid, "shape": shape, "lives": lives, "nan": bool(o.get("nan", False)),
                   "nan_at": [float(t) for t in o.get("nan_at", []) or []],
                   "decoys": [dict(d) for d in o.get("decoys", []) or []]}
            self.objects.append(obj)
            if not obj["nan"]:
                self.lives.extend(lives)
        # Message stamps, which copies are NaN, and each life's message delay.
        self.stamps = []
        k = 0
        while True:
            t = round(self.phase + k / self.rate, 9)
            if t > duration + 1e-9:
                break
            self.stamps.append(t)
            k += 1
        for obj in self.objects:
            obj["nan_stamps"] = set()
            obj["decoy_stamps"] = {}
            for life in obj["lives"]:
                alive = [t for t in self.stamps if life.exists(t)]
                if not alive:
                    raise ValueError("%s: tracker %s: %s: a life without any message" % (where, self.topic, oid))
                for t in obj["nan_at"]:
                    if life.on <= t < life.off:
                        obj["nan_stamps"].add(min(alive, key=lambda s: abs(s - t)))
                for d in obj["decoys"]:
                    if life.on <= float(d["t"]) < life.off:
                        obj["decoy_stamps"][min(alive, key=lambda s: abs(s - float(d["t"])))] = d
                good = [t for t in alive if t not in obj["nan_stamps"]]
                if not good:
                    continue
                # The node knows the life from its first good copy and keeps it across NaN copies.
                gaps = [b - a for a, b in zip(good[:-1], good[1:])]
                life.msg_delay = max([1.0 / self.rate, good[0] - life.on] + gaps)
                life.first_good = good[0]
                life.nan_copies = len(alive) - len(good)

    def summary(self):
        """The truth's "trackers" entry for this source."""
        return {"topic": self.topic, "prefix": self.prefix, "timeout": self.timeout, "rate": self.rate,
                "in_node": self.in_node, "objects": sum(1 for o in self.objects if not o["nan"]),
                "lives": len(self.lives), "nan_objects": sum(1 for o in self.objects if o["nan"]),
                "nan_copies": sum(len(o["nan_stamps"]) for o in self.objects if not o["nan"]),
                "decoys": sum(len(o["decoy_stamps"]) for o in self.objects), "arrays": len(self.stamps)}

    def alive(self, obj, t):
        """The life of obj at stamp t, or None."""
        return next((life for life in obj["lives"] if life.exists(t)), None)

    def info(self):
        """The truth's "tracks" entry: per tracked body, its lives and its source."""
        out = {}
        for obj in self.objects:
            if obj["nan"]:
                continue
            lives = obj["lives"]
            out[lives[0].name] = {
                "topic": self.topic, "prefix": self.prefix, "timeout": self.timeout, "rate": self.rate,
                "lives": [[life.on, None if life.off == math.inf else life.off] for life in lives],
                "first_good": [getattr(life, "first_good", None) for life in lives],
                "nan_copies": sum(getattr(life, "nan_copies", 0) for life in lives)}
        return out

    def message(self, t):
        """vadop/TrackedObjectArray at stamp t."""
        import rospy
        from shape_msgs.msg import SolidPrimitive
        from vadop.msg import TrackedObject, TrackedObjectArray
        m = TrackedObjectArray()
        m.header.stamp = rospy.Time.from_sec(T0 + t)
        m.header.frame_id = self.frame
        for obj in self.objects:
            life = self.alive(obj, t)
            if life is None:
                continue
            copies = []
            decoy = obj["decoy_stamps"].get(t)
            if decoy is not None:  # a wrong copy first: the same id twice in one array, the last kept
                copies.append(np.array([float(decoy.get("dx", 0.0)), float(decoy.get("dy", 0.0))]))
            copies.append(np.zeros(2))
            for off in copies:
                o = TrackedObject()
                o.id = obj["id"]
                sh = obj["shape"]
                if sh is None:
                    o.shape = SolidPrimitive()  # type 0: the source's default_shape
                else:
                    o.shape.type = SOLID_TYPES[sh["type"]]
                    if sh["type"] == "box":
                        o.shape.dimensions = [float(v) for v in sh["size"]]
                    elif sh["type"] == "sphere":
                        o.shape.dimensions = [float(sh["radius"])]
                    else:
                        o.shape.dimensions = [float(sh["length"]), float(sh["radius"])]  # [height, radius]
                x, y = life.position(t) + off
                o.pose.position.x, o.pose.position.y, o.pose.position.z = float(x), float(y), life.z
                o.pose.orientation.z = math.sin(0.5 * life.yaw)
                o.pose.orientation.w = math.cos(0.5 * life.yaw)
                o.twist.linear.x, o.twist.linear.y = float(life.v[0]), float(life.v[1])
                if obj["nan"] or t in obj["nan_stamps"]:
                    o.pose.position.x = float("nan")
                m.objects.append(o)
        return m


class Scenario:
    def __init__(self, path):
        self.path = os.path.abspath(path)
        self.name = os.path.splitext(os.path.basename(path))[0]
        with open(path) as f:
            self.params = yaml.safe_load(f)
        sc = self.params["scenario"]
        self.sc = sc
        self.duration = float(sc["duration"])
        self.seed = int(sc.get("seed", 0))
        here = os.path.dirname(self.path)
        self.urdfs = {}
        for pname, fname in (sc.get("urdf", {}) or {}).items():
            with open(os.path.join(here, fname)) as f:
                self.urdfs[pname.lstrip("/")] = Urdf(f.read(), fname)
        rng = np.random.default_rng(self.seed)
        scripts = copy.deepcopy(sc.get("bodies", {}) or {})
        if sc.get("crowd"):
            scripts.update(_crowd(sc["crowd"], rng, self.duration))
        defaults = sc.get("defaults", {}) or {}
        self.bodies = []
        for cfg in _expand_bodies(self.params):
            if cfg["name"] not in scripts:
                raise ValueError("scenario %s: no motion for body %s" % (self.name, cfg["name"]))
            script = dict(defaults)
            script.update(scripts[cfg["name"]])
            self.bodies.append(BodyScript(cfg["name"], cfg, script, self.duration, self.urdfs))
        unknown = set(scripts) - {b.name for b in self.bodies}
        if unknown:
            raise ValueError("scenario %s: motion for unknown bodies %s" % (self.name, sorted(unknown)))
        self.statics = []
        for o in self.params.get("static_obstacles", []) or []:
            s = Static(o["name"], _static_pose(o.get("pose")))
            if "shape" in o:
                s.elements.append(Element(s, "", o["shape"], (np.eye(3), np.zeros(3))))
            else:
                u = self.urdfs[o["robot_description"].lstrip("/")]
                for link, items in u.collisions.items():
                    for spec, origin in items:
                        s.elements.append(Element(s, link, spec, gt.compose(u.link_in_root(link, {}), origin)))
            self.statics.append(s)
        self.noise_rng = np.random.default_rng(self.seed + 1)
        trackers = sc.get("tracker") or []
        if isinstance(trackers, dict):
            trackers = [trackers]
        self.trackers = [Tracker(t, self.params, self.duration, self.name) for t in trackers]
        names = {b.name for b in self.bodies} | {s.name for s in self.statics}
        for tr in self.trackers:
            for life in tr.lives:
                if life.name in names and life is tr.lives[0]:
                    raise ValueError("scenario %s: tracked object %s has a configured body's name" % (self.name, life.name))
        # Tracked lives are bodies of the truth (each life its own element, existing over its life).
        self.track_lives = [life for tr in self.trackers for life in tr.lives]

    # ------------------------------------------------------------------ element poses
    def element_pose(self, el, t):
        if el.body.is_static:
            return gt.compose(el.body.pose, el.local)
        local = el.local(t) if callable(el.local) else el.local
        return gt.compose(el.body.pose(t), local)

    def element_origins(self, el, ts):
        """Origins (n x 3) of the element at times ts."""
        if el.body.is_static:
            p = gt.compose(el.body.pose, el.local)[1]
            return np.tile(p, (len(ts), 1))
        if callable(el.local):
            return np.array([self.element_pose(el, t)[1] for t in ts])
        x, y, yaw = el.body.poses_vec(ts)
        off = el.local[1]
        c, s = np.cos(yaw), np.sin(yaw)
        return np.stack([x + c * off[0] - s * off[1], y + s * off[0] + c * off[1],
                         np.full_like(x, el.body.z + off[2])], axis=1)

    def speed_bounds(self, el, margin):
        """(origin speed bound, bound on the speed of any point of the padded shape)."""
        if el.body.is_static:
            return 0.0, 0.0
        ts = np.arange(0.0, self.duration + TRUTH_EXTRA, 0.002)
        o = self.element_origins(el, ts)
        vo = np.linalg.norm(np.diff(o, axis=0), axis=1) / 0.002
        body = el.body
        w_body = np.abs(np.array([body.twist.at(t)[2] for t in ts[:-1]]))
        if callable(el.local) and body.joints:
            # rotation rate of the link relative to the body: finite differences
            rs = [el.local(t)[0] for t in ts[::5]]
            rel = []
            for a, b in zip(rs[:-1], rs[1:]):
                c = np.clip((np.trace(b @ a.T) - 1.0) / 2.0, -1.0, 1.0)
                rel.append(math.acos(c) / 0.01)
            wrel = np.repeat(np.array(rel + [rel[-1]]), 5)[:len(w_body)]
        else:
            wrel = 0.0
        r = el.shape.bounding_radius + margin
        vp = vo + (w_body + wrel) * r
        return float(vo.max()) * 1.02 + 1e-6, float(vp.max()) * 1.02 + 1e-6

    # ------------------------------------------------------------------ ground truth
    def all_elements(self):
        out = []
        for b in self.bodies:
            out.extend(b.elements)
        for s in self.statics:
            out.extend(s.elements)
        for life in self.track_lives:
            out.extend(life.elements)
        return out

    def ghost_window(self, tracker):
        """How long after a life's end a monitor may still report the object: while it holds it
        (the source's timeout, plus two cycles) its cycles look a horizon ahead."""
        rate = float(self.params.get("rate", 30.0))
        horizon = float(self.params.get("horizon", 2.0))
        return tracker.timeout + 2.0 / rate + horizon

    def ghost_elements(self):
        """For every life that ends in the bag: the object going on straight and standing still
        over ghost_window after its end (the truth has no such body: a contact of a ghost is one a
        monitor may legitimately report, which the scenario must avoid)."""
        out = []
        for tr in self.trackers:
            w = self.ghost_window(tr)
            for life in tr.lives:
                if life.off < self.duration:
                    for kind in ("straight", "standing"):
                        out.extend(life.ghost_of(kind, w).elements)
        return out

    def truth(self, padding, until=None, log=None):
        """First contacts in [0, until] (default: the bag's duration; at most TRUTH_EXTRA more)."""
        start = time.time()
        until = self.duration if until is None else min(float(until), self.duration + TRUTH_EXTRA - 0.01)
        els = self.all_elements()
        n_real = len(els)
        els = els + self.ghost_elements()
        n = len(els)
        grid = np.arange(0.0, until + 1e-9, BROAD_DT)
        if grid[-1] < until:
            grid = np.append(grid, until)
        origins = np.stack([self.element_origins(e, grid) for e in els])  # n x g x 3
        bounds = np.array([e.shape.bounding_radius + padding for e in els])
        sb = [self.speed_bounds(e, padding) for e in els]
        vo = np.array([s[0] for s in sb])
        vp = np.array([s[1] for s in sb])
        moving = np.array([not e.body.is_static for e in els])
        body_of = [e.body.name for e in els]
        shapes = [e.shape.padded(padding) for e in els]
        # Existence (tracked lives): [on, off) per element; interval k of the grid must meet both.
        on = np.array([getattr(e.body, "on", -math.inf) for e in els])
        off = np.array([getattr(e.body, "off", math.inf) for e in els])
        exists = (on[:, None] <= grid[None, 1:]) & (grid[None, :-1] < off[:, None])  # n x (g - 1)
        ghost = np.array([getattr(e.body, "is_ghost", False) for e in els])
        pairs = []
        ghost_pairs = []
        checked = 0
        for i in range(n):
            if i >= n_real:
                break  # ghosts only against real elements
            js = np.arange(i + 1, n)
            keep = np.array([(moving[i] or moving[j]) and body_of[i] != body_of[j] and not (ghost[i] and ghost[j])
                             for j in js], dtype=bool)
            js = js[keep]
            if len(js) == 0:
                continue
            sep = np.linalg.norm(origins[js] - origins[i][None], axis=2) - (bounds[js] + bounds[i])[:, None]
            reach = ((vo[js] + vo[i]) * BROAD_DT)[:, None]
            flag = sep[:, :-1] <= reach + 1e-9  # interval k = [grid[k], grid[k+1]] may hold a contact
            flag &= exists[js] & exists[i][None]
            for jj in np.nonzero(flag.any(axis=1))[0]:
                j = js[jj]
                checked += 1
                vmax = vp[i] + vp[j]
                ea, eb, sa, sbb = els[i], els[j], shapes[i], shapes[j]

                def dist(t, ea=ea, eb=eb, sa=sa, sbb=sbb):
                    return gt.distance(sa, self.element_pose(ea, t), sbb, self.element_pose(eb, t))
                hit = None
                ks = np.nonzero(flag[jj])[0]
                # runs of consecutive flagged intervals
                run_start = ks[0]
                prev = ks[0]
                runs = []
                for k in ks[1:]:
                    if k != prev + 1:
                        runs.append((run_start, prev))
                        run_start = k
                    prev = k
                runs.append((run_start, prev))
                # contacts only while both exist (tracked lives): [max(on), min(off))
                lo, hi = max(on[i], on[j]), min(off[i], off[j])
                for (k0, k1) in runs:
                    a_, b_ = max(grid[k0], lo), min(grid[k1 + 1], hi)
                    if a_ > b_:
                        continue
                    hit = gt.first_contact(dist, a_, b_, vmax, gap=CONTACT_GAP)
                    if hit is not None and hit >= hi:
                        hit = None  # the life ended first
                    if hit is not None:
                        break
                if hit is None:
                    continue
                a, b = (ea, eb)
                if ghost[i] or ghost[j]:
                    g, o = (ea, eb) if ghost[i] else (eb, ea)
                    ghost_pairs.append({"body": g.body.name, "model": g.body.ghost, "life_end": g.body.on,
                                        "window": g.body.off - g.body.on, "other": o.body.name,
                                        "other_link": o.link, "t": float(hit)})
                    continue
                pairs.append(self._pair_record(a, b, hit))
        pairs.sort(key=lambda p: p["t"])
        ghost_pairs.sort(key=lambda p: p["t"])
        if log:
            log("truth %s (padding %.3f): %d elements, %d pairs checked exactly, %d impacts, %.1f s"
                % (self.name, padding, n_real, checked, len(pairs), time.time() - start))
            for g in ghost_pairs:
                log("truth %s: scenario design: %s, gone at %.3f s, %s would touch %s at %.3f s"
                    % (self.name, g["body"], g["life_end"], "going on straight" if g["model"] == "straight"
                       else "standing still", g["other"], g["t"]))
        out = {"scenario": self.name, "t0": T0, "duration": self.duration, "until": until, "padding": padding,
               "pairs": pairs, "bodies": self.body_info()}
        if self.trackers:
            out["tracks"] = {}
            for tr in self.trackers:
                out["tracks"].update(tr.info())
            out["ghost_window"] = {tr.prefix: self.ghost_window(tr) for tr in self.trackers}
            out["trackers"] = [tr.summary() for tr in self.trackers]
            out["ghost_contacts"] = ghost_pairs
        return out

    def _pair_record(self, a, b, t):
        since = -1e9
        rotating = False
        extra = 0.0
        exists_since = None
        for el in (a, b):
            if el.body.is_static:
                continue
            s, rot = el.body.exact_since(t)
            first = el.body.phase
            since = max(since, s, first)
            rotating = rotating or rot
            if getattr(el.body, "is_track", False):
                # known from its first good copy, kept across NaN copies (see Tracker)
                extra = max(extra, el.body.msg_delay)
                exists_since = el.body.on if exists_since is None else max(exists_since, el.body.on)
                continue
            extra = max(extra, 1.0 / el.body.rate)
            if el.body.links_from_tf:
                extra = max(extra, 2.0 / el.body.tf_rate)
            if el.body.joint_states_topic:
                extra = max(extra, 2.0 / el.body.joint_rate)
        rec = {"a": a.body.name, "la": a.link, "b": b.body.name, "lb": b.link, "t": float(t),
               "clean_since": float(since), "msg_delay": float(extra), "rotating": bool(rotating)}
        if exists_since is not None:
            # a tracked life: the pair exists from then on (an earlier life of the same id is another pair)
            rec["exists_since"] = float(exists_since)
        return rec

    def body_info(self):
        info = {}
        for b in self.bodies:
            invalid = sum(1 for x in b.bad if x["kind"] in INVALID_KINDS)
            ooo = sum(1 for x in b.bad if x["kind"] in ("out_of_order", "duplicate"))
            info[b.name] = {"rate": b.rate, "dropouts": b.dropouts, "invalid": invalid, "out_of_order": ooo,
                            "first": b.phase}
            if b.path is not None:
                stamps = b.path_stamps()
                info[b.name]["path"] = {"topic": b.path["topic"], "rate": b.path["rate"],
                                        "first": stamps[0] if stamps else None}
        for s in self.statics:
            info[s.name] = {"static": True}
        return info

    # ------------------------------------------------------------------ bag
    def write_bag(self, path, log=None):
        import rosbag
        import rospy
        from geometry_msgs.msg import TransformStamped
        from nav_msgs.msg import Odometry
        from tf2_msgs.msg import TFMessage

        start = time.time()
        records = []  # (bag time, order, topic, msg)
        tf_groups = {}  # stamp (us) -> [TransformStamped]
        order = 0
        for b in self.bodies:
            nz = b.noise
            bad_at = {}
            stamps = []
            t = b.phase
            while t <= self.duration + 1e-9:
                stamps.append(t)
                t = b.phase + len(stamps) / b.rate
            stamps = [t for t in stamps if not b.in_dropout(t)]
            extra = []
            for item in b.bad:
                k = int(np.argmin([abs(s - float(item["t"])) for s in stamps]))
                if item["kind"] in INVALID_KINDS:
                    bad_at[k] = item["kind"]
                else:
                    extra.append((k, item))
            for k, t in enumerate(stamps):
                msg, pose3 = self._odom(b, t, nz)
                kind = bad_at.get(k)
                if kind:
                    _corrupt(msg, kind)
                records.append((t, order, b.topic, msg))
                order += 1
                if not kind:
                    tf_groups.setdefault(int(round(t * 1e6)), []).append(self._tf(pose3, t, "odom", b.frame))
            for k, item in extra:
                t = stamps[k]
                if item["kind"] == "out_of_order":
                    old = t - float(item.get("back", 0.2))
                    msg, _ = self._odom(b, old, {})
                else:  # duplicate
                    msg, _ = self._odom(b, t, {})
                records.append((t + 1e-4, order, b.topic, msg))
                order += 1
            for t in b.path_stamps():
                records.append((t, order, b.path["topic"], self._path(b, t)))
                order += 1
            if b.trajectory is not None:
                records.append((b.trajectory["stamp"], order, b.trajectory["topic"], self._trajectory(b)))
                order += 1
            if b.joint_states_topic:
                n = int(math.floor(self.duration * b.joint_rate + 1e-9)) + 1
                for k in range(n):
                    t = k / b.joint_rate
                    if not b.in_dropout(t):
                        records.append((t, order, b.joint_states_topic, self._joint_state(b, t)))
                        order += 1
            if b.links_from_tf:
                n = int(math.floor(self.duration * b.tf_rate + 1e-9)) + 1
                prefix = b.tf_prefix + "/" if b.tf_prefix else ""
                for k in range(n):
                    t = k / b.tf_rate
                    if b.in_dropout(t):
                        continue
                    qs = b.q(t)
                    for child, (jn, jtype, parent, origin, axis) in b.urdf.joints.items():
                        tr = b.urdf.joint_transform(child, qs.get(jn, 0.0))
                        tf_groups.setdefault(int(round(t * 1e6)), []).append(
                            self._tf(tr, t, prefix + parent, prefix + child))
        for tr in self.trackers:
            for t in tr.stamps:
                records.append((t, order, tr.topic, tr.message(t)))
                order += 1
        for us, transforms in tf_groups.items():
            records.append((us * 1e-6, -1, "/tf", TFMessage(transforms=transforms)))
        records.sort(key=lambda r: (r[0], r[1]))
        with rosbag.Bag(path, "w") as bag:
            for t, _, topic, msg in records:
                bag.write(topic, msg, rospy.Time.from_sec(T0 + t))
        if log:
            log("bag %s: %d messages over %.1f s, %.1f s" % (path, len(records), self.duration, time.time() - start))
        _ = (Odometry, TransformStamped)

    def _odom(self, b, t, nz):
        from nav_msgs.msg import Odometry
        import rospy
        x, y, yaw = b.pose2d(t)
        vx, vy, w = b.twist.at(t)
        rng = self.noise_rng
        if nz:
            x += rng.normal(0.0, nz.get("position", 0.0))
            y += rng.normal(0.0, nz.get("position", 0.0))
            yaw += rng.normal(0.0, nz.get("yaw", 0.0))
            vx += rng.normal(0.0, nz.get("linear", 0.0))
            vy += rng.normal(0.0, nz.get("linear", 0.0))
            w += rng.normal(0.0, nz.get("angular", 0.0))
        m = Odometry()
        m.header.stamp = rospy.Time.from_sec(T0 + t)
        m.header.frame_id = "odom"
        m.child_frame_id = b.frame
        m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z = x, y, b.z
        m.pose.pose.orientation.z = math.sin(0.5 * yaw)
        m.pose.pose.orientation.w = math.cos(0.5 * yaw)
        m.twist.twist.linear.x, m.twist.twist.linear.y = vx, vy
        m.twist.twist.angular.z = w
        return m, (gt.rot_z(yaw), np.array([x, y, b.z]))

    @staticmethod
    def _path(b, t):
        """nav_msgs/Path of body b at t: its true poses over the lookahead (see the docstring)."""
        import rospy
        from geometry_msgs.msg import PoseStamped
        from nav_msgs.msg import Path
        m = Path()
        m.header.stamp = rospy.Time.from_sec(T0 + t)
        m.header.frame_id = b.path["frame"]
        for ti in b.path_times(t):
            x, y, yaw = b.pose2d(ti)
            p = PoseStamped()
            p.header.stamp = rospy.Time.from_sec(T0 + ti)
            p.header.frame_id = b.path["frame"]
            p.pose.position.x, p.pose.position.y, p.pose.position.z = x, y, b.z
            p.pose.orientation.z = math.sin(0.5 * yaw)
            p.pose.orientation.w = math.cos(0.5 * yaw)
            m.poses.append(p)
        return m

    @staticmethod
    def _trajectory(b):
        """trajectory_msgs/JointTrajectory of body b: its true joint motion from the message's
        stamp over `duration`, a point every dt and at every joint segment boundary inside."""
        import rospy
        from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
        tr = b.trajectory
        m = JointTrajectory()
        m.header.stamp = rospy.Time.from_sec(T0 + tr["stamp"])
        m.joint_names = list(tr["joints"])
        times = set(round(k * tr["dt"], 9) for k in range(int(math.floor(tr["duration"] / tr["dt"] + 1e-9)) + 1))
        for jn in tr["joints"]:
            for seg in b.joints[jn][1].segs:
                for edge in (seg[0], seg[1]):
                    if tr["stamp"] < edge < tr["stamp"] + tr["duration"]:
                        times.add(round(edge - tr["stamp"], 9))
        for tfs in sorted(times):
            t = tr["stamp"] + tfs
            qs = b.q(t)
            p = JointTrajectoryPoint()
            p.positions = [float(qs[jn]) for jn in tr["joints"]]
            p.velocities = [float(b.joints[jn][1].at(t)[0]) for jn in tr["joints"]]
            p.time_from_start = rospy.Duration.from_sec(tfs)
            m.points.append(p)
        return m

    @staticmethod
    def _joint_state(b, t):
        """sensor_msgs/JointState of body b's scripted joints at t (true positions and rates)."""
        import rospy
        from sensor_msgs.msg import JointState
        m = JointState()
        m.header.stamp = rospy.Time.from_sec(T0 + t)
        qs = b.q(t)
        for jn, (q0, pw) in sorted(b.joints.items()):
            m.name.append(jn)
            m.position.append(float(qs[jn]))
            m.velocity.append(float(pw.at(t)[0]))
        return m

    @staticmethod
    def _tf(pose, t, parent, child):
        import rospy
        from geometry_msgs.msg import TransformStamped
        m = TransformStamped()
        m.header.stamp = rospy.Time.from_sec(T0 + t)
        m.header.frame_id = parent
        m.child_frame_id = child
        m.transform.translation.x, m.transform.translation.y, m.transform.translation.z = [float(v) for v in pose[1]]
        q = gt.quaternion_from_matrix(pose[0])
        m.transform.rotation.x, m.transform.rotation.y, m.transform.rotation.z, m.transform.rotation.w = [float(v) for v in q]
        return m


INVALID_KINDS = ("nan_position", "inf_twist", "zero_quaternion", "huge_position")


def _corrupt(m, kind):
    if kind == "nan_position":
        m.pose.pose.position.x = float("nan")
    elif kind == "inf_twist":
        m.twist.twist.linear.x = float("inf")
    elif kind == "zero_quaternion":
        m.pose.pose.orientation.x = m.pose.pose.orientation.y = 0.0
        m.pose.pose.orientation.z = m.pose.pose.orientation.w = 0.0
    elif kind == "huge_position":
        m.pose.pose.position.y = 1e12


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenario")
    ap.add_argument("--bag")
    ap.add_argument("--truth")
    ap.add_argument("--padding", type=float, default=None, help="default: the file's padding parameter")
    ap.add_argument("--until", type=float, default=None,
                    help="truth up to this time (s; default: the duration plus the file's horizon)")
    args = ap.parse_args(argv)
    sc = Scenario(args.scenario)

    def log(s):
        print(s, file=sys.stderr)
    if args.bag:
        sc.write_bag(args.bag, log)
    if args.truth:
        p = args.padding if args.padding is not None else float(sc.params.get("padding", 0.0))
        with open(args.truth, "w") as f:
            until = args.until if args.until is not None else sc.duration + float(sc.params.get("horizon", 2.0)) + 0.5
            json.dump(sc.truth(p, until, log), f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
