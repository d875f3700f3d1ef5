// The ROS-level tests' planar two-joint arm (a URDF): what test_joint_states checks the links'
// kinematics on and test_monitor_core the first contacts of.
#pragma once

namespace vadop_test {

// A planar two-joint arm: shoulder about z at the base origin, upper arm 1 m along x, elbow about
// z at its end (limited to [-2, 2] rad), a sphere 0.8 m along the forearm, a box at the middle
// of the upper arm.
inline const char* kPlanarArm = R"(<robot name="planar_arm">
  <link name="base_link"/>
  <link name="upper"><collision><origin xyz="0.5 0 0"/><geometry><box size="1 0.1 0.1"/></geometry></collision></link>
  <link name="fore"><collision><origin xyz="0.8 0 0"/><geometry><sphere radius="0.1"/></geometry></collision></link>
  <joint name="shoulder" type="continuous"><parent link="base_link"/><child link="upper"/><axis xyz="0 0 1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/><origin xyz="1 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>)";

}  // namespace vadop_test
