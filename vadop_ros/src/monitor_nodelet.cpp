// vadop/MonitorNodelet: the monitor (monitor_node.h) in a nodelet manager, with the same
// parameters, topics and behaviour as the node vadop_monitor. A driver or fleet manager loaded
// in the same manager hands its messages over as pointers, without serialization. Its callbacks
// run on the nodelet's single-threaded queue (as the node's on its one spinner); a start-up
// error (a bad parameter) is logged as fatal and leaves the nodelet loaded but idle: it cannot
// end the manager's process.
#include "vadop_ros/monitor_node.h"
#include "vadop_ros/params.h"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <exception>
#include <memory>

namespace vadop_ros {

class MonitorNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    try {
      monitor_ = startMonitor(getNodeHandle(), getPrivateNodeHandle());
    } catch (const ParamError& e) {
      NODELET_FATAL("vadop_monitor: bad parameter %s (the nodelet stays idle)", e.what());
    } catch (const std::exception& e) {
      NODELET_FATAL("vadop_monitor: cannot start: %s (the nodelet stays idle)", e.what());
    }
  }

  std::unique_ptr<Monitor> monitor_;
};

}  // namespace vadop_ros

PLUGINLIB_EXPORT_CLASS(vadop_ros::MonitorNodelet, nodelet::Nodelet)
