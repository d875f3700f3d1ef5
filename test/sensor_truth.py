"""Independent geometry for the sensor rostests (sensors_scenarios.py): what a simulated 2D laser
sees of wall segments, the points a published scan or cloud stands for, and the first contact of
a moving shape with points (balls) or grid cells (boxes), found by a dense search in time.

Nothing of vadop is used: every shape is reduced to a distance between a point and an
axis-aligned box (a ball is a box of zero size grown by its radius), computed with numpy over
all elements and many instants at once. It does not handle rotated boxes or rotating bodies:
the scenes move their bodies in straight lines without turning."""
import math

import numpy as np

F32 = np.float32


def f32(v):
    """A value as a float32 field carries it (what the monitor receives)."""
    return float(F32(v))


def ray_cast(origin, angles, segments, range_max, circles=()):
    """Ranges (float32) from `origin` (x, y) along the world angles `angles` to the nearest of
    `segments` [(x1, y1, x2, y2)] and `circles` [(x, y, radius)] (origin outside them); +inf
    where none lies within range_max (REP 117)."""
    r = np.minimum(ray_segments(origin, angles, segments), ray_circles(origin, angles, circles))
    r[r >= range_max] = np.inf
    return r.astype(F32)


def ray_circles(origin, angles, circles):
    """Distances from origin along angles to the nearest circle entry, +inf for none."""
    if len(circles) == 0:
        return np.full(len(angles), np.inf)
    c = np.asarray(circles, dtype=float)
    dx, dy = np.cos(angles)[:, None], np.sin(angles)[:, None]
    fx, fy = origin[0] - c[None, :, 0], origin[1] - c[None, :, 1]
    b = fx * dx + fy * dy
    disc = b * b - (fx * fx + fy * fy - c[None, :, 2] ** 2)
    with np.errstate(invalid="ignore"):
        t = -b - np.sqrt(disc)
    return np.where((disc >= 0) & (t > 0), t, np.inf).min(axis=1)


def ray_segments(origin, angles, segments):
    """Distances from origin along angles to the nearest segment, +inf for none."""
    if len(segments) == 0:
        return np.full(len(angles), np.inf)
    ox, oy = origin
    dx, dy = np.cos(angles)[:, None], np.sin(angles)[:, None]
    seg = np.asarray(segments, dtype=float)
    ax, ay = seg[:, 0][None, :], seg[:, 1][None, :]
    ex, ey = (seg[:, 2] - seg[:, 0])[None, :], (seg[:, 3] - seg[:, 1])[None, :]
    # origin + r d = a + s e  ->  r d - s e = a - origin (Cramer's rule).
    det = -dx * ey + dy * ex
    px, py = ax - ox, ay - oy
    with np.errstate(divide="ignore", invalid="ignore"):
        r = (-px * ey + py * ex) / det
        s = (dx * py - dy * px) / det
    hit = (np.abs(det) > 1e-12) & (r > 0.0) & (s >= 0.0) & (s <= 1.0)
    return np.where(hit, r, np.inf).min(axis=1)


def scan_points(angle_min, angle_increment, ranges, range_min, range_max, laser_pose):
    """The fixed-frame points of a published scan: beam i at angle_min + i * angle_increment,
    kept when range_min <= range < range_max (finite), from a level laser at laser_pose
    (x, y, z, yaw). Values as the message carries them (float32)."""
    x, y, z, yaw = laser_pose
    r = np.asarray(ranges, dtype=float)
    a = float(F32(angle_min)) + np.arange(len(r)) * float(F32(angle_increment))
    keep = np.isfinite(r) & (r >= float(F32(range_min))) & (r < float(F32(range_max)))
    r, a = r[keep], a[keep] + yaw
    return np.column_stack([x + r * np.cos(a), y + r * np.sin(a), np.full(len(r), z)])


def transform(points, translation, yaw):
    """Points of a frame turned by yaw about z and shifted by translation, in its parent."""
    c, s = math.cos(yaw), math.sin(yaw)
    p = np.asarray(points, dtype=float)
    return np.column_stack([c * p[:, 0] - s * p[:, 1] + translation[0], s * p[:, 0] + c * p[:, 1] + translation[1],
                            p[:, 2] + translation[2]])


def inverse_transform(points, translation, yaw):
    p = np.asarray(points, dtype=float) - np.asarray(translation, dtype=float)[None, :]
    c, s = math.cos(yaw), math.sin(yaw)
    return np.column_stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1], p[:, 2]])


def box_distance(lo, hi, p):
    """Distance between points p and axis-aligned boxes [lo, hi] (0 inside), broadcast over
    the leading axes of all three; the last axis is x, y, z."""
    d = np.maximum(np.maximum(lo - p, p - hi), 0.0)
    return np.sqrt((d * d).sum(axis=-1))


def gap_sphere_balls(centres, radius, points, point_radius):
    """(T,) the smallest gap between a sphere at each of centres (T, 3) and balls at points."""
    return np.min(box_distance(points[None, :, :], points[None, :, :], centres[:, None, :]), axis=1) \
        - radius - point_radius


def gap_box_balls(centres, half, points, point_radius):
    """(T,) the smallest gap between an axis-aligned box of half sizes `half` centred at each of
    centres (T, 3) and balls at points."""
    h = np.asarray(half, dtype=float)[None, None, :]
    c = centres[:, None, :]
    return np.min(box_distance(c - h, c + h, points[None, :, :]), axis=1) - point_radius


def gap_sphere_boxes(centres, radius, lo, hi):
    """(T,) the smallest gap between a sphere at each of centres (T, 3) and boxes [lo, hi] (N, 3)."""
    return np.min(box_distance(lo[None, :, :], hi[None, :, :], centres[:, None, :]), axis=1) - radius


def first_contact(gap, t0, t1, step=1e-3, chunk=400):
    """The first time in [t0, t1] at which gap(times) (vectorised over an array of times) is
    <= 0, to 1e-6 s: sampled every `step` s, then bisected between the last sample with a gap
    and the first without. None when the samples never touch. A contact shorter than `step`
    may be missed: the scenes' bodies move at <= 1 m/s, so such a graze is under 1 mm deep."""
    times = np.arange(t0, t1 + step, step)
    for k in range(0, len(times), chunk):
        g = gap(times[k:k + chunk])
        touching = np.nonzero(g <= 0.0)[0]
        if len(touching) == 0:
            continue
        i = k + touching[0]
        if i == 0:
            return float(times[0])
        lo, hi = float(times[i - 1]), float(times[i])
        while hi - lo > 1e-6:
            mid = 0.5 * (lo + hi)
            if gap(np.array([mid]))[0] <= 0.0:
                hi = mid
            else:
                lo = mid
        return hi
    return None
