#!/usr/bin/python3
"""markers_to_tracks.py's conversion (MarkerConverter) without ROS transport: ids, shapes,
frames, velocities from successive arrays (smoothed, reset after a gap), DELETE / DELETEALL."""
import os
import sys
import unittest

import rospy
from shape_msgs.msg import SolidPrimitive
from visualization_msgs.msg import Marker, MarkerArray

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "vadop_ros", "nodes"))
from markers_to_tracks import MarkerConverter  # noqa: E402


def marker(mid, x, y, t, kind=Marker.CYLINDER, ns="people", frame="odom", scale=(0.6, 0.6, 1.8)):
    m = Marker()
    m.header.frame_id = frame
    m.header.stamp = rospy.Time.from_sec(t)
    m.ns = ns
    m.id = mid
    m.type = kind
    m.action = Marker.ADD
    m.pose.position.x = x
    m.pose.position.y = y
    m.pose.orientation.w = 1.0
    m.scale.x, m.scale.y, m.scale.z = scale
    return m


def array(*markers):
    a = MarkerArray()
    a.markers = list(markers)
    return a


class MarkerConverterTest(unittest.TestCase):
    def test_ids_shapes_and_frame(self):
        c = MarkerConverter(smoothing=0.0)
        out = c.convert(array(marker(3, 1, 2, 10.0), marker(4, 0, 0, 10.0, Marker.SPHERE, scale=(0.5, 0.4, 0.3)),
                              marker(5, 0, 0, 10.0, Marker.CUBE, ns="", scale=(1, 2, 3)),
                              marker(6, 0, 0, 10.0, Marker.TEXT_VIEW_FACING)), rospy.Time.from_sec(10.5))
        self.assertEqual([o.id for o in out.objects], ["people/3", "people/4", "5"])
        self.assertEqual(out.header.frame_id, "odom")
        self.assertAlmostEqual(out.header.stamp.to_sec(), 10.0)
        cyl, sph, box = (o.shape for o in out.objects)
        self.assertEqual(cyl.type, SolidPrimitive.CYLINDER)
        self.assertEqual(list(cyl.dimensions), [1.8, 0.3])  # height, radius
        self.assertEqual(sph.type, SolidPrimitive.SPHERE)
        self.assertEqual(list(sph.dimensions), [0.25])
        self.assertEqual(box.type, SolidPrimitive.BOX)
        self.assertEqual(list(box.dimensions), [1, 2, 3])
        self.assertEqual(out.objects[0].pose.position.y, 2)
        # Another frame than the first marker's: skipped, warned.
        out = c.convert(array(marker(3, 1, 2, 11.0), marker(7, 0, 0, 11.0, frame="map")), rospy.Time.from_sec(11.0))
        self.assertEqual([o.id for o in out.objects], ["people/3"])
        self.assertEqual(len(c.warnings), 1)
        self.assertIsNone(c.convert(array(marker(1, 0, 0, 12.0, Marker.ARROW)), rospy.Time.from_sec(12.0)))

    def test_velocity_from_successive_positions(self):
        c = MarkerConverter(smoothing=0.5, max_gap=0.5)
        first = c.convert(array(marker(1, 0.0, 0.0, 10.0)), rospy.Time.from_sec(10.0))
        self.assertEqual(first.objects[0].twist.linear.x, 0.0)  # nothing to differentiate yet
        second = c.convert(array(marker(1, 0.1, 0.0, 10.1)), rospy.Time.from_sec(10.1))
        self.assertAlmostEqual(second.objects[0].twist.linear.x, 0.5)  # 1 m/s, half-smoothed from 0
        third = c.convert(array(marker(1, 0.2, 0.0, 10.2)), rospy.Time.from_sec(10.2))
        self.assertAlmostEqual(third.objects[0].twist.linear.x, 0.75)
        # Unseen for longer than max_gap: the estimate restarts.
        late = c.convert(array(marker(1, 5.0, 0.0, 11.0)), rospy.Time.from_sec(11.0))
        self.assertEqual(late.objects[0].twist.linear.x, 0.0)

    def test_delete_and_default_shape(self):
        c = MarkerConverter(smoothing=0.0, default_shape=True)
        c.convert(array(marker(1, 0.0, 0.0, 10.0), marker(2, 0, 0, 10.0)), rospy.Time.from_sec(10.0))
        gone = Marker()
        gone.ns, gone.id, gone.action = "people", 1, Marker.DELETE
        out = c.convert(array(gone, marker(1, 0.1, 0.0, 10.1)), rospy.Time.from_sec(10.1))
        self.assertEqual(out.objects[0].twist.linear.x, 0.0)  # forgotten: no velocity from before
        self.assertEqual(out.objects[0].shape.type, 0)
        wipe = Marker()
        wipe.action = Marker.DELETEALL
        c.convert(array(wipe), rospy.Time.from_sec(10.2))
        self.assertEqual(c.tracks, {})
        with self.assertRaises(ValueError):
            MarkerConverter(smoothing=1.0)


if __name__ == "__main__":
    if any(a.startswith("--gtest_output") for a in sys.argv):  # run by catkin: junit result file
        import rosunit
        rosunit.unitrun("vadop", "test_markers_to_tracks", MarkerConverterTest, sys.argv)
    else:
        unittest.main()
