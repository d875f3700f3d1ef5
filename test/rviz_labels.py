#!/usr/bin/python3
"""rostest node (rviz_labels.test): the impact labels of a crowded scene with links are readable
in rviz with rviz/vadop.rviz.

Four bodies converge on the origin: two URDF robots (test/scenarios/turning_robot.urdf: a base
and an arm, so each robot pair has impacts between several link pairs) and two spheres, so all
six body pairs have impacts close together. The test checks, on ~markers of one cycle against
~impacts of the same cycle (same stamp):
  (a) exactly one TEXT_VIEW_FACING label in namespace "impacts" per body pair with an impact,
      naming the pair's soonest link pair and its time;
  (b) no two labels' boxes intersect in world space (width: characters x 0.6 x height, as in
      label_layout.h's estimate; the footprint a square of that side; height scale.z);
  (c) on the screen of the config's view (projected as rviz_head_on.py does), no two labels'
      text boxes intersect, and each label has light pixels where it projects (it is drawn).
The last screenshot is saved as rviz_labels.png in the test results directory.
"""
import atexit
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
import yaml
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from visualization_msgs.msg import Marker, MarkerArray

from vadop.msg import ImpactArray

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import rviz_head_on as rh  # noqa: E402  (Xvfb, rviz, screenshots and the camera model)

CHAR_WIDTH = 0.6   # label_layout.h kLabelCharWidth
SPEED = 1.0
# name: x, y, yaw, forward speed (body frame x): each faces and drives towards the origin.
BODIES = {
    "r1": (-2.5, 0.0, 0.0, SPEED),
    "r2": (2.5, 0.0, math.pi, SPEED),
    "s1": (0.0, -2.5, 0.5 * math.pi, SPEED),
    "s2": (0.0, 2.5, -0.5 * math.pi, SPEED),
}
RENDER_TIMEOUT = 60.0


def label_of(body, link):
    return body + "/" + link if link else body


def world_box(m):
    h = m.scale.z
    w = len(m.text) * CHAR_WIDTH * h
    return np.array([m.pose.position.x, m.pose.position.y, m.pose.position.z]), 0.5 * w, 0.5 * h


def world_overlap(a, b):
    (ca, wa, ha), (cb, wb, hb) = a, b
    d = np.abs(ca - cb)
    return d[0] < wa + wb and d[1] < wa + wb and d[2] < ha + hb


