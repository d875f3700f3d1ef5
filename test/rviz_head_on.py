#!/usr/bin/python3
"""rostest node (rviz_head_on.test): rviz shows the head-on scenario with rviz/vadop.rviz.

It starts Xvfb (on a display number the server picks itself) and rviz with the given config,
publishes odometry for three spheres at fixed poses with fresh stamps (so the picture is still):
`left` and `right` on a head-on course (impact in 1.79 s, within the 2 s horizon: amber), and
`clear`, moving away from them (grey). It grabs the screen until the swept volumes show up,
then checks the last screenshot against the camera of the config's view, projected by hand:

  (a) impact-coloured pixels cover the start spheres of `left` and `right`, the path between
      them and their end spheres near the middle;
  (b) there are none anywhere in the 3D view outside the projected box of the pair's swept
      volumes (and none, in particular, in front of the pair, where nothing is);
  (c) the `clear` body is drawn grey, with no impact colour.

Xvfb and rviz run in their own process groups, are stopped in every case (end of test, failure,
ROS shutdown, exit) and die with this process if it is killed (setpriv --pdeathsig).
The last screenshot is saved as rviz_head_on.png in the test results directory.
"""
import atexit
import math
import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
import yaml
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from PIL import ImageGrab

RADIUS = 0.5
SPEED = 1.4        # m/s, each of the head-on pair
START_X = 3.0      # left at -3, right at +3: contact in (2 * 3 - 2 * 0.5) / (2 * 1.4) = 1.79 s
HORIZON = 2.0      # as in rviz_head_on.test: the end spheres are at -/+ (3 - 1.4 * 2) = -/+ 0.2
CLEAR_XY = (0.0, 3.0)
CLEAR_VY = 0.5     # moving away from the pair: no impact, grey
PUBLISH_HZ = 30.0
SCREEN = (1280, 800)
RENDER_TIMEOUT = 60.0  # s from rviz's start until the swept volumes must be on screen

# markers.cpp, impactColour(): amber when the soonest impact is within the horizon but not
# below kRedSeconds (grey, 0.6 0.6 0.6, when clear).
IMPACT_RGB = (1.0, 0.65, 0.0)


def results_dir():
    for a in sys.argv:
        if a.startswith("--gtest_output=xml:"):
            return os.path.dirname(a[len("--gtest_output=xml:"):])
    return os.environ.get("ROS_TEST_RESULTS_DIR", tempfile.gettempdir())


# ---------------------------------------------------------------------------------------------
# Pixels
# ---------------------------------------------------------------------------------------------
def hue_255(rgb):
    r, g, b = rgb
    mx, mn = max(rgb), min(rgb)
    if mx == mn:
        return 0.0
    if mx == r:
        h = ((g - b) / (mx - mn)) % 6.0
    elif mx == g:
        h = (b - r) / (mx - mn) + 2.0
    else:
        h = (r - g) / (mx - mn) + 4.0
    return h / 6.0 * 255.0


class Classified:
    """Masks of one screenshot: the impact colour (hue of IMPACT_RGB, whatever the shading and
    the blending with the background), neutral grey, and the exact background colour."""

    def __init__(self, image, background):
        self.image = image.convert("RGB")
        rgb = np.asarray(self.image).astype(np.int16)
        hsv = np.asarray(self.image.convert("HSV")).astype(np.int16)
        h, s, v = hsv[..., 0], hsv[..., 1], hsv[..., 2]
        dh = np.abs(h - hue_255(IMPACT_RGB))
        dh = np.minimum(dh, 255 - dh)
        self.impact = (dh <= 8) & (s >= 128) & (v >= 60)
        # Neutral and mid-bright: the shaded grey spheres; not the background (40, 40, 48), not the
        # grid lines (blended with the bluish background: spread 6 to 8), not the white label text.
        spread = rgb.max(axis=2) - rgb.min(axis=2)
        self.grey = (spread <= 4) & (v >= 80) & (v <= 200)
        self.background = np.all(rgb == np.array(background, dtype=np.int16), axis=2)

    def render_rect(self):
        """Bounding box (x0, y0, x1, y1), exclusive ends, of the background colour: rviz's 3D
        view (the panels around it are Qt's light grey)."""
        ys, xs = np.nonzero(self.background)
        if len(xs) < 1000:
            return None
        return int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1

    @staticmethod
    def _window(mask, centre, half):
        x, y = int(round(centre[0])), int(round(centre[1]))
        half = int(math.ceil(half))
        return mask[max(0, y - half):y + half + 1, max(0, x - half):x + half + 1]

    def fraction(self, mask, centre, half):
        w = self._window(mask, centre, half)
        return float(w.mean()) if w.size else 0.0

    def count(self, mask, centre, half):
        return int(self._window(mask, centre, half).sum())


