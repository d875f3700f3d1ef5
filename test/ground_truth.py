#!/usr/bin/env python3
"""Independent collision geometry for the scenario ground truth (numpy only, no vadop_core).

Shapes follow URDF conventions, centred on their frame origin: sphere, box (full edge lengths),
cylinder and capsule (both along z; cylinder length = full height, capsule length = segment
length), each optionally grown by a margin (the monitor's padding: a Minkowski sum with a ball).

distance(shape_a, pose_a, shape_b, pose_b) is the Euclidean distance between the two (padded)
shapes, computed with our own GJK on support functions: every shape is a convex "core" (point,
segment, box or cylinder) plus a radius (sphere radius, capsule radius, margin), so the distance
is the GJK distance of the cores minus both radii (negative when only the radii overlap, -1.0
when the cores themselves intersect).

first_contact(...) is conservative advancement: from t, step by distance / v_max, where v_max
bounds the relative speed of any two points of the shapes, so it can never step over a
contact, however thin the obstacle or fast the body (no tunnelling); it stops when the gap is
below `gap` (1e-6 m) and returns that time, a lower bound within gap / closing speed of the
exact first contact.

Poses are (R, p): a 3x3 rotation matrix and a translation, the shape frame in the world.
"""
import itertools
import math

import numpy as np

SHAPE_KINDS = ("sphere", "box", "cylinder", "capsule")


class Shape:
    def __init__(self, kind, radius=0.0, length=0.0, size=None, margin=0.0):
        if kind not in SHAPE_KINDS:
            raise ValueError("unknown shape type %r" % kind)
        self.kind = kind
        self.margin = float(margin)
        self.half_extents = np.zeros(3)
        self.half_length = 0.0
        self.core_radius = 0.0  # radius of the cylinder core
        if kind == "sphere":
            self.rad = float(radius) + self.margin
            core_bound = 0.0
        elif kind == "capsule":
            self.half_length = 0.5 * float(length)
            self.rad = float(radius) + self.margin
            core_bound = self.half_length
        elif kind == "box":
            self.half_extents = 0.5 * np.asarray(size, dtype=float)
            self.rad = self.margin
            core_bound = float(np.linalg.norm(self.half_extents))
        else:  # cylinder
            self.half_length = 0.5 * float(length)
            self.core_radius = float(radius)
            self.rad = self.margin
            core_bound = math.hypot(self.core_radius, self.half_length)
        # Largest distance from the frame origin to a point of the (padded) shape.
        self.bounding_radius = core_bound + self.rad

    @staticmethod
    def from_spec(spec, margin=0.0):
        """From a monitor-style spec: {type: sphere, radius: r} etc."""
        kind = spec["type"]
        if kind == "box":
            return Shape("box", size=spec["size"], margin=margin)
        if kind == "sphere":
            return Shape("sphere", radius=spec["radius"], margin=margin)
        return Shape(kind, radius=spec["radius"], length=spec["length"], margin=margin)

    def padded(self, margin):
        s = Shape.__new__(Shape)
        s.__dict__.update(self.__dict__)
        s.margin = self.margin + margin
        s.rad = self.rad + margin
        s.bounding_radius = self.bounding_radius + margin
        return s

    def core_support(self, d):
        """Farthest point of the core along d (local frame)."""
        if self.kind == "sphere":
            return np.zeros(3)
        if self.kind == "capsule":
            return np.array([0.0, 0.0, self.half_length if d[2] >= 0.0 else -self.half_length])
        if self.kind == "box":
            return np.where(d >= 0.0, self.half_extents, -self.half_extents)
        # cylinder
        r = math.hypot(d[0], d[1])
        z = self.half_length if d[2] >= 0.0 else -self.half_length
        if r > 0.0:
            return np.array([self.core_radius * d[0] / r, self.core_radius * d[1] / r, z])
        return np.array([0.0, 0.0, z])

    def __repr__(self):
        return "Shape(%s, rad=%.4g, bound=%.4g)" % (self.kind, self.rad, self.bounding_radius)


def _closest_on_simplex(points):
    """Closest point to the origin of conv(points) (1 to 4 points). Returns (v, indices,
    weights); v is None when the origin lies inside a (non-degenerate) tetrahedron."""
    n = len(points)
    best = None
    for k in range(n, 0, -1):
        for subset in itertools.combinations(range(n), k):
            w0 = points[subset[0]]
            if k == 1:
                lam = np.array([1.0])
            else:
                d = np.array([points[i] - w0 for i in subset[1:]])  # (k-1) x 3
                g = d @ d.T
                if abs(np.linalg.det(g)) < 1e-18 * max(1.0, np.trace(g)) ** (k - 1):
                    continue  # degenerate
                mu = np.linalg.solve(g, -(d @ w0))
                lam = np.concatenate(([1.0 - mu.sum()], mu))
            if np.any(lam < -1e-12):
                continue
            lam = np.clip(lam, 0.0, None)
            lam /= lam.sum()
            v = sum(l * points[i] for l, i in zip(lam, subset))
            if k == 4:
                return None, subset, lam  # origin inside the tetrahedron
            dist2 = float(v @ v)
            if best is None or dist2 < best[0] - 1e-30:
                best = (dist2, v, subset, lam)
        # a valid face of higher dimension is closer or equal; continuing checks every face
    if best is None:  # numerically degenerate: fall back to the closest vertex
        i = int(np.argmin([p @ p for p in points]))
        return points[i], (i,), np.array([1.0])
    return best[1], best[2], best[3]


