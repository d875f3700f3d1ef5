// vadop/FleetDriverNodelet: the fleet driver (fleet_driver.cpp: what it publishes, its
// parameters) in a nodelet manager, on a thread of its own. Loaded in the manager of
// vadop/MonitorNodelet, its messages reach the monitor as shared pointers, without
// serialization (launch/fleet_transport.launch nodelet:=true). A bad parameter is logged as
// fatal and leaves the nodelet loaded but idle: it cannot end the manager's process. Unloading
// it stops the thread.
#include "fleet_driver.h"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>
#include <stdexcept>
#include <thread>

namespace vadop_ros {

class FleetDriverNodelet : public nodelet::Nodelet {
 public:
  ~FleetDriverNodelet() override {
    if (driver_) driver_->stop();
    if (thread_.joinable()) thread_.join();
  }

 private:
  void onInit() override {
    FleetDriverSettings s;
    try {
      s = FleetDriverSettings::read(getPrivateNodeHandle());
    } catch (const std::invalid_argument& e) {
      NODELET_FATAL("vadop_fleet_driver: %s (the nodelet stays idle)", e.what());
      return;
    }
    driver_ = std::make_unique<FleetDriver>(getNodeHandle(), s);
    NODELET_INFO("vadop_fleet_driver: %s", driver_->describe().c_str());
    thread_ = std::thread([this] { driver_->run(); });
  }

  std::unique_ptr<FleetDriver> driver_;
  std::thread thread_;
};

}  // namespace vadop_ros

PLUGINLIB_EXPORT_CLASS(vadop_ros::FleetDriverNodelet, nodelet::Nodelet)
