// vadop_fleet_driver: the fleet driver (fleet_driver.cpp: what it publishes, its parameters) as
// a node of its own. A bad parameter ends it with an error naming the parameter.
#include "fleet_driver.h"

#include <stdexcept>

int main(int argc, char** argv) {
  ros::init(argc, argv, "vadop_fleet_driver");
  ros::NodeHandle nh, pnh("~");
  vadop_ros::FleetDriverSettings s;
  try {
    s = vadop_ros::FleetDriverSettings::read(pnh);
  } catch (const std::invalid_argument& e) {
    ROS_FATAL("vadop_fleet_driver: %s", e.what());
    return 1;
  }
  vadop_ros::FleetDriver driver(nh, s);
  ROS_INFO("vadop_fleet_driver: %s", driver.describe().c_str());
  driver.run();
  return 0;
}
