// Checks of message fields against the library's range (vadop/limits.h), shared by the
// registry's message handlers and the tracked-object sources: each returns false and sets
// `why` (naming the field) on NaN/Inf, a value out of range or a zero quaternion.
// Internal to vadop_ros (not installed).
#pragma once

#include <geometry_msgs/Point.h>
#include <geometry_msgs/Quaternion.h>
#include <geometry_msgs/Vector3.h>

#include <vadop/error.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <string_view>

namespace vadop_ros {

// Field names are views: a literal costs no string per message (the odometry of thousands of
// bodies goes through these every cycle); the text is built only on failure.

// Checks one value against the library's range for its kind (vadop/limits.h); returns false
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

}  // namespace vadop_ros
