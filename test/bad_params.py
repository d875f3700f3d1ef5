#!/usr/bin/python3
"""rostest node: vadop_monitor started with malformed parameters exits with status 1 and a
fatal error naming the parameter (bad_params.test)."""
import os
import subprocess
import sys
import unittest

import rosgraph
import roslib.packages
import rosparam
import rospy
import rostest

CASES = [
    # (parameters, text the fatal error must contain)
    ({"rate": -5.0}, "~rate"),
    ({"horizon": "soon"}, "~horizon: must be a number"),
    ({"bodies": [{"name": "a", "odom_topic": "/a", "shape": {"type": "sphere", "radius": -1.0}}]},
     '~bodies[0] ("a").shape.radius: must be a number > 0, got -1'),
    ({"bodies": [{"name": "a", "shape": {"type": "sphere", "radius": 1.0}}]},
     '~bodies[0] ("a").odom_topic: is required'),
    ({"ignore_pairs": [["a"]]}, "~ignore_pairs[0]"),
    # Issue 13: these aborted the node (ros::Duration out of range; an uncaught
    # ros::InvalidNameException from subscribe) instead of a fatal error naming the parameter.
    ({"rate": 1e-10}, "~rate: must be in [0.1, 1000], got 1e-10"),
    ({"bodies": [{"name": "a", "odom_topic": "/a/odom", "shape": {"type": "sphere", "radius": 1.0}},
                 {"name": "b", "odom_topic": "/a b/odom!", "shape": {"type": "sphere", "radius": 1.0}}]},
     '~bodies[1] ("b").odom_topic: must be a valid ROS topic name'),
    ({"bodies": [{"name": "a", "twist_topic": "/a/vel", "frame": "base link",
                  "shape": {"type": "sphere", "radius": 1.0}}]},
     '~bodies[0] ("a").frame: must be a valid tf frame id'),
    ({"bodies": [{"name": "a", "odom_topic": "/a/odom", "robot_description": "~robot_description"}]},
     '~bodies[0] ("a").robot_description: must not be a private (~) parameter name'),
    # Issue 13: a static obstacle at 1e200 was accepted (and blinded the node); NaN from YAML.
    ({"static_obstacles": [{"name": "w", "shape": {"type": "sphere", "radius": 1.0},
                            "pose": {"position": [1e200, 0.0, 0.0]}}]},
     '~static_obstacles[0] ("w").pose.position[0]: must be within 1e+07 m'),
    ({"padding": float("nan")}, "~padding"),
    # Issue 48: one deceleration without the other (braking along an arc needs both).
    ({"bodies": [{"name": "a", "odom_topic": "/a/odom", "shape": {"type": "sphere", "radius": 1.0},
                  "max_linear_decel": 1.0}]},
     '~bodies[0] ("a").max_angular_decel: is required with max_linear_decel'),
    ({"bodies": [{"name": "a", "odom_topic": "/a/odom", "shape": {"type": "sphere", "radius": 1.0},
                  "gate": {"cmd_vel_in": "/a/nav_vel", "cmd_vel_out": "/a/cmd_vel", "reaction_time": 5.0}}]},
     '~bodies[0] ("a").gate.reaction_time: must be in [0, 2], got 5'),
    # Issue 51: a typo at any level stops the node, naming the nearest valid key.
    ({"pading": 0.1}, '~pading: unknown key; did you mean "padding"?'),
    ({"bodies": [{"name": "a", "odom_topc": "/a/odom", "shape": {"type": "sphere", "radius": 1.0}}]},
     '~bodies[0] ("a").odom_topc: unknown key; did you mean "odom_topic"?'),
    # A robot_description that is missing: nothing of the body could be hit.
    ({"bodies": [{"name": "a", "odom_topic": "/a/odom", "robot_description": "/no_such_description"}]},
     '~bodies[0] ("a").robot_description: nothing to monitor: robot_description parameter "/no_such_description"'
     ' does not exist'),
]


class BadParams(unittest.TestCase):
    def test_fatal_error_names_the_parameter(self):
        rospy.init_node("bad_params_test", anonymous=True)
        exe = roslib.packages.find_node("vadop", "vadop_monitor")
        self.assertTrue(exe, "vadop_monitor not found")
        for k, (params, expected) in enumerate(CASES):
            ns = "/bad_monitor_%d" % k
            for key, value in params.items():
                rospy.set_param(ns + "/" + key, value)
            proc = subprocess.run([exe[0], "__name:=bad_monitor_%d" % k], stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT, timeout=60, env=os.environ)
            out = proc.stdout.decode(errors="replace")
            self.assertEqual(proc.returncode, 1, "case %d: exit status %d, output:\n%s" % (k, proc.returncode, out))
            self.assertIn("bad parameter", out)
            self.assertIn(expected, out, "case %d: output:\n%s" % (k, out))
            rospy.delete_param(ns)


if __name__ == "__main__":
    rostest.rosrun("vadop", "bad_params", BadParams, sys.argv)
