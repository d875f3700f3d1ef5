#!/usr/bin/python3
"""rostest node of test/tutorials/your_robot.test: what docs/tutorials/your_robot.md promises.
A simulated base (tutorial_sim.Base: 0.06 s delay, 1 m/s^2 ramp) follows the gate's cmd_vel_out
and publishes its odometry; its planner commands 0.8 m/s straight at the wall. The robot (the
0.3 m radius base of urdf/agent.urdf) must stop short of the wall without touching it, close to
it (it was slowed by the gate, not stopped at the start), and the gate must say why."""
import sys
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from vadop.msg import GateState, GateStateArray

import tutorial_sim

ROBOT_RADIUS = 0.3   # urdf/agent.urdf: base cylinder; the mast stays inside it seen from above
WALL_FACE_X = 2.9    # config/tutorials/your_robot.yaml: box 0.2 m thick centred at x = 3
SPEED = 0.8
ODOM_HZ = 50.0
PLAN_HZ = 20.0
DRIVE_SECONDS = 9.0  # ungated it would touch the wall after 2.6 / 0.8 = 3.25 s; gated it creeps the last cm


class YourRobot(unittest.TestCase):
    def test_gate_stops_short_of_the_wall(self):
        rospy.init_node("your_robot_check")
        base = tutorial_sim.Base(0.0, 0.0, 0.0)
        odom = rospy.Publisher("/my_robot/odom", Odometry, queue_size=10)
        plan = rospy.Publisher("/my_robot/nav_vel", Twist, queue_size=10)
        cmd = rospy.Subscriber("/my_robot/cmd_vel", Twist, base.on_command, queue_size=100)
        states = []
        gate = rospy.Subscriber("/vadop_monitor/gate_states", GateStateArray, states.append, queue_size=100)
        self.assertTrue(tutorial_sim.wait_for_connections([odom, plan], [cmd, gate]), "vadop_monitor did not connect")

        command = Twist()
        command.linear.x = SPEED
        rate = rospy.Rate(ODOM_HZ)
        last = rospy.get_time()
        start = last
        next_plan = last + 0.5   # half a second of odometry standing still first
        min_gap = float("inf")
        while not rospy.is_shutdown() and last - start < DRIVE_SECONDS:
            rate.sleep()
            now = rospy.get_time()
            base.advance(now, now - last)
            last = now
            x, y, yaw, v, w = base.state()
            min_gap = min(min_gap, WALL_FACE_X - (x + ROBOT_RADIUS))
            odom.publish(tutorial_sim.odometry(rospy.Time.now(), "base_link", x, y, yaw, v, w))
            if now >= next_plan:
                plan.publish(command)
                next_plan = now + 1.0 / PLAN_HZ

        x, _, _, v, _ = base.state()
        final_gap = WALL_FACE_X - (x + ROBOT_RADIUS)
        rospy.loginfo("your_robot: stopped at x = %.3f m, %.3f m from the wall (smallest gap %.3f m), speed %.4f m/s",
                      x, final_gap, min_gap, v)
        self.assertGreater(min_gap, 0.0, "the robot touched the wall")
        # padding 0.05 on both shapes: it stops about 0.1 m short (0.107 m when this was written).
        self.assertLess(final_gap, 0.3, "the robot stopped %.2f m from the wall: too far to have been gated" % final_gap)
        last_state = [s for s in states[-1].gates if s.body == "my_robot"][0]
        rospy.loginfo("your_robot: last gate state %s scale %.3f limiting %s in %.3f s", last_state.reason,
                      last_state.scale, last_state.limiting_body, last_state.time_to_contact)
        self.assertLess(abs(v), 0.01, "the robot is still moving at %.3f m/s" % v)
        self.assertEqual(last_state.reason, GateState.REASON_STOP)
        self.assertEqual(last_state.limiting_body, "wall")
        self.assertEqual(last_state.rule, GateState.RULE_BRAKING)


if __name__ == "__main__":
    rostest.rosrun("vadop", "tutorial_your_robot", YourRobot, sys.argv)