# ---------------------------------------------------------------------------------------------
# The camera of the config's view (rviz/Orbit), as rviz's OrbitViewController places it
# ---------------------------------------------------------------------------------------------
class OrbitCamera:
    def __init__(self, view, rect):
        if view.get("Class") != "rviz/Orbit":
            raise AssertionError("the test projects rviz/Orbit views only, the config has %s" % view.get("Class"))
        if view.get("Invert Z Axis", False):
            raise AssertionError("the test does not handle 'Invert Z Axis: true'")
        fp = view["Focal Point"]
        self.focal = np.array([fp["X"], fp["Y"], fp["Z"]], dtype=float)
        d, yaw, pitch = float(view["Distance"]), float(view["Yaw"]), float(view["Pitch"])
        self.pos = self.focal + d * np.array([math.cos(yaw) * math.cos(pitch),
                                              math.sin(yaw) * math.cos(pitch), math.sin(pitch)])
        self.fwd = (self.focal - self.pos) / np.linalg.norm(self.focal - self.pos)
        right = np.cross(self.fwd, [0.0, 0.0, 1.0])  # fixed yaw axis: z of the fixed frame
        self.right = right / np.linalg.norm(right)
        self.up = np.cross(self.right, self.fwd)
        x0, y0, x1, y1 = rect
        self.cx, self.cy = (x0 + x1) / 2.0, (y0 + y1) / 2.0
        fovy = float(view.get("Field of View", math.pi / 4))
        self.f = (y1 - y0) / 2.0 / math.tan(fovy / 2.0)

    def project(self, p):
        v = np.asarray(p, dtype=float) - self.pos
        z = v.dot(self.fwd)
        return (self.cx + self.f * v.dot(self.right) / z, self.cy - self.f * v.dot(self.up) / z)

    def radius_px(self, p, r):
        a, b = self.project(p), self.project(np.asarray(p, dtype=float) + r * self.right)
        return math.hypot(b[0] - a[0], b[1] - a[1])

    def box_px(self, lo, hi):
        pts = [self.project((x, y, z)) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
        return (min(p[0] for p in pts), min(p[1] for p in pts), max(p[0] for p in pts), max(p[1] for p in pts))


def demo_wall_corners(rviz_config):
    """The 8 corners of each wall (static obstacle named wall_*) of config/demo.yaml, beside the
    rviz directory of the given config."""
    path = os.path.join(os.path.dirname(os.path.abspath(rviz_config)), "..", "config", "demo.yaml")
    with open(path) as f:
        demo = yaml.safe_load(f)
    out = []
    for o in demo["static_obstacles"]:
        if not o["name"].startswith("wall_") or o["shape"]["type"] != "box":
            continue
        c, h = np.asarray(o["pose"]["position"], dtype=float), 0.5 * np.asarray(o["shape"]["size"], dtype=float)
        out += [c + h * np.array([sx, sy, sz]) for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    return out


# ---------------------------------------------------------------------------------------------
# Xvfb and rviz
# ---------------------------------------------------------------------------------------------
class Processes:
    """Child processes in their own process groups, each stopped exactly once."""

    def __init__(self):
        self.procs = []
        self.lock = threading.Lock()

    def start(self, name, argv, **kw):
        # setpriv --pdeathsig: the child gets SIGTERM when this process dies, even by SIGKILL.
        p = subprocess.Popen(["setpriv", "--pdeathsig", "TERM", "--"] + argv, start_new_session=True, **kw)
        with self.lock:
            self.procs.append((name, p))
        return p

    def stop_all(self):
        with self.lock:
            procs, self.procs = self.procs, []
        for name, p in reversed(procs):  # rviz before Xvfb
            if p.poll() is None:
                try:
                    os.killpg(p.pid, signal.SIGTERM)
                except ProcessLookupError:
                    pass
                try:
                    p.wait(timeout=5.0)
                except subprocess.TimeoutExpired:
                    try:
                        os.killpg(p.pid, signal.SIGKILL)
                    except ProcessLookupError:
                        pass
                    p.wait(timeout=5.0)


def start_xvfb(procs, log):
    """Starts Xvfb on a free display (-displayfd: the server picks it) and returns ':N'."""
    r, w = os.pipe()
    try:
        p = procs.start("Xvfb", ["Xvfb", "-displayfd", str(w), "-screen", "0", "%dx%dx24" % SCREEN,
                                 "-nolisten", "tcp", "-noreset"],
                        pass_fds=(w,), stdin=subprocess.DEVNULL, stdout=log, stderr=log)
        os.close(w)
        w = None
        out = b""
        deadline = time.monotonic() + 15.0
        while not out.endswith(b"\n"):
            left = deadline - time.monotonic()
            if left <= 0 or p.poll() is not None:
                raise AssertionError("Xvfb did not report its display (exit status %s)" % p.poll())
            if select.select([r], [], [], left)[0]:
                chunk = os.read(r, 64)
                if not chunk:
                    raise AssertionError("Xvfb closed -displayfd without a display number")
                out += chunk
        return ":" + out.decode().strip()
    finally:
        os.close(r)
        if w is not None:
            os.close(w)


def grab(display):
    return ImageGrab.grab(xdisplay=display)


# ---------------------------------------------------------------------------------------------
# The test
# ---------------------------------------------------------------------------------------------
class RvizHeadOn(unittest.TestCase):
    def setUp(self):
        self.config = [a for a in sys.argv[1:] if not a.startswith("--")][0]
        with open(self.config) as f:
            self.rviz = yaml.safe_load(f)
        self.procs = Processes()
        atexit.register(self.procs.stop_all)
        self.tmp = tempfile.mkdtemp(prefix="vadop_rviz_")
        self.out_dir = results_dir()
        os.makedirs(self.out_dir, exist_ok=True)
        self.shot_path = os.path.join(self.out_dir, "rviz_head_on.png")
        self.log_path = os.path.join(self.out_dir, "rviz_head_on_rviz.log")
        self.last_shot = None
        rospy.init_node("rviz_head_on_test", anonymous=True)
        rospy.on_shutdown(self.procs.stop_all)
        self.pubs = {name: rospy.Publisher("/%s/odom" % name, Odometry, queue_size=10)
                     for name in ("left", "right", "clear")}
        self.tf = tf2_ros.TransformBroadcaster()  # so that rviz knows the fixed frame "odom"

    def tearDown(self):
        self.procs.stop_all()
        if self.last_shot is not None:
            self.last_shot.save(self.shot_path)
            rospy.loginfo("last screenshot: %s", self.shot_path)
        shutil.rmtree(self.tmp, ignore_errors=True)

    # x, y, vx, vy of each body: fixed poses, so the swept volumes stand still on screen.
    STATES = {
        "left": (-START_X, 0.0, SPEED, 0.0),
        "right": (START_X, 0.0, -SPEED, 0.0),
        "clear": (CLEAR_XY[0], CLEAR_XY[1], 0.0, CLEAR_VY),
    }

    def publish(self, _event=None):
        now = rospy.Time.now()
        for name, (x, y, vx, vy) in self.STATES.items():
            m = Odometry()
            m.header.stamp = now
            m.header.frame_id = "odom"
            m.child_frame_id = name
            m.pose.pose.position.x = x
            m.pose.pose.position.y = y
            m.pose.pose.orientation.w = 1.0
            m.twist.twist.linear.x = vx  # identity orientation: body frame = odom axes
            m.twist.twist.linear.y = vy
            self.pubs[name].publish(m)
            t = TransformStamped()
            t.header = m.header
            t.child_frame_id = name
            t.transform.translation.x = x
            t.transform.translation.y = y
            t.transform.rotation.w = 1.0
            self.tf.sendTransform(t)

    def start_rviz(self, display, log):
        env = dict(os.environ)
        paths = [p for p in env.get("ROS_PACKAGE_PATH", "").split(":") if p]
        if "/usr/share" not in paths:
            paths.append("/usr/share")  # Debian's ROS packages, rviz's own media among them
        env.update(DISPLAY=display, ROS_PACKAGE_PATH=":".join(paths), LIBGL_ALWAYS_SOFTWARE="1",
                   HOME=self.tmp, XDG_RUNTIME_DIR=self.tmp, QT_X11_NO_MITSHM="1")
        env.pop("WAYLAND_DISPLAY", None)
        return self.procs.start("rviz", ["rviz", "-d", self.config, "-s", ""], env=env, cwd=self.tmp,
                                stdin=subprocess.DEVNULL, stdout=log, stderr=log)

    def expectations(self, shot):
        """The camera for this screenshot, or None while rviz's 3D view is not up."""
        rect = shot.render_rect()
        if rect is None or rect[2] - rect[0] < 200 or rect[3] - rect[1] < 200:
            return None
        return rect, OrbitCamera(self.rviz["Visualization Manager"]["Views"]["Current"], rect)

    def starts_drawn(self, shot, cam):
        return all(shot.fraction(shot.impact, cam.project((x, 0.0, 0.0)), 0.5 * cam.radius_px((x, 0.0, 0.0), RADIUS))
                   > 0.5 for x in (-START_X, START_X))

    def test_swept_volumes_on_screen(self):
        bg = [int(c) for c in self.rviz["Visualization Manager"]["Global Options"]["Background Color"].split(";")]
        t0 = time.monotonic()
        with open(self.log_path, "w") as log:
            display = start_xvfb(self.procs, log)
            rospy.loginfo("Xvfb on display %s", display)
            timer = rospy.Timer(rospy.Duration(1.0 / PUBLISH_HZ), self.publish)
            rviz = self.start_rviz(display, log)

            # Poll the screen until both start spheres show in the impact colour.
            shot = None
            ready = False
            view_up = False
            restarted = False
            while not rospy.is_shutdown() and time.monotonic() - t0 < RENDER_TIMEOUT:
                status = rviz.poll()
                if status is not None and not view_up and not restarted:
                    # rviz on software OpenGL under Xvfb now and then dies while it creates its
                    # window, before drawing anything: started once more. Dying once its view is
                    # up (when the markers are drawn) fails the test.
                    rospy.logwarn("rviz exited with status %s before its view was up: starting it again", status)
                    restarted = True
                    rviz = self.start_rviz(display, log)
                    continue
                self.assertIsNone(status, "rviz exited with status %s (see %s)" % (status, self.log_path))
                time.sleep(0.5)
                image = grab(display)
                self.last_shot = image
                shot = Classified(image, bg)
                e = self.expectations(shot)
                view_up = view_up or e is not None
                if e is not None and self.starts_drawn(shot, e[1]):
                    ready = True
                    break
            self.assertTrue(ready, "the head-on pair was not drawn in the impact colour within %.0f s "
                            "(screenshot: %s, rviz output: %s)" % (RENDER_TIMEOUT, self.shot_path, self.log_path))
            rospy.loginfo("swept volumes on screen %.1f s after starting Xvfb", time.monotonic() - t0)
            time.sleep(1.0)  # one more second of frames, then the screenshot that is checked
            image = grab(display)
            self.last_shot = image
            timer.shutdown()
            self.procs.stop_all()
        self.check(Classified(image, bg))

    def check(self, shot):
        e = self.expectations(shot)
        self.assertIsNotNone(e, "rviz's 3D view (background colour) not found in the last screenshot")
        rect, cam = e
        x0, y0, x1, y1 = rect
        rospy.loginfo("3D view at x %d..%d, y %d..%d of the screenshot", x0, x1, y0, y1)

        def inside(p):
            return x0 <= p[0] < x1 and y0 <= p[1] < y1

        # (a) The impact colour on the pair's swept volumes: start spheres, the path, the end spheres.
        end_x = START_X - SPEED * HORIZON
        for label, (x, need) in {"left start sphere": (-START_X, 0.6), "right start sphere": (START_X, 0.6),
                                 "left end sphere": (-end_x, 0.3), "right end sphere": (end_x, 0.3)}.items():
            p = cam.project((x, 0.0, 0.0))
            self.assertTrue(inside(p), "%s projects outside the 3D view: %s" % (label, p))
            half = 0.5 * cam.radius_px((x, 0.0, 0.0), RADIUS)
            frac = shot.fraction(shot.impact, p, half)
            rospy.loginfo("%s at pixel (%.0f, %.0f): %.0f%% impact colour in a %.0f px square", label, p[0], p[1],
                          100 * frac, 2 * half + 1)
            self.assertGreater(frac, need, "%s at pixel (%.0f, %.0f): only %.0f%% of the pixels have the impact "
                               "colour" % (label, p[0], p[1], 100 * frac))
        for x in (-0.5 * (START_X + end_x), 0.5 * (START_X + end_x)):  # the line strips between start and end
            p = cam.project((x, 0.0, 0.0))
            n = shot.count(shot.impact, p, 4)
            self.assertGreater(n, 2, "path at x = %.2f m, pixel (%.0f, %.0f): no impact colour" % (x, p[0], p[1]))

        # (b) Nowhere else: the projected box of the swept volumes, with a margin of 0.1 m and 3 px.
        m = 0.1
        bx0, by0, bx1, by1 = cam.box_px((-START_X - RADIUS - m, -RADIUS - m, -RADIUS - m),
                                        (START_X + RADIUS + m, RADIUS + m, RADIUS + m))
        region = np.zeros_like(shot.impact)
        region[y0:y1, x0:x1] = True
        region[max(0, int(by0) - 3):int(by1) + 4, max(0, int(bx0) - 3):int(bx1) + 4] = False
        stray = shot.impact & region
        ys, xs = np.nonzero(stray)
        self.assertEqual(len(xs), 0, "%d impact-coloured pixels outside the pair's swept volumes (box x %.0f..%.0f, "
                         "y %.0f..%.0f), e.g. at (%s, %s)" % (len(xs), bx0, bx1, by0, by1,
                                                               xs[:1].tolist(), ys[:1].tolist()))
        for label, q in {"in front of the pair": (0.0, -2.5, 0.0), "behind the left body": (-START_X, 2.5, 0.0)}.items():
            p = cam.project(q)
            self.assertTrue(inside(p), "%s projects outside the 3D view: %s" % (label, p))
            half = 2 * cam.radius_px(q, RADIUS)
            n = shot.count(shot.impact, p, half)
            self.assertEqual(n, 0, "%s, pixel (%.0f, %.0f): %d impact-coloured pixels" % (label, p[0], p[1], n))

        # (c) The body on no collision course: grey, not the impact colour.
        c = (CLEAR_XY[0], CLEAR_XY[1], 0.0)
        p = cam.project(c)
        self.assertTrue(inside(p), "clear body projects outside the 3D view: %s" % (p,))
        half = 0.5 * cam.radius_px(c, RADIUS)
        grey, impact = shot.fraction(shot.grey, p, half), shot.fraction(shot.impact, p, 2 * half)
        rospy.loginfo("clear body at pixel (%.0f, %.0f): %.0f%% grey, %.0f%% impact colour", p[0], p[1], 100 * grey,
                      100 * impact)
        self.assertGreater(grey, 0.8, "clear body at pixel (%.0f, %.0f): only %.0f%% grey" % (p[0], p[1], 100 * grey))
        self.assertEqual(impact, 0.0, "clear body at pixel (%.0f, %.0f) has the impact colour" % p)

        # (d) The view frames the demo's room (config/demo.yaml's walls, demo.launch): every corner
        # of every wall projects inside the 3D view, and the room spans most of its width or height.
        pts = [cam.project(c) for c in demo_wall_corners(self.config)]
        self.assertEqual(len(pts), 32, "config/demo.yaml: four box walls expected")
        for p in pts:
            self.assertTrue(inside(p), "a corner of the demo room's walls projects outside the 3D view: %s" % (p,))
        span_x = (max(p[0] for p in pts) - min(p[0] for p in pts)) / (x1 - x0)
        span_y = (max(p[1] for p in pts) - min(p[1] for p in pts)) / (y1 - y0)
        rospy.loginfo("demo room spans %.0f%% of the 3D view's width, %.0f%% of its height", 100 * span_x, 100 * span_y)
        self.assertGreater(max(span_x, span_y), 0.8, "the demo room fills too little of the view")


if __name__ == "__main__":
    rostest.rosrun("vadop", "rviz_head_on", RvizHeadOn, sys.argv)
