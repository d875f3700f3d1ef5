#!/usr/bin/python3
"""rostest node of test/tutorials/sensors.test: what docs/tutorials/sensors.md promises. A
simulated base (tutorial_sim.Base) follows the gate's cmd_vel_out and publishes its odometry and
tf (odom -> base_link; the laser's mount base_link -> laser, 0.2 m ahead and up, as a static
transform). Its laser (10 Hz) sees a wall that no configuration holds, face at x = 2.9. The
planner commands 0.8 m/s at it: the robot must stop short of the wall without touching it, the
gate naming the laser. Then the planner backs away at 0.3 m/s (passed unchanged), and the scans
stop: after the sensor's timeout every command comes out zero (reason stale, naming the laser)."""
import sys
import unittest

import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from vadop.msg import GateState, GateStateArray

import tutorial_sim

ROBOT_RADIUS = 0.3
LASER = (0.2, 0.2)       # x ahead of base_link, z up
WALL_FACE_X = 2.9
ODOM_HZ, SCAN_HZ, PLAN_HZ = 50.0, 10.0, 20.0
DRIVE, BACK, STALE = 8.0, 1.5, 1.5   # s of each phase
TIMEOUT = 0.5            # the sensor's timeout (config/tutorials/sensors.yaml)


class Sensors(unittest.TestCase):
    def setUp(self):
        rospy.init_node("sensors_check")
        self.base = tutorial_sim.Base(0.0, 0.0, 0.0)
        self.odom = rospy.Publisher("/my_robot/odom", Odometry, queue_size=10)
        self.scan = rospy.Publisher("/my_robot/scan", LaserScan, queue_size=10)
        self.plan = rospy.Publisher("/my_robot/nav_vel", Twist, queue_size=10)
        self.tf = tf2_ros.TransformBroadcaster()
        tf2_ros.StaticTransformBroadcaster().sendTransform(
            tutorial_sim.transform(rospy.Time.now(), "base_link", "laser", LASER[0], 0.0, 0.0))
        self.outputs = []   # (time, linear x) of every cmd_vel_out
        self.cmd = rospy.Subscriber("/my_robot/cmd_vel", Twist, self.on_cmd, queue_size=100)
        self.states = []
        self.gate = rospy.Subscriber("/vadop_monitor/gate_states", GateStateArray, self.states.append,
                                     queue_size=100)
        self.min_gap = float("inf")

    def on_cmd(self, msg):
        self.base.on_command(msg)
        self.outputs.append((rospy.get_time(), msg.linear.x))

    def run_phase(self, seconds, speed, scans):
        """Simulates `seconds`: the planner commands `speed`; the laser scans when `scans`."""
        command = Twist()
        command.linear.x = speed
        rate = rospy.Rate(ODOM_HZ)
        last = rospy.get_time()
        end = last + seconds
        next_plan = next_scan = last
        previous = None   # (stamp, laser x, y) of the last odometry and tf sent
        while not rospy.is_shutdown() and last < end:
            rate.sleep()
            now = rospy.get_time()
            self.base.advance(now, now - last)
            last = now
            x, y, yaw, v, w = self.base.state()
            self.min_gap = min(self.min_gap, WALL_FACE_X - (x + ROBOT_RADIUS))
            stamp = rospy.Time.now()
            self.odom.publish(tutorial_sim.odometry(stamp, "base_link", x, y, yaw, v, w))
            self.tf.sendTransform(tutorial_sim.transform(stamp, "odom", "base_link", x, y, yaw))
            if scans and previous is not None and now >= next_scan:
                # As a driver does: stamped at a pose tf already has (the previous one; the robot
                # drives straight along +x).
                self.scan.publish(tutorial_sim.scan_of_wall(previous[0], "laser", previous[1], previous[2],
                                                            WALL_FACE_X, 2.0))
                next_scan = now + 1.0 / SCAN_HZ
            previous = (stamp, x + LASER[0], y)
            if now >= next_plan:
                self.plan.publish(command)
                next_plan = now + 1.0 / PLAN_HZ

    def last_gate_state(self):
        return [g for g in self.states[-1].gates if g.body == "my_robot"][0]

    def test_scan_wall_and_stale_laser(self):
        self.assertTrue(tutorial_sim.wait_for_connections([self.odom, self.scan, self.plan], [self.cmd, self.gate]),
                        "vadop_monitor did not connect")
        self.run_phase(0.5, 0.0, True)
        self.run_phase(DRIVE, 0.8, True)
        x, _, _, v, _ = self.base.state()
        gap = WALL_FACE_X - (x + ROBOT_RADIUS)
        state = self.last_gate_state()
        rospy.loginfo("sensors: stopped %.3f m from the scanned wall (smallest gap %.3f m), speed %.4f m/s, gate %s "
                      "by %s", gap, self.min_gap, v, state.reason, state.limiting_body)
        self.assertGreater(self.min_gap, 0.0, "the robot touched the wall its laser sees")
        self.assertLess(gap, 0.3, "the robot stopped %.2f m from the wall: too far to have been gated" % gap)
        self.assertEqual((state.reason, state.limiting_body), (GateState.REASON_STOP, "front_laser"))

        t_back = rospy.get_time()
        self.run_phase(BACK, -0.3, True)
        backing = [vx for t, vx in self.outputs if t > t_back + 0.2]
        self.assertTrue(backing and all(vx == -0.3 for vx in backing), "backing away was limited: %s" % backing[:5])

        t_stale = rospy.get_time()
        self.run_phase(STALE, -0.3, False)
        after = [vx for t, vx in self.outputs if t > t_stale + TIMEOUT + 0.2]
        state = self.last_gate_state()
        rospy.loginfo("sensors: scans stopped: %d commands out after the timeout, all zero: %s; gate %s (%s)",
                      len(after), all(vx == 0.0 for vx in after), state.reason, state.detail)
        self.assertTrue(after and all(vx == 0.0 for vx in after), "a stale laser let commands through: %s" % after[:5])
        self.assertEqual(state.reason, GateState.REASON_STALE)
        self.assertIn("front_laser", state.detail)


if __name__ == "__main__":
    rostest.rosrun("vadop", "tutorial_sensors", Sensors, sys.argv)