def core_distance(shape_a, pose_a, shape_b, pose_b, max_iter=100, rel_tol=1e-12):
    """GJK distance between the cores of a and b and the witness points; 0 when they intersect."""
    ra, pa = pose_a
    rb, pb = pose_b

    def support(d):
        a = pa + ra @ shape_a.core_support(ra.T @ d)
        b = pb + rb @ shape_b.core_support(rb.T @ (-d))
        return a, b

    d0 = pa - pb
    if d0 @ d0 < 1e-24:
        d0 = np.array([1.0, 0.0, 0.0])
    a, b = support(-d0)
    simplex = [(a - b, a, b)]
    v = a - b
    for _ in range(max_iter):
        vv = float(v @ v)
        if vv < 1e-28:
            return 0.0, a, b
        a_new, b_new = support(-v)
        w = a_new - b_new
        # Converged: w brings no improvement along v.
        if vv - float(v @ w) <= rel_tol * vv + 1e-20:
            break
        if any(np.allclose(w, s[0], atol=1e-14, rtol=0) for s in simplex):
            break
        simplex.append((w, a_new, b_new))
        v_new, idx, lam = _closest_on_simplex([s[0] for s in simplex])
        if v_new is None:
            return 0.0, a_new, b_new
        simplex = [simplex[i] for i in idx]
        if float(v_new @ v_new) >= vv:  # no progress (numerical floor)
            break
        v = v_new
    # Witness points from the barycentric weights of the final simplex.
    pts = [s[0] for s in simplex]
    v2, idx, lam = _closest_on_simplex(pts)
    if v2 is None:
        return 0.0, simplex[0][1], simplex[0][2]
    wa = sum(l * simplex[i][1] for l, i in zip(lam, idx))
    wb = sum(l * simplex[i][2] for l, i in zip(lam, idx))
    return float(np.linalg.norm(v2)), wa, wb


def distance(shape_a, pose_a, shape_b, pose_b):
    """Distance between the padded shapes (negative when they overlap)."""
    dc, _, _ = core_distance(shape_a, pose_a, shape_b, pose_b)
    if dc <= 0.0:
        return -1.0
    return dc - shape_a.rad - shape_b.rad


def first_contact(dist_at, t0, t1, v_max, gap=1e-6, max_steps=200000):
    """First time in [t0, t1] at which dist_at(t) <= gap, by conservative advancement; None if
    none. v_max must bound |d/dt dist| (the relative speed of any two points of the shapes)."""
    if v_max <= 0.0:
        return t0 if dist_at(t0) <= gap else None
    t = t0
    for _ in range(max_steps):
        d = dist_at(t)
        if d <= gap:
            return t
        t += d / v_max
        if t > t1:
            return None
    raise RuntimeError("conservative advancement did not converge (grazing contact?)")


# ------------------------------------------------------------------ rotations
def rot_z(yaw):
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_axis(axis, angle):
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def rot_rpy(r, p, y):
    """URDF rpy: R = Rz(y) Ry(p) Rx(r)."""
    return rot_axis([0, 0, 1], y) @ rot_axis([0, 1, 0], p) @ rot_axis([1, 0, 0], r)


def compose(a, b):
    return (a[0] @ b[0], a[0] @ b[1] + a[1])


def quaternion_from_matrix(r):
    """(x, y, z, w), w >= 0."""
    tr = r[0, 0] + r[1, 1] + r[2, 2]
    if tr > 0.0:
        s = math.sqrt(tr + 1.0) * 2.0
        q = [(r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s, 0.25 * s]
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2]) * 2.0
        q = [0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s, (r[2, 1] - r[1, 2]) / s]
    elif r[1, 1] > r[2, 2]:
        s = math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2]) * 2.0
        q = [(r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s, (r[0, 2] - r[2, 0]) / s]
    else:
        s = math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1]) * 2.0
        q = [(r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s, (r[1, 0] - r[0, 1]) / s]
    q = np.array(q)
    if q[3] < 0:
        q = -q
    return q / np.linalg.norm(q)