class RvizLabels(unittest.TestCase):
    def setUp(self):
        self.config = [a for a in sys.argv[1:] if not a.startswith("--")][0]
        with open(self.config) as f:
            self.rviz = yaml.safe_load(f)
        self.procs = rh.Processes()
        atexit.register(self.procs.stop_all)
        self.tmp = tempfile.mkdtemp(prefix="vadop_rviz_labels_")
        self.out_dir = rh.results_dir()
        os.makedirs(self.out_dir, exist_ok=True)
        self.shot_path = os.path.join(self.out_dir, "rviz_labels.png")
        self.log_path = os.path.join(self.out_dir, "rviz_labels_rviz.log")
        self.last_shot = None
        rospy.init_node("rviz_labels_test", anonymous=True)
        rospy.on_shutdown(self.procs.stop_all)
        self.pubs = {n: rospy.Publisher("/%s/odom" % n, Odometry, queue_size=10) for n in BODIES}
        self.tf = tf2_ros.TransformBroadcaster()
        self.impacts = {}  # stamp -> ImpactArray
        self.cycles = []   # (ImpactArray, label markers) of the same cycle
        rospy.Subscriber("/vadop_monitor/impacts", ImpactArray, self.on_impacts, queue_size=50)
        rospy.Subscriber("/vadop_monitor/markers", MarkerArray, self.on_markers, queue_size=50)

    def tearDown(self):
        self.procs.stop_all()
        if self.last_shot is not None:
            self.last_shot.save(self.shot_path)
            rospy.loginfo("last screenshot: %s", self.shot_path)
        shutil.rmtree(self.tmp, ignore_errors=True)

    def on_impacts(self, msg):
        self.impacts[msg.header.stamp.to_nsec()] = msg

    def on_markers(self, msg):
        labels = [m for m in msg.markers if m.ns == "impacts" and m.type == Marker.TEXT_VIEW_FACING]
        if not labels:
            return
        imp = self.impacts.get(labels[0].header.stamp.to_nsec())
        if imp is not None:
            self.cycles.append((imp, labels))

    def publish(self, _event=None):
        now = rospy.Time.now()
        for name, (x, y, yaw, v) in BODIES.items():
            m = Odometry()
            m.header.stamp = now
            m.header.frame_id = "odom"
            m.child_frame_id = name
            m.pose.pose.position.x = x
            m.pose.pose.position.y = y
            m.pose.pose.orientation.z = math.sin(0.5 * yaw)
            m.pose.pose.orientation.w = math.cos(0.5 * yaw)
            m.twist.twist.linear.x = v  # body frame: forward
            self.pubs[name].publish(m)
            t = TransformStamped()
            t.header = m.header
            t.child_frame_id = name
            t.transform.translation.x = x
            t.transform.translation.y = y
            t.transform.rotation = m.pose.pose.orientation
            self.tf.sendTransform(t)

    def check_cycle(self, impacts, labels):
        # (a) one label per body pair: its soonest impact's link pair and time.
        soonest = {}
        for i in impacts.impacts:
            key = tuple(sorted((i.body_a, i.body_b)))
            if key not in soonest or i.time_to_impact < soonest[key].time_to_impact:
                soonest[key] = i
        self.assertEqual(len(soonest), 6, "expected impacts between all six body pairs, got %s" % sorted(soonest))
        links = sum(1 for i in impacts.impacts if i.link_a and i.link_b)
        self.assertGreater(links, 1, "expected several link-link impacts between the two robots")
        expected = sorted("%s <-> %s: %.2f s" % (label_of(i.body_a, i.link_a), label_of(i.body_b, i.link_b),
                                                 i.time_to_impact) for i in soonest.values())
        self.assertEqual(sorted(m.text for m in labels), expected)
        # (b) no two boxes intersect in world space.
        boxes = [world_box(m) for m in labels]
        for a in range(len(boxes)):
            for b in range(a + 1, len(boxes)):
                self.assertFalse(world_overlap(boxes[a], boxes[b]), "labels \"%s\" and \"%s\" overlap in the world"
                                 % (labels[a].text, labels[b].text))

    def screen_boxes(self, cam, labels):
        out = []
        for m in labels:
            c, half_w, half_h = world_box(m)
            depth = (c - cam.pos).dot(cam.fwd)
            px, py = cam.project(c)
            s = cam.f / depth  # text faces the camera: its size on screen at the centre's depth
            out.append((px - half_w * s, py - half_h * s, px + half_w * s, py + half_h * s))
        return out

    def test_labels_readable(self):
        bg = [int(c) for c in self.rviz["Visualization Manager"]["Global Options"]["Background Color"].split(";")]
        t0 = time.monotonic()
        with open(self.log_path, "w") as log:
            display = rh.start_xvfb(self.procs, log)
            timer = rospy.Timer(rospy.Duration(1.0 / 30.0), self.publish)
            rviz = self.start_rviz(display, log)
            shot = None
            while not rospy.is_shutdown() and time.monotonic() - t0 < RENDER_TIMEOUT:
                self.assertIsNone(rviz.poll(), "rviz exited (see %s)" % self.log_path)
                time.sleep(0.5)
                self.last_shot = rh.grab(display)
                shot = rh.Classified(self.last_shot, bg)
                if self.cycles and shot.render_rect() is not None and shot.impact.sum() > 500:
                    break
            self.assertTrue(self.cycles, "no labelled markers with their cycle's impacts within %.0f s"
                            % RENDER_TIMEOUT)
            time.sleep(1.0)  # more frames, then the screenshot that is checked
            self.last_shot = rh.grab(display)
            impacts, labels = self.cycles[-1]
            timer.shutdown()
            self.procs.stop_all()
        self.check_cycle(impacts, labels)
        # (c) on screen.
        shot = rh.Classified(self.last_shot, bg)
        rect = shot.render_rect()
        self.assertIsNotNone(rect, "rviz's 3D view not found in the screenshot")
        cam = rh.OrbitCamera(self.rviz["Visualization Manager"]["Views"]["Current"], rect)
        boxes = self.screen_boxes(cam, labels)
        light = np.all(np.asarray(shot.image).astype(np.int16) >= 200, axis=2)
        for k, (x0, y0, x1, y1) in enumerate(boxes):
            rospy.loginfo("label \"%s\" on screen at x %.0f..%.0f, y %.0f..%.0f", labels[k].text, x0, x1, y0, y1)
            n = int(light[int(y0):int(math.ceil(y1)), int(x0):int(math.ceil(x1))].sum())
            self.assertGreater(n, 5, "label \"%s\": no text pixels where it projects" % labels[k].text)
            for j in range(k):
                a, b = boxes[j], boxes[k]
                self.assertFalse(a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3],
                                 "labels \"%s\" and \"%s\" overlap on screen" % (labels[j].text, labels[k].text))

    def start_rviz(self, display, log):
        env = dict(os.environ)
        paths = [p for p in env.get("ROS_PACKAGE_PATH", "").split(":") if p]
        if "/usr/share" not in paths:
            paths.append("/usr/share")
        env.update(DISPLAY=display, ROS_PACKAGE_PATH=":".join(paths), LIBGL_ALWAYS_SOFTWARE="1",
                   HOME=self.tmp, XDG_RUNTIME_DIR=self.tmp, QT_X11_NO_MITSHM="1")
        env.pop("WAYLAND_DISPLAY", None)
        return self.procs.start("rviz", ["rviz", "-d", self.config, "-s", ""], env=env, cwd=self.tmp,
                                stdin=subprocess.DEVNULL, stdout=log, stderr=log)


if __name__ == "__main__":
    rostest.rosrun("vadop", "rviz_labels", RvizLabels, sys.argv)
