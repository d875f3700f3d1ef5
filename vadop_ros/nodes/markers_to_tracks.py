#!/usr/bin/python3
"""Converts a tracker's visualization_msgs/MarkerArray into vadop/TrackedObjectArray (~tracks).

Many trackers publish their tracks for rviz as one MarkerArray of SPHERE, CYLINDER or CUBE markers
whose (ns, id) is the track's id. This node turns each such array into one TrackedObjectArray:

  - id: "<ns>/<id>" (just "<id>" when ns is empty); shape: SPHERE -> SPHERE of radius
    max(scale) / 2, CYLINDER -> CYLINDER [height scale.z, radius max(scale.x, scale.y) / 2], CUBE ->
    BOX [scale.x, scale.y, scale.z] (~default_shape: true sends type 0 instead, the source's
    default_shape);
  - pose: the marker's pose; every marker must share the first one's header.frame_id (others
    are skipped, warned);
  - twist: markers carry no velocity, so it is the finite difference of the track's positions
    between its two latest arrays, smoothed (~smoothing in [0, 1): the weight of the previous
    estimate) and reset to zero when the track was not seen for ~max_gap seconds;
  - DELETE forgets one track, DELETEALL every one; other marker types (text, arrows) are ignored.
The array is stamped with the first marker's header.stamp (the receipt time when zero).

Private parameters: ~input (default markers_in), ~output (default tracks_out), ~smoothing (0.5),
~max_gap (0.5 s), ~default_shape (false). Example:
  rosrun vadop markers_to_tracks.py _input:=/people_tracker/markers _output:=/people/tracks
"""
import math

import rospy
from geometry_msgs.msg import Twist
from shape_msgs.msg import SolidPrimitive
from vadop.msg import TrackedObject, TrackedObjectArray
from visualization_msgs.msg import Marker, MarkerArray


class MarkerConverter:
    """The conversion without ROS transport (unit-tested in test/test_markers_to_tracks.py)."""

    def __init__(self, smoothing=0.5, max_gap=0.5, default_shape=False):
        if not 0.0 <= smoothing < 1.0:
            raise ValueError("smoothing must be in [0, 1), got %r" % smoothing)
        if not max_gap > 0.0:
            raise ValueError("max_gap must be > 0, got %r" % max_gap)
        self.smoothing = smoothing
        self.max_gap = max_gap
        self.default_shape = default_shape
        self.tracks = {}  # id -> (time, (x, y, z), (vx, vy, vz))
        self.warnings = []

    @staticmethod
    def track_id(marker):
        return "%s/%d" % (marker.ns, marker.id) if marker.ns else str(marker.id)

    def shape(self, marker):
        p = SolidPrimitive()
        if self.default_shape:
            return p  # type 0: the source's default_shape
        s = marker.scale
        if marker.type == Marker.SPHERE:
            p.type = SolidPrimitive.SPHERE
            p.dimensions = [max(s.x, s.y, s.z) / 2.0]
        elif marker.type == Marker.CYLINDER:
            p.type = SolidPrimitive.CYLINDER
            p.dimensions = [s.z, max(s.x, s.y) / 2.0]
        else:  # CUBE
            p.type = SolidPrimitive.BOX
            p.dimensions = [s.x, s.y, s.z]
        return p

    def convert(self, markers, receipt):
        """MarkerArray -> TrackedObjectArray, or None when it holds no track marker."""
        self.warnings = []
        out = TrackedObjectArray()
        header = None
        seen = set()
        for m in markers.markers:
            if m.action == Marker.DELETEALL:
                self.tracks.clear()
                continue
            if m.action == Marker.DELETE:
                self.tracks.pop(self.track_id(m), None)
                continue
            if m.type not in (Marker.SPHERE, Marker.CYLINDER, Marker.CUBE):
                continue
            if header is None:
                header = m.header
            elif m.header.frame_id != header.frame_id:
                self.warnings.append("marker %s in frame %r, not %r: skipped"
                                     % (self.track_id(m), m.header.frame_id, header.frame_id))
                continue
            tid = self.track_id(m)
            if tid in seen:
                self.warnings.append("marker %s repeated in one array: the last one is sent" % tid)
            seen.add(tid)
            stamp = m.header.stamp if not m.header.stamp.is_zero() else receipt
            t = stamp.to_sec()
            pos = (m.pose.position.x, m.pose.position.y, m.pose.position.z)
            vel = (0.0, 0.0, 0.0)
            prev = self.tracks.get(tid)
            if prev is not None and 0.0 < t - prev[0] <= self.max_gap and all(map(math.isfinite, pos)):
                raw = tuple((pos[k] - prev[1][k]) / (t - prev[0]) for k in range(3))
                a = self.smoothing
                vel = tuple(a * prev[2][k] + (1.0 - a) * raw[k] for k in range(3))
            elif prev is not None and t <= prev[0]:
                vel = prev[2]  # the same time again: keep the estimate
            self.tracks[tid] = (t, pos, vel)
            o = TrackedObject()
            o.id = tid
            o.shape = self.shape(m)
            o.pose = m.pose
            o.twist = Twist()
            o.twist.linear.x, o.twist.linear.y, o.twist.linear.z = vel
            out.objects = [x for x in out.objects if x.id != tid] + [o]
        if header is None:
            return None
        out.header.frame_id = header.frame_id
        out.header.stamp = header.stamp if not header.stamp.is_zero() else receipt
        return out


def main():
    rospy.init_node("markers_to_tracks")
    converter = MarkerConverter(float(rospy.get_param("~smoothing", 0.5)), float(rospy.get_param("~max_gap", 0.5)),
                                bool(rospy.get_param("~default_shape", False)))
    pub = rospy.Publisher(rospy.get_param("~output", "tracks_out"), TrackedObjectArray, queue_size=5)

    def on_markers(msg):
        out = converter.convert(msg, rospy.Time.now())
        for w in converter.warnings:
            rospy.logwarn_throttle(5.0, "markers_to_tracks: " + w)
        if out is not None:
            pub.publish(out)

    rospy.Subscriber(rospy.get_param("~input", "markers_in"), MarkerArray, on_markers, queue_size=5)
    rospy.spin()


if __name__ == "__main__":
    main()
