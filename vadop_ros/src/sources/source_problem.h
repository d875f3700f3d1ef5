// The one way a body-set source (tracked objects, sensors) records what was wrong with its
// input: the status keeps the latest problem and its receipt (the diagnostics show it), and a
// warning naming the input is logged at most once per kWarnPeriod wall seconds per input.
// Internal to vadop_ros (not installed).
#pragma once

#include <ros/console.h>
#include <ros/time.h>

#include <string>

namespace vadop_ros {

constexpr double kSourceWarnPeriod = 5.0;  // s, per input

// `status` has last_problem, last_problem_receipt and last_warn (wall seconds); `who` names the
// input ("sensor \"lidar\" (/scan)"), `unit` what the throttle is per ("sensor", "source").
template <class Status>
void noteSourceProblem(Status& status, const std::string& who, const char* unit, const std::string& why,
                       const ros::Time& receipt) {
  status.last_problem = why;
  status.last_problem_receipt = receipt;
  const double wall = ros::WallTime::now().toSec();
  if (wall - status.last_warn < kSourceWarnPeriod) return;
  status.last_warn = wall;
  ROS_WARN_NAMED("vadop_monitor", "%s: %s (warnings for this %s throttled to one per %.0f s)", who.c_str(),
                 why.c_str(), unit, kSourceWarnPeriod);
}

}  // namespace vadop_ros
