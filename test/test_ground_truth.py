#!/usr/bin/env python3
"""Unit tests of test/ground_truth.py (the scenario ground truth's own geometry) against analytic
distances and contact times. Plain unittest, no ROS: catkin_add_nosetests(test/test_ground_truth.py),
or `python3 test/test_ground_truth.py`."""
import math
import os
import sys
import unittest

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ground_truth as gt  # noqa: E402

I3 = np.eye(3)


def pose(p, yaw=0.0, r=None):
    return (gt.rot_z(yaw) if r is None else r, np.asarray(p, dtype=float))


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def point_box_distance(point, half):
    q = np.abs(point) - half
    return float(np.linalg.norm(np.maximum(q, 0.0)))


def point_segment_distance(p, a, b):
    ab = b - a
    t = np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * ab)))


def segment_segment_distance(a0, a1, b0, b1, n=1001):
    """Dense reference: min over a fine sampling of segment a of the exact point-segment distance."""
    s = np.linspace(0.0, 1.0, n)
    return min(point_segment_distance(a0 + t * (a1 - a0), b0, b1) for t in s)


class Distances(unittest.TestCase):
    def test_sphere_sphere_random(self):
        rng = np.random.default_rng(1)
        for _ in range(200):
            ra, rb = rng.uniform(0.05, 1.0, 2)
            pa, pb = rng.uniform(-3, 3, 3), rng.uniform(-3, 3, 3)
            expect = np.linalg.norm(pa - pb) - ra - rb
            got = gt.distance(gt.Shape("sphere", radius=ra), (random_rotation(rng), pa),
                              gt.Shape("sphere", radius=rb), (random_rotation(rng), pb))
            if expect > 0:
                self.assertAlmostEqual(got, expect, delta=1e-9)
            else:
                self.assertLessEqual(got, 1e-9)

    def test_box_sphere_random_rotated(self):
        rng = np.random.default_rng(2)
        box = gt.Shape("box", size=[1.0, 0.4, 0.6])
        for _ in range(300):
            r = random_rotation(rng)
            pb = rng.uniform(-1, 1, 3)
            c = rng.uniform(-2.5, 2.5, 3)
            rad = rng.uniform(0.01, 0.3)
            expect = point_box_distance(r.T @ (c - pb), box.half_extents) - rad
            got = gt.distance(box, (r, pb), gt.Shape("sphere", radius=rad), (I3, c))
            if expect > 1e-6:
                self.assertAlmostEqual(got, expect, delta=1e-7)
            elif expect < -1e-6:
                self.assertLess(got, 1e-7)

    def test_box_box_axis_aligned(self):
        rng = np.random.default_rng(3)
        for _ in range(200):
            sa, sb = rng.uniform(0.1, 1.5, 3), rng.uniform(0.1, 1.5, 3)
            pa, pb = rng.uniform(-2, 2, 3), rng.uniform(-2, 2, 3)
            gap = np.maximum(np.abs(pa - pb) - 0.5 * (sa + sb), 0.0)
            expect = float(np.linalg.norm(gap))
            got = gt.distance(gt.Shape("box", size=sa), (I3, pa), gt.Shape("box", size=sb), (I3, pb))
            if expect > 1e-6:
                self.assertAlmostEqual(got, expect, delta=1e-8)
            else:
                self.assertLess(got, 1e-8)

    def test_box_corner_to_face_45deg(self):
        # A unit cube turned 45 degrees about z, its corner towards a second cube's face.
        a = gt.Shape("box", size=[1, 1, 1])
        for gap in (0.3, 0.05, 1e-3):
            x = 0.5 * math.sqrt(2.0) + 0.5 + gap
            got = gt.distance(a, pose([0, 0, 0], math.pi / 4), a, pose([x, 0.1, 0.2]))
            self.assertAlmostEqual(got, gap, delta=1e-9)

    def test_capsule_capsule_random(self):
        rng = np.random.default_rng(4)
        for _ in range(20):
            ra, rb = random_rotation(rng), random_rotation(rng)
            pa, pb = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)
            la, lb = rng.uniform(0.2, 1.5, 2)
            a0, a1 = pa + ra @ [0, 0, -la / 2], pa + ra @ [0, 0, la / 2]
            b0, b1 = pb + rb @ [0, 0, -lb / 2], pb + rb @ [0, 0, lb / 2]
            seg = segment_segment_distance(a0, a1, b0, b1)
            expect = seg - 0.1 - 0.05
            got = gt.distance(gt.Shape("capsule", radius=0.1, length=la), (ra, pa),
                              gt.Shape("capsule", radius=0.05, length=lb), (rb, pb))
            if seg > 1e-3:
                self.assertAlmostEqual(got, expect, delta=2e-6 + 1e-4 * seg)

    def test_cylinder_sphere_and_cylinder_cylinder(self):
        cyl = gt.Shape("cylinder", radius=0.3, length=0.5)
        rng = np.random.default_rng(5)
        for _ in range(200):
            c = rng.uniform(-1.5, 1.5, 3)
            radial = max(math.hypot(c[0], c[1]) - 0.3, 0.0)
            axial = max(abs(c[2]) - 0.25, 0.0)
            expect = math.hypot(radial, axial) - 0.1
            got = gt.distance(cyl, (I3, np.zeros(3)), gt.Shape("sphere", radius=0.1), (I3, c))
            if expect > 1e-4:
                self.assertAlmostEqual(got, expect, delta=1e-6)
        # Two upright cylinders at the same height: the distance of their circles.
        for _ in range(100):
            p = np.array([*rng.uniform(-2, 2, 2), rng.uniform(-0.2, 0.2)])
            expect = math.hypot(p[0], p[1]) - 0.3 - 0.2
            got = gt.distance(cyl, (I3, np.zeros(3)), gt.Shape("cylinder", radius=0.2, length=0.4), pose(p, 0.7))
            if expect > 1e-4:
                self.assertAlmostEqual(got, expect, delta=1e-6)

    def test_margin_is_minkowski_ball(self):
        box = gt.Shape("box", size=[1, 1, 1])
        # Corner to corner along the diagonal: the margin rounds the corners.
        p = np.array([1.5, 1.5, 1.5])
        plain = gt.distance(box, (I3, np.zeros(3)), box, (I3, p))
        self.assertAlmostEqual(plain, math.sqrt(3) * 0.5, delta=1e-9)
        padded = gt.distance(box.padded(0.1), (I3, np.zeros(3)), box.padded(0.1), (I3, p))
        self.assertAlmostEqual(padded, plain - 0.2, delta=1e-9)

    def test_intersecting_is_negative(self):
        box = gt.Shape("box", size=[1, 1, 1])
        self.assertLess(gt.distance(box, (I3, np.zeros(3)), box, pose([0.5, 0.2, 0], 0.3)), 0.0)


