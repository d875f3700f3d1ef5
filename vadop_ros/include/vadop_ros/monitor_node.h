// The monitor on ROS: parameters read from a private node handle, the registry's sources
// subscribed, the cycle on a timer, gates, dynamic_reconfigure and diagnostics
// (src/monitor_node.cpp). The node vadop_monitor (src/vadop_monitor.cpp) and the nodelet
// vadop/MonitorNodelet (src/monitor_nodelet.cpp) both run it, so they share every parameter,
// topic and behaviour; they differ only in whose callback queue and threads serve it and how
// a start-up error ends (the node exits, the nodelet stays loaded and idle).
// It does not spin: its callbacks run on the queue of the node handles it is given (the gates
// on a queue and thread of their own; the odometry callbacks on roscpp's receiving thread, or
// on a queue of their own with ~ingest_threads threads).
#pragma once

#include <ros/node_handle.h>

#include <memory>

namespace vadop_ros {

// A running monitor: it stops (unsubscribes, stops its timer and gate thread) when destroyed.
class Monitor {
 public:
  virtual ~Monitor() = default;
};

// Starts a monitor with topics in `nh` and its parameters, ~impacts, ~markers and ~gate_states
// in `pnh`. Throws ParamError (params.h) naming a bad parameter, or std::exception when it
// cannot start for another reason.
std::unique_ptr<Monitor> startMonitor(ros::NodeHandle nh, ros::NodeHandle pnh);

}  // namespace vadop_ros
