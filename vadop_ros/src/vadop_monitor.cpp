// vadop_monitor: the monitor (monitor_node.h) as a node of its own. Parameters:
// config/monitor.yaml; behaviour: docs/monitor.md.
#include "vadop_ros/monitor_node.h"
#include "vadop_ros/params.h"

#include <ros/ros.h>

#include <cstdio>
#include <exception>
#include <memory>

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // log lines appear at once, also when piped
  ros::init(argc, argv, "vadop_monitor");
  // The node handles outlive the monitor: the last one's destruction shuts roscpp (and its
  // logging) down, and the fatal message would be lost.
  std::unique_ptr<ros::NodeHandle> nh_ptr, pnh_ptr;
  std::unique_ptr<vadop_ros::Monitor> monitor;
  // Start-up: any error ends the node with a fatal message and exit status 1, never an abort
  // (an exception escaping main). Parameters are checked first and name the parameter.
  try {
    nh_ptr = std::make_unique<ros::NodeHandle>();
    pnh_ptr = std::make_unique<ros::NodeHandle>("~");
    monitor = vadop_ros::startMonitor(*nh_ptr, *pnh_ptr);
  } catch (const vadop_ros::ParamError& e) {
    ROS_FATAL("vadop_monitor: bad parameter %s", e.what());
    return 1;
  } catch (const std::exception& e) {
    ROS_FATAL("vadop_monitor: cannot start: %s", e.what());
    return 1;
  }
  try {
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("vadop_monitor: stopped by an error: %s", e.what());
    return 1;
  }
  monitor.reset();  // before roscpp shuts down
  return 0;
}