class FirstContact(unittest.TestCase):
    def test_spheres_head_on(self):
        a = gt.Shape("sphere", radius=0.5)

        def dist(t):
            return gt.distance(a, pose([-4 + t, 0, 0]), a, pose([4 - t, 0, 0]))
        t = gt.first_contact(dist, 0.0, 10.0, 2.0)
        self.assertAlmostEqual(t, 3.5, delta=1e-6)

    def test_tunnelling_through_thin_wall(self):
        # A 5 cm ball at 20 m/s through a 2 cm wall: in contact for 6 ms only; sampling at
        # 10 Hz (2 m per sample) would never see it.
        ball = gt.Shape("sphere", radius=0.05)
        wall = gt.Shape("box", size=[0.02, 4.0, 2.0])

        def dist(t):
            return gt.distance(ball, pose([-10.5 + 20.0 * t, 0.3, 0.0]), wall, pose([0.0, 0.0, 0.0]))
        t = gt.first_contact(dist, 0.0, 2.0, 20.0)
        self.assertAlmostEqual(t, (10.5 - 0.01 - 0.05) / 20.0, delta=1e-6)
        self.assertTrue(all(dist(k * 0.1) > 0 for k in range(21)))

    def test_rotating_bar_hits_post(self):
        # A 2 m bar (box) turning about its end at w; a post of radius 0.1 at distance 1.5 m,
        # 90 degrees ahead. Contact when the bar's leading face touches the post.
        bar = gt.Shape("box", size=[2.0, 0.1, 0.1])
        post = gt.Shape("cylinder", radius=0.1, length=1.0)
        w = 0.5

        def dist(t):
            r = gt.rot_z(w * t)
            return gt.distance(bar, (r, r @ [1.0, 0, 0]), post, pose([0, 1.5, 0]))
        t = gt.first_contact(dist, 0.0, 10.0, w * 2.0)
        # Leading face at y = +0.05 in the bar frame; the post centre (0, 1.5) in the bar frame
        # at angle theta is (1.5 sin th, 1.5 cos th): touching when its distance to the face
        # line y = 0.05 is 0.1: 1.5 cos th - 0.05 = 0.1 -> th = acos(0.15 / 1.5) (the corner
        # is not involved: 1.5 sin th < 2).
        expect = math.acos(0.15 / 1.5) / w
        self.assertAlmostEqual(t, expect, delta=1e-5)

    def test_near_miss_none(self):
        a = gt.Shape("sphere", radius=0.5)

        def dist(t):
            return gt.distance(a, pose([-4 + t, 0, 0]), a, pose([4 - t, 1.05, 0]))
        self.assertIsNone(gt.first_contact(dist, 0.0, 10.0, 2.0))
        pa = a.padded(0.1)

        def dist_padded(t):
            return gt.distance(pa, pose([-4 + t, 0, 0]), pa, pose([4 - t, 1.05, 0]))
        t = gt.first_contact(dist_padded, 0.0, 10.0, 2.0)
        # |centre gap| = 1.2 when (8 - 2t)^2 + 1.05^2 = 1.2^2
        self.assertAlmostEqual(t, (8 - math.sqrt(1.2 ** 2 - 1.05 ** 2)) / 2, delta=1e-6)


