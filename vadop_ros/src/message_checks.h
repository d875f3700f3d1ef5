// Checks of message fields against the library's range (vadop/error.h), shared by the input
// sources (src/sources) and the tracked-object sources: each returns false and sets `why`
// (naming the field) on NaN/Inf, a value out of range or a zero quaternion; and the texts
// their messages are written with. Internal to vadop_ros (not installed).
#pragma once

#include <geometry_msgs/Point.h>
#include <geometry_msgs/Quaternion.h>
#include <geometry_msgs/Vector3.h>

#include "vadop_ros/joint_kinematics.h"

#include <vadop/error.h>

#include <ros/time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace vadop_ros {

// Field names are views: a literal costs no string per message (the odometry of thousands of
// bodies goes through these every cycle); the text is built only on failure.

// Checks one value against the library's range for its kind (vadop/error.h); returns false
// (and sets `why`) on NaN/Inf or beyond `limit`.
inline bool checkValue(double v, double limit, const char* unit, std::string_view field, std::string& why) {
  if (!std::isfinite(v)) {
    why = std::string("NaN/Inf in ").append(field);
    return false;
  }
  if (std::fabs(v) > limit) {
    std::ostringstream os;
    os << field << " = " << v << " is out of range (|value| > " << limit << " " << unit << ")";
    why = os.str();
    return false;
  }
  return true;
}

inline bool checkVector(const geometry_msgs::Vector3& v, double limit, const char* unit, std::string_view field,
                        std::string& why) {
  // Every value in range (false for a NaN): no field name is spelled out (per message, per body).
  if (std::fabs(v.x) <= limit && std::fabs(v.y) <= limit && std::fabs(v.z) <= limit) return true;
  const std::string name(field);
  return checkValue(v.x, limit, unit, name + ".x", why) && checkValue(v.y, limit, unit, name + ".y", why) &&
         checkValue(v.z, limit, unit, name + ".z", why);
}

inline bool checkPoint(const geometry_msgs::Point& v, std::string_view field, std::string& why) {
  const double limit = vadop::kMaxCoordinate;
  if (std::fabs(v.x) <= limit && std::fabs(v.y) <= limit && std::fabs(v.z) <= limit) return true;
  const std::string name(field);
  return checkValue(v.x, limit, "m", name + ".x", why) && checkValue(v.y, limit, "m", name + ".y", why) &&
         checkValue(v.z, limit, "m", name + ".z", why);
}

inline bool checkQuaternion(const geometry_msgs::Quaternion& q, std::string_view field, std::string& why) {
  if (!(std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z) && std::isfinite(q.w))) {
    why = std::string("NaN/Inf in ").append(field);
    return false;
  }
  // Scaled before squaring: a quaternion of 1e200 components is a valid orientation.
  const double m = std::max({std::fabs(q.x), std::fabs(q.y), std::fabs(q.z), std::fabs(q.w)});
  if (!(m > 0.0) || !(std::sqrt((q.x / m) * (q.x / m) + (q.y / m) * (q.y / m) + (q.z / m) * (q.z / m) +
                                (q.w / m) * (q.w / m)) * m > 1e-9)) {
    why = std::string("zero-norm quaternion in ").append(field);
    return false;
  }
  return true;
}

// A frame id without its leading slashes (tf2 refuses them), as a view into `s`.
inline std::string_view withoutSlash(const std::string& s) {
  std::string_view v(s);
  while (!v.empty() && v.front() == '/') v.remove_prefix(1);
  return v;
}
inline std::string stripSlash(const std::string& s) { return std::string(withoutSlash(s)); }

// A stamp as "sec.nsec" (exact).
inline std::string stampText(const ros::Time& t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%u.%09u", t.sec, t.nsec);
  return buf;
}

// A number as a stream writes it.
inline std::string numberText(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// The movable joints `names` (a message's field `field`) name, in order; "" or why not (a name
// that is not a movable joint of the URDF, or repeats).
inline std::string jointIndices(const JointKinematics& kin, const std::vector<std::string>& names,
                                const std::string& field, std::vector<int>& index) {
  index.assign(names.size(), -1);
  std::vector<char> seen(kin.joints().size(), 0);
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string item = field + "[" + std::to_string(i) + "] \"" + names[i] + "\"";
    index[i] = kin.jointIndex(names[i]);
    if (index[i] < 0) return item + " is not a movable joint of the body's URDF";
    if (seen[static_cast<size_t>(index[i])]++) return item + " repeats";
  }
  return "";
}

}  // namespace vadop_ros