class TrackedLives(unittest.TestCase):
    """test/scenario_gen.py's tracked objects (issue 17): a body per life, contacts only within lives."""

    BASE = {"fixed_frame": "odom", "rate": 30.0, "horizon": 2.0,
            "bodies": [{"name": "robot", "odom_topic": "/robot/odom", "shape": {"type": "sphere", "radius": 0.5}}],
            "tracks": [{"topic": "/people/tracks", "prefix": "people", "timeout": 0.5,
                        "default_shape": {"type": "cylinder", "radius": 0.3, "length": 1.8}}]}

    def scenario(self, objects, duration=12.0):
        import tempfile
        import yaml
        import scenario_gen as sg
        spec = dict(self.BASE)
        spec["scenario"] = {"duration": duration, "bodies": {"robot": {"pose": [0.0, 0.0, 0.0], "z": 0.9}},
                            "tracker": {"topic": "/people/tracks", "rate": 10, "objects": objects}}
        with tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False) as f:
            yaml.safe_dump(spec, f)
        try:
            return sg.Scenario(f.name)
        finally:
            os.unlink(f.name)

    def test_contact_within_life_only(self):
        # a walks at 1 m/s towards the robot (a sphere r 0.5 at the origin) from x = 5 at 1 s: touches at x = 0.8, 5.2 s
        sc = self.scenario([{"id": "a", "life": [1.0], "p": [5.0, 0.0], "v": [-1.0, 0.0]},
                            {"id": "b", "life": [1.0, 3.0], "p": [5.0, 3.0], "v": [-1.0, 0.0], "yaw": 0.0},
                            {"id": "c", "life": [0.0, 4.0], "at": 4.2, "p": [0.0, 0.8], "v": [0.0, -1.0]},
                            {"id": "n", "nan": True, "life": [0.0], "p": [0.0, 0.0]}])
        truth = sc.truth(0.0, 12.0)
        pairs = {(p["a"], p["b"]): p for p in truth["pairs"]}
        self.assertEqual(sorted(pairs), [("robot", "people/a")])  # c left at 4.0, 0.2 s before contact
        p = pairs[("robot", "people/a")]
        self.assertAlmostEqual(p["t"], 5.2, delta=1e-5)
        self.assertEqual((p["clean_since"], p["exists_since"]), (1.0, 1.0))
        self.assertNotIn("people/n", truth["tracks"])  # always NaN: never a body
        self.assertEqual(truth["tracks"]["people/c"]["lives"], [[0.0, 4.0]])
        # c going on straight would touch the robot 0.2 s after leaving: a ghost contact (design error)
        ghosts = {(g["body"], g["model"]) for g in truth["ghost_contacts"]}
        self.assertIn(("people/c", "straight"), ghosts)
        self.assertNotIn(("people/b", "straight"), ghosts)

    def test_reused_id_gives_one_entry_per_life(self):
        sc = self.scenario([{"id": "a", "lives": [{"life": [0.0, 4.0], "at": 2.0, "p": [0.0, 0.8], "v": [0.0, -1.0]},
                                                  {"life": [6.0], "at": 9.0, "p": [-0.8, 0.0], "v": [1.0, 0.0]}],
                             "nan_at": [7.0]}])
        truth = sc.truth(0.0, 12.0)
        got = [(round(p["t"], 4), p["exists_since"], round(p["msg_delay"], 4)) for p in truth["pairs"]]
        # the NaN copy at 7.0 s: 0.2 s between good copies in the second life
        self.assertEqual(got, [(2.0, 0.0, 0.1), (9.0, 6.0, 0.2)])
        self.assertEqual(truth["tracks"]["people/a"]["lives"], [[0.0, 4.0], [6.0, None]])

    def test_lives_must_not_overlap(self):
        with self.assertRaises(ValueError):
            self.scenario([{"id": "a", "lives": [{"life": [0.0, 4.0], "p": [3.0, 3.0]},
                                                 {"life": [4.2, None], "p": [3.0, 3.0]}]}])


if __name__ == "__main__":
    if any(a.startswith("--gtest_output") for a in sys.argv):  # run by catkin: junit result file
        import rosunit
        rosunit.unitrun("vadop", "test_ground_truth", "test_ground_truth", sys.argv)  # every test of this file
    else:
        unittest.main()
